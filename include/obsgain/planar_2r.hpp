// The lumped planar two-link family of the paper (Pendubot, Acrobot, fully actuated two-link arms),
// parameterised by π1..π5 (Zhang & Tarn). The dynamics are templates on the scalar type so that the same
// code runs on double and on intervals.
#pragma once

#include "obsgain/certified_bounds.hpp"
#include "obsgain/model.hpp"

#include <array>
#include <cmath>

namespace obsgain {

struct Planar2RParameters {
  std::array<double, 5> pi{};  // π1..π5
  double g0 = 9.81;
  std::array<double, 2> armature{};  // reflected rotor inertias, added to M's diagonal
};

// M(q) depends on q2 only.
template <class Scalar>
Eigen::Matrix<Scalar, 2, 2> planar_2r_mass_matrix(const Planar2RParameters& p, const Scalar& q2) {
  using std::cos;
  const Scalar c2 = cos(q2);
  const Scalar off = p.pi[1] + p.pi[2] * c2;
  Eigen::Matrix<Scalar, 2, 2> M;
  M << p.pi[0] + p.pi[1] + p.armature[0] + 2.0 * p.pi[2] * c2, off, off, Scalar(p.pi[1] + p.armature[1]);
  return M;
}

// N_1, N_2 with A_i = vᵀ N_i v: A_1 = -π3 sin q2 (2 v1 v2 + v2²), A_2 = π3 sin q2 v1².
template <class Scalar>
std::array<Eigen::Matrix<Scalar, 2, 2>, 2> planar_2r_coriolis_tensors(const Planar2RParameters& p, const Scalar& q2) {
  using std::sin;
  const Scalar h = p.pi[2] * sin(q2);
  const Scalar zero(0.0);
  Eigen::Matrix<Scalar, 2, 2> N1, N2;
  N1 << zero, -h, -h, -h;
  N2 << h, zero, zero, zero;
  return {N1, N2};
}

template <class Scalar>
Eigen::Matrix<Scalar, 2, 1> planar_2r_gravity(const Planar2RParameters& p, const Scalar& q1, const Scalar& q2) {
  using std::cos;
  const Scalar c12 = cos(q1 + q2);
  Eigen::Matrix<Scalar, 2, 1> g;
  g << p.pi[3] * p.g0 * cos(q1) + p.pi[4] * p.g0 * c12, p.pi[4] * p.g0 * c12;
  return g;
}

class Planar2RDynamics final : public Dynamics, public IntervalDynamics {
 public:
  explicit Planar2RDynamics(const Planar2RParameters& parameters) : parameters_(parameters) {}
  int dof() const override { return 2; }
  void mass_matrix(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M) const override;
  void coriolis(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                Eigen::Ref<Eigen::VectorXd> A) const override;
  void gravity(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g) const override;
  void coriolis_tensors(const Eigen::Ref<const Eigen::VectorXd>& q, std::vector<Eigen::MatrixXd>& N) const override;
  void coriolis_bilinear(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& x,
                         const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::VectorXd> out) const override;
  std::vector<int> configuration_joints() const override { return {1}; }
  // π1π2 > π3² (model files check it) makes the rigid part positive definite; the armature adds on top.
  double inertia_floor() const override { return std::min(parameters_.armature[0], parameters_.armature[1]); }
  // The same templates on intervals, for certified bounds.
  MatrixEnclosure mass_matrix(const std::vector<DualInterval>& q) const override;
  std::vector<MatrixEnclosure> coriolis_tensors(const std::vector<DualInterval>& q) const override;
  MatrixEnclosure gravity(const std::vector<DualInterval>& q) const override;
  const Planar2RParameters& parameters() const { return parameters_; }

 private:
  Planar2RParameters parameters_;
};

// A planar two-link model with F = diag(friction), H = input_matrix, both continuous revolute joints.
Model make_planar_2r(const std::string& name, const Planar2RParameters& parameters, const Eigen::Vector2d& friction,
                     const Eigen::MatrixXd& input_matrix, const Eigen::VectorXd& velocity_bounds);

// The paper's Pendubot: π = (0.0308, 0.0106, 0.0095, 0.2086, 0.0630), g0 = 9.81, F = 0, H = diag(1, 0),
// V = (10, 10).
Model pendubot();

}  // namespace obsgain
