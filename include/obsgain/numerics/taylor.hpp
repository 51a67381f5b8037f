// Second-order Taylor forms: x = c + Σ_k a_k ε_k + Σ_{k<=l} b_kl ε_k ε_l + e, with ε_k ∈ [-1, 1] the noise symbols of a
// box's sides and |e| <= r. A value computed from a box's midpoint carries its first- and second-order dependence on
// every side exactly (a Taylor model of order two), so that the curvature of what the bounds maximise is known with
// its sign, and only third-order terms (and rounding) go into the remainder r (docs/theory.md, "Taylor forms").
//
// Rigour: every operation bounds the floating-point error of what it computes (|fl(x ∘ y) - x ∘ y| <= 2⁻⁵² |fl(x ∘ y)|
// in any rounding mode, plus 2⁻¹⁰⁷⁴ for underflow) and adds it to r, and every sum of non-negative error terms is
// inflated to cover its own rounding, so the forms are enclosures whatever the FPU's rounding mode.
#pragma once

#include "obsgain/numerics/interval.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace obsgain {

// Noise symbols per form: up to two per searched joint (an arc's, bounds/box_forms.hpp; a chain of up to eight
// joints searches seven).
inline constexpr int kTaylorSymbols = 14;
// Products ε_k ε_l, k <= l.
inline constexpr int kTaylorPairs = kTaylorSymbols * (kTaylorSymbols + 1) / 2;

// The symbols of pair p, and the pair of two symbols. Ordered by the larger symbol, so that the pairs of the first m
// symbols are the first m (m + 1) / 2.
struct TaylorPairs {
  std::array<int, kTaylorPairs> first{}, second{};
  std::array<std::array<int, kTaylorSymbols>, kTaylorSymbols> index{};
  constexpr TaylorPairs() {
    int p = 0;
    for (int l = 0; l < kTaylorSymbols; ++l)
      for (int k = 0; k <= l; ++k) {
        first[p] = k;
        second[p] = l;
        index[k][l] = index[l][k] = p;
        ++p;
      }
  }
};
inline constexpr TaylorPairs kPairs{};
constexpr int pair_count(int symbols) { return symbols * (symbols + 1) / 2; }

// Only the coefficients of the form's own symbols (those below `symbols`, and their pairs: a prefix of kPairs) are
// stored, copied and read: a form of few symbols costs little whatever the capacity (slope() and curvature() read any
// symbol, zero beyond).
struct Taylor {
  double c = 0.0;                        // centre
  std::array<double, kTaylorSymbols> a;  // first-order coefficients (the first `symbols`)
  std::array<double, kTaylorPairs> b;    // second-order coefficients in the order of kPairs (the first pair_count(symbols))
  double r = 0.0;                        // remainder radius
  int symbols = 0;

  // Not "= default": a defaulted constructor would make value-initialisation (std::vector<Taylor>(n)) zero all the
  // coefficients, kilobytes per form that are never read beyond `symbols`.
  Taylor() {}  // NOLINT(modernize-use-equals-default)
  Taylor(double x) : c(x) {}  // NOLINT: an exact constant mixes freely with forms
  Taylor(const Taylor& x) : c(x.c), r(x.r), symbols(x.symbols) { copy_coefficients(x); }
  Taylor& operator=(const Taylor& x) {
    if (this == &x) return *this;
    c = x.c;
    r = x.r;
    symbols = x.symbols;
    copy_coefficients(x);
    return *this;
  }
  // centre + radius ε_k.
  static Taylor symbol(double centre, double radius, int k) {
    Taylor x(centre);
    x.symbols = k + 1;
    std::fill_n(x.a.begin(), k + 1, 0.0);
    std::fill_n(x.b.begin(), pair_count(k + 1), 0.0);
    x.a[k] = radius;
    return x;
  }
  double slope(int k) const { return k < symbols ? a[k] : 0.0; }
  // The exact constant 0 (a derivative along a joint the value does not depend on): sums and products with it are
  // exact, so they are taken without arithmetic and keep it exactly zero.
  bool is_zero() const { return symbols == 0 && c == 0.0 && r == 0.0; }
  double curvature(int p) const { return p < pair_count(symbols) ? b[p] : 0.0; }
  // Σ|a_k|, Σ|b_kl|: the first- and second-order deviations' sizes.
  double linear_size() const;
  double quadratic_size() const;
  // The form's deviation from its centre over the box, rounded up.
  double radius() const;
  // An enclosure of the range, rounded outward (squares ε_k² taken in [0, 1]).
  double lower() const;
  double upper() const;

