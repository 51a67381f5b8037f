// Forward-mode derivatives: a value and its partial derivatives along up to kMaxDirections directions.
// On Interval it encloses a function and its gradient over a box at once, which the centred (mean-value)
// forms of the certified bounds need: f(q) ∈ f(m) + Σ_k ∂f/∂q_k(box) (q_k - m_k).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace obsgain {

// The certified bounds search at most this many joints (a serial chain's first joint does not enter M or C,
// so chains of up to kMaxDirections + 1 joints).
inline constexpr int kMaxDirections = 7;

template <class T>
struct Dual {
  T value{0.0};
  // Value-initialised: zero for every scalar the duals are taken of (double, Interval, Taylor), without forming a zero
  // and copying it seven times (a Taylor form's copy is a call, and a box's forms make tens of thousands of duals).
  std::array<T, kMaxDirections> derivative{};
  int directions = 0;  // entries beyond this are zero and never read

  // Provided, not defaulted: a defaulted one would make value-initialisation (std::vector<Dual>(n)) zero the whole
  // object first, kilobytes per dual of Taylor forms.
  Dual() {}  // NOLINT(modernize-use-equals-default)
  Dual(double v) : value(v) {}  // NOLINT: constants mix freely with duals
  Dual(const T& v) : value(v) {}  // NOLINT
  // Copies only the derivatives in use (those beyond are zero): seven derivatives of Taylor forms are kilobytes, and
  // a box's forms copy thousands of duals.
  Dual(const Dual& x) : value(x.value), directions(x.directions) {
    std::copy_n(x.derivative.begin(), directions, derivative.begin());
  }
  Dual& operator=(const Dual& x) {
    if (this == &x) return *this;
    value = x.value;
    std::copy_n(x.derivative.begin(), x.directions, derivative.begin());
    for (int k = x.directions; k < directions; ++k) derivative[k] = T(0.0);
    directions = x.directions;
    return *this;
  }
  // The variable q_k: value v, derivative e_k.
  static Dual variable(const T& v, int k, int directions) {
    Dual d(v);
    d.directions = directions;
    d.derivative[k] = T(1.0);
    return d;
  }
};

namespace dual_detail {

// z = x + y, -x, x - y, s x, x y: written in place where the value type can (Taylor forms, numerics/taylor.hpp and
// taylor3.hpp, whose values are kilobytes: a temporary and its copy per derivative would cost as much as the
// arithmetic), else assigned.
template <class T>
void sum(T& z, const T& x, const T& y) {
  if constexpr (requires { add_into(z, x, y); })
    add_into(z, x, y);
  else
    z = x + y;
}
template <class T>
void negated(T& z, const T& x) {
  if constexpr (requires { negate_into(z, x); })
    negate_into(z, x);
  else
    z = -x;
}
template <class T>
void difference(T& z, const T& x, const T& y) {
  if constexpr (requires { subtract_into(z, x, y); })
    subtract_into(z, x, y);
  else
    z = x - y;
}
template <class T>
void scaled(T& z, double s, const T& x) {
  if constexpr (requires { scale_into(z, s, x); })
    scale_into(z, s, x);
  else
    z = s * x;
}
template <class T>
void product(T& z, const T& x, const T& y) {
  if constexpr (requires { multiply_into(z, x, y); })
    multiply_into(z, x, y);
  else
    z = x * y;
}

// z += x y as a product and a sum (third-order forms multiply into the sum in place: MeasuresFactors, below).
template <class T>
void product_added(T& z, const T& x, const T& y) {
  T term;
  product(term, x, y);
  sum(z, z, term);
}

}  // namespace dual_detail

// Value types that measure a factor before multiplying it into a sum (third-order forms: its orders' sizes,
// numerics/taylor3.hpp). A dual's value enters one product per derivative of the other factor, and is measured once.
template <class T>
concept MeasuresFactors = requires(T& z, const T& x) { multiply_add_into(z, x, factor_sizes(x), x, factor_sizes(x)); };

// z = a + b, -a, a - b, s b written into a dual with no derivative in use (a fresh one): the operators below, and the
// terms of a rotated inertia about a coordinate axis, formed where they are kept (model/chain_dynamics.hpp).
template <class T>
void sum_into(Dual<T>& r, const Dual<T>& a, const Dual<T>& b) {
  dual_detail::sum(r.value, a.value, b.value);
  r.directions = std::max(a.directions, b.directions);
  for (int k = 0; k < r.directions; ++k) dual_detail::sum(r.derivative[k], a.derivative[k], b.derivative[k]);
}
template <class T>
void negated_into(Dual<T>& r, const Dual<T>& a) {
  dual_detail::negated(r.value, a.value);
  r.directions = a.directions;
  for (int k = 0; k < r.directions; ++k) dual_detail::negated(r.derivative[k], a.derivative[k]);
}
template <class T>
void difference_into(Dual<T>& r, const Dual<T>& a, const Dual<T>& b) {
  dual_detail::difference(r.value, a.value, b.value);
  r.directions = std::max(a.directions, b.directions);
  for (int k = 0; k < r.directions; ++k) dual_detail::difference(r.derivative[k], a.derivative[k], b.derivative[k]);
}
template <class T>
void scaled_into(Dual<T>& r, double a, const Dual<T>& b) {
  dual_detail::scaled(r.value, a, b.value);
  r.directions = b.directions;
  for (int k = 0; k < r.directions; ++k) dual_detail::scaled(r.derivative[k], a, b.derivative[k]);
}

