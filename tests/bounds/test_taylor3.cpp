// Third-order Taylor forms (numerics/taylor3.hpp), on which a box's M and Christoffel tensors are computed: they
// contain the double values at random points, keep cubic terms exactly among the cubic symbols and bound them beyond,
// the in-place operations agree with the operators, and the dynamics' rules about a coordinate axis give the general
// rules' forms to the bit. The dynamics computed on them are tested in test_taylor.cpp (the box forms' containment,
// their remainders' order and how close they are to the sampled deviation).
#include "obsgain/model/chain_dynamics.hpp"
#include "obsgain/numerics/dual.hpp"
#include "obsgain/numerics/interval.hpp"
#include "obsgain/numerics/taylor3.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace {

using obsgain::Taylor3;

// x(ε) without its remainder.
double polynomial_part(const Taylor3& x, const std::vector<double>& e) {
  double v = x.c;
  for (int k = 0; k < x.s1; ++k) v += x.a[k] * e[k];
  for (int p = 0; p < x.pairs(); ++p) v += x.b[p] * e[obsgain::kPairs.first[p]] * e[obsgain::kPairs.second[p]];
  for (int m = 0; m < x.s3; ++m)
    for (int p = 0; p < obsgain::pair_count(m + 1); ++p)
      v += x.t[obsgain::triple_count(m) + p] * e[obsgain::kPairs.first[p]] * e[obsgain::kPairs.second[p]] * e[m];
  return v;
}
bool encloses(const Taylor3& x, const std::vector<double>& e, double value, double slack) {
  return std::abs(value - polynomial_part(x, e)) <= x.r + slack;
}
// |c| + Σ|coefficients|, which `magnitude` must bound.
double total(const Taylor3& x) {
  const Taylor3::Sizes s = x.sizes();
  return std::abs(x.c) + s.linear() + s.quadratic() + s.cubic;
}

// Every coefficient, the remainder and the magnitude of two forms, to the bit.
void expect_identical(const Taylor3& a, const Taylor3& b) {
  EXPECT_EQ(a.c, b.c);
  EXPECT_EQ(a.r, b.r);
  EXPECT_EQ(a.magnitude, b.magnitude);
  ASSERT_EQ(a.s1, b.s1);
  ASSERT_EQ(a.s2, b.s2);
  ASSERT_EQ(a.s3, b.s3);
  for (int k = 0; k < a.s1; ++k) EXPECT_EQ(a.a[k], b.a[k]);
  for (int p = 0; p < a.pairs(); ++p) EXPECT_EQ(a.b[p], b.b[p]);
  for (int q = 0; q < a.triples(); ++q) EXPECT_EQ(a.t[q], b.t[q]);
}

// Random forms over ten symbols, three of them beyond the cubic ones (an arc's x), through products of products
// (degree six), sums, differences, multiples, products added in place, constants with a remainder, and the cosine and
// sine of one symbol's forms: each contains the value computed in double at random points, and its magnitude bounds
// its coefficients.
TEST(ThirdOrderForms, EncloseProductsSumsAndTrigonometryAtRandomPoints) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), centre(-2.0, 2.0), radius(0.0, 0.6);
  const auto symbol = [&](int k) { return Taylor3::symbol(centre(rng), radius(rng), k); };
  for (int trial = 0; trial < 300; ++trial) {
    const Taylor3 x = symbol(0) + symbol(3) + symbol(8), y = symbol(2) + symbol(6) + symbol(9);
    const Taylor3 z = symbol(1) + symbol(7);
    const Taylor3 angle = symbol(4), wide = Taylor3::symbol(centre(rng), 2.0, 5);
    Taylor3 constant(centre(rng));
    constant.r = 1e-3;
    const Taylor3 c = cos(angle), s = sin(wide), xy = x * y, cube = xy * z, sixth = cube * (x * (y - z));
    Taylor3 accumulated = 0.7 * xy - z;
    obsgain::multiply_add_into(accumulated, c, cube);
    obsgain::multiply_add_into(accumulated, constant, y);
    obsgain::scale_add_into(accumulated, -1.3, s * x);
    const Taylor3 products = (c * s) * (x + constant);
    for (int point = 0; point < 20; ++point) {
      std::vector<double> e(10);
      for (double& v : e) v = unit(rng);
      const double xv = polynomial_part(x, e), yv = polynomial_part(y, e), zv = polynomial_part(z, e);
      const double cv = std::cos(polynomial_part(angle, e)), sv = std::sin(polynomial_part(wide, e));
      const double kv = constant.c + 1e-3 * unit(rng);
      EXPECT_TRUE(encloses(c, e, cv, 1e-15));
      EXPECT_TRUE(encloses(s, e, sv, 1e-15));
      EXPECT_TRUE(encloses(xy, e, xv * yv, 1e-14));
      EXPECT_TRUE(encloses(cube, e, xv * yv * zv, 1e-13));
      EXPECT_TRUE(encloses(sixth, e, xv * yv * zv * xv * (yv - zv), 1e-12));
      EXPECT_TRUE(encloses(accumulated, e, 0.7 * xv * yv - zv + cv * xv * yv * zv + kv * yv - 1.3 * sv * xv, 1e-12));
      EXPECT_TRUE(encloses(products, e, cv * sv * (xv + kv), 1e-13));
    }
    for (const Taylor3& f : {c, s, xy, cube, sixth, accumulated, products}) EXPECT_GE(f.magnitude, total(f));
  }
}

