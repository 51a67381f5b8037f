#include "obsgain/model/dynamics.hpp"

#include <numeric>

namespace obsgain {

namespace {

constexpr int kMaxFlat = kMaxChainJoints * kMaxChainJoints;

}  // namespace

void ConfigurationDynamics::set(const Eigen::Ref<const Eigen::VectorXd>& q) noexcept {
  if (is_planar_2r(model_)) {
    planar_q_ = {q(0), q(1)};
    return;
  }
  chain_kinematics(std::get<SerialChain>(model_.structure), q.data(), kinematics_);
}

void ConfigurationDynamics::mass_matrix(Eigen::Ref<Eigen::MatrixXd> M) const noexcept {
  const int n = model_.dof();
  std::array<double, kMaxFlat> flat;
  if (is_planar_2r(model_))
    mass_matrix_of(model_, planar_q_.data(), flat.data());
  else
    chain_mass_matrix(std::get<SerialChain>(model_.structure), kinematics_, flat.data());
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) M(i, j) = flat[i * n + j];
}

void ConfigurationDynamics::gravity(Eigen::Ref<Eigen::VectorXd> g) const noexcept {
  std::array<double, kMaxChainJoints> out;
  if (is_planar_2r(model_))
    gravity_of(model_, planar_q_.data(), out.data());
  else
    chain_gravity(std::get<SerialChain>(model_.structure), kinematics_, out.data());
  for (int i = 0; i < model_.dof(); ++i) g(i) = out[i];
}

void ConfigurationDynamics::coriolis(const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> A) const noexcept {
  if (const auto* p = std::get_if<Planar2RParameters>(&model_.structure)) {
    const double h = p->pi[2] * std::sin(planar_q_[1]);
    A(0) = -h * (2.0 * v(0) * v(1) + v(1) * v(1));
    A(1) = h * v(0) * v(0);
    return;
  }
  const SerialChain& chain = std::get<SerialChain>(model_.structure);
  std::array<double, kMaxChainJoints> out;
  chain_coriolis(chain, kinematics_, v.data(), out.data());
  for (int i = 0; i < chain.dof(); ++i) A(i) = out[i];
}

void ConfigurationDynamics::coriolis_bilinear(const Eigen::Ref<const Eigen::VectorXd>& x,
                                              const Eigen::Ref<const Eigen::VectorXd>& y,
                                              Eigen::Ref<Eigen::VectorXd> out) const noexcept {
  if (const auto* p = std::get_if<Planar2RParameters>(&model_.structure)) {
    // From the analytic tensors: exact however small x is.
    const auto tensors = planar_2r_coriolis_tensors(*p, planar_q_[1]);
    const Eigen::Vector2d x2 = x, y2 = y;
    out(0) = x2.dot(tensors[0] * y2);
    out(1) = x2.dot(tensors[1] * y2);
    return;
  }
  const SerialChain& chain = std::get<SerialChain>(model_.structure);
  ChainVelocities<double> wx, wy;
  chain_velocities(chain, kinematics_, x.data(), wx);
  chain_velocities(chain, kinematics_, y.data(), wy);
  const std::array<double, kMaxChainJoints> zero{};
  std::array<double, kMaxChainJoints> tau;
  chain_forces(chain, kinematics_, wx, wy, x.data(), y.data(), zero.data(), false, tau.data());
  for (int i = 0; i < chain.dof(); ++i) out(i) = tau[i];
}

void mass_matrix(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M) {
  ConfigurationDynamics at(model);
  at.set(q);
  at.mass_matrix(M);
}

void coriolis(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
              Eigen::Ref<Eigen::VectorXd> A) {
  ConfigurationDynamics at(model);
  at.set(q);
  at.coriolis(v, A);
}

void coriolis_bilinear(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                       const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& y,
                       Eigen::Ref<Eigen::VectorXd> out) {
  ConfigurationDynamics at(model);
  at.set(q);
  at.coriolis_bilinear(x, y, out);
}

void gravity(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g) {
  ConfigurationDynamics at(model);
  at.set(q);
  at.gravity(g);
}

void coriolis_tensors(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, std::vector<Eigen::MatrixXd>& N) {
  const int n = model.dof();
  std::array<double, kMaxFlat * kMaxChainJoints> flat;
  coriolis_tensors_of(model, q.data(), flat.data());
  N.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    N[i].resize(n, n);  // same size: no allocation when reused
    for (int j = 0; j < n; ++j)
      for (int l = 0; l < n; ++l) N[i](j, l) = flat[(i * n + j) * n + l];
  }
}

Eigen::MatrixXd coriolis_jacobian(const std::vector<Eigen::MatrixXd>& N, const Eigen::Ref<const Eigen::VectorXd>& w) {
  const int n = static_cast<int>(N.size());
  Eigen::MatrixXd J(n, n);
  for (int i = 0; i < n; ++i) J.row(i) = 2.0 * (N[i] * w).transpose();
  return J;
}

std::vector<int> configuration_joints(const Model& model) {
  if (is_planar_2r(model)) return {1};
  std::vector<int> joints(static_cast<std::size_t>(model.dof() - 1));
  std::iota(joints.begin(), joints.end(), 1);
  return joints;
}

double inertia_floor(const Model& model) {
  if (const auto* p = std::get_if<Planar2RParameters>(&model.structure))
    return std::min(p->armature[0], p->armature[1]);  // π1π2 > π3² makes the rigid part positive definite
  return chain_inertia_floor(std::get<SerialChain>(model.structure));
}

void plant_acceleration(const Model& model, const ConfigurationDynamics& at, const Eigen::LLT<Eigen::MatrixXd>& llt,
                        const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& tau,
                        Eigen::Ref<Eigen::VectorXd> qdd, DynamicsWorkspace& work) {
  at.coriolis(v, work.A);
  at.gravity(work.g);
  work.rhs = tau - work.A - work.g;
  work.rhs.noalias() -= model.friction * v;
  llt.solveInPlace(work.rhs);
  qdd = work.rhs;
}

void forward_dynamics(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& tau,
                      Eigen::Ref<Eigen::VectorXd> qdd, DynamicsWorkspace& work) {
  ConfigurationDynamics at(model);
  at.set(q);
  at.mass_matrix(work.M);
  work.llt.compute(work.M);
  plant_acceleration(model, at, work.llt, v, tau, qdd, work);
}

void inverse_dynamics(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& a,
                      Eigen::Ref<Eigen::VectorXd> tau, DynamicsWorkspace& work) {
  ConfigurationDynamics at(model);
  at.set(q);
  at.mass_matrix(work.M);
  at.coriolis(v, work.A);
  at.gravity(work.g);
  work.rhs.noalias() = work.M * a;
  work.rhs += work.A + work.g;
  work.rhs.noalias() += model.friction * v;
  tau = work.rhs;
}

}  // namespace obsgain
