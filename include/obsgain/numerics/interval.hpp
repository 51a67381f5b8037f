// The interval scalar of obsgain's rigorous bounds: Boost.Interval with outward-rounded arithmetic, and
// cos/sin from the C library widened outward by a few ulps (Boost's own transcendental policies do not
// round outward). Arithmetic runs with the FPU rounding upward (lower ends by negation), and each operation
// switches the mode only if it is not already upward: a hot loop holds an UpwardRounding guard and pays no
// mode switch at all (Boost's save_state switches twice per operation, 60 % of the run time).
#pragma once

#include <boost/numeric/interval.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cfenv>
#include <cmath>
#include <limits>

namespace obsgain {

// The upper end of a bound nothing has bounded yet.
inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Boost's cos (and sin, computed as a shifted cos) call cos_down/cos_up on a reduced argument; widen
// glibc's result (accurate to < 1 ulp in every rounding mode) outward by 4 ulps and clamp to [-1, 1].
struct OutwardTranscendentals : boost::numeric::interval_lib::rounded_arith_opp<double> {
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

// How many UpwardRounding guards this thread holds: inside one, the FPU already rounds upward and an interval
// operation need not even ask (fegetround costs more than the arithmetic).
inline thread_local int upward_guards = 0;

// Constructed by Boost around every interval operation.
struct UpwardUnlessAlready : OutwardTranscendentals {
  UpwardUnlessAlready() : saved_(upward_guards > 0 ? FE_UPWARD : std::fegetround()) {
    if (saved_ != FE_UPWARD) std::fesetround(FE_UPWARD);
  }
  ~UpwardUnlessAlready() {
    if (saved_ != FE_UPWARD) std::fesetround(saved_);
  }
  UpwardUnlessAlready(const UpwardUnlessAlready&) = delete;
  UpwardUnlessAlready& operator=(const UpwardUnlessAlready&) = delete;
  using unprotected_rounding = boost::numeric::interval_lib::save_state_nothing<OutwardTranscendentals>;

 private:
  int saved_;
};

// Holds the rounding mode upward for a scope (a worker's loop); floating-point estimates computed inside it
// are still estimates, only rounded the other way.
class UpwardRounding {
 public:
  UpwardRounding() : saved_(std::fegetround()) {
    std::fesetround(FE_UPWARD);
    ++upward_guards;
  }
  ~UpwardRounding() {
    --upward_guards;
    std::fesetround(saved_);
  }
  UpwardRounding(const UpwardRounding&) = delete;
  UpwardRounding& operator=(const UpwardRounding&) = delete;

 private:
  int saved_;
};

using Interval = boost::numeric::interval<
    double, boost::numeric::interval_lib::policies<UpwardUnlessAlready, boost::numeric::interval_lib::checking_strict<double>>>;

// A point inside x (its midpoint up to rounding), without Boost's median, which switches the rounding mode.
inline double centre(const Interval& x) { return std::clamp(0.5 * x.lower() + 0.5 * x.upper(), x.lower(), x.upper()); }

}  // namespace obsgain

namespace obsgain {
// What Eigen needs to hold a scalar built on doubles (intervals, duals of intervals) in its matrices.
template <class Scalar, int Cost>
struct DoubleBasedNumTraits : Eigen::GenericNumTraits<double> {
  using Real = Scalar;
  using NonInteger = Scalar;
  using Nested = Scalar;
  using Literal = double;
  enum { IsComplex = 0, IsInteger = 0, IsSigned = 1, RequireInitialization = 1, ReadCost = 2, AddCost = Cost, MulCost = 2 * Cost };
};
}  // namespace obsgain

namespace Eigen {
template <>
struct NumTraits<obsgain::Interval> : obsgain::DoubleBasedNumTraits<obsgain::Interval, 4> {};
}  // namespace Eigen
