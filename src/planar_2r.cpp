#include "obsgain/planar_2r.hpp"

namespace obsgain {

void Planar2RDynamics::mass_matrix(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M) const {
  M = planar_2r_mass_matrix(parameters_, q(1));
}

void Planar2RDynamics::coriolis(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                                Eigen::Ref<Eigen::VectorXd> A) const {
  const double h = parameters_.pi[2] * std::sin(q(1));
  A(0) = -h * (2.0 * v(0) * v(1) + v(1) * v(1));
  A(1) = h * v(0) * v(0);
}

void Planar2RDynamics::gravity(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g) const {
  g = planar_2r_gravity(parameters_, q(0), q(1));
}

void Planar2RDynamics::coriolis_tensors(const Eigen::Ref<const Eigen::VectorXd>& q,
                                        std::vector<Eigen::MatrixXd>& N) const {
  const auto tensors = planar_2r_coriolis_tensors(parameters_, q(1));
  N.resize(2);
  N[0] = tensors[0];  // same-size assignments: no allocation in the simulation's inner loop
  N[1] = tensors[1];
}

// From the analytic tensors: exact however small x is (no cancellation, unlike polarisation).
void Planar2RDynamics::coriolis_bilinear(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& x,
                                         const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::VectorXd> out) const {
  const auto tensors = planar_2r_coriolis_tensors(parameters_, q(1));
  const Eigen::Vector2d x2 = x, y2 = y;
  out(0) = x2.dot(tensors[0] * y2);
  out(1) = x2.dot(tensors[1] * y2);
}

MatrixEnclosure Planar2RDynamics::mass_matrix(const std::vector<DualInterval>& q) const {
  return enclosure_of(planar_2r_mass_matrix(parameters_, q[1]), q[1].directions);
}

std::vector<MatrixEnclosure> Planar2RDynamics::coriolis_tensors(const std::vector<DualInterval>& q) const {
  const auto tensors = planar_2r_coriolis_tensors(parameters_, q[1]);
  return {enclosure_of(tensors[0], q[1].directions), enclosure_of(tensors[1], q[1].directions)};
}

MatrixEnclosure Planar2RDynamics::gravity(const std::vector<DualInterval>& q) const {
  return enclosure_of(planar_2r_gravity(parameters_, q[0], q[1]), std::max(q[0].directions, q[1].directions));
}

Model make_planar_2r(const std::string& name, const Planar2RParameters& parameters, const Eigen::Vector2d& friction,
                     const Eigen::MatrixXd& input_matrix, const Eigen::VectorXd& velocity_bounds) {
  Model model;
  model.name = name;
  model.dynamics = std::make_shared<Planar2RDynamics>(parameters);
  model.joints = {JointDomain{}, JointDomain{}};
  model.friction = friction.asDiagonal();
  model.input_matrix = input_matrix;
  model.velocity_bounds = velocity_bounds;
  model.armature = Eigen::Vector2d(parameters.armature[0], parameters.armature[1]);
  validate_model(model);
  return model;
}

Model pendubot() {
  const Planar2RParameters parameters{{0.0308, 0.0106, 0.0095, 0.2086, 0.0630}, 9.81};
  Eigen::Matrix2d H;
  H << 1.0, 0.0, 0.0, 0.0;
  return make_planar_2r("pendubot", parameters, Eigen::Vector2d::Zero(), H, Eigen::Vector2d(10.0, 10.0));
}

}  // namespace obsgain
