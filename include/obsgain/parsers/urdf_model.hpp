// Robots from URDF (urdfdom parses): any serial chain of revolute, continuous and prismatic joints becomes a
// SerialChain — joint placements and axes, the links' inertias lumped into one rigid body per moving joint (fixed
// joints, side branches and grippers locked), gravity 9.81 m/s² along -z of the base link, and the reflected rotor
// inertia of Drake-style transmissions. From the URDF as well: joint domains (<limit lower upper>, or the circle for
// continuous joints), the velocity box (<limit velocity>), and viscous friction F = diag(<dynamics damping>). The
// dynamics are then the chain's own (model/chain_dynamics.hpp); the tests check them against KDL.
#pragma once

#include "obsgain/model/model.hpp"

namespace obsgain {

// source.robot is the file; base_link defaults to the tree's root, tip_link to its single leaf (an error if
// it has several); actuated, one 0/1 per moving joint, to all (H = I). Throws InputError naming the file and
// what is wrong: unreadable file, broken XML, a chain that does not exist, a joint type outside the three
// above, or masses that leave M(q) singular.
Model load_urdf(const RobotSource& source);

}  // namespace obsgain
