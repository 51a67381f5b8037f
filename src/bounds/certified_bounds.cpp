#include "obsgain/bounds/certified_bounds.hpp"

#include "obsgain/bounds/enclosures.hpp"
#include "obsgain/model/dynamics.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

namespace obsgain {

namespace {

using boost::numeric::square;

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The floating-point eigensolvers are backward stable: their error is a small multiple of n ε ||X||, far
// below this relative pad for the sizes obsgain accepts (n <= 16).
constexpr double kEigenPad = 1e-12;

Interval magnitude_interval(const Interval& x) { return Interval(boost::numeric::norm(x)); }

// max |x - centre| over x, rounded up.
double radius_about(const Interval& x, double centre) {
  return std::max((Interval(x.upper()) - Interval(centre)).upper(), (Interval(centre) - Interval(x.lower())).upper());
}

// ||mid X||₂ computed in floating point, padded, plus ||rad X||_F (rounded up): an upper bound for every X
// in the interval matrix (Weyl).
double weyl_norm_upper_bound(const IntervalMatrix& X) {
  Eigen::MatrixXd mid(X.rows(), X.cols());
  Interval radius2(0.0);
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    for (Eigen::Index j = 0; j < X.cols(); ++j) {
      mid(i, j) = centre(X(i, j));
      radius2 += square(Interval(radius_about(X(i, j), mid(i, j))));
    }
  const double m = mid.operatorNorm();
  return (Interval(m) * Interval(1.0 + kEigenPad) + boost::numeric::sqrt(radius2)).upper();
}

// Frobenius norm, rounded up: a cheap upper bound of ||X||₂ used to skip choices before an eigensolve.
double frobenius_upper_bound(const IntervalMatrix& X) {
  Interval sum(0.0);
  for (Eigen::Index i = 0; i < X.size(); ++i) sum += square(magnitude_interval(X(i)));
  return boost::numeric::sqrt(sum).upper();
}

}  // namespace

double norm_upper_bound(const IntervalMatrix& X) {
  if (X.rows() != 2 || X.cols() != 2) return weyl_norm_upper_bound(X);
  // λmax(XᵀX) = (p + r)/2 + sqrt(((p - r)/2)² + s²) with XᵀX = [[p, s], [s, r]].
  const Interval p = square(X(0, 0)) + square(X(1, 0));
  const Interval r = square(X(0, 1)) + square(X(1, 1));
  const Interval s = X(0, 0) * X(0, 1) + X(1, 0) * X(1, 1);
  const Interval lambda = (p + r) / 2.0 + boost::numeric::sqrt(square((p - r) / 2.0) + square(s));
  // Both are valid upper bounds; the closed form wins on wide boxes, Weyl's on narrow ones (no dependency).
  return std::min(boost::numeric::sqrt(lambda).upper(), weyl_norm_upper_bound(X));
}

double smallest_eigenvalue_lower_bound(const IntervalMatrix& M) {
  if (M.rows() == 2) {
    const Interval a = M(0, 0), b = M(0, 1), c = M(1, 1);
    return ((a + c) / 2.0 - boost::numeric::sqrt(square((a - c) / 2.0) + square(b))).lower();
  }
  // Weyl: λmin(M) >= λmin(mid M) - ||rad M||_F, with a pad for the floating-point eigenvalue.
  Eigen::MatrixXd mid(M.rows(), M.cols());
  Interval radius2(0.0);
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    for (Eigen::Index j = 0; j < M.cols(); ++j) {
      mid(i, j) = centre(M(i, j));
      radius2 += square(Interval(radius_about(M(i, j), mid(i, j))));
    }
  const Eigen::VectorXd lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(mid).eigenvalues();
  const double pad = kEigenPad * lambda.cwiseAbs().maxCoeff();
  return (Interval(lambda(0)) - Interval(pad) - boost::numeric::sqrt(radius2)).lower();
}

namespace {

IntervalMatrix product(const IntervalMatrix& A, const IntervalMatrix& B) {
  IntervalMatrix C(A.rows(), B.cols());
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    for (Eigen::Index j = 0; j < B.cols(); ++j) {
      Interval sum(0.0);
      for (Eigen::Index k = 0; k < A.cols(); ++k) sum += A(i, k) * B(k, j);
      C(i, j) = sum;
    }
  return C;
}

IntervalMatrix to_interval(const Eigen::MatrixXd& A) { return A.cast<Interval>(); }

// Both contain the true values, so their intersection does too (never empty in exact arithmetic; if rounding
// ever made it so, keep the first).
IntervalMatrix intersection(const IntervalMatrix& A, const IntervalMatrix& B) {
  IntervalMatrix C = A;
  for (Eigen::Index i = 0; i < A.size(); ++i) {
    const double lo = std::max(A(i).lower(), B(i).lower()), hi = std::min(A(i).upper(), B(i).upper());
    if (lo <= hi) C(i) = Interval(lo, hi);
  }
  return C;
}

// A matrix function over a box in centred form: X(q) = X(m) + Σ_k S_k (q_k - m_k) with S_k ∈ slope[k]
// (the mean-value theorem, entry by entry), and the natural enclosure `box` as a safeguard.
struct Centred {
  IntervalMatrix box, mid;
  std::vector<IntervalMatrix> slope;
};

// t_k = q_k - m_k over the box (outward rounded).
using Offsets = std::vector<Interval>;

IntervalMatrix enclosure(const Centred& c, const Offsets& t) {
  IntervalMatrix sum = c.mid;
  for (std::size_t k = 0; k < t.size(); ++k) sum += c.slope[k] * t[k];
  return intersection(c.box, sum);
}

// The second-order refinement: ||X(m) + Σ mid(S_k) t_k|| is convex in t, so its maximum over the box of t
// sits at a corner; the rest, Σ (S_k - mid S_k) t_k, is bounded by ||Σ rad(S_k) |t_k|||_F. Its excess over the
// true supremum shrinks quadratically with the box (the slopes' widths times the box's).
template <class CornerBound>
double centred_corners(const Centred& c, const Offsets& t, CornerBound&& corner_bound, bool maximum) {
  const auto m = static_cast<int>(t.size());
  const Eigen::Index rows = c.mid.rows(), cols = c.mid.cols();
  IntervalMatrix remainder_sum = IntervalMatrix::Constant(rows, cols, Interval(0.0));
  for (int k = 0; k < m; ++k) {
    const double reach = boost::numeric::norm(t[k]);
    for (Eigen::Index i = 0; i < c.mid.size(); ++i)
      remainder_sum(i) += Interval(radius_about(c.slope[k](i), centre(c.slope[k](i)))) * reach;
  }
  const double rest = frobenius_upper_bound(remainder_sum);
  double best = maximum ? -kInfinity : kInfinity;
  for (unsigned corner = 0; corner < (1u << m); ++corner) {
    IntervalMatrix Y = c.mid;
    for (int k = 0; k < m; ++k) {
      const Interval tk((corner >> k) & 1u ? t[k].upper() : t[k].lower());
      for (Eigen::Index i = 0; i < Y.size(); ++i) Y(i) += Interval(centre(c.slope[k](i))) * tk;
    }
    const double value = corner_bound(Y);
    best = maximum ? std::max(best, value) : std::min(best, value);
  }
  return maximum ? (Interval(best) + Interval(rest)).upper() : (Interval(best) - Interval(rest)).lower();
}

// Corners are 2^m eigen-solves: worth it only on boxes narrow enough for the quadratic term to win.
constexpr int kMaxCornerDimensions = 6;

double centred_norm_upper(const Centred& c, const Offsets& t) {
  double bound = norm_upper_bound(enclosure(c, t));
  if (static_cast<int>(t.size()) <= kMaxCornerDimensions)
    bound = std::min(bound, centred_corners(c, t, [](const IntervalMatrix& Y) { return weyl_norm_upper_bound(Y); }, true));
  return bound;
}

double centred_smallest_eigenvalue_lower(const Centred& c, const Offsets& t) {
  double bound = smallest_eigenvalue_lower_bound(enclosure(c, t));
  if (static_cast<int>(t.size()) <= kMaxCornerDimensions)
    bound = std::max(bound, centred_corners(c, t, [](const IntervalMatrix& Y) { return smallest_eigenvalue_lower_bound(Y); },
                                            false));
  return bound;
}

// Encloses M⁻¹ for every M in an interval matrix: with C ≈ mid(M)⁻¹ and E = I - C M, ||E||_∞ = ε < 1,
// M⁻¹ = (I - E)⁻¹ C = C + E C + E² (I - E)⁻¹ C, and every entry of the last term is at most ε² ||C||_∞ / (1 - ε).
std::optional<IntervalMatrix> inverse_enclosure(const IntervalMatrix& M) {
  const Eigen::Index n = M.rows();
  Eigen::MatrixXd mid(n, n);
  for (Eigen::Index i = 0; i < M.size(); ++i) mid(i) = centre(M(i));
  const Eigen::MatrixXd C = mid.inverse();
  if (!C.allFinite()) return std::nullopt;
  const IntervalMatrix Ci = to_interval(C);
  IntervalMatrix E = -product(Ci, M);
  for (Eigen::Index i = 0; i < n; ++i) E(i, i) += 1.0;
  Interval epsilon(0.0), c_norm(0.0);
  for (Eigen::Index i = 0; i < n; ++i) {
    Interval row(0.0), c_row(0.0);
    for (Eigen::Index j = 0; j < n; ++j) {
      row += magnitude_interval(E(i, j));
      c_row += Interval(std::abs(C(i, j)));
    }
    epsilon = Interval(std::max(epsilon.upper(), row.upper()));
    c_norm = Interval(std::max(c_norm.upper(), c_row.upper()));
  }
  if (!(epsilon.upper() < 1.0)) return std::nullopt;
  const double tail = (square(epsilon) * c_norm / (Interval(1.0) - epsilon)).upper();
  IntervalMatrix inverse = Ci + product(E, Ci);
  for (Eigen::Index i = 0; i < inverse.size(); ++i) inverse(i) += Interval(-tail, tail);
  return inverse;
}

// The searched joints' box, the full configuration as duals (the box, and its midpoint without directions),
// and the offsets q - m.
struct BoxPoint {
  std::vector<DualInterval> box, mid;
  Offsets offsets;
  Eigen::VectorXd midpoint;
};

struct SearchDomain {
  std::vector<int> joints;
  Eigen::VectorXd fixed_q;
  std::vector<Interval> domain;
};

BoxPoint box_point(const SearchDomain& s, const std::vector<Interval>& x) {
  const auto m = static_cast<int>(x.size());
  BoxPoint b;
  b.midpoint = s.fixed_q;
  for (Eigen::Index i = 0; i < s.fixed_q.size(); ++i) {
    b.box.emplace_back(Interval(s.fixed_q(i)));
    b.mid.emplace_back(Interval(s.fixed_q(i)));
  }
  for (int k = 0; k < m; ++k) {
    const double c = centre(x[k]);
    b.box[s.joints[k]] = DualInterval::variable(x[k], k, m);
    b.mid[s.joints[k]] = DualInterval(Interval(c));
    b.midpoint(s.joints[k]) = c;
    b.offsets.push_back(x[k] - Interval(c));
  }
  return b;
}

// The vertex/pattern structure of B and L_joint (docs/theory.md, "The constants"): J(q, w) = 2 [wᵀN_1; …; wᵀN_n] is linear in
// the tensors, so its centred form follows from theirs.
IntervalMatrix jacobian_of(const std::vector<IntervalMatrix>& N, const Eigen::VectorXd& w) {
  const auto n = static_cast<Eigen::Index>(N.size());
  IntervalMatrix J(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index k = 0; k < n; ++k) {
      Interval sum(0.0);
      for (Eigen::Index j = 0; j < n; ++j) sum += N[i](k, j) * w(j);
      J(i, k) = 2.0 * sum;
    }
  return J;
}

struct TensorEnclosure {
  std::vector<IntervalMatrix> box, mid;
  std::vector<std::vector<IntervalMatrix>> slope;  // [direction][i]
};

TensorEnclosure tensors_over(const Model& model, const BoxPoint& b) {
  TensorEnclosure t;
  const std::vector<MatrixEnclosure> over_box = coriolis_tensor_enclosures(model, b.box);
  const std::vector<MatrixEnclosure> at_mid = coriolis_tensor_enclosures(model, b.mid);
  t.slope.resize(b.offsets.size());
  for (std::size_t i = 0; i < over_box.size(); ++i) {
    t.box.push_back(over_box[i].value);
    t.mid.push_back(at_mid[i].value);
    for (std::size_t k = 0; k < b.offsets.size(); ++k) t.slope[k].push_back(over_box[i].derivative[k]);
  }
  return t;
}

Centred jacobian_centred(const TensorEnclosure& t, const Eigen::VectorXd& w) {
  Centred c{jacobian_of(t.box, w), jacobian_of(t.mid, w), {}};
  for (const auto& slope : t.slope) c.slope.push_back(jacobian_of(slope, w));
  return c;
}

Centred mass_centred(const Model& model, const BoxPoint& b) {
  const MatrixEnclosure over_box = mass_matrix_enclosure(model, b.box);
  return {over_box.value, mass_matrix_enclosure(model, b.mid).value, over_box.derivative};
}

// Per searched side: Σ width(∂X/∂q_k) |q_k - m_k| over the entries, the side's share of the centred form's remainder.
void add_smear(const Centred& c, const Offsets& t, double weight, std::vector<double>& smear) {
  smear.resize(t.size(), 0.0);
  for (std::size_t k = 0; k < t.size(); ++k) {
    double sum = 0.0;
    for (Eigen::Index i = 0; i < c.slope[k].size(); ++i) sum += boost::numeric::width(c.slope[k](i));
    smear[k] += weight * sum * boost::numeric::norm(t[k]);
  }
}

// One bound's search: the generic branch and bound over the searched joints, with `upper` and `point` seeing the
// full configuration.
BoundBracket search(const SearchDomain& s, const std::function<BoxBound(const BoxPoint&, double)>& upper,
                    const std::function<double(const Eigen::VectorXd&)>& point, const Eigen::VectorXd& seed,
                    const CertifiedOptions& options, std::chrono::steady_clock::time_point deadline, const char* name) {
  const auto full = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd q = s.fixed_q;
    for (std::size_t k = 0; k < s.joints.size(); ++k) q(s.joints[k]) = x(static_cast<Eigen::Index>(k));
    return q;
  };
  BranchAndBoundProblem problem;
  problem.domain = s.domain;
  problem.bound = [&](const std::vector<Interval>& box, double lower) { return upper(box_point(s, box), lower); };
  problem.value = [&](const Eigen::VectorXd& x) { return point(full(x)); };
  Eigen::VectorXd seed_x(static_cast<Eigen::Index>(s.joints.size()));
  for (std::size_t k = 0; k < s.joints.size(); ++k) seed_x(static_cast<Eigen::Index>(k)) = seed(s.joints[k]);
  BranchAndBoundOptions o;
  o.relative_gap = options.relative_gap;
  o.max_boxes = options.max_boxes;
  o.deadline = deadline;
  o.threads = options.threads;
  o.name = name;
  o.progress = options.progress;
  const BranchAndBoundResult r = branch_and_bound(problem, seed_x, o);
  return {r.lower, r.upper, full(r.argmax), r.boxes, r.seconds, r.stop};
}

// A continuous joint's period, widened by an ulp so that the rounded π leaves no sliver of the circle out.
Interval search_interval(const JointDomain& joint) {
  if (!joint.continuous) return Interval(joint.lower, joint.upper);
  const double pi_up = std::nextafter(std::numbers::pi, kInfinity);
  return Interval(-pi_up, pi_up);
}

}  // namespace

