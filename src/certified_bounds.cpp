#include "obsgain/certified_bounds.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <numbers>
#include <queue>

namespace obsgain {

namespace {

Interval hull_of(double lo, double hi) { return Interval(lo, hi); }

// ||mid X||₂ computed in floating point, padded for its rounding, plus ||rad X||_F (rounded up): an upper
// bound for every X in the interval matrix (Weyl), used beyond 2 x 2.
double weyl_norm_upper_bound(const IntervalMatrix& X) {
  Eigen::MatrixXd mid(X.rows(), X.cols());
  Interval radius2(0.0);
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    for (Eigen::Index j = 0; j < X.cols(); ++j) {
      mid(i, j) = boost::numeric::median(X(i, j));
      const Interval r = Interval(std::max(X(i, j).upper() - mid(i, j), mid(i, j) - X(i, j).lower()));
      radius2 += boost::numeric::square(r);
    }
  const double m = mid.operatorNorm();
  return (Interval(m) * Interval(1.0 + 1e-13) + boost::numeric::sqrt(radius2)).upper();
}

}  // namespace

double norm_upper_bound(const IntervalMatrix& X) {
  if (X.rows() != 2 || X.cols() != 2) return weyl_norm_upper_bound(X);
  // λmax(XᵀX) = (p + r)/2 + sqrt(((p - r)/2)² + s²) with XᵀX = [[p, s], [s, r]].
  const Interval p = boost::numeric::square(X(0, 0)) + boost::numeric::square(X(1, 0));
  const Interval r = boost::numeric::square(X(0, 1)) + boost::numeric::square(X(1, 1));
  const Interval s = X(0, 0) * X(0, 1) + X(1, 0) * X(1, 1);
  const Interval half_difference = (p - r) / 2.0;
  const Interval lambda =
      (p + r) / 2.0 + boost::numeric::sqrt(boost::numeric::square(half_difference) + boost::numeric::square(s));
  // Both are valid upper bounds; the closed form wins on wide boxes, Weyl's on narrow ones (no dependency).
  return std::min(boost::numeric::sqrt(lambda).upper(), weyl_norm_upper_bound(X));
}

double smallest_eigenvalue_lower_bound(const IntervalMatrix& M) {
  if (M.rows() == 2) {
    const Interval a = M(0, 0), b = M(0, 1), c = M(1, 1);
    const Interval half_difference = (a - c) / 2.0;
    return ((a + c) / 2.0 - boost::numeric::sqrt(boost::numeric::square(half_difference) + boost::numeric::square(b)))
        .lower();
  }
  // Weyl: λmin(M) >= λmin(mid M) - ||rad M||_F, with a pad for the floating-point eigenvalue.
  Eigen::MatrixXd mid(M.rows(), M.cols());
  Interval radius2(0.0);
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    for (Eigen::Index j = 0; j < M.cols(); ++j) {
      mid(i, j) = boost::numeric::median(M(i, j));
      radius2 += boost::numeric::square(Interval(std::max(M(i, j).upper() - mid(i, j), mid(i, j) - M(i, j).lower())));
    }
  const Eigen::VectorXd lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(mid).eigenvalues();
  const double pad = 1e-13 * lambda.cwiseAbs().maxCoeff();
  return (Interval(lambda(0)) - Interval(pad) - boost::numeric::sqrt(radius2)).lower();
}

namespace {

IntervalMatrix inverse_2x2(const IntervalMatrix& M, bool& invertible) {
  const Interval det = M(0, 0) * M(1, 1) - M(0, 1) * M(1, 0);
  invertible = det.lower() > 0.0;
  IntervalMatrix inverse(2, 2);
  if (!invertible) return inverse;
  inverse(0, 0) = M(1, 1) / det;
  inverse(0, 1) = -M(0, 1) / det;
  inverse(1, 0) = -M(1, 0) / det;
  inverse(1, 1) = M(0, 0) / det;
  return inverse;
}

struct Box {
  IntervalVector x;  // the searched joints
  double upper;
  bool operator<(const Box& other) const { return upper < other.upper; }
};

// Best-first branch and bound: always split the box with the largest upper bound, so the global upper is
// the top of the queue; stop when it is within the gap of the best point value.
Bracket branch_and_bound(const std::vector<int>& joints, const Eigen::VectorXd& fixed_q,
                         const IntervalVector& domain, const std::function<double(const IntervalVector&)>& upper,
                         const std::function<double(const Eigen::VectorXd&)>& point, const Eigen::VectorXd& seed,
                         const CertifiedOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const auto full = [&](const IntervalVector& x) {
    IntervalVector q(fixed_q.size());
    for (Eigen::Index i = 0; i < fixed_q.size(); ++i) q[i] = Interval(fixed_q(i));
    for (std::size_t k = 0; k < joints.size(); ++k) q[joints[k]] = x[k];
    return q;
  };
  const auto midpoint = [&](const IntervalVector& x) {
    Eigen::VectorXd q = fixed_q;
    for (std::size_t k = 0; k < joints.size(); ++k) q(joints[k]) = boost::numeric::median(x[k]);
    return q;
  };
  Bracket bracket;
  bracket.argmax = seed;
  bracket.lower = point(seed);
  std::priority_queue<Box> queue;
  queue.push({domain, upper(full(domain))});
  bracket.boxes = 1;
  while (!queue.empty() && bracket.boxes < options.max_boxes) {
    const Box box = queue.top();
    if (std::isfinite(box.upper) && box.upper - bracket.lower <= options.relative_gap * box.upper) break;
    queue.pop();
    std::size_t widest = 0;
    for (std::size_t k = 1; k < box.x.size(); ++k)
      if (boost::numeric::width(box.x[k]) > boost::numeric::width(box.x[widest])) widest = k;
    const double middle = boost::numeric::median(box.x[widest]);
    for (const Interval& half : {hull_of(box.x[widest].lower(), middle), hull_of(middle, box.x[widest].upper())}) {
      Box child{box.x, 0.0};
      child.x[widest] = half;
      ++bracket.boxes;
      const Eigen::VectorXd q = midpoint(child.x);
      const double value = point(q);
      if (value > bracket.lower) {
        bracket.lower = value;
        bracket.argmax = q;
      }
      child.upper = upper(full(child.x));
      if (child.upper > bracket.lower) queue.push(std::move(child));
    }
  }
  bracket.upper = queue.empty() ? bracket.lower : std::max(queue.top().upper, bracket.lower);
  bracket.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return bracket;
}

}  // namespace

std::optional<CertifiedBounds> certify_bounds(const Model& model, const BoundReport& numeric,
                                              const CertifiedOptions& options) {
  const auto* dynamics = dynamic_cast<const IntervalDynamics*>(model.dynamics.get());
  if (dynamics == nullptr || model.dof() != 2) return std::nullopt;
  const Eigen::VectorXd& V = numeric.velocity_bounds;
  const int n = model.dof();
  const std::vector<int> joints = model.dynamics->configuration_joints();
  Eigen::VectorXd fixed_q = Eigen::VectorXd::Zero(n);
  IntervalVector domain;
  for (int j : joints) {
    const JointDomain& joint = model.joints[j];
    domain.push_back(joint.continuous ? Interval(-std::numbers::pi, std::numbers::pi) : Interval(joint.lower, joint.upper));
  }
  const Eigen::MatrixXd vertices = box_vertices(V);
  const unsigned count = static_cast<unsigned>(vertices.cols());
  // J(q, -w) = -J(q, w): with F = 0 the vertices with w_n < 0 repeat the others (as in compute_bounds).
  const unsigned first = model.friction.isZero(0.0) ? count / 2 : 0u;
  const auto pattern = [n](unsigned s) {
    Eigen::VectorXd D(n);
    for (int i = 0; i < n; ++i) D(i) = ((s >> i) & 1u) ? 1.0 : 0.0;
    return D;
  };

  CertifiedBounds result;
  // M0 = sup 1/λmin(M): refuse a box whose M cannot be shown positive definite by splitting it further.
  const auto m0_upper = [&](const IntervalVector& q) {
    const double lambda = smallest_eigenvalue_lower_bound(dynamics->mass_matrix(q));
    return lambda > 0.0 ? (Interval(1.0) / Interval(lambda)).upper() : std::numeric_limits<double>::infinity();
  };
  result.M0 = branch_and_bound(joints, fixed_q, domain, m0_upper,
                               [&](const Eigen::VectorXd& q) { return inverse_inertia_norm(model, q); },
                               numeric.M0.q, options);

  const auto interval_jacobian = [&](const std::vector<IntervalMatrix>& N, const Eigen::VectorXd& w) {
    IntervalMatrix J(n, n);
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < n; ++k) {
        Interval sum(0.0);
        for (int j = 0; j < n; ++j) sum += N[i](k, j) * w(j);
        J(i, k) = 2.0 * sum;
      }
    return J;
  };
  const auto b_upper = [&](const IntervalVector& q) {
    const std::vector<IntervalMatrix> N = dynamics->coriolis_tensors(q);
    double best = 0.0;
    for (unsigned c = first; c < count; ++c) best = std::max(best, norm_upper_bound(interval_jacobian(N, vertices.col(c))));
    return best;
  };
  const auto b_point = [&](const Eigen::VectorXd& q) {
    double best = 0.0;
    for (unsigned c = first; c < count; ++c) best = std::max(best, coriolis_jacobian_norm(model, q, vertices.col(c)));
    return best;
  };
  result.B = branch_and_bound(joints, fixed_q, domain, b_upper, b_point, numeric.B.q, options);

