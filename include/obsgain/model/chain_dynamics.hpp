// The dynamics of a serial chain (serial_chain.hpp) as templates on the scalar: the same code runs on double
// (design, simulation, the real-time observer), on intervals, on Taylor forms and on forward-mode duals of
// them (certified bounds). Every algorithm works in body frames with the rotations kept factored (below).
//   chain_mass_matrix       M(q) by the composite-rigid-body algorithm (one pass, O(n²) frame changes)
//   chain_forces            τ = M(q) q'' + B(q; x, y) [+ g(q)] by a bilinear recursive Newton–Euler pass:
//                           B is the symmetric bilinear form with B(q; v, v) = C(q, v) v = A(q, v)
//   chain_coriolis_tensors  N_i(q) with A_i(q, v) = vᵀ N_i(q) v: N_i[j][k] = B_i(q; e_j, e_k), one pass per
//                           pair, each entry computed directly (no difference of evaluations)
#pragma once

#include "obsgain/model/serial_chain.hpp"
#include "obsgain/numerics/dual.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

namespace obsgain {

// Small fixed-size algebra on any scalar (Eigen's expression templates do not mix double with duals of
// intervals without ceremony, and these loops are all the recursions need).
template <class S>
using Vec3 = std::array<S, 3>;

namespace chain_detail {

template <class S>
Vec3<S> cross(const Vec3<S>& a, const Vec3<S>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class S>
Vec3<S> cross(const Eigen::Vector3d& a, const Vec3<S>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class S>
Vec3<S> add(const Vec3<S>& a, const Vec3<S>& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
template <class S>
Vec3<S> times(double s, const Vec3<S>& a) {
  return {s * a[0], s * a[1], s * a[2]};
}
template <class S>
Vec3<S> scaled(const Eigen::Vector3d& a, double s) {
  return {S(a[0] * s), S(a[1] * s), S(a[2] * s)};
}
template <class S>
Vec3<S> zero() {
  return {S(0.0), S(0.0), S(0.0)};
}
// sum + c x, in place where the scalar can (Taylor forms and their duals, found by argument-dependent lookup).
template <class S>
void add_product(S& sum, double c, const S& x) {
  sum = sum + c * x;
}
// z + x y, in place where the scalar can (duals of third-order forms, found by argument-dependent lookup).
template <class S>
void multiply_add(S& z, const S& x, const S& y) {
  z = z + x * y;
}
// sum + c x for a negligible c: by the scalar's own rule where it has one, found by argument-dependent lookup
// (Taylor forms and their duals bound |c x| into the remainder), else the product itself.
template <class S>
void add_small_product(S& sum, double c, const S& x) {
  sum = sum + c * x;
}
// Coefficients this small against the largest of a combination are bounded rather than multiplied: a URDF's
// rotations by quarter turns carry entries of 1e-16 (cos(π/2) in double) that cost a product of forms each.
inline constexpr double kSmallCoefficient = 1e-8;
// Whether c is negligible in a combination whose largest coefficient has modulus `largest`. An enclosure then sees
// only |c| (add_small_product), which the symmetries of nearly square placements rest on
// (model/dynamics.hpp, ChainSymmetry; docs/theory.md, "Chain symmetries").
inline bool negligible_coefficient(double c, double largest) { return std::abs(c) <= kSmallCoefficient * largest; }
// Σ_j c_j x_j for constant c: on enclosures the zero coefficients are skipped and the negligible ones bounded (an axis
// along a coordinate axis makes most of them zero, and every product and sum of forms costs work and adds rounding);
// in double, the plain sum. One return of one named sum, so that the sum is formed in the caller's object (a second
// return, even in a discarded branch, made GCC copy the kilobytes of a dual of forms on the way out).
template <class S>
S combine(double c0, const S& x0, double c1, const S& x1, double c2, const S& x2) {
  S sum(0.0);
  if constexpr (std::is_same_v<S, double>) {
    sum = c0 * x0 + c1 * x1 + c2 * x2;
  } else {
    const std::array<std::pair<double, const S*>, 3> terms{{{c0, &x0}, {c1, &x1}, {c2, &x2}}};
    const double largest = std::max({std::abs(c0), std::abs(c1), std::abs(c2)});
    for (const auto& [c, x] : terms)
      if (!negligible_coefficient(c, largest)) add_product(sum, c, *x);
    for (const auto& [c, x] : terms)
      if (c != 0.0 && negligible_coefficient(c, largest)) add_small_product(sum, c, *x);
  }
  return sum;
}
// R v for a constant R (not named apply: std::apply would join the overload set through std::array). The components
// are formed in place rather than assigned: a dual of Taylor forms is kilobytes, and the recursions rotate a few
// vectors per body.
template <class S>
Vec3<S> rotate(const Eigen::Matrix3d& R, const Vec3<S>& v) {
  const auto row = [&](int i) { return combine(R(i, 0), v[0], R(i, 1), v[1], R(i, 2), v[2]); };
  return {row(0), row(1), row(2)};
}
// Rᵀ v.
template <class S>
Vec3<S> rotate_back(const Eigen::Matrix3d& R, const Vec3<S>& v) {
  const auto column = [&](int i) { return combine(R(0, i), v[0], R(1, i), v[1], R(2, i), v[2]); };
  return {column(0), column(1), column(2)};
}
template <class S>
S dot(const Eigen::Vector3d& a, const Vec3<S>& b) {
  return combine(a[0], b[0], a[1], b[1], a[2], b[2]);
}
// ½ (a_x × b_y + a_y × b_x): the symmetrised product of two quantities linear in the joint velocities.
// `same`: x and y are one velocity, and the product is computed once. Always inlined: the recursions call it a
// few times per body, and its call would cost more than its arithmetic.
template <class S>
[[gnu::always_inline]] inline Vec3<S> symmetric_cross(const Vec3<S>& ax, const Vec3<S>& by, const Vec3<S>& ay, const Vec3<S>& bx, bool same) {
  if (same) return cross(ax, by);
  return times(0.5, add(cross(ax, by), cross(ay, bx)));
}

}  // namespace chain_detail

// Where each body sits relative to its parent at q. Body i's frame maps into body i-1's by P_i Rot(a_i, q_i)
// (revolute) or P_i (prismatic), P_i the joint's constant placement; p[i] is body i's origin in body i-1's
// frame. On enclosures the rotation is kept factored — P_i applied in double, Rot by Rodrigues with cos q_i and
// sin q_i and the axis's projectors in double — rather than multiplied out: a multiplied-out 3 x 3 matrix of
// intervals forgets that its entries share one angle, and the enclosures of a long chain blow up (the wrapping
// effect). In double nothing is lost by multiplying out, and a frame change is then one 3 x 3 product: the
// real-time observer's update relies on it.
template <class S>
struct ChainKinematics {
  std::array<S, kMaxChainJoints> c, s;
  std::array<S, kMaxChainJoints> c2, s2;  // enclosures only: cos 2q_i, sin 2q_i (rotated inertias, below)
  std::array<Vec3<S>, kMaxChainJoints> p;
  std::array<Eigen::Matrix3d, kMaxChainJoints> rotation;  // double only: P_i Rot(a_i, q_i)
};

template <class S>
void chain_kinematics(const SerialChain& chain, const S* q, ChainKinematics<S>& k) {
  using std::cos;
  using std::sin;
  for (int i = 0; i < chain.dof(); ++i) {
    const ChainJoint& joint = chain.joints[i];
    if (joint.type == JointType::revolute) {
      k.c[i] = cos(q[i]);
      k.s[i] = sin(q[i]);
      for (int r = 0; r < 3; ++r) k.p[i][r] = S(joint.translation[r]);
    } else {
      k.c[i] = S(1.0);
      k.s[i] = S(0.0);
      const Eigen::Vector3d Pa = joint.rotation * joint.axis;
      for (int r = 0; r < 3; ++r) k.p[i][r] = joint.translation[r] + Pa[r] * q[i];
    }
    if constexpr (!std::is_same_v<S, double>) {
      if (joint.type == JointType::revolute) {
        k.c2[i] = cos(2.0 * q[i]);
        k.s2[i] = sin(2.0 * q[i]);
      }
    } else {
      const Eigen::Vector3d& a = joint.axis;
      Eigen::Matrix3d skew;
      skew << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
      const Eigen::Matrix3d along = a * a.transpose();
      k.rotation[i] = joint.rotation * (along + k.c[i] * (Eigen::Matrix3d::Identity() - along) + k.s[i] * skew);
    }
  }
}

// Replaces joint i's cosine and sine, and on enclosures those of 2 q_i by cos 2q = c² - s², sin 2q = 2 c s: for
// enclosures of (cos q_i, sin q_i) that are not functions of an enclosure of q_i (the certified bounds' arcs,
// docs/theory.md, "Taylor forms").
template <class S>
void set_joint_trigonometry(ChainKinematics<S>& k, int i, const S& c, const S& s) {
  k.c[i] = c;
  k.s[i] = s;
  if constexpr (!std::is_same_v<S, double>) {
    k.c2[i] = c * c - s * s;
    k.s2[i] = 2.0 * (c * s);
  }
}

namespace chain_detail {

// rodrigues_about_any_axis (below) about a coordinate axis a = ±e_k. There every entry of the projectors is 0 or 1 and
// every component of a × v is ±v_j or zero, so the general rule's terms are v's own components, copied or negated
// first: component k is v_k, and component i != k is c v_i + (±s) v_j, with the sign on s (a product by a negated
// factor is the negated product, so the forms are the general rule's to the bit). A URDF's axes mostly are coordinate
// axes, and a box forms every rotation dozens of times (docs/history.md, the fortieth round).
template <class S>
Vec3<S> rodrigues_about_coordinate_axis(int k, const Eigen::Vector3d& a, const S& c, const S& s, const Vec3<S>& v,
                                        double sign) {
  const S negated_s = -s;
  const auto component = [&](int i) {
    if (i == k) return v[k];
    const int j = 3 - i - k;
    S z(0.0);
    multiply_add(z, v[i], c);
    multiply_add(z, v[j], sign * a.cross(Eigen::Vector3d::Unit(j))(i) > 0.0 ? s : negated_s);  // ± (a × v)_i s
    return z;
  };
  return {component(0), component(1), component(2)};
}

// Rot(a, ±q) v = (a aᵀ) v + c (I - a aᵀ) v ± s (a × v), the projectors in double: for an axis along a
// coordinate axis each component then involves c and s at most once (no dependency on intervals).
template <class S>
Vec3<S> rodrigues_about_any_axis(const Eigen::Vector3d& a, const S& c, const S& s, const Vec3<S>& v, double sign) {
  const Eigen::Matrix3d along = a * a.transpose();
  const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - along;
  const Vec3<S> perpendicular = rotate(across, v), axv = cross(a, v);
  // ±s is exact, and so is a product by it: the sign goes on s, and each component is one sum of products. +s is s
  // itself, not a copy (a dual of third-order forms is kilobytes, and the recursions turn vectors forward as often
  // as back).
  S negated_s;
  if (!(sign > 0.0)) negated_s = -s;
  const S& signed_s = sign > 0.0 ? s : negated_s;
  const auto component = [&](int i) {
    S z = combine(along(i, 0), v[0], along(i, 1), v[1], along(i, 2), v[2]);  // (a aᵀ v)_i, formed where it is summed
    multiply_add(z, perpendicular[i], c);
    multiply_add(z, axv[i], signed_s);
    return z;
  };
  return {component(0), component(1), component(2)};
}

// Rot(a, ±q) v on enclosures, by either rule above (the same forms either way about a coordinate axis).
template <class S>
Vec3<S> rodrigues(const Eigen::Vector3d& a, const S& c, const S& s, const Vec3<S>& v, double sign) {
  const int k = coordinate_axis(a);
  return k >= 0 ? rodrigues_about_coordinate_axis(k, a, c, s, v, sign) : rodrigues_about_any_axis(a, c, s, v, sign);
}

// From body i's frame into body i-1's, and back. A joint placed without a rotation (P_i = 1) skips it: the
// combination by 1 would give each component back exactly, through a copy of kilobytes.
template <class S>
Vec3<S> to_parent(const SerialChain& chain, const ChainKinematics<S>& k, int i, const Vec3<S>& v) {
  if constexpr (std::is_same_v<S, double>) return rotate(k.rotation[i], v);
  const ChainJoint& joint = chain.joints[i];
  const bool revolute = joint.type == JointType::revolute;
  if (joint.rotation.isIdentity(0.0)) return revolute ? rodrigues(joint.axis, k.c[i], k.s[i], v, 1.0) : v;
  return rotate(joint.rotation, revolute ? rodrigues(joint.axis, k.c[i], k.s[i], v, 1.0) : v);
}
template <class S>
Vec3<S> from_parent(const SerialChain& chain, const ChainKinematics<S>& k, int i, const Vec3<S>& v) {
  if constexpr (std::is_same_v<S, double>) return rotate_back(k.rotation[i], v);
  const ChainJoint& joint = chain.joints[i];
  const bool revolute = joint.type == JointType::revolute;
  if (joint.rotation.isIdentity(0.0)) return revolute ? rodrigues(joint.axis, k.c[i], k.s[i], v, -1.0) : v;
  const Vec3<S> u = rotate(Eigen::Matrix3d(joint.rotation.transpose()), v);
  return revolute ? rodrigues(joint.axis, k.c[i], k.s[i], u, -1.0) : u;
}

}  // namespace chain_detail

// The angular velocity of every body for one vector of joint velocities (linear in it), in body frames:
// `inflow[i]` is body i-1's, `body[i]` body i's own.
template <class S>
struct ChainVelocities {
  std::array<Vec3<S>, kMaxChainJoints> inflow, body;
};

template <class S>
void chain_velocities(const SerialChain& chain, const ChainKinematics<S>& k, const double* qd, ChainVelocities<S>& w) {
  using namespace chain_detail;
  Vec3<S> previous = zero<S>();
  for (int i = 0; i < chain.dof(); ++i) {
    w.inflow[i] = from_parent(chain, k, i, previous);
    const bool revolute = chain.joints[i].type == JointType::revolute;
    w.body[i] = revolute ? add(w.inflow[i], scaled<S>(chain.joints[i].axis, qd[i])) : w.inflow[i];
    previous = w.body[i];
  }
}

namespace chain_detail {

// The first joint with a non-zero velocity (n when none).
inline int first_moving(const double* v, int n) {
  int i = 0;
  while (i < n && v[i] == 0.0) ++i;
  return i;
}

}  // namespace chain_detail

// τ = M(q) qdd + B(q; x, y) [+ g(q)] by recursive Newton–Euler in body frames. Every quantity is either linear in
// the velocities (ω, computed for x and for y in wx, wy) or quadratic (accelerations, forces); a product of two
// linear ones is symmetrised, so the pass is the symmetric bilinear form of the usual one, which it equals for
// x = y (then pass the same velocities twice: `x == y` computes each product once).
template <class S>
void chain_forces(const SerialChain& chain, const ChainKinematics<S>& k, const ChainVelocities<S>& wx,
                  const ChainVelocities<S>& wy, const double* x, const double* y, const double* qdd, bool with_gravity,
                  S* tau) {
  using namespace chain_detail;
  const int n = chain.dof();
  const bool same = x == y;
  std::array<Vec3<S>, kMaxChainJoints> dw, a, f, m;
  Vec3<S> dw_prev = zero<S>();
  // The base accelerates upwards at -gravity: gravity then acts on every body through the recursion.
  Vec3<S> a_prev = with_gravity ? scaled<S>(chain.gravity, -1.0) : zero<S>();
  // Without gravity and q'', every acceleration and force is a product of x's and y's velocities: nothing moves
  // before the later of the first joints they set in motion (the tensors' passes for unit velocities start there).
  const int start = with_gravity || std::any_of(qdd, qdd + n, [](double v) { return v != 0.0; })
                        ? 0
                        : std::max(first_moving(x, n), first_moving(y, n));
  for (int i = 0; i < std::min(start, n); ++i) f[i] = m[i] = zero<S>();
  for (int i = start; i < n; ++i) {
    const Eigen::Vector3d& axis = chain.joints[i].axis;
    const Vec3<S>& p = k.p[i];
    const Vec3<S> w0x = i > 0 ? wx.body[i - 1] : zero<S>(), w0y = i > 0 ? wy.body[i - 1] : zero<S>();
    // The origin's acceleration: a_prev + ω̇ × p + ω × (ω × p), in the parent's frame, then in this body's.
    const Vec3<S> centripetal = symmetric_cross(w0x, cross(w0y, p), w0y, cross(w0x, p), same);
    const Vec3<S> a_origin = from_parent(chain, k, i, add(add(a_prev, cross(dw_prev, p)), centripetal));
    const Vec3<S> relative = symmetric_cross(wx.inflow[i], scaled<S>(axis, y[i]), wy.inflow[i], scaled<S>(axis, x[i]), same);
    if (chain.joints[i].type == JointType::revolute) {
      dw[i] = add(add(from_parent(chain, k, i, dw_prev), scaled<S>(axis, qdd[i])), relative);
      a[i] = a_origin;
    } else {
      dw[i] = from_parent(chain, k, i, dw_prev);
      a[i] = add(add(a_origin, scaled<S>(axis, qdd[i])), times(2.0, relative));  // Coriolis 2 ω × ḋ
    }
    const RigidBody& body = chain.bodies[i];
    const Vec3<S> c{S(body.com[0]), S(body.com[1]), S(body.com[2])};
    const Vec3<S>& bx = wx.body[i];
    const Vec3<S>& by = wy.body[i];
    const Vec3<S> a_com = add(add(a[i], cross(dw[i], c)), symmetric_cross(bx, cross(by, c), by, cross(bx, c), same));
    for (int r = 0; r < 3; ++r) f[i][r] = body.mass * a_com[r];
    const Vec3<S> gyroscopic = symmetric_cross(bx, rotate(body.inertia, by), by, rotate(body.inertia, bx), same);
    m[i] = add(add(rotate(body.inertia, dw[i]), gyroscopic), cross(c, f[i]));
    dw_prev = dw[i];
    a_prev = a[i];
  }
  for (int i = n - 1; i >= 0; --i) {
    if (i + 1 < n) {
      const Vec3<S> f_child = to_parent(chain, k, i + 1, f[i + 1]);
      f[i] = add(f[i], f_child);
      m[i] = add(add(m[i], to_parent(chain, k, i + 1, m[i + 1])), cross(k.p[i + 1], f_child));
    }
    const ChainJoint& joint = chain.joints[i];
    tau[i] = dot(joint.axis, joint.type == JointType::revolute ? m[i] : f[i]);
    if (chain.armature.size() > i && chain.armature[i] != 0.0) tau[i] = tau[i] + chain.armature[i] * qdd[i];
  }
}

namespace chain_detail {

// A subtree's inertia about a frame's origin: mass, first moment h = m c, rotational inertia (rows).
template <class S>
struct CompositeInertia {
  double mass = 0.0;
  Vec3<S> moment;
  std::array<Vec3<S>, 3> rotational;
};

template <class S>
CompositeInertia<S> body_inertia(const RigidBody& body) {
  CompositeInertia<S> I;
  I.mass = body.mass;
  const Eigen::Matrix3d about_origin =
      body.inertia + body.mass * (body.com.squaredNorm() * Eigen::Matrix3d::Identity() - body.com * body.com.transpose());
  for (int r = 0; r < 3; ++r) {
    I.moment[r] = S(body.mass * body.com[r]);
    for (int c = 0; c < 3; ++c) I.rotational[r][c] = S(about_origin(r, c));
  }
  return I;
}

// Which entries of a symmetric 3 x 3 result are formed: all, or those on and above the diagonal (the ones below left
// zero) for a reader that takes (r, c) with r <= c only. add_to_parent is one: a rotated inertia's entries below the
// diagonal cost a third of its sums of products and were never read.
enum class Entries { all, upper };
// The rows of a 3 x 3 matrix from its entries `entry(r, c)`, each formed in place (a brace list evaluates in order).
template <class S, class Entry>
std::array<Vec3<S>, 3> rows_of(const Entry& entry, Entries formed) {
  const auto at = [&](int r, int c) { return formed == Entries::upper && r > c ? S(0.0) : entry(r, c); };
  const auto row = [&](int r) { return Vec3<S>{at(r, 0), at(r, 1), at(r, 2)}; };
  return {row(0), row(1), row(2)};
}
// Rows of X = A I Bᵀ for constant A, B and a symmetric I given by its rows.
template <class S>
std::array<Vec3<S>, 3> sandwich(const Eigen::Matrix3d& A, const std::array<Vec3<S>, 3>& I, const Eigen::Matrix3d& B,
                                Entries formed) {
  const std::array<Vec3<S>, 3> IB{rotate(B, I[0]), rotate(B, I[1]), rotate(B, I[2])};  // I Bᵀ: row r is (B I_r)ᵀ
  const auto entry = [&](int r, int c) { return combine(A(r, 0), IB[0][c], A(r, 1), IB[1][c], A(r, 2), IB[2][c]); };
  return rows_of<S>(entry, formed);
}

// Rot(a, q) = A0 + c A1 + s A2 with A0 = a aᵀ, A1 = 1 - a aᵀ and A2 = [a×], in double.
struct AxisProjectors {
  Eigen::Matrix3d A0, A1, A2;
  explicit AxisProjectors(const Eigen::Vector3d& a) : A0(a * a.transpose()), A1(Eigen::Matrix3d::Identity() - A0) {
    A2 << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  }
};

// Rot I Rotᵀ for Rot = Rot(a, q) on enclosures. With Rot = A0 + c A1 + s A2 (A0 = a aᵀ, A1 = 1 - a aᵀ, A2 = [a×]) and
// c² = (1 + cos 2q)/2, s² = (1 - cos 2q)/2, cs = sin 2q / 2:
//   Rot I Rotᵀ = T0 + c T1 + s T2 + cos 2q T3 + sin 2q T4,
//   T0 = A0 I A0ᵀ + (A1 I A1ᵀ + A2 I A2ᵀ)/2, T1 = A0 I A1ᵀ + A1 I A0ᵀ, T2 = A0 I A2ᵀ + A2 I A0ᵀ,
//   T3 = (A1 I A1ᵀ - A2 I A2ᵀ)/2, T4 = (A1 I A2ᵀ + A2 I A1ᵀ)/2,
// an identity in c and s. The part of I symmetric about a lives in T0 alone, which no enclosure of c or s multiplies:
// a subtree nearly axisymmetric about its joint's axis turns with the enclosure error of its asymmetry only (a wrist
// over its whole range; docs/theory.md, "Taylor forms"). Each entry is one sum of products (sum_of_products), whose
// cubic terms are gathered across the four before their moduli are taken ("Cubic terms gathered across a rotated
// inertia's sum").
template <class S>
std::array<Vec3<S>, 3> rotated_inertia_about_any_axis(const Eigen::Vector3d& a, const S& c, const S& s, const S& c2,
                                                      const S& s2, const std::array<Vec3<S>, 3>& I, Entries formed) {
  const AxisProjectors A(a);
  // An entry (r, k) reads I00, I11 and I22 at (r, k) only, the other three at (r, k) and (k, r).
  const auto I00 = sandwich(A.A0, I, A.A0, formed), I11 = sandwich(A.A1, I, A.A1, formed);
  const auto I22 = sandwich(A.A2, I, A.A2, formed), I01 = sandwich(A.A0, I, A.A1, Entries::all);
  const auto I02 = sandwich(A.A0, I, A.A2, Entries::all), I12 = sandwich(A.A1, I, A.A2, Entries::all);
  const auto entry = [&](int r, int k) {
    const S T0 = I00[r][k] + 0.5 * (I11[r][k] + I22[r][k]);
    const S T1 = I01[r][k] + I01[k][r], T2 = I02[r][k] + I02[k][r];
    const S T3 = 0.5 * (I11[r][k] - I22[r][k]), T4 = 0.5 * (I12[r][k] + I12[k][r]);
    return sum_of_products(T0, std::array<const S*, 4>{&c, &s, &c2, &s2}, std::array<const S*, 4>{&T1, &T2, &T3, &T4});
  };
  return rows_of<S>(entry, formed);
}

// z = x + y, -x, x - y, s x into a fresh z: in place where the scalar can (duals, found by argument-dependent lookup).
template <class S>
void sum_into(S& z, const S& x, const S& y) {
  z = x + y;
}
template <class S>
void negated_into(S& z, const S& x) {
  z = -x;
}
template <class S>
void difference_into(S& z, const S& x, const S& y) {
  z = x - y;
}
template <class S>
void scaled_into(S& z, double s, const S& x) {
  z = s * x;
}

// A term of rotated_inertia_about_coordinate_axis (below): sign times *form, or zero (sign 0).
template <class S>
struct SignedTerm {
  int sign = 0;
  const S* form = nullptr;
};
// Where the ±1 of each row of a matrix of 0 and ±1 (at most one per row) is, and its sign (0: a zero row).
struct UnitRows {
  std::array<int, 3> column{}, sign{};
  explicit UnitRows(const Eigen::Matrix3d& A) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        if (A(r, c) != 0.0) column[r] = c, sign[r] = A(r, c) > 0.0 ? 1 : -1;
  }
  // Entry (r, c) of A I Bᵀ for this A: ±I[i][j] or zero.
  template <class S>
  SignedTerm<S> sandwich(const std::array<Vec3<S>, 3>& I, const UnitRows& B, int r, int c) const {
    const int s = sign[r] * B.sign[c];
    return {s, s == 0 ? nullptr : &I[column[r]][B.column[c]]};
  }
};
// x + sign y (sign ±1) as the general rule's x + y or x - y rounds it: a zero term gives the other back, and two
// nonzero ones are summed into `storage`, their common sign carried (-x - y is -(x + y) to the bit).
template <class S>
SignedTerm<S> signed_sum(const SignedTerm<S>& x, SignedTerm<S> y, int sign, S& storage) {
  y.sign *= sign;
  if (x.sign == 0) return y;
  if (y.sign == 0) return x;
  if (x.sign == y.sign) {
    sum_into(storage, *x.form, *y.form);
    return {x.sign, &storage};
  }
  if (x.sign > 0)
    difference_into(storage, *x.form, *y.form);
  else
    difference_into(storage, *y.form, *x.form);  // -x + y, the same sums
  return {1, &storage};
}
// 0.5 x, its sign carried (0.5 (-x) is -(0.5 x) to the bit).
template <class S>
SignedTerm<S> signed_half(const SignedTerm<S>& x, S& storage) {
  if (x.sign == 0) return x;
  scaled_into(storage, 0.5, *x.form);
  return {x.sign, &storage};
}

// rotated_inertia_about_any_axis (above) about a coordinate axis a = ±e_k. Every row of A0, A1 and A2 then has one
// entry ±1 or none, so every entry of A_i I A_jᵀ is ±I_rc or zero: it is referred to, not formed by copies (which the
// general rule makes: 9 % of the UR5's forms, docs/history.md, the fortieth round), and a sum of two is formed only
// where both are nonzero. Each sum, half and product of nonzero terms is the general rule's on the same forms, with a
// sign carried or moved onto the other factor ((-c) x is -(c x) to the bit), so every entry is the general rule's.
template <class S>
std::array<Vec3<S>, 3> rotated_inertia_about_coordinate_axis(const Eigen::Vector3d& a, const S& c, const S& s,
                                                             const S& c2, const S& s2, const std::array<Vec3<S>, 3>& I,
                                                             Entries formed) {
  const AxisProjectors A(a);
  const UnitRows R0(A.A0), R1(A.A1), R2(A.A2);
  const std::array<const S*, 4> factors{&c, &s, &c2, &s2};
  const S zero(0.0);
  std::array<S, 4> negated_factors;
  for (std::size_t m = 0; m < 4; ++m) negated_into(negated_factors[m], *factors[m]);
  const auto entry = [&](int r, int k) {
    std::array<S, 10> storage;  // fresh duals: the sums formed for this entry
    const auto S00 = R0.sandwich(I, R0, r, k), S11 = R1.sandwich(I, R1, r, k), S22 = R2.sandwich(I, R2, r, k);
    const auto T0 = signed_sum(S00, signed_half(signed_sum(S11, S22, 1, storage[0]), storage[1]), 1, storage[2]);
    const std::array<SignedTerm<S>, 4> T{
        signed_sum(R0.sandwich(I, R1, r, k), R0.sandwich(I, R1, k, r), 1, storage[3]),
        signed_sum(R0.sandwich(I, R2, r, k), R0.sandwich(I, R2, k, r), 1, storage[4]),
        signed_half(signed_sum(S11, S22, -1, storage[5]), storage[6]),
        signed_half(signed_sum(R1.sandwich(I, R2, r, k), R1.sandwich(I, R2, k, r), 1, storage[7]), storage[8])};
    std::array<const S*, 4> x, y;
    for (std::size_t m = 0; m < 4; ++m) {
      x[m] = T[m].sign < 0 ? &negated_factors[m] : factors[m];
      y[m] = T[m].sign == 0 ? &zero : T[m].form;
    }
    if (T0.sign < 0) negated_into(storage[9], *T0.form);
    return sum_of_products(T0.sign == 0 ? zero : T0.sign > 0 ? *T0.form : storage[9], x, y);
  };
  return rows_of<S>(entry, formed);
}

// Rot I Rotᵀ on enclosures, by either rule above (the same forms either way about a coordinate axis).
template <class S>
std::array<Vec3<S>, 3> rotated_inertia(const Eigen::Vector3d& a, const S& c, const S& s, const S& c2, const S& s2,
                                       const std::array<Vec3<S>, 3>& I, Entries formed) {
  return coordinate_axis(a) >= 0 ? rotated_inertia_about_coordinate_axis(a, c, s, c2, s2, I, formed)
                                 : rotated_inertia_about_any_axis(a, c, s, c2, s2, I, formed);
}

// Rows of R I Rᵀ for body i's R = P_i Rot(a_i, q_i) and a symmetric I given by its rows, returned where they are
// formed (a dual of forms is kilobytes: an assignment would copy nine). On enclosures' revolute joints only the entries
// on and above the diagonal are formed (Entries::upper).
template <class S>
std::array<Vec3<S>, 3> turned_to_parent(const SerialChain& chain, const ChainKinematics<S>& k, int i,
                                        const std::array<Vec3<S>, 3>& I) {
  const ChainJoint& joint = chain.joints[i];
  if constexpr (!std::is_same_v<S, double>) {
    if (joint.type == JointType::revolute) {
      // P = 1 (a joint placed without a rotation) would give each entry back, by a copy.
      if (joint.rotation.isIdentity(0.0))
        return rotated_inertia(joint.axis, k.c[i], k.s[i], k.c2[i], k.s2[i], I, Entries::upper);
      const auto turned = rotated_inertia(joint.axis, k.c[i], k.s[i], k.c2[i], k.s2[i], I, Entries::all);
      return sandwich(joint.rotation, turned, joint.rotation, Entries::upper);
    }
  }
  // R I Rᵀ = (R (R I)ᵀ)ᵀ: rotate I's columns (its rows, by symmetry) into T = R I, then T's rows.
  std::array<Vec3<S>, 3> columns;  // columns[j] = T's column j
  for (int j = 0; j < 3; ++j) columns[j] = to_parent(chain, k, i, I[j]);
  const auto row = [&](int r) { return to_parent(chain, k, i, Vec3<S>{columns[0][r], columns[1][r], columns[2][r]}); };
  return {row(0), row(1), row(2)};
}

// Body i's composite inertia expressed about body i-1's origin, in its frame: h' = R h + m p, and
// I' = R I Rᵀ - m [p×]² - [p×][(R h)×] - [(R h)×][p×] (parallel axes, with the first moment).
template <class S>
void add_to_parent(const SerialChain& chain, const ChainKinematics<S>& k, int i, const CompositeInertia<S>& child,
                   CompositeInertia<S>& parent) {
  const std::array<Vec3<S>, 3> rotated = turned_to_parent(chain, k, i, child.rotational);
  const Vec3<S> h = to_parent(chain, k, i, child.moment);
  const Vec3<S>& p = k.p[i];
  parent.mass += child.mass;
  for (int r = 0; r < 3; ++r) parent.moment[r] += h[r] + child.mass * p[r];
  // -[a×][b×] v = -a × (b × v) = (a·b) v - b (a·v): entry (r, c) = (a·b) δ_rc - b_r a_c.
  const S pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2], ph = p[0] * h[0] + p[1] * h[1] + p[2] * h[2];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      S shift = child.mass * (-(p[r] * p[c])) - p[r] * h[c] - h[r] * p[c];
      if (r == c) shift = shift + child.mass * pp + 2.0 * ph;
      S& entry = parent.rotational[r][c];  // summed in place: the sum of three duals of forms, without its copy
      entry += r <= c ? rotated[r][c] : rotated[c][r];
      entry += shift;
    }
}

}  // namespace chain_detail

// M(q) by the composite-rigid-body algorithm, written into M[i * n + j]: M_ji = S_jᵀ (I^c_i S_i) for j <= i, the
// composite inertia's momentum carried to body j's frame.
template <class S>
void chain_mass_matrix(const SerialChain& chain, const ChainKinematics<S>& k, S* M) {
  using namespace chain_detail;
  const int n = chain.dof();
  // On the stack in double (the real-time observer allocates nothing); on the heap for enclosures, whose scalars
  // are kilobytes each.
  std::conditional_t<std::is_same_v<S, double>, std::array<CompositeInertia<S>, kMaxChainJoints>,
                     std::vector<CompositeInertia<S>>>
      composite{};
  if constexpr (std::is_same_v<S, double>) {
    for (int i = 0; i < n; ++i) composite[i] = body_inertia<S>(chain.bodies[i]);
  } else {
    // Appended rather than resized and assigned: resizing would value-initialise, zeroing each inertia's kilobytes.
    composite.reserve(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) composite.push_back(body_inertia<S>(chain.bodies[i]));
  }
  for (int i = n - 1; i > 0; --i) add_to_parent(chain, k, i, composite[i], composite[i - 1]);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d& axis = chain.joints[i].axis;
    const CompositeInertia<S>& I = composite[i];
    // Momentum of the subtree moving with S_i: revolute ω = a: (K, L) = (I a, a × h); prismatic v = a: (h × a, m a).
    Vec3<S> K, L;
    if (chain.joints[i].type == JointType::revolute) {
      for (int r = 0; r < 3; ++r) K[r] = I.rotational[r][0] * axis[0] + I.rotational[r][1] * axis[1] + I.rotational[r][2] * axis[2];
      L = cross(axis, I.moment);
    } else {
      K = times(-1.0, cross(axis, I.moment));
      L = scaled<S>(axis, I.mass);
    }
    for (int j = i; j >= 0; --j) {
      if (j < i) {
        L = to_parent(chain, k, j + 1, L);
        K = add(to_parent(chain, k, j + 1, K), cross(k.p[j + 1], L));
      }
      const ChainJoint& joint = chain.joints[j];
      S value = dot(joint.axis, joint.type == JointType::revolute ? K : L);
      if (j == i && chain.armature.size() > i && chain.armature[i] != 0.0) value = value + chain.armature[i];
      M[j * n + i] = value;
      if (j != i) M[i * n + j] = value;
    }
  }
}

