// The interval scalar of obsgain's rigorous bounds: Boost.Interval with outward-rounded arithmetic, and
// cos/sin from the C library widened outward by a few ulps (Boost's own transcendental policies do not
// round outward).
#pragma once

#include <boost/numeric/interval.hpp>

#include <Eigen/Core>

#include <cmath>

namespace obsgain {

// Boost's cos (and sin, computed as a shifted cos) call cos_down/cos_up on a reduced argument; widen
// glibc's result (accurate to < 1 ulp in every rounding mode) outward by 4 ulps and clamp to [-1, 1].
struct OutwardTranscendentals : boost::numeric::interval_lib::rounded_arith_std<double> {
  static double widen_down(double x) {
    for (int i = 0; i < 4; ++i) x = std::nextafter(x, -2.0);
    return std::max(x, -1.0);
  }
  static double widen_up(double x) {
    for (int i = 0; i < 4; ++i) x = std::nextafter(x, 2.0);
    return std::min(x, 1.0);
  }
  double cos_down(double x) { return widen_down(std::cos(x)); }
  double cos_up(double x) { return widen_up(std::cos(x)); }
};

using Interval = boost::numeric::interval<
    double, boost::numeric::interval_lib::policies<
                boost::numeric::interval_lib::save_state<OutwardTranscendentals>,
                boost::numeric::interval_lib::checking_strict<double>>>;

}  // namespace obsgain

// Lets Eigen hold intervals (the templated dynamics build Eigen matrices of them).
namespace Eigen {
template <>
struct NumTraits<obsgain::Interval> : GenericNumTraits<double> {
  using Real = obsgain::Interval;
  using NonInteger = obsgain::Interval;
  using Nested = obsgain::Interval;
  using Literal = double;
  enum { IsComplex = 0, IsInteger = 0, IsSigned = 1, RequireInitialization = 1, ReadCost = 2, AddCost = 4, MulCost = 8 };
};
}  // namespace Eigen
