#include "obsgain/numerics/optimize.hpp"

#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>
#include <nlopt.hpp>

#include <cmath>
#include <exception>
#include <limits>
#include <sstream>
#include <vector>

namespace obsgain {

namespace {

// NLopt and Ipopt swallow exceptions thrown by the objective: keep the first one and rethrow it after the
// optimiser returns, so that an InputError (a singular inertia matrix, say) reaches the user intact.
struct GlobalData {
  const Objective* f;
  OptimumPoint best;
  std::exception_ptr error;
};

double nlopt_objective(const std::vector<double>& x, std::vector<double>& /*grad*/, void* data) {
  auto* d = static_cast<GlobalData*>(data);
  const Eigen::VectorXd point = Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
  // A step computed from values near double's range can be NaN: no configuration, so no question to the model.
  if (!point.allFinite()) return -std::numeric_limits<double>::max();
  double value = 0.0;
  try {
    value = (*d->f)(point);
  } catch (...) {
    d->error = std::current_exception();
    throw nlopt::forced_stop();
  }
  ++d->best.evaluations;
  if (std::isfinite(value) && value > d->best.value) {
    d->best.value = value;
    d->best.x = point;
  }
  return std::isfinite(value) ? value : -std::numeric_limits<double>::max();
}

// The second differences' step, relative to a coordinate (at least 1): their truncation error is of order h² and their
// rounding of order ε/h², both near 1e-8 of the function's scale here.
constexpr double kHessianStep = 1e-4;

// Minimises -f; keeps the best point seen so that a premature Ipopt stop still returns a valid maximum.
class PolishProblem final : public Ipopt::TNLP {
 public:
  PolishProblem(const Objective& f, const Eigen::VectorXd& x0, const Eigen::VectorXd& lower,
                const Eigen::VectorXd& upper)
      : f_(f), x0_(x0), lower_(lower), upper_(upper) {
    best_.x = x0;
    best_.value = -std::numeric_limits<double>::infinity();
    evaluate(x0);
  }

  const OptimumPoint& best() const { return best_; }
  const std::exception_ptr& error() const { return error_; }

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g, Ipopt::Index& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = static_cast<Ipopt::Index>(x0_.size());
    m = 0;
    nnz_jac_g = 0;
    nnz_h_lag = n * (n + 1) / 2;
    index_style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index, Ipopt::Number*,
                       Ipopt::Number*) override {
    for (Ipopt::Index i = 0; i < n; ++i) {
      x_l[i] = lower_(i);
      x_u[i] = upper_(i);
    }
    return true;
  }
  bool get_starting_point(Ipopt::Index n, bool, Ipopt::Number* x, bool, Ipopt::Number*, Ipopt::Number*,
                          Ipopt::Index, bool, Ipopt::Number*) override {
    for (Ipopt::Index i = 0; i < n; ++i) x[i] = x0_(i);
    return true;
  }
  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool, Ipopt::Number& obj_value) override {
    const double value = evaluate(Eigen::Map<const Eigen::VectorXd>(x, n));
    if (!std::isfinite(value)) return false;
    obj_value = -value;
    return true;
  }
  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool, Ipopt::Number* grad_f) override {
    Eigen::VectorXd point = Eigen::Map<const Eigen::VectorXd>(x, n);
    for (Ipopt::Index i = 0; i < n; ++i) {
      const double h = 1e-6 * std::max(1.0, std::abs(point(i)));
      const double xi = point(i);
      point(i) = xi + h;
      const double forward = evaluate(point);
      point(i) = xi - h;
      const double backward = evaluate(point);
      point(i) = xi;
      if (!std::isfinite(forward) || !std::isfinite(backward)) return false;
      grad_f[i] = -(forward - backward) / (2.0 * h);
    }
    return true;
  }
  // The Hessian of -f by second differences, its lower triangle row by row: Newton's steps take a handful of
  // iterations where limited-memory updates take a hundred, each a factorisation (docs/theory.md, "The constants").
  bool eval_h(Ipopt::Index n, const Ipopt::Number* x, bool, Ipopt::Number obj_factor, Ipopt::Index, const Ipopt::Number*,
              bool, Ipopt::Index, Ipopt::Index* iRow, Ipopt::Index* jCol, Ipopt::Number* values) override {
    if (values == nullptr) {
      for (Ipopt::Index i = 0, k = 0; i < n; ++i)
        for (Ipopt::Index j = 0; j <= i; ++j, ++k) iRow[k] = i, jCol[k] = j;
      return true;
    }
    const Eigen::VectorXd point = Eigen::Map<const Eigen::VectorXd>(x, n);
    const Eigen::VectorXd h = (point.cwiseAbs().cwiseMax(1.0) * kHessianStep).eval();
    const auto at = [&](Ipopt::Index i, double a, Ipopt::Index j, double b) {
      Eigen::VectorXd moved = point;
      moved(i) += a * h(i);
      moved(j) += b * h(j);
      return evaluate(moved);
    };
    const double centre = evaluate(point);
    const auto second_difference = [&](Ipopt::Index i, Ipopt::Index j) {
      if (i == j) return (at(i, 1.0, i, 0.0) - 2.0 * centre + at(i, -1.0, i, 0.0)) / (h(i) * h(i));
      const double cross = at(i, 1.0, j, 1.0) - at(i, 1.0, j, -1.0) - at(i, -1.0, j, 1.0) + at(i, -1.0, j, -1.0);
      return cross / (4.0 * h(i) * h(j));
    };
    for (Ipopt::Index i = 0, k = 0; i < n; ++i)
      for (Ipopt::Index j = 0; j <= i; ++j, ++k) {
        const double second = second_difference(i, j);
        if (!std::isfinite(second)) return false;
        values[k] = -obj_factor * second;
      }
    return true;
  }
  bool eval_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Number*) override { return true; }
  bool eval_jac_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Index, Ipopt::Index*,
                  Ipopt::Index*, Ipopt::Number*) override {
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index, const Ipopt::Number*, const Ipopt::Number*,
                         const Ipopt::Number*, Ipopt::Index, const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {}

 private:
  double evaluate(const Eigen::VectorXd& x) {
    // After an error, or at a NaN step (from values near double's range): no value, and Ipopt steps back.
    if (error_ || !x.allFinite()) return std::numeric_limits<double>::quiet_NaN();
    double value = 0.0;
    try {
      value = f_(x);
    } catch (...) {
      error_ = std::current_exception();
      return std::numeric_limits<double>::quiet_NaN();
    }
    ++best_.evaluations;
    if (std::isfinite(value) && value > best_.value && (x.array() >= lower_.array()).all() &&
        (x.array() <= upper_.array()).all()) {
      best_.value = value;
      best_.x = x;
    }
    return value;
  }

  const Objective& f_;
  Eigen::VectorXd x0_, lower_, upper_;
  OptimumPoint best_;
  std::exception_ptr error_;
};

}  // namespace

