// Certified brackets [lower, upper] for M0, B and L_joint: interval branch and bound over the joint
// domain, with the model's dynamics evaluated on intervals (models that implement IntervalDynamics).
// `lower` is a value attained at a point; `upper` provably bounds the supremum (outward rounding
// throughout, exact vertex reduction in v and D).
#pragma once

#include "obsgain/bounds.hpp"
#include "obsgain/interval.hpp"

#include <array>
#include <optional>
#include <vector>

namespace obsgain {

using IntervalMatrix = Eigen::Matrix<Interval, Eigen::Dynamic, Eigen::Dynamic>;
using IntervalVector = std::vector<Interval>;

// A model whose M(q) and N_i(q) can be enclosed over a box of configurations.
class IntervalDynamics {
 public:
  virtual ~IntervalDynamics() = default;
  virtual IntervalMatrix mass_matrix(const IntervalVector& q) const = 0;
  virtual std::vector<IntervalMatrix> coriolis_tensors(const IntervalVector& q) const = 0;
};

struct CertifiedOptions {
  double relative_gap = 1e-6;  // stop when upper - lower <= relative_gap * upper
  int max_boxes = 200000;      // per bound; reaching it leaves a wider (still valid) bracket
};

// lower: attained at argmax; upper: >= the supremum; boxes: boxes processed.
using Bracket = BoundBracket;

struct CertifiedBounds {
  Bracket M0, B, L_joint;
};

// Seeds its lower bounds with the numerical search's maxima. std::nullopt when the model cannot be
// evaluated on intervals (the caller falls back to the numeric bounds and says so).
std::optional<CertifiedBounds> certify_bounds(const Model& model, const BoundReport& numeric,
                                              const CertifiedOptions& options = {});

// Replaces the report's M0, B, L_joint (and L_paper) by the brackets' upper ends: θ* then rests on
// provable bounds.
void apply_certified_bounds(BoundReport& report, const CertifiedBounds& certified);

// Upper bound of ||X||₂ for a 2 x 2 interval matrix (closed form of λmax(XᵀX) in interval arithmetic).
double norm_upper_bound(const IntervalMatrix& X);
// Lower bound of λmin of a symmetric 2 x 2 interval matrix.
double smallest_eigenvalue_lower_bound(const IntervalMatrix& M);

}  // namespace obsgain
