// M(q), N_i(q) and g(q) of any model enclosed over a box of configurations, with their partial derivatives: the
// model's own dynamics templates (dynamics.hpp) evaluated on interval forward-mode duals.
#pragma once

#include "obsgain/model/model.hpp"
#include "obsgain/numerics/dual.hpp"
#include "obsgain/numerics/interval.hpp"

#include <string>
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

// q holds every joint; the searched joints carry derivative directions (DualInterval::variable), the others none.
MatrixEnclosure mass_matrix_enclosure(const Model& model, const std::vector<DualInterval>& q);
std::vector<MatrixEnclosure> coriolis_tensor_enclosures(const Model& model, const std::vector<DualInterval>& q);
MatrixEnclosure gravity_enclosure(const Model& model, const std::vector<DualInterval>& q);  // n x 1

// Upper bound of ||X||₂ over an interval matrix (closed form for 2 x 2, Weyl's ||mid|| + ||rad||_F beyond).
double norm_upper_bound(const IntervalMatrix& X);
// Lower bound of λmin over a symmetric interval matrix.
double smallest_eigenvalue_lower_bound(const IntervalMatrix& M);

}  // namespace obsgain

// Lets Eigen hold duals of intervals.
namespace Eigen {
template <>
struct NumTraits<obsgain::DualInterval> : obsgain::DoubleBasedNumTraits<obsgain::DualInterval, 16> {};
}  // namespace Eigen
