// Third-order Taylor forms: x = c + Σ a_k ε_k + Σ b_kl ε_k ε_l + Σ t_klm ε_k ε_l ε_m + e, |e| <= r, the forms a box's M
// and its derivatives are computed on (bounds/box_forms.cpp) before they are turned into second-order forms
// (numerics/taylor.hpp) with their cubic part bounded monomial by monomial. Carrying the cubic terms through the
// composite-rigid-body recursion lets them cancel where they do, instead of each product bounding its own by its
// factors' sizes (docs/theory.md, "Third-order forms for M and the tensors").
//
// Cubic terms are kept among the first kCubicSymbols symbols (a box's angles, and ys of its arcs: box_forms numbers an
// arc's x, whose coefficient is of second order in the side's radius, after them); a product's cubic terms with any
// other symbol go into the remainder by sizes. Each order stores a prefix of its coefficients (`s1`, `s2`, `s3`: the
// slopes of the first s1 symbols, the pairs and triples of the first s2 and s3, zero beyond), so a joint's cosine (two
// slopes, no curvature) multiplies a dense form at the cost of its slopes.
//
// Rigour as in taylor.hpp: every operation bounds its floating-point error (at most 2⁻⁵² of each rounded sum or
// product's modulus, in any rounding mode, plus the underflow floor) and adds it to r. `magnitude`, an upper bound of
// |c| + Σ|coefficients| kept by every operation without a pass over the coefficients, bounds the rounding only.
#pragma once

#include "obsgain/numerics/taylor.hpp"

#include <stdexcept>

namespace obsgain {

inline constexpr int kCubicSymbols = 7;  // a chain of up to eight joints searches seven
inline constexpr int kCubicPairs = pair_count(kCubicSymbols);
constexpr int triple_count(int symbols) { return symbols * (symbols + 1) * (symbols + 2) / 6; }
inline constexpr int kCubicTriples = triple_count(kCubicSymbols);

// Monomials ε_k ε_l ε_m (k <= l <= m < kCubicSymbols), ordered by m, then by the pair (k, l) in kPairs' order: those
// of the first s symbols are the first triple_count(s). `cross[k][p]`: the monomial of ε_k times pair p's.
struct TaylorTriples {
  std::array<std::array<int, kCubicPairs>, kCubicSymbols> cross{};
  constexpr TaylorTriples() {
    for (int k = 0; k < kCubicSymbols; ++k)
      for (int p = 0; p < kCubicPairs; ++p) {
        int v[3] = {k, kPairs.first[p], kPairs.second[p]};
        std::sort(v, v + 3);
        cross[k][p] = triple_count(v[2]) + kPairs.index[v[0]][v[1]];
      }
  }
};
inline constexpr TaylorTriples kTriples{};

struct Taylor3 {
  double c = 0.0;
  std::array<double, kTaylorSymbols> a;
  std::array<double, kTaylorPairs> b;
  std::array<double, kCubicTriples> t;
  double r = 0.0;
  int s1 = 0, s2 = 0, s3 = 0;  // a[0, s1), b[0, pair_count(s2)), t[0, triple_count(s3)) stored; zero beyond
  double magnitude = 0.0;      // >= |c| + Σ|a| + Σ|b| + Σ|t|