template <class T>
Dual<T> operator+(const Dual<T>& a, const Dual<T>& b) {
  Dual<T> r;
  sum_into(r, a, b);
  return r;
}
template <class T>
Dual<T> operator-(const Dual<T>& a) {
  Dual<T> r;
  negated_into(r, a);
  return r;
}
template <class T>
Dual<T> operator-(const Dual<T>& a, const Dual<T>& b) {
  Dual<T> r;
  difference_into(r, a, b);
  return r;
}
template <class T>
Dual<T> operator*(const Dual<T>& a, const Dual<T>& b) {
  Dual<T> r;
  if constexpr (MeasuresFactors<T>) {  // into a zero: the same products, each factor's value measured once
    multiply_add(r, a, b);
  } else {
    dual_detail::product(r.value, a.value, b.value);
    r.directions = std::max(a.directions, b.directions);
    for (int k = 0; k < r.directions; ++k) {
      dual_detail::product(r.derivative[k], a.derivative[k], b.value);
      dual_detail::product_added(r.derivative[k], a.value, b.derivative[k]);
    }
  }
  return r;
}
template <class T>
Dual<T> operator*(double a, const Dual<T>& b) {
  Dual<T> r;
  scaled_into(r, a, b);
  return r;
}
template <class T>
Dual<T> operator*(const Dual<T>& a, double b) {
  return b * a;
}
template <class T>
Dual<T> operator+(double a, const Dual<T>& b) {
  return Dual<T>(a) + b;
}
template <class T>
Dual<T> operator+(const Dual<T>& a, double b) {
  return a + Dual<T>(b);
}
template <class T>
Dual<T> operator-(double a, const Dual<T>& b) {
  return Dual<T>(a) - b;
}
template <class T>
Dual<T> operator-(const Dual<T>& a, double b) {
  return a - Dual<T>(b);
}
template <class T>
Dual<T>& operator+=(Dual<T>& a, const Dual<T>& b) {
  dual_detail::sum(a.value, a.value, b.value);
  a.directions = std::max(a.directions, b.directions);
  for (int k = 0; k < a.directions; ++k) dual_detail::sum(a.derivative[k], a.derivative[k], b.derivative[k]);
  return a;
}
template <class T>
Dual<T>& operator-=(Dual<T>& a, const Dual<T>& b) {
  return a = a - b;
}
template <class T>
Dual<T>& operator*=(Dual<T>& a, const Dual<T>& b) {
  return a = a * b;
}

// z = base + Σ_m x_m y_m, by the value type's own rule where it has one (second-order forms gather the products' cubic
// terms across the sum, numerics/taylor.hpp; duals of third-order forms add each product in place,
// measured_sum_of_products below), else term by term. The x_m are the factors of few symbols (a joint's cos q, sin q,
// cos 2q, sin 2q). Written into z, so that a dual's value is formed in place (a returned form would be copied into it:
// kilobytes).
template <class T, std::size_t N>
void sum_of_products_to(T& z, const T& base, const std::array<const T*, N>& x, const std::array<const T*, N>& y) {
  if constexpr (requires { sum_of_products_into(z, base, x.data(), y.data(), 1); }) {
    sum_of_products_into(z, base, x.data(), y.data(), static_cast<int>(N));
  } else {
    z = base;
    for (std::size_t m = 0; m < N; ++m) z = z + *x[m] * *y[m];
  }
}
template <class T, std::size_t N>
T sum_of_products(const T& base, const std::array<const T*, N>& x, const std::array<const T*, N>& y) {
  T z;
  sum_of_products_to(z, base, x, y);
  return z;
}
// sum_of_products below for value types that measure their factors: each value measured once for its value's product
// and every derivative's, each product added in place, base first and then in the order of the factors.
template <MeasuresFactors T, std::size_t N>
void measured_sum_of_products(Dual<T>& r, const Dual<T>& base, const std::array<const T*, N>& xv,
                              const std::array<const T*, N>& yv, const std::array<const Dual<T>*, N>& x,
                              const std::array<const Dual<T>*, N>& y) {
  std::array<decltype(factor_sizes(base.value)), N> X, Y;
  r.value = base.value;
  for (std::size_t m = 0; m < N; ++m) {
    X[m] = factor_sizes(*xv[m]);
    Y[m] = factor_sizes(*yv[m]);
    multiply_add_into(r.value, *xv[m], X[m], *yv[m], Y[m]);
  }
  for (int k = 0; k < r.directions; ++k) {
    T& z = r.derivative[k];
    z = base.derivative[k];
    for (std::size_t m = 0; m < N; ++m) {
      const T &dx = x[m]->derivative[k], &dy = y[m]->derivative[k];
      multiply_add_into(z, dx, factor_sizes(dx), *yv[m], Y[m]);
      multiply_add_into(z, *xv[m], X[m], dy, factor_sizes(dy));
    }
  }
}
// On duals, the value's sum by the value type's rule, and each derivative, Σ_m (x_m' y_m + x_m y_m'), term by term, each
// product added in place where the value type can. (On second-order forms, gathering the derivatives' cubic terms too
// cost a third more for the iiwa 14's forms, for a bound 1 % lower on its widest boxes: docs/theory.md, "Cubic terms
// gathered across a rotated inertia's sum"; third-order forms keep those terms.)
template <class T, std::size_t N>
Dual<T> sum_of_products(const Dual<T>& base, const std::array<const Dual<T>*, N>& x,
                        const std::array<const Dual<T>*, N>& y) {
  std::array<const T*, N> xv, yv;
  int directions = base.directions;
  for (std::size_t m = 0; m < N; ++m) {
    xv[m] = &x[m]->value;
    yv[m] = &y[m]->value;
    directions = std::max({directions, x[m]->directions, y[m]->directions});
  }
  Dual<T> r;
  r.directions = directions;
  if constexpr (MeasuresFactors<T>) {
    measured_sum_of_products(r, base, xv, yv, x, y);
  } else {
    sum_of_products_to(r.value, base.value, xv, yv);
    for (int k = 0; k < directions; ++k) {
      T& z = r.derivative[k];
      z = base.derivative[k];
      for (std::size_t m = 0; m < N; ++m) {
        dual_detail::product_added(z, x[m]->derivative[k], y[m]->value);
        dual_detail::product_added(z, x[m]->value, y[m]->derivative[k]);
      }
    }
  }
  return r;
}

