#include "obsgain/bounds/box_bounds.hpp"

#include "obsgain/bounds/taylor_matrix.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace obsgain {

namespace {

static_assert(kTaylorSymbols <= kMaxDirections, "the Christoffel tensors differentiate along every searched joint");

// The model's M (and N) over one box of the searched joints, as second-order Taylor forms: symbol k is side k.
struct BoxDynamics {
  int n = 0, m = 0;
  std::vector<double> radius;       // of each side
  std::vector<Taylor> M, N;         // row-major: M[i * n + j], N[(i * n + j) * n + k]
  std::vector<double> sensitivity;  // of M to each side: Σ over entries of its first- and second-order coefficients
};

// Σ over M's entries of |a_k| + Σ_{l} |b_kl|: how much of M's variation over the box comes from side k.
std::vector<double> sensitivities(const std::vector<Taylor>& M, int m) {
  std::vector<double> s(static_cast<std::size_t>(m), 0.0);
  for (const Taylor& x : M)
    for (int k = 0; k < m; ++k) {
      s[k] += std::abs(x.a[k]);
      for (int l = 0; l < m; ++l) s[k] += std::abs(x.b[kPairs.index[k][l]]);
    }
  return s;
}

// The sensitivity of M to side k is r_k Σ_ij sup |∂M_ij/∂q_k| over the box, from the derivatives the tensors are
// computed from (or, for M alone, from derivatives on intervals): it sees a side's influence even where its
// trigonometric enclosure went constant and its coefficients vanished into the remainder.
BoxDynamics box_dynamics(const Model& model, const JointSearch& s, const std::vector<Interval>& box, bool tensors) {
  BoxDynamics d;
  d.n = model.dof();
  d.m = static_cast<int>(box.size());
  std::vector<Taylor> q(static_cast<std::size_t>(d.n));
  for (int i = 0; i < d.n; ++i) q[i] = Taylor(s.fixed_q(i));
  for (int k = 0; k < d.m; ++k) {
    // [lo, hi] inside centre ± radius (radius rounded up).
    const double c = centre(box[k]);
    const double radius = std::max(box[k].upper() - c, c - box[k].lower()) * (1.0 + 0x1p-50) + kTaylorUnderflow;
    q[static_cast<std::size_t>(s.joints[k])] = Taylor::symbol(c, radius, k);
    d.radius.push_back(radius);
  }
  const std::size_t entries = static_cast<std::size_t>(d.n * d.n);
  d.M.resize(entries);
  if (std::holds_alternative<Planar2RParameters>(model.structure)) {  // one searched joint: no split to choose
    mass_matrix_of(model, q.data(), d.M.data());
    d.sensitivity = sensitivities(d.M, d.m);
    if (tensors) {
      d.N.resize(entries * static_cast<std::size_t>(d.n));
      coriolis_tensors_of(model, q.data(), d.N.data());
    }
    return d;
  }
  if (!tensors) {  // M alone: the derivatives' enclosures by intervals, cheaper than on forms
    mass_matrix_of(model, q.data(), d.M.data());
    std::vector<Interval> qi(static_cast<std::size_t>(d.n));
    for (int i = 0; i < d.n; ++i) qi[i] = Interval(s.fixed_q(i));
    for (int k = 0; k < d.m; ++k) qi[static_cast<std::size_t>(s.joints[k])] = box[k];
    const std::vector<Dual<Interval>> M = mass_matrix_with_derivatives(model, s.joints, qi.data());
    d.sensitivity.assign(static_cast<std::size_t>(d.m), 0.0);
    for (std::size_t e = 0; e < entries; ++e)
      for (int k = 0; k < d.m; ++k) d.sensitivity[k] += d.radius[k] * boost::numeric::norm(M[e].derivative[k]);
    return d;
  }
  const std::vector<Dual<Taylor>> M = mass_matrix_with_derivatives(model, s.joints, q.data());
  d.sensitivity.assign(static_cast<std::size_t>(d.m), 0.0);
  for (std::size_t e = 0; e < entries; ++e) {
    d.M[e] = M[e].value;
    for (int k = 0; k < d.m; ++k) d.sensitivity[k] += d.radius[k] * (std::abs(M[e].derivative[k].c) + M[e].derivative[k].radius());
  }
  d.N.resize(entries * static_cast<std::size_t>(d.n));
  christoffel_tensors_from(d.n, s.joints, M, d.N.data());
  return d;
}

// J_j = ∂A/∂v at v = e_j as forms, (J_j)_ik = 2 N_i[j][k]: J(q, w) = Σ_j w_j J_j (docs/theory.md, "The constants").
std::vector<Taylor> unit_jacobian(const BoxDynamics& d, int j) {
  const int n = d.n;
  std::vector<Taylor> J(static_cast<std::size_t>(n * n));
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) J[i * n + k] = 2.0 * d.N[(i * n + j) * n + k];
  return J;
}