// Among the cubic symbols a product of three first-order forms is exact: its cubic coefficient is the product of the
// slopes, and its remainder only rounding. With a symbol beyond them (here 7, kCubicSymbols) the cubic monomial goes
// into the remainder, whole. A fourth-order product's quartic terms are bounded by its factors' sizes: (x y)² over
// ε ∈ [-1, 1]² with x = 1 + ε_0, y = 1 + ε_1 has remainder at least the quartic term's 1 and its sizes' bound 1.
TEST(ThirdOrderForms, CubicTermsAreExactAmongTheCubicSymbolsAndBoundedBeyond) {
  ASSERT_EQ(obsgain::kCubicSymbols, 7);
  const Taylor3 x = Taylor3::symbol(1.0, 0.5, 0), y = Taylor3::symbol(2.0, 0.25, 3);
  const Taylor3 z = Taylor3::symbol(-1.0, 0.125, 6);
  const Taylor3 xyz = x * y * z;
  EXPECT_EQ(xyz.t[obsgain::triple_count(6) + obsgain::kPairs.index[0][3]], 0.5 * 0.25 * 0.125);
  EXPECT_LT(xyz.r, 1e-13);  // rounding only
  const Taylor3 beyond = x * y * Taylor3::symbol(-1.0, 0.125, 7);
  for (int q = 0; q < beyond.triples(); ++q) EXPECT_EQ(beyond.t[q], 0.0);
  EXPECT_GE(beyond.r, 0.5 * 0.25 * 0.125);
  EXPECT_LT(beyond.r, 0.5 * 0.25 * 0.125 + 1e-13);
  const Taylor3 u = Taylor3::symbol(1.0, 1.0, 0), v = Taylor3::symbol(1.0, 1.0, 1), uv = u * v;
  const Taylor3 square = uv * uv;  // (1 + ε_0)² (1 + ε_1)²: the ε_0² ε_1² term is the only quartic one
  EXPECT_EQ(square.t[obsgain::triple_count(1) + obsgain::kPairs.index[0][1]], 2.0);  // ε_0 ε_1², and ε_0² ε_1:
  EXPECT_EQ(square.t[obsgain::triple_count(1) + obsgain::kPairs.index[0][0]], 2.0);
  EXPECT_GE(square.r, 1.0);
  EXPECT_LT(square.r, 1.0 + 1e-12);  // and rounding
}

// The operations that write into a given form agree with the operators when the form written is an operand (x += y,
// y = x + y, x -= y, x = s x, x = -x), to the bit; a product added in place agrees with the sum of the product to
// rounding, and so does a dual's product (the product rule) and a dual's product added in place.
TEST(ThirdOrderForms, InPlaceOperationsAgreeWithTheOperators) {
  const Taylor3 x = cos(Taylor3::symbol(0.3, 0.2, 0)) * Taylor3::symbol(2.0, 0.5, 2);
  const Taylor3 y = sin(Taylor3::symbol(-0.7, 0.3, 4)) + Taylor3::symbol(0.1, 0.05, 1) * Taylor3::symbol(1.0, 0.2, 8);
  Taylor3 sum = x;
  obsgain::add_into(sum, sum, y);
  expect_identical(sum, x + y);
  Taylor3 into_second = y;
  obsgain::add_into(into_second, x, into_second);
  expect_identical(into_second, x + y);
  Taylor3 difference = y;
  obsgain::subtract_into(difference, difference, x);
  expect_identical(difference, y - x);
  Taylor3 scaled = x;
  obsgain::scale_into(scaled, 2.5, scaled);
  expect_identical(scaled, 2.5 * x);
  Taylor3 negated = y;
  obsgain::negate_into(negated, negated);
  expect_identical(negated, -y);
  const auto expect_close = [](const Taylor3& a, const Taylor3& b) {
    EXPECT_NEAR(a.c, b.c, 1e-15);
    EXPECT_NEAR(a.r, b.r, 1e-14);
    for (int k = 0; k < std::max(a.s1, b.s1); ++k) EXPECT_NEAR(k < a.s1 ? a.a[k] : 0.0, k < b.s1 ? b.a[k] : 0.0, 1e-15);
    for (int q = 0; q < std::max(a.triples(), b.triples()); ++q)
      EXPECT_NEAR(q < a.triples() ? a.t[q] : 0.0, q < b.triples() ? b.t[q] : 0.0, 1e-15);
  };
  Taylor3 accumulated = y;
  obsgain::multiply_add_into(accumulated, x, y);
  expect_close(accumulated, y + x * y);
  using DualForm = obsgain::Dual<Taylor3>;
  DualForm u = DualForm::variable(x, 0, 2), v = DualForm::variable(y, 1, 2);
  u.derivative[1] = y;
  v.derivative[0] = 0.5 * x;
  const DualForm product = u * v;
  DualForm added = v;
  obsgain::multiply_add(added, u, v);
  for (int k = 0; k < 2; ++k) {
    expect_close(product.derivative[k], u.derivative[k] * v.value + u.value * v.derivative[k]);
    expect_close(added.derivative[k], v.derivative[k] + (u.derivative[k] * v.value + u.value * v.derivative[k]));
  }
}

