#include "obsgain/bounds/box_bounds.hpp"

#include "obsgain/bounds/affine_matrix.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace obsgain {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
static_assert(kAffineSymbols <= kMaxDirections, "the Christoffel tensors differentiate along every searched joint");

// The model's M (and N) over one box of the searched joints, as affine forms: symbol k is side k.
struct BoxDynamics {
  int n = 0, m = 0;
  std::vector<double> radius;  // of each side
  std::vector<Affine> M, N;    // row-major: M[i * n + j], N[(i * n + j) * n + k]
};

BoxDynamics box_dynamics(const Model& model, const JointSearch& s, const std::vector<Interval>& box, bool tensors) {
  BoxDynamics d;
  d.n = model.dof();
  d.m = static_cast<int>(box.size());
  std::vector<Affine> q(static_cast<std::size_t>(d.n));
  for (int i = 0; i < d.n; ++i) q[i] = Affine(s.fixed_q(i));
  for (int k = 0; k < d.m; ++k) {
    // [lo, hi] inside centre ± radius (radius rounded up).
    const double c = centre(box[k]);
    const double radius = std::max(box[k].upper() - c, c - box[k].lower()) * (1.0 + 0x1p-50) + kUnderflow;
    q[static_cast<std::size_t>(s.joints[k])] = Affine::symbol(c, radius, k);
    d.radius.push_back(radius);
  }
  d.M.resize(static_cast<std::size_t>(d.n * d.n));
  mass_matrix_of(model, q.data(), d.M.data());
  if (tensors) {
    d.N.resize(static_cast<std::size_t>(d.n * d.n * d.n));
    christoffel_tensors_of(model, s.joints, q.data(), d.N.data());
  }
  return d;
}

// J_j = ∂A/∂v at v = e_j as forms, (J_j)_ik = 2 N_i[j][k]: J(q, w) = Σ_j w_j J_j (docs/theory.md, "The constants").
std::vector<Affine> unit_jacobian(const BoxDynamics& d, int j) {
  const int n = d.n;
  std::vector<Affine> J(static_cast<std::size_t>(n * n));
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) J[i * n + k] = 2.0 * d.N[(i * n + j) * n + k];
  return J;
}

// Split where splitting removes most of the bound's excess: each side's first-order variation ||G_k||_F, and its
// share of the second-order remainder, which grows with the side's width (a side along which X is stationary at
// the centre has no first-order variation, and still a curvature). The largest over the choices.
void weigh_sides(const AffineMatrix& X, const BoxDynamics& d, std::vector<double>& weights) {
  weights.resize(X.slopes.size(), 0.0);
  double total = 0.0;
  for (double r : d.radius) total += r;
  for (std::size_t k = 0; k < X.slopes.size(); ++k)
    weights[k] = std::max(weights[k], X.slopes[k].norm() + X.remainder * d.radius[k] / total);
}

// J_j over the box as affine matrices.
std::vector<AffineMatrix> unit_jacobians(const BoxDynamics& d) {
  std::vector<AffineMatrix> J;
  for (int j = 0; j < d.n; ++j) J.push_back(affine_matrix(unit_jacobian(d, j).data(), d.n, d.n, d.m));
  return J;
}

// A proven lower bound of λmin(M) over the box (the model's inertia floor where that is higher).
double inertia_lower(const Model& model, const BoxDynamics& d, std::vector<double>* weights) {
  const AffineMatrix M = affine_matrix(d.M.data(), d.n, d.n, d.m);
  if (weights) weigh_sides(M, d, *weights);
  return std::max(smallest_eigenvalue_lower(M), inertia_floor(model));
}