  // Not "= default", as Taylor's: value-initialisation would clear every coefficient.
  Taylor3() {}  // NOLINT(modernize-use-equals-default)
  Taylor3(double x) : c(x), magnitude(std::abs(x)) {}  // NOLINT: an exact constant mixes freely with forms
  Taylor3(const Taylor3& x) : c(x.c), r(x.r), s1(x.s1), s2(x.s2), s3(x.s3), magnitude(x.magnitude) { copy(x); }
  Taylor3& operator=(const Taylor3& x) {
    if (this == &x) return *this;
    c = x.c;
    r = x.r;
    s1 = x.s1;
    s2 = x.s2;
    s3 = x.s3;
    magnitude = x.magnitude;
    copy(x);
    return *this;
  }
  // centre + radius ε_k.
  static Taylor3 symbol(double centre, double radius, int k) {
    Taylor3 x(centre);
    x.s1 = k + 1;
    std::fill_n(x.a.begin(), k, 0.0);
    x.a[k] = radius;
    x.magnitude = taylor_detail::up(std::abs(centre) + std::abs(radius));
    return x;
  }
  int pairs() const { return pair_count(s2); }
  int triples() const { return triple_count(s3); }
  bool is_zero() const { return s1 == 0 && s2 == 0 && s3 == 0 && c == 0.0 && r == 0.0; }
  bool is_constant() const { return s1 == 0 && s2 == 0 && s3 == 0; }
  // The orders' sizes, Σ|a_k| and Σ|b_p| each split at the cubic symbols (low: their slopes and pairs), and Σ|t|.
  struct Sizes {
    double low1, high1, low2, high2, cubic;
    double linear() const { return taylor_detail::up(low1 + high1); }
    double quadratic() const { return taylor_detail::up(low2 + high2); }
  };
  Sizes sizes() const {
    const int l1 = std::min(s1, kCubicSymbols), l2 = std::min(pairs(), kCubicPairs);
    return {sum_abs(a.data(), 0, l1), sum_abs(a.data(), l1, s1), sum_abs(b.data(), 0, l2),
            sum_abs(b.data(), l2, pairs()), sum_abs(t.data(), 0, triples())};
  }
  // Each order's prefix widened to at least the given symbols, zeros beyond its own.
  void widen(int e1, int e2, int e3) {
    if (e1 > s1) std::fill(a.begin() + s1, a.begin() + e1, 0.0), s1 = e1;
    if (e2 > s2) std::fill(b.begin() + pairs(), b.begin() + pair_count(e2), 0.0), s2 = e2;
    if (e3 > s3) std::fill(t.begin() + triples(), t.begin() + triple_count(e3), 0.0), s3 = e3;
  }

