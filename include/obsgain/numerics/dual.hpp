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
  std::array<T, kMaxDirections> derivative{};
  int directions = 0;  // entries beyond this are zero and never read

  Dual() : derivative(zeros()) {}
  Dual(double v) : value(v), derivative(zeros()) {}  // NOLINT: constants mix freely with duals
  Dual(const T& v) : value(v), derivative(zeros()) {}  // NOLINT
  // The variable q_k: value v, derivative e_k.
  static Dual variable(const T& v, int k, int directions) {
    Dual d(v);
    d.directions = directions;
    d.derivative[k] = T(1.0);
    return d;
  }

 private:
  static std::array<T, kMaxDirections> zeros() {
    std::array<T, kMaxDirections> z;
    z.fill(T(0.0));
    return z;
  }
};

template <class T>
Dual<T> operator+(const Dual<T>& a, const Dual<T>& b) {
  Dual<T> r(a.value + b.value);
  r.directions = std::max(a.directions, b.directions);
  for (int k = 0; k < r.directions; ++k) r.derivative[k] = a.derivative[k] + b.derivative[k];
  return r;
}
template <class T>
Dual<T> operator-(const Dual<T>& a, const Dual<T>& b) {
  Dual<T> r(a.value - b.value);
  r.directions = std::max(a.directions, b.directions);
  for (int k = 0; k < r.directions; ++k) r.derivative[k] = a.derivative[k] - b.derivative[k];
  return r;
}
template <class T>
Dual<T> operator-(const Dual<T>& a) {
  Dual<T> r(-a.value);
  r.directions = a.directions;
  for (int k = 0; k < r.directions; ++k) r.derivative[k] = -a.derivative[k];
  return r;
}
template <class T>
Dual<T> operator*(const Dual<T>& a, const Dual<T>& b) {
  Dual<T> r(a.value * b.value);
  r.directions = std::max(a.directions, b.directions);
  for (int k = 0; k < r.directions; ++k) r.derivative[k] = a.derivative[k] * b.value + a.value * b.derivative[k];
  return r;
}
template <class T>
Dual<T> operator*(double a, const Dual<T>& b) {
  Dual<T> r(a * b.value);
  r.directions = b.directions;
  for (int k = 0; k < r.directions; ++k) r.derivative[k] = a * b.derivative[k];
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
  return a = a + b;
}
template <class T>
Dual<T>& operator-=(Dual<T>& a, const Dual<T>& b) {
  return a = a - b;
}
template <class T>
Dual<T>& operator*=(Dual<T>& a, const Dual<T>& b) {
  return a = a * b;
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
  for (int k = 0; k < r.directions; ++k) r.derivative[k] = c * a.derivative[k];
  return r;
}
template <class T>
Dual<T> cos(const Dual<T>& a) {
  using std::cos;
  using std::sin;
  Dual<T> r(cos(a.value));
  r.directions = a.directions;
  const T s = sin(a.value);
  for (int k = 0; k < r.directions; ++k) r.derivative[k] = -(s * a.derivative[k]);
  return r;
}

}  // namespace obsgain