// Where M⁻¹ cannot be enclosed (a box too wide for the Neumann series): ||M⁻¹(J D + F)|| <= (||J|| + ||F||) / λmin(M),
// finite once M is proven positive definite on the box.
BoxBound lipschitz_by_inertia_floor(const Model& model, const BoxDynamics& d, const std::vector<AffineMatrix>& J,
                                    const Eigen::MatrixXd& vertices, unsigned first, unsigned count) {
  BoxBound bound{kInfinity, {}};
  const double lambda = inertia_lower(model, d, &bound.split_weight);
  if (!(lambda > 0.0)) return bound;
  double J_norm = 0.0;
  for (unsigned c = first; c < count; ++c) J_norm = std::max(J_norm, norm_upper(linear_combination(J, vertices.col(c)), kInfinity));
  bound.upper = ((Interval(J_norm) + Interval(spectral_norm_upper(model.friction))) / Interval(lambda)).upper();
  return bound;
}

// Column norms of A D + R term by term (the centre, then each symbol's slope), with A's column j kept (d_j = 1) or
// dropped (d_j = 0): ||A D + R||_F over the box for any pattern, without forming A D + R.
class PatternColumns {
 public:
  PatternColumns(const AffineMatrix& A, const AffineMatrix& R) : remainder_(A.remainder + R.remainder) {
    const auto terms = static_cast<Eigen::Index>(A.slopes.size() + 1);
    on_.resize(terms, A.centre.cols());
    off_.resize(terms, A.centre.cols());
    for (Eigen::Index t = 0; t < terms; ++t) {
      const Eigen::MatrixXd& a = t == 0 ? A.centre : A.slopes[t - 1];
      const Eigen::MatrixXd& r = t == 0 ? R.centre : R.slopes[t - 1];
      on_.row(t) = (a + r).colwise().norm();
      off_.row(t) = r.colwise().norm();
    }
  }
  // The bound for one pattern (bit j: d_j = 1), and for every pattern at once (per column the larger choice).
  double pattern(unsigned bits) const {
    Eigen::MatrixXd chosen = off_;
    for (Eigen::Index j = 0; j < on_.cols(); ++j)
      if ((bits >> j) & 1u) chosen.col(j) = on_.col(j);
    return total(chosen);
  }
  double every_pattern() const { return total(on_.cwiseMax(off_)); }

 private:
  // Σ over terms of the row norms, rounded up (relative errors of a few ulps per norm, covered by the inflation).
  double total(const Eigen::MatrixXd& chosen) const {
    const double terms = chosen.rowwise().norm().sum();
    return (terms * (1.0 + 0x1p-40) + remainder_) * kAffineInflation + kUnderflow;
  }
  Eigen::MatrixXd on_, off_;
  double remainder_;
};

// One choice of velocity vertex and saturation pattern (bit j: d_j = 1), with its cheap (Frobenius) bound.
struct Choice {
  double cheap;
  unsigned vertex, bits;
};

// The largest bound over the choices, refined in decreasing order of their cheap bounds: once the next cheap bound
// cannot beat the best refined one (or the value attained elsewhere, `lower`), neither can any after it.
// `refined` counts the refinements.
template <class Refine>
double refine_choices(std::vector<Choice>& choices, double lower, const Refine& refine, int& refined) {
  std::stable_sort(choices.begin(), choices.end(), [](const Choice& x, const Choice& y) { return x.cheap > y.cheap; });
  double best = 0.0;
  for (const Choice& choice : choices) {
    if (choice.cheap <= std::max(best, lower)) return std::max(best, choice.cheap);
    best = std::max(best, refine(choice, std::max(best, lower)));
    ++refined;
  }
  return best;
}

}  // namespace

BoxCosts box_costs(int n, int m) {
  // Per core, in seconds (fits of timings on the reference machine, within about 30 % for n = 2 ... 7), halved
  // for its two cores.
  const double n2 = static_cast<double>(n * n);
  const BoxCosts core{15e-6 + 2e-6 * n2, 33e-6 * n2, 2e-6 + 0.06e-6 * n2 * (m + 1), 0.05e-6 + 0.003e-6 * n2};
  return {core.inertia / 2, core.tensors / 2, core.refinement / 2, core.choice / 2};
}