namespace {

// Maximises f with one of NLopt's algorithms from x over [lower, upper]: the best point evaluated.
OptimumPoint run_nlopt(nlopt::algorithm algorithm, const Objective& f, std::vector<double> x, const Eigen::VectorXd& lower,
                       const Eigen::VectorXd& upper, double tolerance, int max_evaluations) {
  const auto n = static_cast<unsigned>(x.size());
  GlobalData data{&f, {}, nullptr};
  data.best.value = -std::numeric_limits<double>::infinity();
  nlopt::opt opt(algorithm, n);
  opt.set_lower_bounds(std::vector<double>(lower.data(), lower.data() + n));
  opt.set_upper_bounds(std::vector<double>(upper.data(), upper.data() + n));
  opt.set_max_objective(nlopt_objective, &data);
  opt.set_maxeval(max_evaluations);
  opt.set_xtol_abs(tolerance);
  double value = 0.0;
  try {
    opt.optimize(x, value);
  } catch (const nlopt::roundoff_limited&) {
    // Rounding at a converged point: the best point found so far is the answer.
  } catch (const nlopt::forced_stop&) {
  }
  if (data.error) std::rethrow_exception(data.error);
  return data.best;
}

}  // namespace

OptimumPoint maximize_global(const Objective& f, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                             int max_evaluations) {
  std::vector<double> x(static_cast<std::size_t>(lower.size()));
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 0.5 * (lower(static_cast<Eigen::Index>(i)) + upper(static_cast<Eigen::Index>(i)));
  return run_nlopt(nlopt::GN_DIRECT_L, f, x, lower, upper, 1e-12, max_evaluations);
}

ScalarOptimum minimize_golden(const std::function<double(double)>& f, double lower, double upper, double tolerance,
                              int max_iterations) {
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  ScalarOptimum best{lower, std::numeric_limits<double>::infinity(), 0};
  const auto evaluate = [&](double x) {
    const double value = f(x);
    ++best.evaluations;
    if (value < best.value) best = {x, value, best.evaluations};
    return value;
  };
  double lo = lower, hi = upper;
  double a = hi - ratio * (hi - lo), b = lo + ratio * (hi - lo);
  double fa = evaluate(a), fb = evaluate(b);
  for (int i = 0; i < max_iterations && hi - lo > tolerance; ++i) {
    if (fa <= fb) {
      hi = b, b = a, fb = fa;
      a = hi - ratio * (hi - lo), fa = evaluate(a);
    } else {
      lo = a, a = b, fa = fb;
      b = lo + ratio * (hi - lo), fb = evaluate(b);
    }
  }
  return best;
}

OptimumPoint maximize_local(const Objective& f, const Eigen::VectorXd& x0, const Eigen::VectorXd& lower,
                            const Eigen::VectorXd& upper) {
  Ipopt::SmartPtr<PolishProblem> problem = new PolishProblem(f, x0, lower, upper);
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetIntegerValue("print_level", 0);
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetNumericValue("tol", 1e-11);
  app->Options()->SetNumericValue("bound_relax_factor", 0.0);
  app->Options()->SetIntegerValue("max_iter", 200);
  // MUMPS's own default workspace margin, not Ipopt's 1000 %: on these problems (at most 2n variables) the latter made
  // every factorisation allocate 2 MB and touch it, a third of a polish's time. MUMPS asks for more when it runs short
  // (Ipopt retries with twice the margin) and the workspace's size changes no pivot, so the results are bit for bit
  // the same (docs/theory.md, "The constants").
  app->Options()->SetIntegerValue("mumps_mem_percent", 20);
  std::istringstream no_option_file;  // never read an ipopt.opt from the user's working directory
  if (app->Initialize(no_option_file) == Ipopt::Solve_Succeeded) app->OptimizeTNLP(problem);
  if (problem->error()) std::rethrow_exception(problem->error());
  return problem->best();
}

}  // namespace obsgain