  const auto l_upper = [&](const IntervalVector& q) {
    bool invertible = false;
    const IntervalMatrix Minv = inverse_2x2(dynamics->mass_matrix(q), invertible);
    if (!invertible) return std::numeric_limits<double>::infinity();
    const std::vector<IntervalMatrix> N = dynamics->coriolis_tensors(q);
    double best = 0.0;
    for (unsigned c = first; c < count; ++c) {
      const IntervalMatrix J = interval_jacobian(N, vertices.col(c));
      for (unsigned s = 0; s < count; ++s) {
        IntervalMatrix X(n, n);
        for (int i = 0; i < n; ++i)
          for (int k = 0; k < n; ++k) X(i, k) = J(i, k) * ((s >> k) & 1u ? 1.0 : 0.0) + model.friction(i, k);
        IntervalMatrix product(n, n);
        for (int i = 0; i < n; ++i)
          for (int k = 0; k < n; ++k) {
            Interval sum(0.0);
            for (int j = 0; j < n; ++j) sum += Minv(i, j) * X(j, k);
            product(i, k) = sum;
          }
        best = std::max(best, norm_upper_bound(product));
      }
    }
    return best;
  };
  const auto l_point = [&](const Eigen::VectorXd& q) {
    double best = 0.0;
    for (unsigned c = first; c < count; ++c)
      for (unsigned s = 0; s < count; ++s) best = std::max(best, joint_lipschitz_norm(model, q, vertices.col(c), pattern(s)));
    return best;
  };
  result.L_joint = branch_and_bound(joints, fixed_q, domain, l_upper, l_point, numeric.L_joint.q, options);
  return result;
}

void apply_certified_bounds(BoundReport& report, const CertifiedBounds& certified) {
  report.certified = true;
  report.M0_bracket = certified.M0;
  report.B_bracket = certified.B;
  report.L_joint_bracket = certified.L_joint;
  report.M0.value = certified.M0.upper;
  report.B.value = certified.B.upper;
  report.L_joint.value = certified.L_joint.upper;
  report.L_paper = (Interval(report.M0.value) * (Interval(report.B.value) + Interval(report.F_norm))).upper();
  report.wall_seconds += certified.M0.seconds + certified.B.seconds + certified.L_joint.seconds;
}

}  // namespace obsgain