BoxBounds::BoxBounds(const Model& model, const JointSearch& search, const Eigen::VectorXd& velocity_bounds)
    : model_(model), search_(search), velocity_bounds_(velocity_bounds), vertices_(box_vertices(velocity_bounds)),
      count_(static_cast<unsigned>(vertices_.cols())), half_(count_ / 2), frictionless_(model.friction.isZero(0.0)),
      costs_(box_costs(model.dof(), static_cast<int>(search.joints.size()))) {}

BoxBound BoxBounds::inverse_inertia(const std::vector<Interval>& box) const {
  BoxBound bound{kInfinity, {}, costs_.inertia + costs_.refinement};
  const double lambda = inertia_lower(model_, box_dynamics(model_, search_, box, false), &bound.split_weight);
  if (lambda > 0.0) bound.upper = (Interval(1.0) / Interval(lambda)).upper();
  return bound;
}

BoxBound BoxBounds::jacobian(const std::vector<Interval>& box, double lower) const {
  const BoxDynamics d = box_dynamics(model_, search_, box, true);
  const std::vector<AffineMatrix> J = unit_jacobians(d);
  BoxBound bound{0.0, {}, costs_.tensors};
  for (unsigned c = half_; c < count_; ++c) {
    const AffineMatrix Jw = linear_combination(J, vertices_.col(c));
    weigh_sides(Jw, d, bound.split_weight);
    const double floor = std::max(bound.upper, lower);
    bound.work += costs_.choice + (Jw.frobenius_upper() > floor ? costs_.refinement : 0.0);
    bound.upper = std::max(bound.upper, norm_upper(Jw, floor));
  }
  return bound;
}

namespace {

// Φ = M⁻¹(J(w) D + F) = Σ_j w_j A_j D + R over a box, A_j = M⁻¹ J_j and R = M⁻¹ F as affine matrices, M⁻¹'s
// Neumann tail in their remainders.
struct LipschitzTerms {
  std::vector<AffineMatrix> A;
  AffineMatrix R;
};

LipschitzTerms lipschitz_terms(const Model& model, const BoxDynamics& d, const AffineInverse& inverse_M) {
  LipschitzTerms t;
  const auto with_tail = [&](const std::vector<Affine>& Y) {
    AffineMatrix X = affine_matrix(product(inverse_M.entries, Y, d.n, d.n, d.n).data(), d.n, d.n, d.m);
    X.remainder = (Interval(X.remainder) + Interval(inverse_M.tail) * Interval(frobenius_upper(Y))).upper();
    X.entry_remainder.resize(0, 0);  // the tail is known as a norm only
    return X;
  };
  for (int j = 0; j < d.n; ++j) t.A.push_back(with_tail(unit_jacobian(d, j)));
  std::vector<Affine> F(static_cast<std::size_t>(d.n * d.n));
  for (int i = 0; i < d.n * d.n; ++i) F[i] = Affine(model.friction(i / d.n, i % d.n));
  t.R = with_tail(F);
  return t;
}

// The velocity box's vertices to visit (columns first..count-1), and whether F = 0 (then only the full pattern).
struct VelocityChoices {
  const Eigen::MatrixXd& vertices;
  unsigned first, count;
  bool frictionless;
  const BoxCosts& costs;
};

// The maximum over the vertices w and the saturation patterns D of ||A(w) D + R||, each choice's cheap bound first.
double choices_upper(const LipschitzTerms& t, const BoxDynamics& d, const VelocityChoices& v, double lower,
                     std::vector<double>& weights, double& work) {
  std::vector<AffineMatrix> Aw;
  std::vector<Choice> choices;
  for (unsigned c = v.first; c < v.count; ++c) {
    Aw.push_back(linear_combination(t.A, v.vertices.col(c)));
    weigh_sides(Aw.back(), d, weights);
    const auto index = static_cast<unsigned>(Aw.size() - 1);
    if (v.frictionless) {
      choices.push_back({Aw.back().frobenius_upper(), index, (1u << d.n) - 1});
      continue;
    }
    const PatternColumns columns(Aw.back(), t.R);
    for (unsigned bits = 0; bits < (1u << d.n); ++bits) choices.push_back({columns.pattern(bits), index, bits});
  }
  work += static_cast<double>(choices.size()) * v.costs.choice;
  int refined = 0;
  const double upper = refine_choices(choices, lower, [&](const Choice& choice, double floor) {
    if (v.frictionless) return norm_upper(Aw[choice.vertex], floor);
    Eigen::VectorXd D(d.n);
    for (int j = 0; j < d.n; ++j) D(j) = (choice.bits >> j) & 1u;
    return norm_upper(sum(scale_columns(Aw[choice.vertex], D), t.R), floor);
  }, refined);
  work += refined * v.costs.refinement;
  return upper;
}

}  // namespace