std::string certification_unavailable(const Model& model) {
  if (static_cast<int>(configuration_joints(model).size()) > kMaxDirections)
    return fmt::format("model '{}' depends on {} joint positions; certified bounds search at most {}", model.name,
                       configuration_joints(model).size(), kMaxDirections);
  return {};
}

namespace {

// What every bound's box evaluation shares: the model, the velocity vertices and which of them matter.
struct VertexContext {
  const Model& model;
  Eigen::MatrixXd vertices;
  // J(q, -w) = -J(q, w): the vertices with w_n < 0 repeat the others for ||J||, and for ||M⁻¹(J D + F)|| too
  // when F = 0 (as in compute_bounds).
  unsigned count, half;
  bool frictionless;
  IntervalMatrix F;
  VertexContext(const Model& m, const Eigen::VectorXd& V)
      : model(m), vertices(box_vertices(V)), count(static_cast<unsigned>(vertices.cols())), half(count / 2),
        frictionless(m.friction.isZero(0.0)), F(to_interval(m.friction)) {}
};

// ||M⁻¹(J D + F)|| <= (||J|| + ||F||) / λmin(M), for boxes where M varies too much for a Neumann enclosure of M⁻¹
// (ill-conditioned inertia on a wide box): finite as soon as M is proven positive definite.
BoxBound lipschitz_by_inertia_floor(const VertexContext& v, const BoxPoint& b, const Centred& M, const TensorEnclosure& t) {
  BoxBound bound{kInfinity, {}};
  add_smear(M, b.offsets, 1.0, bound.split_weight);
  const double lambda = std::max(centred_smallest_eigenvalue_lower(M, b.offsets), inertia_floor(v.model));
  if (!(lambda > 0.0)) return bound;
  double J_norm = 0.0;
  for (unsigned c = v.half; c < v.count; ++c)
    J_norm = std::max(J_norm, norm_upper_bound(enclosure(jacobian_centred(t, v.vertices.col(c)), b.offsets)));
  bound.upper = ((Interval(J_norm) + Interval(norm_upper_bound(v.F))) / Interval(lambda)).upper();
  return bound;
}

// The bound of ||A D + R|| over the saturation patterns D of one vertex, at least `best` (the box's running value);
// a pattern whose cheap bound cannot beat max(best, lower) is not refined (its cheap bound still counts).
double patterns_bound(const VertexContext& v, const BoxPoint& b, const Centred& A, const Centred& R, double best,
                      double lower) {
  const int n = v.model.dof();
  const unsigned last_pattern = v.frictionless ? v.count - 1 : 0u;
  // Full patterns first: with F = 0 the full pattern is the maximum (||A D|| <= ||A||) and the only one searched;
  // in general it usually wins, so that a high running value lets the cheap bound skip most of the others.
  for (unsigned pattern = v.count; pattern-- > last_pattern;) {
    const auto select = [&](const IntervalMatrix& a, const IntervalMatrix& r) {
      IntervalMatrix x = r;
      for (int j = 0; j < n; ++j)
        if ((pattern >> j) & 1u) x.col(j) += a.col(j);
      return x;
    };
    Centred X{select(A.box, R.box), select(A.mid, R.mid), {}};
    for (std::size_t k = 0; k < b.offsets.size(); ++k) X.slope.push_back(select(A.slope[k], R.slope[k]));
    const IntervalMatrix enclosed = enclosure(X, b.offsets);
    const double floor = std::max(best, lower);
    const double frobenius = frobenius_upper_bound(enclosed);
    if (frobenius <= floor) {
      best = std::max(best, frobenius);
      continue;
    }
    const double cheap = norm_upper_bound(enclosed);
    best = std::max(best, cheap <= floor ? cheap : centred_norm_upper(X, b.offsets));
  }
  return best;
}

// L_joint over a box. X = M⁻¹(J D + F) = A D + R with A = M⁻¹J, R = M⁻¹F; centred forms: ∂A/∂q_k = M⁻¹(∂J_k -
// ∂M_k A), likewise R.
BoxBound joint_lipschitz_upper(const VertexContext& v, const BoxPoint& b, double lower) {
  const int n = v.model.dof();
  const Centred M = mass_centred(v.model, b);
  const auto inverse_box = inverse_enclosure(enclosure(M, b.offsets));
  const auto inverse_mid = inverse_enclosure(M.mid);
  const TensorEnclosure t = tensors_over(v.model, b);
  if (!inverse_box || !inverse_mid) return lipschitz_by_inertia_floor(v, b, M, t);
  const auto m = b.offsets.size();
  const auto left_inverse = [&](const Centred& Y) {
    Centred X{product(*inverse_box, Y.box), product(*inverse_mid, Y.mid), {}};
    for (std::size_t k = 0; k < m; ++k) X.slope.push_back(product(*inverse_box, Y.slope[k] - product(M.slope[k], X.box)));
    return X;
  };
  const Centred R = left_inverse(Centred{v.F, v.F, std::vector<IntervalMatrix>(m, IntervalMatrix::Constant(n, n, Interval(0.0)))});
  BoxBound bound{0.0, {}};
  for (unsigned c = v.frictionless ? v.half : 0u; c < v.count; ++c) {
    const Centred A = left_inverse(jacobian_centred(t, v.vertices.col(c)));
    add_smear(A, b.offsets, 1.0, bound.split_weight);
    bound.upper = patterns_bound(v, b, A, R, bound.upper, lower);
  }
  return bound;
}

// B over a box. A vertex whose cheap bound cannot beat what is already known (this box's best, or the value
// attained elsewhere) changes neither the box's fate nor the bracket: its refinement is skipped (its cheap bound
// still counts, so that the box's value stays an upper bound).
BoxBound jacobian_upper(const VertexContext& v, const BoxPoint& b, double lower) {
  const TensorEnclosure t = tensors_over(v.model, b);
  BoxBound bound{0.0, {}};
  for (unsigned c = v.half; c < v.count; ++c) {
    const Centred J = jacobian_centred(t, v.vertices.col(c));
    add_smear(J, b.offsets, 1.0, bound.split_weight);
    const double cheap = norm_upper_bound(enclosure(J, b.offsets));
    bound.upper = std::max(bound.upper, cheap <= std::max(bound.upper, lower) ? cheap : centred_norm_upper(J, b.offsets));
  }
  return bound;
}

// M0 = sup 1/λmin(M): a box whose M cannot be shown positive definite gets +∞ and is split further.
BoxBound inverse_inertia_upper(const Model& model, const BoxPoint& b) {
  const Centred M = mass_centred(model, b);
  const double lambda = std::max(centred_smallest_eigenvalue_lower(M, b.offsets), inertia_floor(model));
  BoxBound bound{lambda > 0.0 ? (Interval(1.0) / Interval(lambda)).upper() : kInfinity, {}};
  add_smear(M, b.offsets, 1.0, bound.split_weight);
  return bound;
}

// Each bound gets an equal share of what is left of the budget when it starts.
std::chrono::steady_clock::time_point share_of_budget(const CertifiedOptions& options,
                                                      std::chrono::steady_clock::time_point start, int remaining_bounds) {
  if (options.budget_seconds <= 0.0) return std::chrono::steady_clock::time_point::max();
  const auto now = std::chrono::steady_clock::now();
  const double used = std::chrono::duration<double>(now - start).count();
  const double share = std::max(0.0, options.budget_seconds - used) / remaining_bounds;
  return now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(share));
}

