// Affine forms: x = c + Σ_k a_k ε_k + e with ε_k ∈ [-1, 1] the noise symbols of a box's sides and |e| <= r. A value
// computed from a box's midpoint carries its first-order dependence on every side exactly (a first-order Taylor
// model), so that a chain of rotations does not forget that its entries share one angle: where an interval's excess
// over the true range grows with the box's width w, an affine form's is the remainder r, which grows as w².
//
// Rigour: every operation bounds the floating-point error of what it computes (|fl(x ∘ y) - x ∘ y| <= 2⁻⁵² |fl(x ∘ y)|
// in any rounding mode, plus 2⁻¹⁰⁷⁴ for underflow) and adds it to r, and every sum of non-negative error terms is
// inflated to cover its own rounding, so the forms are enclosures whatever the FPU's rounding mode
// (docs/theory.md, "Affine forms").
#pragma once

#include "obsgain/numerics/interval.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace obsgain {

// Noise symbols per form: one per searched joint (a chain of up to eight joints searches seven).
inline constexpr int kAffineSymbols = 7;

struct Affine {
  double c = 0.0;                          // centre
  std::array<double, kAffineSymbols> a{};  // partial deviations
  double r = 0.0;                          // remainder radius

  Affine() = default;
  Affine(double x) : c(x) {}  // NOLINT: an exact constant mixes freely with forms
  // centre + radius ε_k.
  static Affine symbol(double centre, double radius, int k) {
    Affine x(centre);
    x.a[k] = radius;
    return x;
  }
  // Σ|a_k| + r, rounded up: the form's deviation from its centre over the box.
  double radius() const;
  // The range [c - radius, c + radius], rounded outward.
  double lower() const;
  double upper() const;
};

// The inflation that covers the rounding of a short sum of non-negative error terms, the unit roundoff bound and
// the underflow floor.
inline constexpr double kAffineInflation = 1.0 + 0x1p-45;
inline constexpr double kRoundoff = 0x1p-52;
inline constexpr double kUnderflow = 0x1p-1060;

namespace affine_detail {

inline double sum_abs(const std::array<double, kAffineSymbols>& a) {
  double s = 0.0;
  for (double x : a) s += std::abs(x);
  return s;
}

// r from a sum of non-negative error terms.
inline double remainder(double terms) { return terms * kAffineInflation + kUnderflow; }

}  // namespace affine_detail

inline double Affine::radius() const { return affine_detail::remainder(affine_detail::sum_abs(a) + r); }
inline double Affine::lower() const { return c - radius() * kAffineInflation - 2.0 * kRoundoff * (std::abs(c) + radius()); }
inline double Affine::upper() const { return c + radius() * kAffineInflation + 2.0 * kRoundoff * (std::abs(c) + radius()); }

// The rounding of a_k = fl(x_k + y_k) is at most 2⁻⁵² |a_k| <= 2⁻⁵² (|x_k| + |y_k|).
inline Affine operator+(const Affine& x, const Affine& y) {
  Affine z(x.c + y.c);
  double X = 0.0, Y = 0.0;
  for (int k = 0; k < kAffineSymbols; ++k) {
    z.a[k] = x.a[k] + y.a[k];
    X += std::abs(x.a[k]);
    Y += std::abs(y.a[k]);
  }
  z.r = affine_detail::remainder(x.r + y.r + kRoundoff * (std::abs(z.c) + X + Y));
  return z;
}

inline Affine operator-(const Affine& x) {
  Affine z(-x.c);
  for (int k = 0; k < kAffineSymbols; ++k) z.a[k] = -x.a[k];
  z.r = x.r;
  return z;
}

inline Affine operator-(const Affine& x, const Affine& y) { return x + (-y); }

inline Affine operator*(double s, const Affine& x) {
  Affine z(s * x.c);
  double X = 0.0;
  for (int k = 0; k < kAffineSymbols; ++k) {
    z.a[k] = s * x.a[k];
    X += std::abs(x.a[k]);
  }
  const double as = std::abs(s);
  z.r = affine_detail::remainder(as * x.r + kRoundoff * (std::abs(z.c) + as * X));
  return z;
}