// z += x y, component by component in place, for value types that multiply into a sum (third-order forms; any other
// scalar takes chain_detail::multiply_add's z + x y, model/chain_dynamics.hpp).
template <MeasuresFactors T>
void multiply_add(Dual<T>& z, const Dual<T>& x, const Dual<T>& y) {
  const auto X = factor_sizes(x.value), Y = factor_sizes(y.value);
  multiply_add_into(z.value, x.value, X, y.value, Y);
  z.directions = std::max({z.directions, x.directions, y.directions});
  for (int k = 0; k < z.directions; ++k) {
    const T &dx = x.derivative[k], &dy = y.derivative[k];
    multiply_add_into(z.derivative[k], dx, factor_sizes(dx), y.value, Y);
    multiply_add_into(z.derivative[k], x.value, X, dy, factor_sizes(dy));
  }
}

// sum + c x, in place, component by component.
template <class T>
void add_product(Dual<T>& sum, double c, const Dual<T>& x) {
  const auto add = [c](T& s, const T& y) {
    if constexpr (requires { scale_add_into(s, c, y); }) {
      scale_add_into(s, c, y);
    } else {
      T term;
      dual_detail::scaled(term, c, y);
      dual_detail::sum(s, s, term);
    }
  };
  add(sum.value, x.value);
  sum.directions = std::max(sum.directions, x.directions);
  for (int k = 0; k < x.directions; ++k) add(sum.derivative[k], x.derivative[k]);
}

// sum + c x for a negligible constant c, component by component by the value type's own rule where it has one
// (Taylor forms: into the remainder, numerics/taylor.hpp), else computed.
template <class T>
void add_small_product(Dual<T>& sum, double c, const Dual<T>& x) {
  const auto add = [c](T& s, const T& y) {
    if constexpr (requires { add_small_product(s, c, y); })
      add_small_product(s, c, y);
    else
      s = s + c * y;
  };
  add(sum.value, x.value);
  sum.directions = std::max(sum.directions, x.directions);
  for (int k = 0; k < x.directions; ++k) add(sum.derivative[k], x.derivative[k]);
}

// sin and cos of the value type are found by argument-dependent lookup (std:: for double, boost::numeric::
// for intervals).
template <class T>
Dual<T> sin(const Dual<T>& a) {
  using std::cos;
  using std::sin;
  Dual<T> r(sin(a.value));
  r.directions = a.directions;
  const T c = cos(a.value);
  for (int k = 0; k < r.directions; ++k) dual_detail::product(r.derivative[k], c, a.derivative[k]);
  return r;
}
template <class T>
Dual<T> cos(const Dual<T>& a) {
  using std::cos;
  using std::sin;
  Dual<T> r(cos(a.value));
  r.directions = a.directions;
  const T s = sin(a.value);
  T slope;
  for (int k = 0; k < r.directions; ++k) {
    dual_detail::product(slope, s, a.derivative[k]);
    dual_detail::negated(r.derivative[k], slope);
  }
  return r;
}

}  // namespace obsgain
