#include "obsgain/bounds/inertia_floor.hpp"

#include "obsgain/numerics/interval.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <algorithm>

namespace obsgain {

namespace {

// Whether C - Bᵀ W B ≻ 0 is proven, with C = diag(c), W = diag((λ - a)₊) and B bidiagonal (ones on the diagonal and
// below it): then Σ c_k u_k² >= Σ (λ - a_k)₊ (u_k + u_{k-1})² for every u (docs/theory.md, "The inertia floor").
bool floor_holds(const Eigen::VectorXd& c, const Eigen::VectorXd& a, double lambda) {
  const Eigen::Index n = c.size();
  IntervalMatrix X = IntervalMatrix::Zero(n, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const Interval w = max(Interval(lambda) - Interval(a(k)), Interval(0.0));
    X(k, k) += Interval(c(k)) - w;  // (Bᵀ W B)_kk = w_k + w_{k+1}, (Bᵀ W B)_{k,k-1} = w_k
    if (k > 0) {
      X(k - 1, k - 1) -= w;
      X(k, k - 1) -= w;
      X(k - 1, k) -= w;
    }
  }
  return positive_definite_proven(X);
}

// The largest λ (to a relative 1e-9) with floor_holds, or 0 when none above the armature's minimum holds.
double chain_floor(const Eigen::VectorXd& c, const Eigen::VectorXd& a) {
  const Eigen::Index n = c.size();
  double lo = a.minCoeff(), hi = a(n - 1) + c(n - 1);  // the last joint alone moves only the last body: λ <= a_n + c_n
  if (!(hi > lo) || !floor_holds(c, a, lo)) return 0.0;
  while (hi - lo > 1e-9 * hi) {
    const double middle = 0.5 * (lo + hi);
    (floor_holds(c, a, middle) ? lo : hi) = middle;
  }
  return lo;
}

}  // namespace

double inertia_floor(const Model& model) {
  if (const auto* p = std::get_if<Planar2RParameters>(&model.structure))
    return std::min(p->armature[0], p->armature[1]);  // π1π2 > π3² makes the rigid part positive definite
  const SerialChain& chain = std::get<SerialChain>(model.structure);
  const int n = chain.dof();
  const Eigen::VectorXd a = armature(model);
  // Each body's smallest principal moment, proven from below. Rounding in the lumped inertias may leave one a hair
  // below zero: a body's angular velocity has norm <= sqrt(n) |q'|, so such a deficit costs the floor at most n
  // times itself (doubled for safety).
  Eigen::VectorXd c(n);
  double deficit = 0.0;
  for (int k = 0; k < n; ++k) {
    const double moment = smallest_eigenvalue_lower(chain.bodies[static_cast<std::size_t>(k)].inertia);
    c(k) = std::max(moment, 0.0);
    deficit += std::max(-moment, 0.0);
  }
  const bool revolute = std::all_of(chain.joints.begin(), chain.joints.end(),
                                    [](const ChainJoint& j) { return j.type == JointType::revolute; });
  const double floor = std::max(a.minCoeff(), revolute ? chain_floor(c, a) : 0.0);
  return std::max(0.0, (Interval(floor) - Interval(2.0 * n) * Interval(deficit)).lower());
}

double similar_inertia_floor(const Model& model, double floor, const Eigen::VectorXd& s) {
  const Eigen::VectorXd a = armature(model);
  double by_floor = kInfinity, by_armature = kInfinity;
  for (Eigen::Index k = 0; k < s.size(); ++k) {
    const Interval square = boost::numeric::square(Interval(s(k)));
    by_floor = std::min(by_floor, (Interval(floor) * square).lower());
    by_armature = std::min(by_armature, (Interval(a(k)) * square).lower());
  }
  return std::max(by_floor, by_armature);
}

}  // namespace obsgain