// Split where splitting removes most of the bound's excess: each side's first- and second-order variation
// ||G_k||_F + Σ_l ||H_kl||_F (a side along which X is stationary at the centre has no first-order variation, and
// still a curvature), and its share of the third-order remainder: mostly by how much of M's variation comes from it
// (a side M does not depend on adds nothing), a tenth by its width (so that a wide side whose trigonometric
// enclosure went constant is split in the end). The largest over the choices.
void weigh_sides(const TaylorMatrix& X, const BoxDynamics& d, std::vector<double>& weights) {
  weights.resize(X.slopes.size(), 0.0);
  double widths = 0.0, sensitivity = 0.0;
  for (std::size_t k = 0; k < d.radius.size(); ++k) {
    widths += d.radius[k];
    sensitivity += d.sensitivity[k];
  }
  const auto pairs = symbol_pairs(X.symbols());
  std::vector<double> variation(X.slopes.size());
  for (std::size_t k = 0; k < X.slopes.size(); ++k) variation[k] = X.slopes[k].norm();
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    const double h = X.curvatures[p].norm();
    variation[pairs[p].first] += h;
    if (pairs[p].second != pairs[p].first) variation[pairs[p].second] += h;
  }
  for (std::size_t k = 0; k < X.slopes.size(); ++k) {
    const double share = 0.1 * d.radius[k] / widths + (sensitivity > 0.0 ? 0.9 * d.sensitivity[k] / sensitivity : 0.9 * d.radius[k] / widths);
    weights[k] = std::max(weights[k], variation[k] + X.remainder * share);
  }
}

// J_j over the box as Taylor matrices.
std::vector<TaylorMatrix> unit_jacobians(const BoxDynamics& d) {
  std::vector<TaylorMatrix> J;
  for (int j = 0; j < d.n; ++j) J.push_back(taylor_matrix(unit_jacobian(d, j).data(), d.n, d.n, d.m));
  return J;
}

// A proven lower bound of λmin(M) over the box (the model's inertia floor where that is higher).
double inertia_lower(const Model& model, const BoxDynamics& d, std::vector<double>* weights) {
  const TaylorMatrix M = taylor_matrix(d.M.data(), d.n, d.n, d.m);
  if (weights) weigh_sides(M, d, *weights);
  return std::max(smallest_eigenvalue_lower(M), inertia_floor(model));
}

// Where M⁻¹ cannot be enclosed (a box too wide for the Neumann series): ||M⁻¹(J D + F)|| <= (||J|| + ||F||) / λmin(M),
// finite once M is proven positive definite on the box.
BoxBound lipschitz_by_inertia_floor(const Model& model, const BoxDynamics& d, const std::vector<TaylorMatrix>& J,
                                    const Eigen::MatrixXd& vertices, unsigned first, unsigned count) {
  BoxBound bound{kInfinity, {}};
  const double lambda = inertia_lower(model, d, &bound.split_weight);
  if (!(lambda > 0.0)) return bound;
  double J_norm = 0.0;
  const std::vector<double> J_frobenius = frobenius_uppers(J);
  for (unsigned c = first; c < count; ++c)
    J_norm = std::max(J_norm, norm_upper(linear_combination(J, vertices.col(c), J_frobenius), kInfinity));
  bound.upper = ((Interval(J_norm) + Interval(spectral_norm_upper(model.friction))) / Interval(lambda)).upper();
  return bound;
}