 private:
  void copy_coefficients(const Taylor& x) {
    std::copy_n(x.a.begin(), symbols, a.begin());
    std::copy_n(x.b.begin(), pair_count(symbols), b.begin());
  }
};

inline constexpr double kTaylorInflation = 1.0 + 0x1p-45;
inline constexpr double kTaylorRoundoff = 0x1p-52;
inline constexpr double kTaylorUnderflow = 0x1p-1060;

namespace taylor_detail {

// r from a sum of non-negative error terms.
inline double up(double terms) { return terms * kTaylorInflation + kTaylorUnderflow; }

}  // namespace taylor_detail

inline double Taylor::linear_size() const {
  double s = 0.0;
  for (int k = 0; k < symbols; ++k) s += std::abs(a[k]);
  return taylor_detail::up(s);
}
inline double Taylor::quadratic_size() const {
  double s = 0.0;
  for (int p = 0; p < pair_count(symbols); ++p) s += std::abs(b[p]);
  return taylor_detail::up(s);
}
inline double Taylor::radius() const { return taylor_detail::up(linear_size() + quadratic_size() + r); }

inline double Taylor::upper() const {
  double high = linear_size() + r;
  for (int p = 0; p < pair_count(symbols); ++p) high += kPairs.first[p] == kPairs.second[p] ? std::max(0.0, b[p]) : std::abs(b[p]);
  high = taylor_detail::up(high);
  return c + high * kTaylorInflation + 2.0 * kTaylorRoundoff * (std::abs(c) + high);
}
inline double Taylor::lower() const {
  double low = linear_size() + r;
  for (int p = 0; p < pair_count(symbols); ++p) low += kPairs.first[p] == kPairs.second[p] ? std::max(0.0, -b[p]) : std::abs(b[p]);
  low = taylor_detail::up(low);
  return c - low * kTaylorInflation - 2.0 * kTaylorRoundoff * (std::abs(c) + low);
}

// The operations write their result into a given form (`*_into`), so that a form inside a larger value (a dual's
// derivative) is computed where it lives, not built as a temporary and copied: forms are kilobytes. The operators
// below return through them.

// z = x + y, coefficient-wise: each coefficient's rounding is at most 2⁻⁵² of its modulus. The form of fewer symbols
// adds to a prefix of the other's coefficients. z may be x or y (x += y).
inline void add_into(Taylor& z, const Taylor& x, const Taylor& y) {
  if (x.is_zero() || y.is_zero()) {  // exact: the other operand
    z = y.is_zero() ? x : y;
    return;
  }
  const Taylor& more = x.symbols >= y.symbols ? x : y;
  const int fewer = std::min(x.symbols, y.symbols), symbols = more.symbols;
  const int pairs = pair_count(fewer), all = pair_count(symbols);
  const double remainders = x.r + y.r;
  z.c = x.c + y.c;
  // The rounded sums' moduli, Σ|z_i| (only the sums are rounded: the copied coefficients are exact).
  double moduli = std::abs(z.c);
  for (int k = 0; k < fewer; ++k) {
    z.a[k] = x.a[k] + y.a[k];
    moduli += std::abs(z.a[k]);
  }
  for (int p = 0; p < pairs; ++p) {
    z.b[p] = x.b[p] + y.b[p];
    moduli += std::abs(z.b[p]);
  }
  if (&more != &z) {
    std::copy(more.a.begin() + fewer, more.a.begin() + symbols, z.a.begin() + fewer);
    std::copy(more.b.begin() + pairs, more.b.begin() + all, z.b.begin() + pairs);
  }
  z.symbols = symbols;
  z.r = taylor_detail::up(remainders + kTaylorRoundoff * taylor_detail::up(moduli));
}

// z = -x, exact. z may be x.
inline void negate_into(Taylor& z, const Taylor& x) {
  z.c = -x.c;
  z.symbols = x.symbols;
  for (int k = 0; k < z.symbols; ++k) z.a[k] = -x.a[k];
  for (int p = 0; p < pair_count(z.symbols); ++p) z.b[p] = -x.b[p];
  z.r = x.r;
}

// z = x - y, as x + (-y). z may be x (x -= y), not y.
inline void subtract_into(Taylor& z, const Taylor& x, const Taylor& y) {
  Taylor minus_y;
  negate_into(minus_y, y);
  add_into(z, x, minus_y);
}