SearchDomain configuration_domain(const Model& model) {
  SearchDomain s;
  s.joints = configuration_joints(model);
  s.fixed_q = Eigen::VectorXd::Zero(model.dof());
  for (int j : s.joints) s.domain.push_back(search_interval(model.joints[j]));
  return s;
}

}  // namespace

std::optional<CertifiedBounds> certify_bounds(const Model& model, const BoundReport& numeric,
                                              const CertifiedOptions& options) {
  if (!certification_unavailable(model).empty()) return std::nullopt;
  const Eigen::VectorXd& V = numeric.velocity_bounds;
  const SearchDomain s = configuration_domain(model);
  const VertexContext vertices(model, V);
  const auto start = std::chrono::steady_clock::now();
  CertifiedBounds result;
  // L_joint goes first: the default design rests on it alone (M0 and B only enter L_paper).
  result.L_joint = search(s, [&](const BoxPoint& b, double lower) { return joint_lipschitz_upper(vertices, b, lower); },
                          [&](const Eigen::VectorXd& q) { return max_joint_lipschitz_norm(model, q, V); },
                          numeric.L_joint.q, options, share_of_budget(options, start, 3), "L_joint");
  result.B = search(s, [&](const BoxPoint& b, double lower) { return jacobian_upper(vertices, b, lower); },
                    [&](const Eigen::VectorXd& q) { return max_coriolis_jacobian_norm(model, q, V); }, numeric.B.q,
                    options, share_of_budget(options, start, 2), "B");
  result.M0 = search(s, [&](const BoxPoint& b, double) { return inverse_inertia_upper(model, b); },
                     [&](const Eigen::VectorXd& q) { return inverse_inertia_norm(model, q); }, numeric.M0.q, options,
                     share_of_budget(options, start, 1), "M0");
  return result;
}

