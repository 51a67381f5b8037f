// Robots from URDF, through kdl_parser and KDL: any serial chain of revolute, continuous and prismatic
// joints. M(q) comes from ChainDynParam::JntToMass, A(q, v) from JntToCoriolis, g(q) from JntToGravity
// (gravity 9.81 m/s² along -z of the base link), and the Coriolis tensors N_i by polarisation of A.
// From the URDF as well: joint domains (<limit lower upper>, or the circle for continuous joints), the
// velocity box (<limit velocity>), and viscous friction F = diag(<dynamics damping>).
#pragma once

#include "obsgain/model.hpp"

namespace obsgain {

// source.robot is the file; base_link defaults to the tree's root, tip_link to its single leaf (an error if
// it has several); actuated, one 0/1 per moving joint, to all (H = I). Throws InputError naming the file and
// what is wrong: unreadable file, broken XML, a chain that does not exist, a joint type outside the three
// above, or masses that leave M(q) singular.
Model load_urdf(const RobotSource& source);

}  // namespace obsgain