namespace taylor_detail {

// z = s x where that is exact (s is 0 or ±1, or x the exact zero; a constant rotation's or an axis' entries), taken
// without arithmetic, 0 x as the exact zero: whether it was. For second- and third-order forms (taylor3.hpp) alike.
template <class Form>
bool scaled_exactly(Form& z, double s, const Form& x) {
  if (x.is_zero() || s == 1.0) {
    z = x;
  } else if (s == 0.0) {
    z = Form(0.0);
  } else if (s == -1.0) {
    negate_into(z, x);
  } else {
    return false;
  }
  return true;
}

}  // namespace taylor_detail

// z = s x: each product rounded within 2⁻⁵² of its modulus, which is at most (1 + 2⁻⁵²) |s| times the coefficient's;
// by 0 and ±1 exactly. z may be x.
inline void scale_into(Taylor& z, double s, const Taylor& x) {
  if (taylor_detail::scaled_exactly(z, s, x)) return;
  double moduli = std::abs(x.c);
  for (int k = 0; k < x.symbols; ++k) moduli += std::abs(x.a[k]);
  for (int p = 0; p < pair_count(x.symbols); ++p) moduli += std::abs(x.b[p]);
  const double as = std::abs(s);
  z.r = taylor_detail::up(as * x.r + kTaylorRoundoff * taylor_detail::up(as * taylor_detail::up(moduli) * (1.0 + kTaylorRoundoff)));
  z.c = s * x.c;
  z.symbols = x.symbols;
  for (int k = 0; k < z.symbols; ++k) z.a[k] = s * x.a[k];
  for (int p = 0; p < pair_count(z.symbols); ++p) z.b[p] = s * x.b[p];
}

// z = x y: (xc + xl + xq + xe)(yc + yl + yq + ye): the centre, the linear terms xc yl + yc xl, the quadratic terms
// xc yq + yc xq + xl yl exactly; the cubic and quartic terms xl yq + xq yl + xq yq, bounded by the products of the
// coefficient sums (|ε| <= 1), and every product with an error term bounded by the factors' ranges.
// Rounding: every coefficient is a sum of at most four products of one term of x and one of y, each such product
// appearing in one coefficient only: the rounding of them all is within 4.01 · 2⁻⁵² · (|xc| + X1 + X2)(|yc| + Y1 + Y2).
// z is neither x nor y (its coefficients are written while theirs are read).
// `cubic_by_sizes` false: the cubic terms are left out of r, for a caller that bounds them itself
// (sum_of_products_into); returns their sizes' bound X1 Y2 + X2 Y1 either way.
inline double multiply_into(Taylor& z, const Taylor& x, const Taylor& y, bool cubic_by_sizes = true) {
  if (x.is_zero() || y.is_zero()) {  // the exact zero
    z = Taylor(0.0);
    return 0.0;
  }
  const double X1 = x.linear_size(), X2 = x.quadratic_size(), Y1 = y.linear_size(), Y2 = y.quadratic_size();
  z.c = x.c * y.c;
  z.symbols = std::max(x.symbols, y.symbols);
  // Both operands' first-order coefficients over the product's symbols (zero beyond their own).
  std::array<double, kTaylorSymbols> xa, ya;
  for (int k = 0; k < z.symbols; ++k) {
    xa[k] = x.slope(k);
    ya[k] = y.slope(k);
  }
  for (int k = 0; k < z.symbols; ++k) z.a[k] = x.c * ya[k] + y.c * xa[k];
  // The pairs in kPairs' order: by the larger symbol l, then k <= l.
  for (int l = 0, p = 0; l < z.symbols; ++l) {
    for (int k = 0; k < l; ++k, ++p) z.b[p] = xa[k] * ya[l] + xa[l] * ya[k];
    z.b[p++] = xa[l] * ya[l];
  }
  for (int p = 0; p < pair_count(y.symbols); ++p) z.b[p] += x.c * y.b[p];
  for (int p = 0; p < pair_count(x.symbols); ++p) z.b[p] += y.c * x.b[p];
  const double xt = std::abs(x.c) + X1 + X2, yt = std::abs(y.c) + Y1 + Y2;
  const double cubic = X1 * Y2 + X2 * Y1;
  z.r = taylor_detail::up((cubic_by_sizes ? cubic : 0.0) + X2 * Y2 + xt * y.r + yt * x.r + x.r * y.r +
                          4.01 * kTaylorRoundoff * xt * yt);
  return cubic;
}

