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
    coriolis_tensors_of(model, q.data(), d.N.data());
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

// The bound of max over saturation patterns D of ||A D + R|| for one vertex, given the box's running value `floor`:
// every pattern is within ||A|| + ||R|| (A D keeps some of A's columns), so only a vertex that could beat the floor
// is refined pattern by pattern, the full pattern (usually the maximum) first.
double patterns_upper(const AffineMatrix& A, const AffineMatrix& R, double R_norm, int n, double floor) {
  double best = norm_upper(A, floor - R_norm) + R_norm;
  if (best <= floor) return best;
  best = 0.0;
  for (unsigned pattern = (1u << n); pattern-- > 0;) {
    Eigen::VectorXd d(n);
    for (int j = 0; j < n; ++j) d(j) = (pattern >> j) & 1u;
    best = std::max(best, norm_upper(sum(scale_columns(A, d), R), std::max(best, floor)));
  }
  return best;
}

}  // namespace

BoxBounds::BoxBounds(const Model& model, const JointSearch& search, const Eigen::VectorXd& velocity_bounds)
    : model_(model), search_(search), vertices_(box_vertices(velocity_bounds)),
      count_(static_cast<unsigned>(vertices_.cols())), half_(count_ / 2), frictionless_(model.friction.isZero(0.0)) {}

BoxBound BoxBounds::inverse_inertia(const std::vector<Interval>& box) const {
  BoxBound bound{kInfinity, {}};
  const double lambda = inertia_lower(model_, box_dynamics(model_, search_, box, false), &bound.split_weight);
  if (lambda > 0.0) bound.upper = (Interval(1.0) / Interval(lambda)).upper();
  return bound;
}

BoxBound BoxBounds::jacobian(const std::vector<Interval>& box, double lower) const {
  const BoxDynamics d = box_dynamics(model_, search_, box, true);
  const std::vector<AffineMatrix> J = unit_jacobians(d);
  BoxBound bound{0.0, {}};
  for (unsigned c = half_; c < count_; ++c) {
    const AffineMatrix Jw = linear_combination(J, vertices_.col(c));
    weigh_sides(Jw, d, bound.split_weight);
    bound.upper = std::max(bound.upper, norm_upper(Jw, std::max(bound.upper, lower)));
  }
  return bound;
}

// L_joint over a box: Φ = M⁻¹(J(w) D + F) = Σ_j w_j A_j D + R with A_j = M⁻¹ J_j and R = M⁻¹ F, all as affine
// matrices (M⁻¹'s Neumann tail in their remainders).
BoxBound BoxBounds::joint_lipschitz(const std::vector<Interval>& box, double lower) const {
  const BoxDynamics d = box_dynamics(model_, search_, box, true);
  const std::vector<AffineMatrix> J = unit_jacobians(d);
  const AffineInverse inverse_M = inverse(d.M, d.n);
  if (!inverse_M.proven) return lipschitz_by_inertia_floor(model_, d, J, vertices_, half_, count_);
  std::vector<AffineMatrix> A;
  for (int j = 0; j < d.n; ++j) {
    const std::vector<Affine> J_j = unit_jacobian(d, j);
    A.push_back(affine_matrix(product(inverse_M.entries, J_j, d.n, d.n, d.n).data(), d.n, d.n, d.m));
    A.back().remainder = (Interval(A.back().remainder) + Interval(inverse_M.tail) * Interval(frobenius_upper(J_j))).upper();
  }
  std::vector<Affine> F(static_cast<std::size_t>(d.n * d.n));
  for (int i = 0; i < d.n * d.n; ++i) F[i] = Affine(model_.friction(i / d.n, i % d.n));
  AffineMatrix R = affine_matrix(product(inverse_M.entries, F, d.n, d.n, d.n).data(), d.n, d.n, d.m);
  R.remainder = (Interval(R.remainder) + Interval(inverse_M.tail) * Interval(frobenius_upper(F))).upper();
  const double R_norm = frictionless_ ? 0.0 : norm_upper(R, kInfinity);
  BoxBound bound{0.0, {}};
  for (unsigned c = frictionless_ ? half_ : 0u; c < count_; ++c) {
    const AffineMatrix Aw = linear_combination(A, vertices_.col(c));
    weigh_sides(Aw, d, bound.split_weight);
    const double floor = std::max(bound.upper, lower);
    bound.upper = std::max(bound.upper, frictionless_ ? norm_upper(Aw, floor) : patterns_upper(Aw, R, R_norm, d.n, floor));
  }
  return bound;
}

}  // namespace obsgain