// A dual copies only the derivatives in use (numerics/dual.hpp): a copy keeps them to the bit, and a dual assigned one
// of fewer directions reads zero beyond them, so that a later sum with a dual of more directions is that dual's
// derivatives exactly, as from a fresh dual.
TEST(ThirdOrderForms, DualsCopyTheDerivativesInUseAndAreZeroBeyond) {
  using DualForm = obsgain::Dual<Taylor3>;
  const Taylor3 x = cos(Taylor3::symbol(0.3, 0.2, 0)) * Taylor3::symbol(2.0, 0.5, 2);
  DualForm wide = DualForm::variable(x, 0, 3);
  wide.derivative[1] = 0.5 * x;
  wide.derivative[2] = x * x;
  const DualForm copy(wide);
  ASSERT_EQ(copy.directions, 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(copy.derivative[k].c, wide.derivative[k].c);
    EXPECT_EQ(copy.derivative[k].r, wide.derivative[k].r);
    ASSERT_EQ(copy.derivative[k].s1, wide.derivative[k].s1);
    for (int i = 0; i < copy.derivative[k].s1; ++i) EXPECT_EQ(copy.derivative[k].a[i], wide.derivative[k].a[i]);
  }
  DualForm narrowed = wide;
  narrowed = DualForm::variable(Taylor3(1.5), 0, 1);
  ASSERT_EQ(narrowed.directions, 1);
  EXPECT_TRUE(narrowed.derivative[1].is_zero());
  EXPECT_TRUE(narrowed.derivative[2].is_zero());
  const DualForm sum = narrowed + wide, fresh = DualForm::variable(Taylor3(1.5), 0, 1) + wide;
  ASSERT_EQ(sum.directions, 3);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(sum.derivative[k].c, fresh.derivative[k].c);
    EXPECT_EQ(sum.derivative[k].r, fresh.derivative[k].r);
    ASSERT_EQ(sum.derivative[k].s1, fresh.derivative[k].s1);
  }
  EXPECT_EQ(sum.derivative[2].c, wide.derivative[2].c);  // x² + 0: x²'s centre, exactly
}

// Every derivative of two duals of forms, as expect_identical above.
void expect_identical(const obsgain::Dual<Taylor3>& x, const obsgain::Dual<Taylor3>& y) {
  expect_identical(x.value, y.value);
  for (int k = 0; k < obsgain::kMaxDirections; ++k) expect_identical(x.derivative[k], y.derivative[k]);
}