namespace taylor_detail {

// The cubic terms of a sum of products Σ_m x_m y_m, xl yq + xq yl, gathered by the factor x_m's symbol or pair: row k
// of `by_slope` holds Σ_m x_mk y_mq (a vector over y's pairs q), row q of `by_pair` Σ_m x_mq y_mk (over y's slopes k).
// Each row is a part of the coefficients of the monomials ε_k μ_q, so their moduli's sum bounds the cubic terms; the
// x_m are the factors of few symbols (a joint's cosine and sine), so few rows are used, each an axpy.
struct CubicGroups {
  std::array<std::array<double, kTaylorPairs>, kTaylorSymbols> by_slope;
  std::array<std::array<double, kTaylorSymbols>, kTaylorPairs> by_pair;
  std::array<bool, kTaylorSymbols> slope_used{};
  std::array<bool, kTaylorPairs> pair_used{};
  int symbols = 0;  // of every operand: the rows' length

  void add(const Taylor& x, const Taylor& y) {
    for (int k = 0; k < x.symbols; ++k) {
      if (x.a[k] == 0.0) continue;
      auto& row = by_slope[k];
      if (!slope_used[k]) std::fill_n(row.begin(), pair_count(symbols), 0.0);
      slope_used[k] = true;
      for (int q = 0; q < pair_count(y.symbols); ++q) row[q] += x.a[k] * y.b[q];
    }
    for (int q = 0; q < pair_count(x.symbols); ++q) {
      if (x.b[q] == 0.0) continue;
      auto& row = by_pair[q];
      if (!pair_used[q]) std::fill_n(row.begin(), symbols, 0.0);
      pair_used[q] = true;
      for (int k = 0; k < y.symbols; ++k) row[k] += x.b[q] * y.a[k];
    }
  }
  // Σ of the rows' moduli, and how many terms that sums (for its rounding).
  std::pair<double, int> moduli() const {
    double sum = 0.0;
    int terms = 0;
    for (int k = 0; k < symbols; ++k)
      if (slope_used[k]) {
        for (int q = 0; q < pair_count(symbols); ++q) sum += std::abs(by_slope[k][q]);
        terms += pair_count(symbols);
      }
    for (int q = 0; q < pair_count(symbols); ++q)
      if (pair_used[q]) {
        for (int k = 0; k < symbols; ++k) sum += std::abs(by_pair[q][k]);
        terms += symbols;
      }
    return {sum, terms};
  }
};

}  // namespace taylor_detail

// z = base + Σ_m x_m y_m for forms x_m of few symbols (a joint's cos q, sin q, cos 2q, sin 2q): the products' cubic
// terms are summed across the sum before their moduli are taken (taylor_detail::CubicGroups), so that where they cancel
// (an entry of a rotated inertia) the remainder does not add them up (docs/theory.md, "Cubic terms gathered across a
// rotated inertia's sum"). Each gathered coefficient is a sum of `count` products, rounded within γ_(count+2) of their
// moduli's sum, at most the sizes' bound Σ_m (X1 Y2 + X2 Y1); the moduli's sum is inflated by its own γ. Never above
// the sizes' bound but for that rounding (the triangle inequality). z is none of the operands.
inline void sum_of_products_into(Taylor& z, const Taylor& base, const Taylor* const* x, const Taylor* const* y,
                                 int count) {
  using taylor_detail::up;
  z = base;
  taylor_detail::CubicGroups cubic;
  for (int m = 0; m < count; ++m) cubic.symbols = std::max({cubic.symbols, x[m]->symbols, y[m]->symbols});
  double sizes = 0.0;
  Taylor term;
  for (int m = 0; m < count; ++m) {
    if (x[m]->is_zero() || y[m]->is_zero()) continue;
    sizes += multiply_into(term, *x[m], *y[m], false);
    add_into(z, z, term);
    cubic.add(*x[m], *y[m]);
  }
  const auto [moduli, terms] = cubic.moduli();
  const double sums = (count + 2) * kTaylorRoundoff * 1.01, moduli_sum = (terms + 2) * kTaylorRoundoff * 1.01;
  z.r = up(z.r + moduli * (1.0 + moduli_sum) + sums * up(sizes) + kTaylorUnderflow * (terms + 1));
}

