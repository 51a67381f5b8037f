#include "obsgain/model/model.hpp"

#include <cmath>
#include <sstream>

namespace obsgain {

int Model::dof() const {
  if (std::holds_alternative<Planar2RParameters>(structure)) return 2;
  return std::get<SerialChain>(structure).dof();
}

Model make_planar_2r(const std::string& name, const Planar2RParameters& parameters, const Eigen::Vector2d& friction,
                     const Eigen::MatrixXd& input_matrix, const Eigen::VectorXd& velocity_bounds) {
  Model model;
  model.name = name;
  model.structure = parameters;
  model.joints = {JointDomain{}, JointDomain{}};
  model.friction = friction.asDiagonal();
  model.input_matrix = input_matrix;
  model.velocity_bounds = velocity_bounds;
  validate_model(model);
  return model;
}

Model pendubot() {
  const Planar2RParameters parameters{{0.0308, 0.0106, 0.0095, 0.2086, 0.0630}, 9.81};
  Eigen::Matrix2d H;
  H << 1.0, 0.0, 0.0, 0.0;
  return make_planar_2r("pendubot", parameters, Eigen::Vector2d::Zero(), H, Eigen::Vector2d(10.0, 10.0));
}

bool is_planar_2r(const Model& model) { return std::holds_alternative<Planar2RParameters>(model.structure); }

Eigen::VectorXd armature(const Model& model) {
  if (const auto* p = std::get_if<Planar2RParameters>(&model.structure))
    return Eigen::Vector2d(p->armature[0], p->armature[1]);
  const SerialChain& chain = std::get<SerialChain>(model.structure);
  return chain.armature.size() == chain.dof() ? chain.armature : Eigen::VectorXd::Zero(chain.dof());
}

void validate_velocity_bounds(const Model& model, const Eigen::VectorXd& velocity_bounds) {
  if (velocity_bounds.size() != model.dof()) {
    std::ostringstream msg;
    msg << "velocity bounds: " << model.name << " has " << model.dof() << " joints, got " << velocity_bounds.size()
        << " bound(s)";
    throw InputError(msg.str());
  }
  for (int i = 0; i < velocity_bounds.size(); ++i) {
    const double V = velocity_bounds(i);
    // Beyond 1e6 rad/s (or m/s) nothing physical moves, and the bounds' products overflow.
    if (!std::isfinite(V) || V <= 0.0 || V > 1e6) {
      std::ostringstream msg;
      msg << "velocity bound V" << i + 1 << " = " << V << " (--vmax) must lie in (0, 1e6]";
      throw InputError(msg.str());
    }
  }
}

void validate_model(const Model& model) {
  const int n = model.dof();
  auto fail = [&](const std::string& what) { throw InputError("model '" + model.name + "': " + what); };
  if (static_cast<int>(model.joints.size()) != n) fail("one joint domain per joint expected");
  for (int i = 0; i < n; ++i) {
    const JointDomain& joint = model.joints[i];
    if (!std::isfinite(joint.lower) || !std::isfinite(joint.upper) || joint.lower >= joint.upper)
      fail("joint " + std::to_string(i + 1) + " has an empty or non-finite range");
  }
  if (model.friction.rows() != n || model.friction.cols() != n) fail("friction matrix must be n x n");
  if (!model.friction.allFinite()) fail("friction has a non-finite entry");
  if (model.input_matrix.rows() != n || model.input_matrix.cols() < 1) fail("input matrix must have n rows");
  if (!model.input_matrix.allFinite()) fail("input matrix has a non-finite entry");
  if (model.velocity_bounds.size() != 0) validate_velocity_bounds(model, model.velocity_bounds);
}

}  // namespace obsgain