// About a coordinate axis, rotations and rotated inertias refer to their operands' forms where the general rule copies
// them (model/chain_dynamics.hpp). The results must be the general rule's to the bit, for ±x, ±y and ±z, turned forward
// and back, on duals of third-order forms (the box forms) and on intervals (the derivatives' enclosures).
TEST(ThirdOrderForms, CoordinateAxesGiveTheGeneralRulesFormsToTheBit) {
  using DualForm = obsgain::Dual<Taylor3>;
  namespace detail = obsgain::chain_detail;
  const DualForm q = DualForm::variable(Taylor3::symbol(0.7, 0.2, 0), 0, 2);
  const DualForm c = cos(q), s = sin(q), c2 = c * c - s * s, s2 = 2.0 * (c * s);
  const auto form = [&](int i) {  // of three symbols, with a derivative in both directions
    const DualForm u = DualForm::variable(Taylor3::symbol(0.4 * i - 1.3, 0.05 + 0.02 * i, 1 + i % 3), 1, 2);
    return u * (i % 2 ? c : s) + DualForm(Taylor3::symbol(0.1 * i, 0.03, 2 - i % 2));
  };
  const obsgain::Vec3<DualForm> v{form(1), form(2), form(3)};
  std::array<obsgain::Vec3<DualForm>, 3> I;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) I[r][k] = k < r ? I[k][r] : form(4 + 3 * r + k);
  const obsgain::Interval qi(0.5, 0.9), ci = cos(qi), si = sin(qi), c2i = cos(2.0 * qi), s2i = sin(2.0 * qi);
  const obsgain::Vec3<obsgain::Interval> vi{obsgain::Interval(-1.0, 0.5), obsgain::Interval(0.25, 2.0),
                                            obsgain::Interval(-3.0, -1.0)};
  std::array<obsgain::Vec3<obsgain::Interval>, 3> Ii;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) Ii[r][k] = k < r ? Ii[k][r] : obsgain::Interval(0.1 * (r - k), 0.2 + 0.3 * r + 0.1 * k);
  for (int axis = 0; axis < 3; ++axis)
    for (const double direction : {1.0, -1.0}) {
      const Eigen::Vector3d a = direction * Eigen::Vector3d::Unit(axis);
      for (const double sign : {1.0, -1.0}) {
        const auto fast = detail::rodrigues_about_coordinate_axis(axis, a, c, s, v, sign);
        const auto general = detail::rodrigues_about_any_axis(a, c, s, v, sign);
        const auto fast_i = detail::rodrigues_about_coordinate_axis(axis, a, ci, si, vi, sign);
        const auto general_i = detail::rodrigues_about_any_axis(a, ci, si, vi, sign);
        for (int i = 0; i < 3; ++i) {
          expect_identical(fast[i], general[i]);
          EXPECT_EQ(fast_i[i].lower(), general_i[i].lower());
          EXPECT_EQ(fast_i[i].upper(), general_i[i].upper());
        }
      }
      for (const auto formed : {detail::Entries::all, detail::Entries::upper}) {
        const auto fast = detail::rotated_inertia_about_coordinate_axis(a, c, s, c2, s2, I, formed);
        const auto general = detail::rotated_inertia_about_any_axis(a, c, s, c2, s2, I, formed);
        const auto fast_i = detail::rotated_inertia_about_coordinate_axis(a, ci, si, c2i, s2i, Ii, formed);
        const auto general_i = detail::rotated_inertia_about_any_axis(a, ci, si, c2i, s2i, Ii, formed);
        for (int r = 0; r < 3; ++r)
          for (int k = 0; k < 3; ++k) {
            expect_identical(fast[r][k], general[r][k]);
            EXPECT_EQ(fast_i[r][k].lower(), general_i[r][k].lower());
            EXPECT_EQ(fast_i[r][k].upper(), general_i[r][k].upper());
          }
      }
      // And both turn: at ε = 0 the forms are the rotation of v's centres.
      const Eigen::Vector3d centres(v[0].value.c, v[1].value.c, v[2].value.c);
      for (const double sign : {1.0, -1.0}) {
        const Eigen::Vector3d turned = Eigen::AngleAxisd(sign * 0.7, a) * centres;
        const auto fast = detail::rodrigues(a, c, s, v, sign);
        for (int i = 0; i < 3; ++i) EXPECT_NEAR(fast[i].value.c, turned(i), 1e-12);
      }
    }
}

// The cosine and sine of a narrow angle are exact to the third order: sin(π/2 + 0.1 ε) = 1 - 0.005 ε² + R with no
// cubic term and |R| <= 0.1⁴/24; cos(0.1 ε) = 1 - 0.005 ε² likewise; sin(0.1 ε) = 0.1 ε - 0.1³/6 ε³ + R.
TEST(ThirdOrderForms, NarrowAnglesAreExpandedToTheThirdOrder) {
  const Taylor3 s = sin(Taylor3::symbol(M_PI / 2, 0.1, 0));
  EXPECT_NEAR(s.b[0], -0.005, 1e-16);
  EXPECT_NEAR(s.t[0], 0.0, 1e-17);
  EXPECT_LT(s.r, 0.1 * 0.1 * 0.1 * 0.1 / 24 + 1e-14);
  EXPECT_GE(s.r, 0.1 * 0.1 * 0.1 * 0.1 / 24);
  const Taylor3 odd = sin(Taylor3::symbol(0.0, 0.1, 2));
  EXPECT_NEAR(odd.a[2], 0.1, 1e-16);  // cos 0 within its enclosure's midpoint
  EXPECT_NEAR(odd.t[obsgain::triple_count(2) + obsgain::kPairs.index[2][2]], -0.1 * 0.1 * 0.1 / 6, 1e-18);
  EXPECT_THROW(cos(Taylor3::symbol(0.0, 0.1, 0) + Taylor3::symbol(0.0, 0.1, 1)), std::logic_error);
}

}  // namespace