// Column norms of A D + R term by term (the centre, each symbol's slope, each pair's curvature), with A's column j
// kept (d_j = 1) or dropped (d_j = 0): for any pattern, the centre's Frobenius norm and the variation
// Σ ||slope||_F + Σ ||curvature||_F + remainders over the box, without forming A D + R.
class PatternColumns {
 public:
  PatternColumns(const TaylorMatrix& A, const TaylorMatrix& R) : remainder_(A.remainder + R.remainder) {
    const auto terms = static_cast<Eigen::Index>(1 + A.slopes.size() + A.curvatures.size());
    on_.resize(terms, A.centre.cols());
    off_.resize(terms, A.centre.cols());
    const auto term = [](const TaylorMatrix& X, Eigen::Index t) -> const Eigen::MatrixXd& {
      if (t == 0) return X.centre;
      const auto k = static_cast<std::size_t>(t - 1);
      return k < X.slopes.size() ? X.slopes[k] : X.curvatures[k - X.slopes.size()];
    };
    for (Eigen::Index t = 0; t < terms; ++t) {
      on_.row(t) = (term(A, t) + term(R, t)).colwise().norm();
      off_.row(t) = term(R, t).colwise().norm();
    }
  }
  // Pattern `bits` (bit j: d_j = 1): the centre's Frobenius norm, and the variation. Each a sum of norms rounded up
  // (relative errors of a few ulps per norm, covered by the inflation).
  struct Sizes {
    double centre, variation;
  };
  Sizes pattern(unsigned bits) const {
    const Eigen::MatrixXd c = chosen(bits);
    return {up(c.row(0).norm()), up(c.bottomRows(c.rows() - 1).rowwise().norm().sum() + remainder_)};
  }

 private:
  Eigen::MatrixXd chosen(unsigned bits) const {
    Eigen::MatrixXd c = off_;
    for (Eigen::Index j = 0; j < on_.cols(); ++j)
      if ((bits >> j) & 1u) c.col(j) = on_.col(j);
    return c;
  }
  static double up(double x) { return (x * (1.0 + 0x1p-40)) * kTaylorInflation + kTaylorUnderflow; }
  Eigen::MatrixXd on_, off_;
  double remainder_;
};

// True when ||C||₂ <= t is proven from G, the Gram matrix CᵀC formed in floating point from terms of total size
// `magnitude` (Σ of their Frobenius norms, squared): a floating-point Cholesky factorisation of (t² - μ) I - G
// completes, with μ = 10⁻¹⁰ (t² + magnitude) far above the rounding of G and of the factorisation
// (docs/theory.md, "Cheap bounds of the choices").
bool centre_norm_below(const Eigen::MatrixXd& G, double t, double magnitude) {
  if (!(t > 0.0) || !std::isfinite(t) || !G.allFinite()) return false;
  const double mu = 1e-10 * (t * t + magnitude);
  Eigen::MatrixXd B = -G;
  B.diagonal().array() += t * t - mu;
  return Eigen::LLT<Eigen::MatrixXd>(B).info() == Eigen::Success;
}

// One choice of velocity vertex and saturation pattern (bit j: d_j = 1): its cheap (Frobenius) bound and the part of
// it that is the variation over the box.
struct Choice {
  double cheap, variation;
  unsigned vertex, bits;
};

// The largest bound over the choices, refined in decreasing order of their cheap bounds: once the next cheap bound
// cannot beat the best refined one (or the value attained elsewhere, `lower`), neither can any after it.
// `refine(choice, floor)` returns an upper bound of the choice's supremum, or `floor` when it is proven not above it.
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
  const double n2 = static_cast<double>(n * n), terms = 1.0 + m + pair_count(m);  // a Taylor matrix's n x n parts
  const BoxCosts core{7e-6 * n2, 77e-6 * n2, 1.25e-6 + 11e-9 * n2 * terms, 0.09e-6 + 8.5e-9 * n * terms};
  return {core.inertia / 2, core.tensors / 2, core.refinement / 2, core.choice / 2};
}