// (xc + xl + xe)(yc + yl + ye): the centre, the linear terms xc yl + yc xl, and the quadratic xl yl: its square
// terms x_k y_k ε_k² lie between 0 and x_k y_k, so half their sum moves to the centre and half their moduli stay,
// the cross terms are bounded by Σ_{k≠l} |x_k y_l| = (Σ|x_k|)(Σ|y_l|) - Σ|x_k y_k|; every product with an error
// term is bounded by the factors' ranges.
// Rounding: a_k = fl(fl(xc y_k) + fl(yc x_k)) is within 2⁻⁵² (|xc y_k| + |yc x_k| + |a_k|) (each with its own
// rounding, covered by the inflation): summed over k, 2⁻⁵² · 2 (|xc| Y + |yc| X); the centre's shift is a sum of
// products no larger than X Y, and so is its rounding.
inline Affine operator*(const Affine& x, const Affine& y) {
  double X = 0.0, Y = 0.0, square = 0.0, square_abs = 0.0;
  for (int k = 0; k < kAffineSymbols; ++k) {
    X += std::abs(x.a[k]);
    Y += std::abs(y.a[k]);
    const double p = x.a[k] * y.a[k];
    square += p;
    square_abs += std::abs(p);
  }
  Affine z(x.c * y.c + 0.5 * square);
  for (int k = 0; k < kAffineSymbols; ++k) z.a[k] = x.c * y.a[k] + y.c * x.a[k];
  const double ax = std::abs(x.c), ay = std::abs(y.c);
  z.r = affine_detail::remainder(X * Y - 0.5 * square_abs + (ax + X) * y.r + (ay + Y) * x.r + x.r * y.r +
                                 kRoundoff * (2.0 * std::abs(z.c) + 2.0 * (ax * Y + ay * X) + 10.0 * X * Y));
  return z;
}

namespace affine_detail {

// The argument's range [c - deviation, c + deviation], rounded outward.
inline Interval argument_range(double c, double deviation) {
  const double slack = 2.0 * kRoundoff * (std::abs(c) + deviation) + kUnderflow;
  return Interval(c - deviation - slack, c + deviation + slack);
}

// f(c + t) = f(c) + f'(c) t + R for f = sin or cos, R = f''(ξ) t²/2 = -f(ξ) t²/2 with f(ξ) in `range`, f's range over
// the argument's: R lies between 0 and -range · ρ²/2, so its midpoint moves to the centre and its half-width is
// the remainder (half the plain Taylor remainder where f keeps its sign). On a wide argument, where that remainder
// alone is wider than the constant form mid(range) ± rad(range), the constant form is taken. value = f(c), slope = f'(c), both from the C library (within
// an ulp, counted twice); `range` is rigorous (interval.hpp).
inline Affine second_order_centred(const Affine& x, double value, double slope, const Interval& range) {
  double X = 0.0;
  for (double a : x.a) X += std::abs(a);
  const double deviation = remainder(X + x.r);
  const double half_square = 0.5 * deviation * deviation * kAffineInflation;
  const double low = std::min(0.0, -range.upper()) * half_square, high = std::max(0.0, -range.lower()) * half_square;
  const double shift = 0.5 * (low + high);
  Affine z(value + shift);
  for (int k = 0; k < kAffineSymbols; ++k) z.a[k] = slope * x.a[k];
  z.r = remainder(0.5 * (high - low) + std::abs(slope) * x.r +
                  kRoundoff * (2.0 * std::abs(z.c) + 2.0 + 3.0 * X + 2.0 * (high - low)));
  const double constant_radius = 0.5 * (range.upper() - range.lower());
  if (constant_radius < z.r) {
    Affine constant(0.5 * (range.lower() + range.upper()));
    constant.r = remainder(constant_radius + 2.0 * kRoundoff * (std::abs(constant.c) + constant_radius));
    return constant;
  }
  return z;
}

}  // namespace affine_detail

inline Affine operator*(const Affine& x, double s) { return s * x; }
inline Affine operator+(double s, const Affine& x) { return Affine(s) + x; }
inline Affine operator+(const Affine& x, double s) { return x + Affine(s); }
inline Affine operator-(double s, const Affine& x) { return Affine(s) - x; }
inline Affine operator-(const Affine& x, double s) { return x - Affine(s); }
inline Affine& operator+=(Affine& x, const Affine& y) { return x = x + y; }
inline Affine& operator-=(Affine& x, const Affine& y) { return x = x - y; }
inline Affine& operator*=(Affine& x, const Affine& y) { return x = x * y; }

inline Affine cos(const Affine& x) {
  const Interval range = boost::numeric::cos(affine_detail::argument_range(x.c, x.radius()));
  return affine_detail::second_order_centred(x, std::cos(x.c), -std::sin(x.c), range);
}
inline Affine sin(const Affine& x) {
  const Interval range = boost::numeric::sin(affine_detail::argument_range(x.c, x.radius()));
  return affine_detail::second_order_centred(x, std::sin(x.c), std::cos(x.c), range);
}

}  // namespace obsgain