// g(q): the bilinear pass at rest.
template <class S>
void chain_gravity(const SerialChain& chain, const ChainKinematics<S>& k, S* g) {
  std::array<double, kMaxChainJoints> zero{};
  ChainVelocities<S> rest;
  chain_velocities(chain, k, zero.data(), rest);
  chain_forces(chain, k, rest, rest, zero.data(), zero.data(), zero.data(), true, g);
}

// A(q, v) + g(q), in one pass.
template <class S>
void chain_bias_forces(const SerialChain& chain, const ChainKinematics<S>& k, const double* v, S* out) {
  std::array<double, kMaxChainJoints> zero{};
  ChainVelocities<S> w;
  chain_velocities(chain, k, v, w);
  chain_forces(chain, k, w, w, v, v, zero.data(), true, out);
}

// A(q, v) = C(q, v) v.
template <class S>
void chain_coriolis(const SerialChain& chain, const ChainKinematics<S>& k, const double* v, S* A) {
  std::array<double, kMaxChainJoints> zero{};
  ChainVelocities<S> w;
  chain_velocities(chain, k, v, w);
  chain_forces(chain, k, w, w, v, v, zero.data(), false, A);
}

// N_i(q), written into N[(i * n + j) * n + l]: N_i[j][l] = B_i(q; e_j, e_l).
template <class S>
void chain_coriolis_tensors(const SerialChain& chain, const ChainKinematics<S>& k, S* N) {
  const int n = chain.dof();
  std::array<std::array<double, kMaxChainJoints>, kMaxChainJoints> unit{};
  std::array<ChainVelocities<S>, kMaxChainJoints> w;
  for (int j = 0; j < n; ++j) {
    unit[j][j] = 1.0;
    chain_velocities(chain, k, unit[j].data(), w[j]);
  }
  const std::array<double, kMaxChainJoints> zero{};
  std::array<S, kMaxChainJoints> tau;
  for (int j = 0; j < n; ++j)
    for (int l = j; l < n; ++l) {
      chain_forces(chain, k, w[j], w[l], unit[j].data(), unit[l].data(), zero.data(), false, tau.data());
      for (int i = 0; i < n; ++i) {
        N[(i * n + j) * n + l] = tau[i];
        N[(i * n + l) * n + j] = tau[i];
      }
    }
}

}  // namespace obsgain