DiagonalScaling diagonal_scaling(const Eigen::VectorXd& t) {
  DiagonalScaling s{t, t.cwiseInverse(), 0.0, 0.0};
  const UpwardRounding upward;
  for (Eigen::Index k = 0; k < t.size(); ++k)
    s.restore = std::max(s.restore, (Interval(1.0) / (Interval(s.columns(k)) * Interval(t(k)))).upper());
  s.stretch = (Interval(t.maxCoeff()) * Interval(s.columns.maxCoeff())).upper();
  return s;
}

BoxBounds::BoxBounds(const Model& model, const JointSearch& search, const Eigen::VectorXd& velocity_bounds,
                     const Eigen::VectorXd& scaling)
    : model_(model), search_(search), velocity_bounds_(velocity_bounds), vertices_(box_vertices(velocity_bounds)),
      count_(static_cast<unsigned>(vertices_.cols())), half_(count_ / 2), frictionless_(model.friction.isZero(0.0)),
      costs_(box_costs(model.dof(), static_cast<int>(search.joints.size()))) {
  if (scaling.size()) scaling_ = diagonal_scaling(scaling);
}

BoxBound BoxBounds::inverse_inertia(const std::vector<Interval>& box) const {
  BoxBound bound{kInfinity, {}, costs_.inertia + costs_.refinement};
  const double lambda = inertia_lower(model_, box_dynamics(model_, search_, box, false), &bound.split_weight);
  if (lambda > 0.0) bound.upper = (Interval(1.0) / Interval(lambda)).upper();
  return bound;
}

BoxBound BoxBounds::jacobian(const std::vector<Interval>& box, double lower) const {
  const BoxDynamics d = box_dynamics(model_, search_, box, true);
  const std::vector<TaylorMatrix> J = unit_jacobians(d);
  const std::vector<double> J_frobenius = frobenius_uppers(J);
  BoxBound bound{0.0, {}, costs_.tensors};
  for (unsigned c = half_; c < count_; ++c) {
    const TaylorMatrix Jw = linear_combination(J, vertices_.col(c), J_frobenius);
    weigh_sides(Jw, d, bound.split_weight);
    const double floor = std::max(bound.upper, lower);
    bound.work += costs_.choice + (Jw.frobenius_upper() > floor ? costs_.refinement : 0.0);
    bound.upper = std::max(bound.upper, norm_upper(Jw, floor));
  }
  return bound;
}