inline Taylor operator+(const Taylor& x, const Taylor& y) {
  Taylor z;
  add_into(z, x, y);
  return z;
}
inline Taylor operator-(const Taylor& x) {
  Taylor z;
  negate_into(z, x);
  return z;
}
inline Taylor operator-(const Taylor& x, const Taylor& y) {
  Taylor z;
  subtract_into(z, x, y);
  return z;
}
inline Taylor operator*(double s, const Taylor& x) {
  Taylor z;
  scale_into(z, s, x);
  return z;
}
inline Taylor operator*(const Taylor& x, const Taylor& y) {
  Taylor z;
  multiply_into(z, x, y);
  return z;
}
inline Taylor operator*(const Taylor& x, double s) { return s * x; }
// sum + s x for a coefficient s negligible against those it is combined with (a placement's 1e-16 entries,
// model/chain_dynamics.hpp): |s x| <= |s| (|x.c| + radius) joins the remainder, without the product and the sum.
inline void add_small_product(Taylor& sum, double s, const Taylor& x) {
  if (x.is_zero() || s == 0.0) return;
  sum.r = taylor_detail::up(sum.r + std::abs(s) * taylor_detail::up(std::abs(x.c) + x.radius()));
}
// sum + s x, computed in place (a combination's terms, model/chain_dynamics.hpp).
inline void add_product(Taylor& sum, double s, const Taylor& x) {
  Taylor term;
  scale_into(term, s, x);
  add_into(sum, sum, term);
}
inline Taylor operator+(double s, const Taylor& x) { return Taylor(s) + x; }
inline Taylor operator+(const Taylor& x, double s) { return x + Taylor(s); }
inline Taylor operator-(double s, const Taylor& x) { return Taylor(s) - x; }
inline Taylor operator-(const Taylor& x, double s) { return x - Taylor(s); }
inline Taylor& operator+=(Taylor& x, const Taylor& y) {
  add_into(x, x, y);
  return x;
}
inline Taylor& operator-=(Taylor& x, const Taylor& y) {
  subtract_into(x, x, y);
  return x;
}
inline Taylor& operator*=(Taylor& x, const Taylor& y) { return x = x * y; }

namespace taylor_detail {

// The argument's range [c - deviation, c + deviation], rounded outward.
inline Interval argument_range(double c, double deviation) {
  const double slack = 2.0 * kTaylorRoundoff * (std::abs(c) + deviation) + kTaylorUnderflow;
  return Interval(c - deviation - slack, c + deviation + slack);
}

// f(c + t) = f(c) + f'(c) t + f''(c) t²/2 + f'''(ξ) t³/6 for f = sin or cos, with |t| <= ρ and f''' bounded by the
// range `third` of f''' over the argument. f(c), f'(c), f''(c) = -f(c) from the C library (within an ulp, counted
// twice). On a wide argument, where that remainder alone is wider than the constant form mid(range) ± rad(range),
// the constant form is taken.
inline Taylor second_order_expansion(const Taylor& x, double value, double slope, const Interval& range,
                                     const Interval& third) {
  Taylor t = x;
  t.c = 0.0;
  const double rho = x.radius();
  const double third_size = std::max(std::abs(third.lower()), std::abs(third.upper()));
  const double cubic = up(third_size * rho * rho * rho / 6.0 * kTaylorInflation);
  const double constant_radius = 0.5 * (range.upper() - range.lower());
  if (constant_radius < cubic) {
    Taylor constant(0.5 * (range.lower() + range.upper()));
    constant.r = up(constant_radius + 2.0 * kTaylorRoundoff * (std::abs(constant.c) + constant_radius));
    return constant;
  }
  Taylor z = value + slope * t + (-0.5 * value) * (t * t);
  z.r = up(z.r + cubic + 2.0 * kTaylorRoundoff * (std::abs(value) + std::abs(slope) * rho + 0.5 * rho * rho));
  return z;
}

}  // namespace taylor_detail

inline Taylor cos(const Taylor& x) {
  const Interval argument = taylor_detail::argument_range(x.c, x.radius());
  return taylor_detail::second_order_expansion(x, std::cos(x.c), -std::sin(x.c), boost::numeric::cos(argument),
                                               boost::numeric::sin(argument));
}
inline Taylor sin(const Taylor& x) {
  const Interval argument = taylor_detail::argument_range(x.c, x.radius());
  return taylor_detail::second_order_expansion(x, std::sin(x.c), std::cos(x.c), boost::numeric::sin(argument),
                                               -boost::numeric::cos(argument));
}

}  // namespace obsgain