void apply_certified_bounds(BoundReport& report, const CertifiedBounds& certified) {
  report.certified = true;
  report.M0_bracket = certified.M0;
  report.B_bracket = certified.B;
  report.L_joint_bracket = certified.L_joint;
  report.M0.value = certified.M0.upper;
  report.B.value = certified.B.upper;
  report.L_paper = (Interval(report.M0.value) * (Interval(report.B.value) + Interval(report.F_norm))).upper();
  // L_joint <= L_paper holds for every q, w, D (docs/theory.md, "The constants"): a proven L_paper bounds L_joint too, and is
  // the smaller of the two when the branch and bound of L_joint ran out of budget on a wide domain.
  if (report.L_paper < report.L_joint_bracket.upper) report.L_joint_bracket.upper = report.L_paper;
  report.L_joint.value = report.L_joint_bracket.upper;
  report.wall_seconds += certified.M0.seconds + certified.B.seconds + certified.L_joint.seconds;
}

namespace {

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
    best = std::max(best, mid.operatorNorm());
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
  SearchDomain s;
  s.fixed_q = Eigen::VectorXd::Zero(n);
  for (int j = 0; j < n; ++j) {
    s.joints.push_back(j);
    s.domain.push_back(search_interval(model.joints[j]));
  }
  std::vector<Interval> a_box, v_box;
  for (int j = 0; j < n; ++j) {
    a_box.emplace_back(-acceleration_bounds(j), acceleration_bounds(j));
    v_box.emplace_back(-velocity_bounds(j), velocity_bounds(j));
  }
  const IntervalMatrix v_products = products_of(v_box);
  const auto box_upper = [&](const BoxPoint& b, double) {
    BoxBound bound{norm_upper_bound(sensitivity_enclosure(sensitivity_terms(model, b.box), a_box, v_products)), {}};
    // No second derivatives to weigh the sides by: split the widest (relative to its domain).
    for (int k = 0; k < n; ++k)
      bound.split_weight.push_back(boost::numeric::width(b.offsets[k]) / boost::numeric::width(s.domain[k]));
    return bound;
  };
  const Eigen::MatrixXd a_vertices = box_vertices(acceleration_bounds), v_vertices = box_vertices(velocity_bounds);
  const auto choices = sensitivity_choices(n, a_vertices.cols(), v_vertices.cols());
  const auto point = [&](const Eigen::VectorXd& q) { return sensitivity_at(model, q, a_vertices, v_vertices, choices); };
  Eigen::VectorXd seed(n);
  for (int j = 0; j < n; ++j) seed(j) = centre(s.domain[j]);
  return search(s, box_upper, point, seed, options, share_of_budget(options, std::chrono::steady_clock::now(), 1), "C_q");
}

}  // namespace obsgain