namespace {

// Φ = M⁻¹(J(w) D + F) = Σ_j w_j A_j D + R over a box, A_j = M⁻¹ J_j and R = M⁻¹ F as Taylor matrices of M⁻¹'s
// second-order part; M⁻¹'s third-order tail T (||T|| <= inverse tail) adds T (J(w) D + F), of norm at most
// tail · sup ||J(w) D + F|| over the box and every choice: `tail`, added once to every choice's bound.
struct LipschitzTerms {
  std::vector<TaylorMatrix> A;
  TaylorMatrix R;
  double tail = 0.0;
};

// With a scaling, the terms are T A_j S and T R S, and the tail's matrix is stretched by at most max t · max s.
LipschitzTerms lipschitz_terms(const Model& model, const BoxDynamics& d, const std::vector<TaylorMatrix>& J,
                               const Eigen::VectorXd& velocity_bounds, const TaylorInverse& inverse_M,
                               const DiagonalScaling* scaling = nullptr) {
  LipschitzTerms t;
  const auto times_inverse = [&](const std::vector<Taylor>& Y) {
    std::vector<Taylor> X = product(inverse_M.entries, Y, d.n, d.n, d.n);
    if (scaling)
      for (int i = 0; i < d.n; ++i)
        for (int k = 0; k < d.n; ++k) X[i * d.n + k] = (X[i * d.n + k] * scaling->rows(i)) * scaling->columns(k);
    return taylor_matrix(X.data(), d.n, d.n, d.m);
  };
  for (int j = 0; j < d.n; ++j) t.A.push_back(times_inverse(unit_jacobian(d, j)));
  std::vector<Taylor> F(static_cast<std::size_t>(d.n * d.n));
  for (int i = 0; i < d.n * d.n; ++i) F[i] = Taylor(model.friction(i / d.n, i % d.n));
  t.R = times_inverse(F);
  const UpwardRounding upward;
  t.tail = (Interval(inverse_M.tail) * Interval(every_choice_upper(J, velocity_bounds, taylor_matrix(F.data(), d.n, d.n, d.m)))).upper();
  if (scaling) t.tail = (Interval(t.tail) * Interval(scaling->stretch)).upper();
  return t;
}

// The velocity box's vertices to visit (columns first..count-1), and whether F = 0 (then only the full pattern).
struct VelocityChoices {
  const Eigen::MatrixXd& vertices;
  unsigned first, count;
  bool frictionless;
  const BoxCosts& costs;
};

// The centre's Gram blocks of one vertex, A = A(w) at the centre and R: (A D + R)ᵀ(A D + R) = D AᵀA D + D AᵀR + RᵀA D + RᵀR
// for every pattern D, with the size of the terms (||A||_F + ||R||_F)².
struct CentreGram {
  Eigen::MatrixXd AA, AR;
  double magnitude;
};

// The maximum over the vertices w and the saturation patterns D of ||A(w) D + R||. Each choice's cheap bound first;
// a choice whose cheap bound beats the running maximum is then tested on its centre (a Cholesky test, O(n³/6)), and
// refined (norm_upper) only when the centre's norm plus the variation may beat it.
double choices_upper(const LipschitzTerms& t, const BoxDynamics& d, const VelocityChoices& v, double lower,
                     std::vector<double>& weights, double& work) {
  std::vector<TaylorMatrix> Aw;
  const std::vector<double> A_frobenius = frobenius_uppers(t.A);
  std::vector<double> Aw_frobenius;
  std::vector<CentreGram> grams;
  std::vector<Choice> choices;
  const Eigen::MatrixXd RR = t.R.centre.transpose() * t.R.centre;
  for (unsigned c = v.first; c < v.count; ++c) {
    Aw.push_back(linear_combination(t.A, v.vertices.col(c), A_frobenius));
    Aw_frobenius.push_back(Aw.back().frobenius_upper());
    weigh_sides(Aw.back(), d, weights);
    const Eigen::MatrixXd& A = Aw.back().centre;
    const double size = A.norm() + t.R.centre.norm();
    grams.push_back({A.transpose() * A, A.transpose() * t.R.centre, size * size});
    const auto index = static_cast<unsigned>(Aw.size() - 1);
    const PatternColumns columns(Aw.back(), t.R);
    const unsigned full = (1u << d.n) - 1;
    for (unsigned bits = v.frictionless ? full : 0u; bits <= full; ++bits) {
      const PatternColumns::Sizes sizes = columns.pattern(bits);
      choices.push_back({(sizes.centre + sizes.variation) * kTaylorInflation, sizes.variation, index, bits});
    }
  }
  work += static_cast<double>(choices.size()) * v.costs.choice;
  int refined = 0, full = 0;
  const double R_frobenius = t.R.frobenius_upper();
  TaylorMatrix X;  // the refined choice's Φ, its storage reused
  const double upper = refine_choices(choices, lower, [&](const Choice& choice, double floor) {
    Eigen::VectorXd D(d.n);
    for (int j = 0; j < d.n; ++j) D(j) = (choice.bits >> j) & 1u;
    const CentreGram& g = grams[choice.vertex];
    const Eigen::MatrixXd G = D.asDiagonal() * g.AA * D.asDiagonal() + D.asDiagonal() * g.AR +
                              g.AR.transpose() * D.asDiagonal() + RR;
    if (centre_norm_below(G, floor - choice.variation, g.magnitude)) return floor;
    ++full;
    scaled_sum(Aw[choice.vertex], D, t.R, Aw_frobenius[choice.vertex] + R_frobenius, X);
    return norm_upper(X, floor);
  }, refined);
  work += refined * v.costs.choice + full * v.costs.refinement;
  return upper;
}

}  // namespace