 private:
  static double sum_abs(const double* x, int from, int to) {
    double s = 0.0;
    for (int i = from; i < to; ++i) s += std::abs(x[i]);
    return taylor_detail::up(s);
  }
  void copy(const Taylor3& x) {
    std::copy_n(x.a.begin(), s1, a.begin());
    std::copy_n(x.b.begin(), pairs(), b.begin());
    std::copy_n(x.t.begin(), triples(), t.begin());
  }
};

namespace taylor3_detail {

// z[i] = x[i] + sign y[i] over the longer prefix (each zero beyond its own); returns Σ|z_i| over the rounded sums (the
// copies and negations beyond the shorter prefix are exact). z may be x or y.
inline double add_order(double* z, const double* x, int nx, const double* y, int ny, double sign) {
  const int common = std::min(nx, ny);
  double moduli = 0.0;
  for (int i = 0; i < common; ++i) {
    z[i] = x[i] + sign * y[i];
    moduli += std::abs(z[i]);
  }
  if (nx > common) {
    if (z != x) std::copy(x + common, x + nx, z + common);
  } else {
    for (int i = common; i < ny; ++i) z[i] = sign * y[i];
  }
  return moduli;
}

// z = x + sign y (sign ±1), each rounded sum within 2⁻⁵² of its modulus. z may be x or y.
inline void add_signed(Taylor3& z, const Taylor3& x, const Taylor3& y, double sign) {
  const double remainders = x.r + y.r, magnitude = taylor_detail::up(x.magnitude + y.magnitude);
  const int e1 = std::max(x.s1, y.s1), e2 = std::max(x.s2, y.s2), e3 = std::max(x.s3, y.s3);
  z.c = x.c + sign * y.c;
  double moduli = std::abs(z.c);
  moduli += add_order(z.a.data(), x.a.data(), x.s1, y.a.data(), y.s1, sign);
  moduli += add_order(z.b.data(), x.b.data(), x.pairs(), y.b.data(), y.pairs(), sign);
  moduli += add_order(z.t.data(), x.t.data(), x.triples(), y.t.data(), y.triples(), sign);
  z.s1 = e1;
  z.s2 = e2;
  z.s3 = e3;
  z.magnitude = magnitude;
  z.r = taylor_detail::up(remainders + kTaylorRoundoff * taylor_detail::up(moduli));
}

}  // namespace taylor3_detail

// z = x + y, z = -x, z = x - y: the operations write their result into a given form, as taylor.hpp's. z may be x or y.
inline void add_into(Taylor3& z, const Taylor3& x, const Taylor3& y) {
  if (x.is_zero() || y.is_zero()) {  // exact: the other operand
    z = y.is_zero() ? x : y;
    return;
  }
  taylor3_detail::add_signed(z, x, y, 1.0);
}
inline void negate_into(Taylor3& z, const Taylor3& x) {
  z.c = -x.c;
  z.s1 = x.s1;
  z.s2 = x.s2;
  z.s3 = x.s3;
  for (int k = 0; k < x.s1; ++k) z.a[k] = -x.a[k];
  for (int p = 0; p < x.pairs(); ++p) z.b[p] = -x.b[p];
  for (int q = 0; q < x.triples(); ++q) z.t[q] = -x.t[q];
  z.r = x.r;
  z.magnitude = x.magnitude;
}
inline void subtract_into(Taylor3& z, const Taylor3& x, const Taylor3& y) {
  if (y.is_zero()) {
    z = x;
    return;
  }
  if (x.is_zero()) {
    negate_into(z, y);
    return;
  }
  taylor3_detail::add_signed(z, x, y, -1.0);
}

// z = s x, each product within 2⁻⁵² of its modulus; by 0 and ±1 exactly. z may be x.
inline void scale_into(Taylor3& z, double s, const Taylor3& x) {
  if (taylor_detail::scaled_exactly(z, s, x)) return;
  const double scaled = taylor_detail::up(std::abs(s) * x.magnitude * (1.0 + kTaylorRoundoff));
  z.r = taylor_detail::up(std::abs(s) * x.r + kTaylorRoundoff * scaled);
  z.c = s * x.c;
  z.s1 = x.s1;
  z.s2 = x.s2;
  z.s3 = x.s3;
  for (int k = 0; k < x.s1; ++k) z.a[k] = s * x.a[k];
  for (int p = 0; p < x.pairs(); ++p) z.b[p] = s * x.b[p];
  for (int q = 0; q < x.triples(); ++q) z.t[q] = s * x.t[q];
  z.magnitude = scaled;
}

// z += s x in place (z not x): each coefficient one product and one sum, within 2.01 · 2⁻⁵² of |z_i| + |s x_i|.
inline void scale_add_into(Taylor3& z, double s, const Taylor3& x) {
  if (x.is_zero() || s == 0.0) return;
  if (z.is_zero()) {
    scale_into(z, s, x);
    return;
  }
  z.widen(x.s1, x.s2, x.s3);
  const double moduli = taylor_detail::up(z.magnitude + std::abs(s) * x.magnitude);
  z.c += s * x.c;
  for (int k = 0; k < x.s1; ++k) z.a[k] += s * x.a[k];
  for (int p = 0; p < x.pairs(); ++p) z.b[p] += s * x.b[p];
  for (int q = 0; q < x.triples(); ++q) z.t[q] += s * x.t[q];
  z.r = taylor_detail::up(z.r + std::abs(s) * x.r + 2.01 * kTaylorRoundoff * moduli);
  z.magnitude = taylor_detail::up(moduli * (1.0 + 3.0 * kTaylorRoundoff));
}

namespace taylor3_detail {

// z.b += x_k y_l at the pair (k, l), for every slope k of x and l of y.
inline void add_slope_products(Taylor3& z, const double* x, int nx, const double* y, int ny) {
  for (int k = 0; k < nx; ++k) {
    if (x[k] == 0.0) continue;
    const auto& index = kPairs.index[k];
    for (int l = 0; l < ny; ++l) z.b[index[l]] += x[k] * y[l];
  }
}
// z.t += a_k b_p at the monomial of ε_k times pair p's, for the slopes k < na and pairs p < nb of the cubic symbols.
inline void add_cross_terms(Taylor3& z, const double* a, int na, const double* b, int nb) {
  for (int k = 0; k < na; ++k) {
    if (a[k] == 0.0) continue;
    const auto& cross = kTriples.cross[k];
    for (int p = 0; p < nb; ++p) z.t[cross[p]] += a[k] * b[p];
  }
}
// z += (c ± e) y for a constant factor: c y by scale_add_into, and |e y| <= e (magnitude(y) + r_y).
inline void add_constant_product(Taylor3& z, const Taylor3& constant, const Taylor3& y) {
  scale_add_into(z, constant.c, y);
  if (constant.r != 0.0) z.r = taylor_detail::up(z.r + constant.r * (y.magnitude + y.r));
}

}  // namespace taylor3_detail

// z += x y truncated at the third order, in place (z neither x nor y). Kept exactly: the products of the centres,
// slopes and curvatures up to the third order among the cubic symbols. Bounded by the factors' sizes: the fourth- and
// higher-order terms, the cubic terms with another symbol, and every product with a remainder. Each coefficient sums at
// most nine terms (its own and eight products, each product in one coefficient): rounding within
// 9.01 · 2⁻⁵² (magnitude(z) + magnitude(x) magnitude(y)).
// X and Y are x's and y's sizes, taken by a caller that multiplies one factor into several products (a dual's value
// enters one per derivative of the other factor, numerics/dual.hpp).
inline void multiply_add_into(Taylor3& z, const Taylor3& x, const Taylor3::Sizes& X, const Taylor3& y,
                              const Taylor3::Sizes& Y) {
  using taylor3_detail::add_constant_product;
  if (x.is_zero() || y.is_zero()) return;
  if (x.is_constant()) return add_constant_product(z, x, y);
  if (y.is_constant()) return add_constant_product(z, y, x);
  const double X1 = X.linear(), X2 = X.quadratic(), Y1 = Y.linear(), Y2 = Y.quadratic();
  const double xt = taylor_detail::up(std::abs(x.c) + X1 + X2 + X.cubic);
  const double yt = taylor_detail::up(std::abs(y.c) + Y1 + Y2 + Y.cubic);
  const int xl = std::min(x.s1, kCubicSymbols), yl = std::min(y.s1, kCubicSymbols);
  const int xp = std::min(x.pairs(), kCubicPairs), yp = std::min(y.pairs(), kCubicPairs);
  const int slopes = x.s1 > 0 && y.s1 > 0 ? std::max(x.s1, y.s1) : 0;
  const int xy = xl > 0 && yp > 0 ? std::max(xl, std::min(y.s2, kCubicSymbols)) : 0;
  const int yx = yl > 0 && xp > 0 ? std::max(yl, std::min(x.s2, kCubicSymbols)) : 0;
  const double rounding = 9.01 * kTaylorRoundoff * taylor_detail::up(z.magnitude + x.magnitude * y.magnitude);
  z.magnitude = taylor_detail::up((z.magnitude + x.magnitude * y.magnitude) * (1.0 + 10.0 * kTaylorRoundoff));
  z.widen(std::max(x.s1, y.s1), std::max({x.s2, y.s2, slopes}), std::max({x.s3, y.s3, xy, yx}));
  z.c += x.c * y.c;
  for (int k = 0; k < y.s1; ++k) z.a[k] += x.c * y.a[k];
  for (int k = 0; k < x.s1; ++k) z.a[k] += y.c * x.a[k];
  for (int p = 0; p < y.pairs(); ++p) z.b[p] += x.c * y.b[p];
  for (int p = 0; p < x.pairs(); ++p) z.b[p] += y.c * x.b[p];
  taylor3_detail::add_slope_products(z, x.a.data(), x.s1, y.a.data(), y.s1);
  for (int q = 0; q < y.triples(); ++q) z.t[q] += x.c * y.t[q];
  for (int q = 0; q < x.triples(); ++q) z.t[q] += y.c * x.t[q];
  taylor3_detail::add_cross_terms(z, x.a.data(), xl, y.b.data(), yp);
  taylor3_detail::add_cross_terms(z, y.a.data(), yl, x.b.data(), xp);
  // Not kept: a slope beyond the cubic symbols by any pair, or one within them by a pair beyond.
  const double dropped = X.high1 * Y2 + X.low1 * Y.high2 + Y.high1 * X2 + Y.low1 * X.high2;
  const double quartic = X1 * Y.cubic + X.cubic * Y1 + X2 * Y2 + X2 * Y.cubic + X.cubic * Y2 + X.cubic * Y.cubic;
  z.r = taylor_detail::up(z.r + dropped + quartic + xt * y.r + yt * x.r + x.r * y.r + rounding);
}
// A factor's sizes for the product above: a constant's are not read there, and are not taken.
inline Taylor3::Sizes factor_sizes(const Taylor3& x) { return x.is_constant() ? Taylor3::Sizes{} : x.sizes(); }
inline void multiply_add_into(Taylor3& z, const Taylor3& x, const Taylor3& y) {
  multiply_add_into(z, x, factor_sizes(x), y, factor_sizes(y));
}
inline void multiply_into(Taylor3& z, const Taylor3& x, const Taylor3& y) {
  z = Taylor3(0.0);
  multiply_add_into(z, x, y);
}
// sum + s x for a negligible constant s: |s x| <= |s| (magnitude(x) + r_x) into the remainder (taylor.hpp's rule).
inline void add_small_product(Taylor3& sum, double s, const Taylor3& x) {
  if (x.is_zero() || s == 0.0) return;
  sum.r = taylor_detail::up(sum.r + std::abs(s) * taylor_detail::up(x.magnitude + x.r));
}

inline Taylor3 operator+(const Taylor3& x, const Taylor3& y) {
  Taylor3 z;
  add_into(z, x, y);
  return z;
}
inline Taylor3 operator-(const Taylor3& x, const Taylor3& y) {
  Taylor3 z;
  subtract_into(z, x, y);
  return z;
}
inline Taylor3 operator-(const Taylor3& x) {
  Taylor3 z;
  negate_into(z, x);
  return z;
}
inline Taylor3 operator*(const Taylor3& x, const Taylor3& y) {
  Taylor3 z;
  multiply_into(z, x, y);
  return z;
}
inline Taylor3 operator*(double s, const Taylor3& x) {
  Taylor3 z;
  scale_into(z, s, x);
  return z;
}
inline Taylor3 operator*(const Taylor3& x, double s) { return s * x; }

namespace taylor3_detail {

// cos (cosine: true) or sin of x = m + u, u = a ε_k (a narrow side's angle, or twice it) or a constant:
// f(m) + f' u + f'' u²/2 + f''' u³/6 with the Lagrange remainder ρ⁴/24 (|f''''| <= 1, ρ = |a|), x's own remainder
// (f is 1-Lipschitz), f(m)'s rounding (cos m and sin m each within its interval's radius, times the powers of ρ their
// Taylor coefficients carry) and the coefficients' own.
inline Taylor3 expansion(const Taylor3& x, bool cosine) {
  int k = -1;
  for (int i = 0; i < x.s1; ++i)
    if (x.a[i] != 0.0) {
      if (k >= 0) throw std::logic_error("Taylor3: cos or sin of a form of more than one symbol");
      k = i;
    }
  if (k >= kCubicSymbols) throw std::logic_error("Taylor3: cos or sin of a symbol beyond the cubic ones");
  for (int p = 0; p < x.pairs(); ++p)
    if (x.b[p] != 0.0) throw std::logic_error("Taylor3: cos or sin of a form with curvature");
  for (int q = 0; q < x.triples(); ++q)
    if (x.t[q] != 0.0) throw std::logic_error("Taylor3: cos or sin of a form with cubic terms");
  const Interval cm = boost::numeric::cos(Interval(x.c)), sm = boost::numeric::sin(Interval(x.c));
  const double c0 = 0.5 * (cm.lower() + cm.upper()), s0 = 0.5 * (sm.lower() + sm.upper());
  const double ec = 0.5 * (cm.upper() - cm.lower()), es = 0.5 * (sm.upper() - sm.lower());
  const double f0 = cosine ? c0 : s0, f1 = cosine ? -s0 : c0, f2 = -f0, f3 = -f1;
  Taylor3 z(f0);
  const double rho = k < 0 ? 0.0 : std::abs(x.a[k]);
  if (k >= 0) {
    z.widen(k + 1, k + 1, k + 1);
    const double u = x.a[k];
    z.a[k] = f1 * u;
    z.b[kPairs.index[k][k]] = 0.5 * f2 * u * u;
    z.t[triple_count(k) + kPairs.index[k][k]] = f3 * u * u * u / 6.0;
  }
  const double rho2 = rho * rho, moduli = std::abs(f0) + rho + rho2 + rho2 * rho;
  const double error = (ec + es) * (1.0 + rho + 0.5 * rho2 + rho2 * rho / 6.0);
  z.r = taylor_detail::up(rho2 * rho2 / 24.0 + x.r + error + 4.0 * kTaylorRoundoff * moduli);
  z.magnitude = taylor_detail::up(moduli * (1.0 + 4.0 * kTaylorRoundoff));
  return z;
}

}  // namespace taylor3_detail

inline Taylor3 cos(const Taylor3& x) { return taylor3_detail::expansion(x, true); }
inline Taylor3 sin(const Taylor3& x) { return taylor3_detail::expansion(x, false); }

}  // namespace obsgain