// L_joint over a box. On a wide box the product M⁻¹ J carries both factors' remainders, and the inertia route
// (||J|| + ||F||) / λmin(M) can be the tighter: where the cheap bound is far above the value attained, both are
// taken.
BoxBound BoxBounds::joint_lipschitz(const std::vector<Interval>& box, double lower) const {
  const BoxDynamics d = box_dynamics(model_, search_, box, true);
  const std::vector<AffineMatrix> J = unit_jacobians(d);
  const AffineInverse inverse_M = inverse(d.M, d.n);
  const double inertia_route_work = costs_.refinement * (1.0 + count_ - half_);
  if (!inverse_M.proven) {
    BoxBound bound = lipschitz_by_inertia_floor(model_, d, J, vertices_, half_, count_);
    bound.work = costs_.tensors + inertia_route_work;
    return bound;
  }
  const LipschitzTerms t = lipschitz_terms(model_, d, inverse_M);
  BoxBound bound{every_choice_upper(t.A, velocity_bounds_, t.R), {}, costs_.tensors};
  if (bound.upper <= lower) {  // cannot beat the value attained: no choice needs enumerating
    weigh_sides(linear_combination(t.A, velocity_bounds_), d, bound.split_weight);
    return bound;
  }
  double cap = kInfinity;
  if (bound.upper > 2.0 * lower) {
    BoxBound by_inertia = lipschitz_by_inertia_floor(model_, d, J, vertices_, half_, count_);
    bound.work += inertia_route_work;
    if (by_inertia.upper <= lower) return {by_inertia.upper, std::move(by_inertia.split_weight), bound.work};
    cap = by_inertia.upper;
  }
  const VelocityChoices choices{vertices_, frictionless_ ? half_ : 0u, count_, frictionless_, costs_};
  bound.upper = std::min(cap, choices_upper(t, d, choices, lower, bound.split_weight, bound.work));
  return bound;
}

}  // namespace obsgain

namespace obsgain {

namespace {

// |X(ε) - C| <= Σ_k |G_k| + Δ entrywise over the box, rounded up (sums of non-negative terms under upward rounding).
Eigen::MatrixXd entrywise_spread(const AffineMatrix& X) {
  const UpwardRounding upward;
  Eigen::MatrixXd spread = X.entry_remainder.size() > 0
                               ? X.entry_remainder
                               : Eigen::MatrixXd::Constant(X.centre.rows(), X.centre.cols(), X.remainder);
  for (const Eigen::MatrixXd& G : X.slopes) spread += G.cwiseAbs();
  return spread;
}

}  // namespace

PolytopeCell BoxBounds::perturbation_cell(const std::vector<Interval>& box) const {
  const BoxDynamics d = box_dynamics(model_, search_, box, true);
  const AffineInverse inverse_M = inverse(d.M, d.n);
  PolytopeCell cell;
  cell.box = box;
  if (!inverse_M.proven) return cell;
  const LipschitzTerms t = lipschitz_terms(model_, d, inverse_M);
  cell.constant = -t.R.centre;
  for (const AffineMatrix& A : t.A) cell.slopes.push_back(-A.centre);
  const UpwardRounding upward;
  cell.radius = entrywise_spread(t.R);
  for (int j = 0; j < d.n; ++j) cell.radius += velocity_bounds_(j) * entrywise_spread(t.A[j]);
  cell.radius += point_rounding(cell, velocity_bounds_);
  cell.proven = true;
  return cell;
}

}  // namespace obsgain
