// Any serial chain as plain data: joint placements and axes, lumped rigid bodies, armature. The URDF reader
// only fills it; the dynamics are templates over it (chain_dynamics.hpp).
#pragma once

#include "obsgain/model/joint.hpp"

#include <Eigen/Dense>

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

// The coordinate axis a unit vector is, exactly (0, 1, 2 for ±x, ±y, ±z), or -1.
inline int coordinate_axis(const Eigen::Vector3d& v) {
  for (int c = 0; c < 3; ++c)
    if (std::abs(v(c)) == 1.0 && v((c + 1) % 3) == 0.0 && v((c + 2) % 3) == 0.0) return c;
  return -1;
}

// A rigid body in the frame of the joint that moves it: mass, centre of mass, inertia about the centre of mass.
struct RigidBody {
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
};

// Body i moves with joint i; body i's frame is joint i's frame displaced by q_i. M(q) gets armature_i (the
// reflected rotor inertia, gear ratio² × rotor inertia) on its diagonal.
struct SerialChain {
  std::vector<ChainJoint> joints;
  std::vector<RigidBody> bodies;
  Eigen::VectorXd armature;
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);  // in the base frame
  int dof() const { return static_cast<int>(joints.size()); }
};

}  // namespace obsgain
