// Any serial chain as plain data (joint placements and axes, rigid bodies, armature), and its dynamics as
// templates on the scalar: the same recursive Newton–Euler code runs on double (design, simulation), on
// intervals and on interval forward-mode derivatives (certified bounds). The URDF reader only fills the data.
#pragma once

#include "obsgain/model.hpp"

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace obsgain {

inline constexpr int kMaxChainJoints = 16;  // fixed-size scratch: the dynamics allocate nothing

struct ChainJoint {
  std::string name;
  JointType type = JointType::revolute;
  // Placement of the joint frame in the previous body's frame (the base frame for the first joint).
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit, in the joint frame
};

// A rigid body in the frame of the joint that moves it: mass, centre of mass, inertia about the centre of mass.
struct RigidBody {
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
};

// `part` placed at (rotation, translation) in `body`'s frame, lumped into `body` (parallel-axis theorem).
RigidBody lump(const RigidBody& body, const RigidBody& part, const Eigen::Matrix3d& rotation,
               const Eigen::Vector3d& translation);

// Body i moves with joint i; body i's frame is joint i's frame displaced by q_i. M(q) gets armature_i (the
// reflected rotor inertia, gear ratio² × rotor inertia) on its diagonal.
struct SerialChain {
  std::vector<ChainJoint> joints;
  std::vector<RigidBody> bodies;
  Eigen::VectorXd armature;
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);  // in the base frame
  int dof() const { return static_cast<int>(joints.size()); }
};

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
Vec3<S> scaled(const Eigen::Vector3d& a, double s) {
  return {S(a[0] * s), S(a[1] * s), S(a[2] * s)};
}
// R v for a constant R (not named apply: std::apply would join the overload set through std::array).
template <class S>
Vec3<S> rotate(const Eigen::Matrix3d& R, const Vec3<S>& v) {
  Vec3<S> r;
  for (int i = 0; i < 3; ++i) r[i] = R(i, 0) * v[0] + R(i, 1) * v[1] + R(i, 2) * v[2];
  return r;
}
template <class S>
S dot(const Eigen::Vector3d& a, const Vec3<S>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

}  // namespace chain_detail

// Where each body sits relative to its parent at q. Body i's frame maps into body i-1's by P_i Rot(a_i, q_i)
// (revolute) or P_i (prismatic), P_i the joint's constant placement; p[i] is body i's origin in body i-1's
// frame. The rotation is kept factored — P_i applied in double, Rot by Rodrigues with cos q_i and sin q_i —
// rather than multiplied out: on intervals a multiplied-out 3 x 3 matrix forgets that its entries share one
// angle, and the enclosures of a long chain blow up (the wrapping effect).
template <class S>
struct ChainKinematics {
  std::array<S, kMaxChainJoints> c, s;
  std::array<Vec3<S>, kMaxChainJoints> p;
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
  }
}

namespace chain_detail {

// Rot(a, ±q) v = (a aᵀ) v + c (I - a aᵀ) v ± s (a × v), the projectors in double: for an axis along a
// coordinate axis each component then involves c and s at most once (no dependency on intervals).
template <class S>
Vec3<S> rodrigues(const Eigen::Vector3d& a, const S& c, const S& s, const Vec3<S>& v, double sign) {
  const Eigen::Matrix3d along = a * a.transpose();
  const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - along;
  const Vec3<S> parallel = rotate(along, v), perpendicular = rotate(across, v), axv = cross(a, v);
  Vec3<S> r;
  for (int i = 0; i < 3; ++i) r[i] = parallel[i] + perpendicular[i] * c + sign * (axv[i] * s);
  return r;
}

// From body i's frame into body i-1's, and back.
template <class S>
Vec3<S> to_parent(const SerialChain& chain, const ChainKinematics<S>& k, int i, const Vec3<S>& v) {
  const ChainJoint& joint = chain.joints[i];
  return rotate(joint.rotation, joint.type == JointType::revolute ? rodrigues(joint.axis, k.c[i], k.s[i], v, 1.0) : v);
}
template <class S>
Vec3<S> from_parent(const SerialChain& chain, const ChainKinematics<S>& k, int i, const Vec3<S>& v) {
  const ChainJoint& joint = chain.joints[i];
  const Vec3<S> u = rotate(Eigen::Matrix3d(joint.rotation.transpose()), v);
  return joint.type == JointType::revolute ? rodrigues(joint.axis, k.c[i], k.s[i], u, -1.0) : u;
}

}  // namespace chain_detail

