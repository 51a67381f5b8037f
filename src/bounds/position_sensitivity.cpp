// C_q, the position sensitivity of the model's torque prediction, by an interval branch and bound over every joint
// with the dynamics on interval forward-mode duals (their partial derivatives enclose ∂h/∂q over each box).
#include "obsgain/bounds/certified_bounds.hpp"
#include "obsgain/bounds/enclosures.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <fmt/format.h>

#include <numeric>

namespace obsgain {

namespace {

using boost::numeric::square;

// The derivative enclosures that ∂h/∂q is built from, h(q) = M(q) a + A(q, v) + g(q): computed once per box,
// combined for as many (a, v) as needed.
struct SensitivityTerms {
  MatrixEnclosure M, g;
  std::vector<MatrixEnclosure> N;
};

SensitivityTerms sensitivity_terms(const Model& model, const std::vector<DualInterval>& q) {
  return {mass_matrix_enclosure(model, q), gravity_enclosure(model, q), coriolis_tensor_enclosures(model, q)};
}

// Columns ∂h/∂q_j for every a and v in the interval vectors (v_k v_l in `velocity_products`).
IntervalMatrix sensitivity_enclosure(const SensitivityTerms& t, const std::vector<Interval>& a,
                                     const IntervalMatrix& velocity_products) {
  const auto n = static_cast<Eigen::Index>(a.size());
  IntervalMatrix K(n, n);
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = 0; i < n; ++i) {
      Interval sum = t.g.derivative[j](i, 0);
      for (Eigen::Index k = 0; k < n; ++k) {
        sum += t.M.derivative[j](i, k) * a[k];
        for (Eigen::Index l = 0; l < n; ++l) sum += t.N[i].derivative[j](k, l) * velocity_products(k, l);
      }
      K(i, j) = sum;
    }
  return K;
}

IntervalMatrix products_of(const std::vector<Interval>& v) {
  const auto n = static_cast<Eigen::Index>(v.size());
  IntervalMatrix P(n, n);
  for (Eigen::Index k = 0; k < n; ++k)
    for (Eigen::Index l = 0; l < n; ++l) P(k, l) = k == l ? square(v[k]) : v[k] * v[l];
  return P;
}

}  // namespace

std::string sensitivity_unavailable(const Model& model) {
  if (model.dof() > kMaxDirections)
    return fmt::format("model '{}' has {} joints; the position sensitivity is searched over at most {}", model.name,
                       model.dof(), kMaxDirections);
  return {};
}

namespace {

// The choices of (a, v) vertices whose ∂h/∂q the attained values try: the norm is convex in a and in v_k v_l
// jointly only along vertices, so all of them up to three joints, a fixed pseudo-random 64 beyond.
std::vector<std::pair<Eigen::Index, Eigen::Index>> sensitivity_choices(int n, Eigen::Index a_count, Eigen::Index v_count) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> choices;
  if (n <= 3) {
    for (Eigen::Index i = 0; i < a_count; ++i)
      for (Eigen::Index k = 0; k < v_count; ++k) choices.emplace_back(i, k);
    return choices;
  }
  std::uint64_t state = 0x9e3779b97f4a7c15ULL;
  for (int c = 0; c < 64; ++c) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    choices.emplace_back(static_cast<Eigen::Index>((state >> 20) % a_count), static_cast<Eigen::Index>((state >> 40) % v_count));
  }
  return choices;
}

// ||∂h/∂q|| at q, the largest over the vertex choices (an attained value).
double sensitivity_at(const Model& model, const Eigen::VectorXd& q, const Eigen::MatrixXd& a_vertices,
                      const Eigen::MatrixXd& v_vertices, const std::vector<std::pair<Eigen::Index, Eigen::Index>>& choices) {
  const int n = model.dof();
  const UpwardRounding upward;
  std::vector<DualInterval> x;
  for (int j = 0; j < n; ++j) x.push_back(DualInterval::variable(Interval(q(j)), j, n));
  const SensitivityTerms terms = sensitivity_terms(model, x);
  double best = 0.0;
  for (const auto& [i, k] : choices) {
    std::vector<Interval> a, v;
    for (int j = 0; j < n; ++j) {
      a.emplace_back(a_vertices(j, i));
      v.emplace_back(v_vertices(j, k));
    }
    const IntervalMatrix K = sensitivity_enclosure(terms, a, products_of(v));
    Eigen::MatrixXd mid(n, n);
    for (Eigen::Index e = 0; e < K.size(); ++e) mid(e) = centre(K(e));
    best = std::max(best, spectral_norm(mid));
  }
  return best;
}

}  // namespace

std::optional<BoundBracket> certify_position_sensitivity(const Model& model, const Eigen::VectorXd& velocity_bounds,
                                                         const Eigen::VectorXd& acceleration_bounds,
                                                         const CertifiedOptions& options) {
  if (!sensitivity_unavailable(model).empty()) return std::nullopt;
  const int n = model.dof();
  // Gravity depends on every joint (the first too, unless its axis is vertical): all of them are searched.
  std::vector<int> every(static_cast<std::size_t>(n));
  std::iota(every.begin(), every.end(), 0);
  const JointSearch s = joint_search(model, every);
  std::vector<Interval> a_box, v_box;
  for (int j = 0; j < n; ++j) {
    a_box.emplace_back(-acceleration_bounds(j), acceleration_bounds(j));
    v_box.emplace_back(-velocity_bounds(j), velocity_bounds(j));
  }
  const IntervalMatrix v_products = products_of(v_box);
  // A box's counted work in reference seconds (as box_bounds.hpp's costs: timings on the suite's two-core machine;
  // 3e-6 n³ counted 2.0 s where arm3's and arm6's searches took 4.4 and 4.5 s).
  const double box_cost = 6.5e-6 * n * n * n;
  const auto box_upper = [&](const std::vector<Interval>& box, double) {
    std::vector<DualInterval> q;
    for (int j = 0; j < n; ++j) q.push_back(DualInterval::variable(box[static_cast<std::size_t>(j)], j, n));
    BoxBound bound{norm_upper_bound(sensitivity_enclosure(sensitivity_terms(model, q), a_box, v_products)), {}, box_cost};
    // No second derivatives to weigh the sides by: split the widest (relative to its domain).
    for (int k = 0; k < n; ++k) bound.split_weight.push_back(boost::numeric::width(box[k]) / boost::numeric::width(s.domain[k]));
    return bound;
  };
  const Eigen::MatrixXd a_vertices = box_vertices(acceleration_bounds), v_vertices = box_vertices(velocity_bounds);
  const auto choices = sensitivity_choices(n, a_vertices.cols(), v_vertices.cols());
  const auto point = [&](const Eigen::VectorXd& q) { return sensitivity_at(model, q, a_vertices, v_vertices, choices); };
  Eigen::VectorXd seed(n);
  for (int j = 0; j < n; ++j) seed(j) = centre(s.domain[j]);
  BranchAndBoundOptions o;
  o.relative_gap = options.relative_gap;
  o.max_boxes = options.max_boxes;
  if (options.budget_seconds > 0.0) {
    o.work_budget = options.budget_seconds;
    const double limit = options.wall_limit_seconds.value_or(3.0 * options.budget_seconds + 30.0);
    o.deadline = std::chrono::steady_clock::now() +
                 std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(limit));
  }
  o.threads = options.threads;
  o.name = "C_q";
  o.progress = options.progress;
  return journaled_search(options, search_request(model, velocity_bounds, options, acceleration_bounds), o,
                          [&](const BranchAndBoundOptions& search) { return search_joints(s, box_upper, point, seed, search); });
}

}  // namespace obsgain