// L_joint over a box. On a wide box the product M⁻¹ J carries both factors' remainders, and the inertia route
// (||J|| + ||F||) / λmin(M) can be the tighter: where the cheap bound is far above the value attained, both are
// taken.
// With a scaling T, every bound below is of ||T Φ S|| (the inertia route's of ||Φ|| times the stretch), and
// `restored` turns it into a bound of ||T Φ T⁻¹||. Without one both factors are 1 and the products exact.
BoxBound BoxBounds::joint_lipschitz(const std::vector<Interval>& box, double lower) const {
  const DiagonalScaling none{};
  const DiagonalScaling& scaling = scaling_ ? *scaling_ : none;
  const auto restored = [&](BoxBound bound) {
    bound.upper = (Interval(bound.upper) * Interval(scaling.restore)).upper();
    return bound;
  };
  const auto by_inertia_floor = [&](const BoxDynamics& d, const std::vector<TaylorMatrix>& J) {
    BoxBound bound = lipschitz_by_inertia_floor(model_, d, J, vertices_, half_, count_);
    bound.upper = (Interval(bound.upper) * Interval(scaling.stretch)).upper();
    return bound;
  };
  const BoxDynamics d = box_dynamics(model_, search_, box, true);
  const std::vector<TaylorMatrix> J = unit_jacobians(d);
  const TaylorInverse inverse_M = inverse(d.M, d.n, d.m);
  const double inertia_route_work = costs_.refinement * (1.0 + count_ - half_);
  if (!inverse_M.proven) {
    BoxBound bound = by_inertia_floor(d, J);
    bound.work = costs_.tensors + inertia_route_work;
    return restored(std::move(bound));
  }
  const LipschitzTerms t = lipschitz_terms(model_, d, J, velocity_bounds_, inverse_M, scaling_ ? &*scaling_ : nullptr);
  const UpwardRounding upward;
  BoxBound bound{every_choice_upper(t.A, velocity_bounds_, t.R) + t.tail, {}, costs_.tensors};
  if (bound.upper <= lower) {  // cannot beat the value attained: no choice needs enumerating
    weigh_sides(linear_combination(t.A, velocity_bounds_, frobenius_uppers(t.A)), d, bound.split_weight);
    return restored(std::move(bound));
  }
  double cap = kInfinity;
  if (bound.upper > 2.0 * lower) {
    BoxBound by_inertia = by_inertia_floor(d, J);
    bound.work += inertia_route_work;
    if (by_inertia.upper <= lower) return restored({by_inertia.upper, std::move(by_inertia.split_weight), bound.work});
    cap = by_inertia.upper;
  }
  const VelocityChoices choices{vertices_, frictionless_ ? half_ : 0u, count_, frictionless_, costs_};
  const double polynomial = choices_upper(t, d, choices, lower - t.tail, bound.split_weight, bound.work);
  bound.upper = std::min(cap, polynomial + t.tail);
  return restored(std::move(bound));
}

}  // namespace obsgain

namespace obsgain {

PolytopeCell BoxBounds::perturbation_cell(const std::vector<Interval>& box) const {
  const BoxDynamics d = box_dynamics(model_, search_, box, true);
  const TaylorInverse inverse_M = inverse(d.M, d.n, d.m);
  PolytopeCell cell;
  cell.box = box;
  if (!inverse_M.proven) return cell;
  const LipschitzTerms t = lipschitz_terms(model_, d, unit_jacobians(d), velocity_bounds_, inverse_M);
  cell.constant = -t.R.centre;
  for (const TaylorMatrix& A : t.A) cell.slopes.push_back(-A.centre);
  const UpwardRounding upward;
  // M⁻¹'s tail adds a matrix of norm <= t.tail to Φ, hence at most t.tail to every entry.
  cell.radius = (t.R.spread().array() + t.tail).matrix();
  for (int j = 0; j < d.n; ++j) cell.radius += velocity_bounds_(j) * t.A[j].spread();
  cell.radius += point_rounding(cell, velocity_bounds_);
  cell.proven = true;
  return cell;
}

}  // namespace obsgain
