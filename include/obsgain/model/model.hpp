// A robot as data: M(q) q'' + A(q, q') + F q' + g(q) = H u, with A(q, v) = C(q, v) v. The dynamics are computed
// from `structure` (the paper's planar two-link family, or any serial chain) by free functions templated on the
// scalar (dynamics.hpp); everything else the theorem needs (joint domains, F, H, the velocity box) sits beside it.
#pragma once

#include "obsgain/model/input_error.hpp"
#include "obsgain/model/joint.hpp"
#include "obsgain/model/planar_2r.hpp"
#include "obsgain/model/serial_chain.hpp"

#include <Eigen/Dense>

#include <string>
#include <variant>
#include <vector>

namespace obsgain {

// Where a model came from, enough to load it again: design files record it so that monte-carlo --design
// simulates the robot that was designed for.
struct RobotSource {
  std::string robot = "pendubot";  // a built-in name, or the path of a model file (*.json) or URDF (*.urdf)
  std::string base_link, tip_link;  // URDF only: the chain (defaults: the root, the single leaf)
  std::vector<int> actuated;        // URDF only: 0/1 per joint (default: all actuated)
  std::vector<double> armature;     // URDF and model files: overrides the file's reflected rotor inertias
  std::vector<JointDomain> joint_limits;  // URDF only: overrides the file's limits (continuous = the circle)
};

// What M, A and g are computed from.
using RobotStructure = std::variant<Planar2RParameters, SerialChain>;

struct Model {
  std::string name;
  RobotSource source;
  RobotStructure structure;
  std::vector<JointDomain> joints;
  Eigen::MatrixXd friction;         // F, n x n (viscous)
  Eigen::MatrixXd input_matrix;     // H, n x m
  Eigen::VectorXd velocity_bounds;  // default V; empty when the model gives none
  std::string missing_velocity_bounds;  // why it gives none (the joints and attributes), for the error
  std::vector<std::string> notes;   // what loading decided for the user (chain chosen, bodies lumped, ...)
  std::string fingerprint;          // of the file it was loaded from (FNV-1a of its bytes), or "built-in"

  int dof() const;
};

// A planar two-link model with F = diag(friction), H = input_matrix, both continuous revolute joints.
Model make_planar_2r(const std::string& name, const Planar2RParameters& parameters, const Eigen::Vector2d& friction,
                     const Eigen::MatrixXd& input_matrix, const Eigen::VectorXd& velocity_bounds);

// The paper's Pendubot: π = (0.0308, 0.0106, 0.0095, 0.2086, 0.0630), g0 = 9.81, F = 0, H = diag(1, 0),
// V = (10, 10).
Model pendubot();

// The paper's own family (the planar two-link lumped model): its example scenario applies.
bool is_planar_2r(const Model& model);

// Reflected rotor inertia on M's diagonal, per joint (zeros: none).
Eigen::VectorXd armature(const Model& model);

// Throws InputError unless every bound is finite and positive and there is one per joint.
void validate_velocity_bounds(const Model& model, const Eigen::VectorXd& velocity_bounds);

// The model's own consistency (sizes, finite numbers).
void validate_model(const Model& model);

}  // namespace obsgain