// Inverse dynamics τ = M(q) qdd + A(q, qd) [+ g(q)] by recursive Newton–Euler, in body frames.
template <class S>
void inverse_dynamics(const SerialChain& chain, const ChainKinematics<S>& k, const double* qd, const double* qdd,
                      bool with_gravity, S* tau) {
  using namespace chain_detail;
  const int n = chain.dof();
  std::array<Vec3<S>, kMaxChainJoints> w, dw, a, f, m;
  Vec3<S> w_prev{S(0.0), S(0.0), S(0.0)}, dw_prev = w_prev;
  // The base accelerates upwards at -gravity: gravity then acts on every body through the recursion.
  Vec3<S> a_prev = with_gravity ? scaled<S>(chain.gravity, -1.0) : w_prev;
  for (int i = 0; i < n; ++i) {
    const ChainJoint& joint = chain.joints[i];
    const Eigen::Vector3d& axis = joint.axis;
    const Vec3<S> w_in = from_parent(chain, k, i, w_prev);
    const Vec3<S> a_origin =
        from_parent(chain, k, i, add(add(a_prev, cross(dw_prev, k.p[i])), cross(w_prev, cross(w_prev, k.p[i]))));
    if (joint.type == JointType::revolute) {
      w[i] = add(w_in, scaled<S>(axis, qd[i]));
      dw[i] = add(add(from_parent(chain, k, i, dw_prev), scaled<S>(axis, qdd[i])), cross(w_in, scaled<S>(axis, qd[i])));
      a[i] = a_origin;
    } else {
      w[i] = w_in;
      dw[i] = from_parent(chain, k, i, dw_prev);
      a[i] = add(add(a_origin, scaled<S>(axis, qdd[i])), cross(w_in, scaled<S>(axis, 2.0 * qd[i])));
    }
    const RigidBody& body = chain.bodies[i];
    const Vec3<S> c{S(body.com[0]), S(body.com[1]), S(body.com[2])};
    const Vec3<S> a_com = add(add(a[i], cross(dw[i], c)), cross(w[i], cross(w[i], c)));
    for (int r = 0; r < 3; ++r) f[i][r] = body.mass * a_com[r];
    const Vec3<S> Iw = rotate(body.inertia, w[i]);
    m[i] = add(add(rotate(body.inertia, dw[i]), cross(w[i], Iw)), cross(c, f[i]));
    w_prev = w[i];
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

// M(q), column by column: M e_j = τ(q, 0, e_j) without gravity. Written into M[i * n + j].
template <class S>
void chain_mass_matrix(const SerialChain& chain, const ChainKinematics<S>& k, S* M) {
  const int n = chain.dof();
  std::array<double, kMaxChainJoints> zero{}, unit{};
  std::array<S, kMaxChainJoints> column;
  for (int j = 0; j < n; ++j) {
    unit.fill(0.0);
    unit[j] = 1.0;
    inverse_dynamics(chain, k, zero.data(), unit.data(), false, column.data());
    for (int i = 0; i < n; ++i) M[i * n + j] = column[i];
  }
  // M is symmetric: the upper triangle's values (or enclosures) serve both halves.
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) M[j * n + i] = M[i * n + j];
}

// N_i(q) with A_i(q, v) = vᵀ N_i v, by polarisation of Newton–Euler passes (design notes §3):
// N_i[j][j] = A_i(e_j), N_i[j][k] = (A_i(e_j + e_k) - A_i(e_j) - A_i(e_k)) / 2. Written into N[(i * n + j) * n + k].
template <class S>
void chain_coriolis_tensors(const SerialChain& chain, const ChainKinematics<S>& k, S* N) {
  const int n = chain.dof();
  std::array<double, kMaxChainJoints> zero{}, v{};
  std::array<std::array<S, kMaxChainJoints>, kMaxChainJoints> diagonal;
  std::array<S, kMaxChainJoints> A;
  for (int j = 0; j < n; ++j) {
    v.fill(0.0);
    v[j] = 1.0;
    inverse_dynamics(chain, k, v.data(), zero.data(), false, diagonal[j].data());
    for (int i = 0; i < n; ++i) N[(i * n + j) * n + j] = diagonal[j][i];
  }
  for (int j = 0; j < n; ++j)
    for (int l = j + 1; l < n; ++l) {
      v.fill(0.0);
      v[j] = 1.0;
      v[l] = 1.0;
      inverse_dynamics(chain, k, v.data(), zero.data(), false, A.data());
      for (int i = 0; i < n; ++i) {
        const S value = (A[i] - diagonal[j][i] - diagonal[l][i]) * 0.5;
        N[(i * n + j) * n + l] = value;
        N[(i * n + l) * n + j] = value;
      }
    }
}

// The chain as a Model's Dynamics (double) and IntervalDynamics (certified bounds): see chain_dynamics.cpp.
std::shared_ptr<const Dynamics> make_chain_dynamics(SerialChain chain);

// Throws InputError naming the joint when the data cannot describe a physical chain (sizes, non-unit axes,
// negative masses, inertias that are not positive semidefinite, non-finite numbers).
void validate_chain(const SerialChain& chain, const std::string& source);

}  // namespace obsgain
