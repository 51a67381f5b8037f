// A robot as data: M(q) q'' + A(q, q') + F q' + g(q) = H u, with A(q, v) = C(q, v) v.
// Algorithms are free functions over a Model (bounds.hpp, simulation.hpp, ...).
#pragma once

#include <Eigen/Dense>

#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace obsgain {

// Every invalid input the user can give ends up here: the apps print what() and exit 2. The message is one
// line whatever it quotes from a file (control characters become spaces) and at most 1000 characters.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(one_line(message)) {}

 private:
  static std::string one_line(std::string text) {
    for (char& c : text)
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
    if (text.size() > 1000) text = text.substr(0, 980) + "... (cut)";
    return text;
  }
};

enum class JointType { revolute, prismatic };

// Where a joint's position q_i may lie. A continuous revolute joint enters the dynamics only through
// sin/cos, so its whole range is one period.
struct JointDomain {
  JointType type = JointType::revolute;
  bool continuous = true;
  double lower = -std::numbers::pi;
  double upper = std::numbers::pi;
};

// The configuration-dependent part of the dynamics. Outputs are written into caller-owned storage so
// that the simulation's inner loop allocates nothing.
class Dynamics {
 public:
  virtual ~Dynamics() = default;
  virtual int dof() const = 0;
  virtual void mass_matrix(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M) const = 0;
  // A(q, v) = C(q, v) v.
  virtual void coriolis(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                        Eigen::Ref<Eigen::VectorXd> A) const = 0;
  virtual void gravity(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g) const = 0;
  // N_i(q) (symmetric) with A_i(q, v) = vᵀ N_i(q) v. The default recovers them exactly from coriolis() by
  // polarisation (design notes §3), which is all a black-box model such as KDL offers.
  virtual void coriolis_tensors(const Eigen::Ref<const Eigen::VectorXd>& q, std::vector<Eigen::MatrixXd>& N) const;
  // out_i = xᵀ N_i(q) y, the symmetric bilinear form of A, which the simulation's error equation needs at
  // every step. The default polarises coriolis(): (A(x + y) - A(x - y)) / 4, two evaluations for any n.
  virtual void coriolis_bilinear(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& x,
                                 const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::VectorXd> out) const;
  // Joints whose positions M and C depend on; the bound search runs over these only. A serial chain's
  // M and C do not depend on its first joint.
  virtual std::vector<int> configuration_joints() const;
};

// Where a model came from, enough to load it again: design files record it so that monte-carlo --design
// simulates the robot that was designed for.
struct RobotSource {
  std::string robot = "pendubot";  // a built-in name, or the path of a model file (*.json) or URDF (*.urdf)
  std::string base_link, tip_link;  // URDF only: the chain (defaults: the root, the single leaf)
  std::vector<int> actuated;        // URDF only: 0/1 per joint (default: all actuated)
  std::vector<double> armature;     // URDF and model files: overrides the file's reflected rotor inertias
  std::vector<JointDomain> joint_limits;  // URDF only: overrides the file's limits (continuous = the circle)
};

struct Model {
  std::string name;
  RobotSource source;
  std::shared_ptr<const Dynamics> dynamics;
  std::vector<JointDomain> joints;
  Eigen::MatrixXd friction;         // F, n x n (viscous)
  Eigen::MatrixXd input_matrix;     // H, n x m
  Eigen::VectorXd velocity_bounds;  // default V; empty when the model gives none
  std::string missing_velocity_bounds;  // why it gives none (the joints and attributes), for the error
  Eigen::VectorXd armature;         // reflected rotor inertia on M's diagonal (already inside the dynamics)
  std::vector<std::string> notes;   // what loading decided for the user (chain chosen, bodies lumped, ...)
  std::string fingerprint;          // of the file it was loaded from (FNV-1a of its bytes), or "built-in"

  int dof() const { return dynamics->dof(); }
};

// ∂A/∂v at (q, w) from the Coriolis tensors: J = 2 [wᵀN_1; …; wᵀN_n]. Linear in w (design notes §3).
Eigen::MatrixXd coriolis_jacobian(const std::vector<Eigen::MatrixXd>& N, const Eigen::Ref<const Eigen::VectorXd>& w);

// Throws InputError unless every bound is finite and positive and there is one per joint.
void validate_velocity_bounds(const Model& model, const Eigen::VectorXd& velocity_bounds);

// The model's own consistency (sizes, finite numbers, positive definite M at the joint domain's centre).
void validate_model(const Model& model);

}  // namespace obsgain
