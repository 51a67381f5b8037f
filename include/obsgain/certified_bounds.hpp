// Certified brackets [lower, upper] for M0, B and L_joint: best-first interval branch and bound over the
// searched joints, on all cores, with the model's dynamics evaluated on intervals and interval derivatives.
// `lower` is a value attained at a point; `upper` provably bounds the supremum (outward rounding throughout,
// exact vertex reduction in v and D, centred forms whose excess shrinks quadratically with the box).
#pragma once

#include "obsgain/bounds.hpp"
#include "obsgain/dual.hpp"
#include "obsgain/interval.hpp"

#include <functional>
#include <optional>
#include <vector>

namespace obsgain {

using IntervalMatrix = Eigen::Matrix<Interval, Eigen::Dynamic, Eigen::Dynamic>;
using DualInterval = Dual<Interval>;

// A matrix function of q over a box: an enclosure of its values and of its partial derivatives along the
// searched joints (the directions of the DualInterval arguments).
struct MatrixEnclosure {
  IntervalMatrix value;
  std::vector<IntervalMatrix> derivative;
};

// Splits an Eigen matrix of duals into value and derivative enclosures.
template <class Matrix>
MatrixEnclosure enclosure_of(const Matrix& X, int directions) {
  MatrixEnclosure e;
  e.value.resize(X.rows(), X.cols());
  e.derivative.assign(static_cast<std::size_t>(directions), IntervalMatrix(X.rows(), X.cols()));
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    for (Eigen::Index j = 0; j < X.cols(); ++j) {
      e.value(i, j) = X(i, j).value;
      for (int k = 0; k < directions; ++k) e.derivative[k](i, j) = X(i, j).derivative[k];
    }
  return e;
}

// A model whose M(q) and N_i(q) can be enclosed over a box of configurations. q holds every joint; the
// searched joints carry derivative directions (DualInterval::variable), the others none.
class IntervalDynamics {
 public:
  virtual ~IntervalDynamics() = default;
  virtual MatrixEnclosure mass_matrix(const std::vector<DualInterval>& q) const = 0;
  virtual std::vector<MatrixEnclosure> coriolis_tensors(const std::vector<DualInterval>& q) const = 0;
  virtual MatrixEnclosure gravity(const std::vector<DualInterval>& q) const = 0;  // n x 1
  // A proven lower bound of λmin(M(q)) for every q: M is the rigid bodies' kinetic-energy matrix, positive
  // semidefinite for every q (a sum of Jᵀ m J + Jᵀ I J, m >= 0, I ⪰ 0), plus diag(armature), so
  // λmin(M) >= min_i armature_i. It makes M⁻¹ bounded on boxes too wide for interval arithmetic to see it.
  virtual double inertia_floor() const { return 0.0; }
};

// Where a running search stands: told about four times a second once a bound has run for a second.
struct SearchProgress {
  const char* bound = "";     // "M0", "B", "L_joint", "C_q"
  int boxes = 0;
  double lower = 0.0, upper = 0.0;  // the bracket so far (upper: the largest open box's bound)
  double relative_gap = 0.0, target_gap = 0.0;
  double seconds = 0.0;
  double seconds_left = -1.0;  // until this bound's share of the budget ends; -1: no budget (until the gap)
};

struct CertifiedOptions {
  double relative_gap = 1e-6;  // stop a bound when upper - lower <= relative_gap * upper
  double budget_seconds = 120;  // wall time for the three bounds together; 0 = until the gap is reached
  int max_boxes = 2000000;      // per bound; reaching it leaves a wider (still valid) bracket
  int threads = 0;              // 0: all cores
  std::function<void(const SearchProgress&)> progress;  // optional; called from a worker, under the search's lock
};

struct CertifiedBounds {
  BoundBracket M0, B, L_joint;
};

// Why a model cannot be certified, or empty when it can.
std::string certification_unavailable(const Model& model);

// Seeds its lower bounds with the numerical search's maxima. std::nullopt when the model cannot be
// evaluated on intervals (certification_unavailable says why).
std::optional<CertifiedBounds> certify_bounds(const Model& model, const BoundReport& numeric,
                                              const CertifiedOptions& options = {});

// C_q = sup ||∂h/∂q|| over the joint domain, a in the acceleration box and v in the velocity box, with
// h(q) = M(q) a + A(q, v) + g(q): how far the model's prediction of the torque moves when it is evaluated at a
// measured rather than the true position (the sampled observer's certificate, deployment.hpp). The budget is
// options.budget_seconds; std::nullopt when sensitivity_unavailable says why not.
std::string sensitivity_unavailable(const Model& model);
std::optional<BoundBracket> certify_position_sensitivity(const Model& model, const Eigen::VectorXd& velocity_bounds,
                                                         const Eigen::VectorXd& acceleration_bounds,
                                                         const CertifiedOptions& options);

// Replaces the report's M0, B, L_joint (and L_paper) by the brackets' upper ends: θ* then rests on
// provable bounds.
void apply_certified_bounds(BoundReport& report, const CertifiedBounds& certified);

// Upper bound of ||X||₂ over an interval matrix (closed form for 2 x 2, Weyl's ||mid|| + ||rad||_F beyond).
double norm_upper_bound(const IntervalMatrix& X);
// Lower bound of λmin over a symmetric interval matrix.
double smallest_eigenvalue_lower_bound(const IntervalMatrix& M);

}  // namespace obsgain

// Lets Eigen hold duals of intervals (the planar templates build fixed-size Eigen matrices of them).
namespace Eigen {
template <>
struct NumTraits<obsgain::DualInterval> : obsgain::DoubleBasedNumTraits<obsgain::DualInterval, 16> {};
}  // namespace Eigen
