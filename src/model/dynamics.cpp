#include "obsgain/model/dynamics.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

namespace obsgain {

namespace {

constexpr int kMaxFlat = kMaxChainJoints * kMaxChainJoints;

}  // namespace

void ConfigurationDynamics::set(const Eigen::Ref<const Eigen::VectorXd>& q) noexcept {
  if (planar_parameters_) {
    // Two sine–cosine pairs for the whole configuration: cos(q1 + q2) = c1 c2 - s1 s2.
    const double c1 = std::cos(q(0)), s1 = std::sin(q(0)), c2 = std::cos(q(1)), s2 = std::sin(q(1));
    planar_.M = planar_2r_mass_matrix(*planar_parameters_, c2);
    planar_.N = planar_2r_coriolis_tensors(*planar_parameters_, s2);
    planar_.g = planar_2r_gravity(*planar_parameters_, c1, c1 * c2 - s1 * s2);
    return;
  }
  chain_kinematics(*chain_, q.data(), kinematics_);
}

void ConfigurationDynamics::mass_matrix(Eigen::Ref<Eigen::MatrixXd> M) const noexcept {
  if (planar_parameters_) {
    M = planar_.M;
    return;
  }
  const int n = chain_->dof();
  std::array<double, kMaxFlat> flat;
  chain_mass_matrix(*chain_, kinematics_, flat.data());
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) M(i, j) = flat[i * n + j];
}

void ConfigurationDynamics::gravity(Eigen::Ref<Eigen::VectorXd> g) const noexcept {
  if (planar_parameters_) {
    g = planar_.g;
    return;
  }
  std::array<double, kMaxChainJoints> out;
  chain_gravity(*chain_, kinematics_, out.data());
  for (int i = 0; i < chain_->dof(); ++i) g(i) = out[i];
}

void ConfigurationDynamics::coriolis(const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> A) const noexcept {
  coriolis_bilinear(v, v, A);
}

void ConfigurationDynamics::bias_forces(const Eigen::Ref<const Eigen::VectorXd>& v,
                                        Eigen::Ref<Eigen::VectorXd> out) const noexcept {
  if (planar_parameters_) {
    coriolis_bilinear(v, v, out);
    out(0) += planar_.g(0);
    out(1) += planar_.g(1);
    return;
  }
  std::array<double, kMaxChainJoints> tau;
  chain_bias_forces(*chain_, kinematics_, v.data(), tau.data());
  for (int i = 0; i < chain_->dof(); ++i) out(i) = tau[i];
}

void ConfigurationDynamics::coriolis_bilinear(const Eigen::Ref<const Eigen::VectorXd>& x,
                                              const Eigen::Ref<const Eigen::VectorXd>& y,
                                              Eigen::Ref<Eigen::VectorXd> out) const noexcept {
  if (planar_parameters_) {
    // From the analytic tensors: exact however small x is.
    for (int i = 0; i < 2; ++i) {
      const Eigen::Matrix2d& N = planar_.N[i];
      out(i) = x(0) * (N(0, 0) * y(0) + N(0, 1) * y(1)) + x(1) * (N(1, 0) * y(0) + N(1, 1) * y(1));
    }
    return;
  }
  std::array<double, kMaxChainJoints> tau;
  if (x.data() == y.data()) {
    chain_coriolis(*chain_, kinematics_, x.data(), tau.data());
  } else {
    ChainVelocities<double> wx, wy;
    chain_velocities(*chain_, kinematics_, x.data(), wx);
    chain_velocities(*chain_, kinematics_, y.data(), wy);
    const std::array<double, kMaxChainJoints> zero{};
    chain_forces(*chain_, kinematics_, wx, wy, x.data(), y.data(), zero.data(), false, tau.data());
  }
  for (int i = 0; i < chain_->dof(); ++i) out(i) = tau[i];
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

namespace {

// The coordinate axis a unit vector is, exactly (0, 1, 2), or -1.
int coordinate_axis(const Eigen::Vector3d& v) {
  for (int c = 0; c < 3; ++c)
    if (std::abs(v(c)) == 1.0 && v((c + 1) % 3) == 0.0 && v((c + 2) % 3) == 0.0) return c;
  return -1;
}

// Whether turning a body about a revolute axis through its frame's origin leaves its spatial inertia unchanged: the
// centre of mass on the axis and the inertia commuting with the rotation's generator [a]x. Only about a coordinate
// axis (±x, ±y, ±z), where every entry of the cross product and of the commutator is one product by 0 or ±1 or the
// difference of two such: all exact, so a zero is a true zero and a body that is only nearly symmetric is not taken.
bool symmetric_about(const RigidBody& body, const Eigen::Vector3d& axis) {
  if (coordinate_axis(axis) < 0) return false;
  Eigen::Matrix3d generator;
  generator << 0.0, -axis.z(), axis.y(), axis.z(), 0.0, -axis.x(), -axis.y(), axis.x(), 0.0;
  const Eigen::Matrix3d commutator = body.inertia * generator - generator * body.inertia;
  return body.com.cross(axis).isZero(0.0) && commutator.isZero(0.0);
}

// Whether a half-turn about a revolute axis through the frame's origin leaves the body's spatial inertia unchanged:
// the centre of mass on the axis, and no product of inertia between the axis and the plane across it. Exact, as
// symmetric_about.
bool half_turn_symmetric(const RigidBody& body, const Eigen::Vector3d& axis) {
  const int c = coordinate_axis(axis);
  if (c < 0) return false;
  const int a = (c + 1) % 3, b = (c + 2) % 3;
  return body.com(a) == 0.0 && body.com(b) == 0.0 && body.inertia(a, c) == 0.0 && body.inertia(c, a) == 0.0 &&
         body.inertia(b, c) == 0.0 && body.inertia(c, b) == 0.0;
}

// Whether a placement's entry (r, c) is negligible in every combination that multiplies it (chain_dynamics.hpp,
// combine): its row in R v, its column in Rᵀ v. Every enclosure of the chain then sees only its modulus.
bool negligible_entry(const Eigen::Matrix3d& R, int r, int c) {
  return chain_detail::negligible_coefficient(R(r, c), R.row(r).cwiseAbs().maxCoeff()) &&
         chain_detail::negligible_coefficient(R(r, c), R.col(c).cwiseAbs().maxCoeff());
}

// Whether a half-turn of the second joint maps the first joint's axis onto itself, reversed: the two joints' axes are
// coordinate axes, the second's placement R carries its own onto another coordinate axis of the first body's frame up
// to negligible entries, and the two meet (the placement's third coordinate is 0). Turning joint 2 by π is then
// turning the first body's axis end for end with R replaced by H R D (H, D the half-turns about the two axes), which
// differs from R only in the signs of those negligible entries: every enclosure of the one model is, bit for bit, one
// of the other (docs/theory.md, "Half-turn symmetries").
bool second_joint_half_turn(const SerialChain& chain) {
  if (chain.dof() < 2 || chain.joints[0].type != JointType::revolute || chain.joints[1].type != JointType::revolute)
    return false;
  const int first = coordinate_axis(chain.joints[0].axis);
  const int own = coordinate_axis(chain.joints[1].axis);
  if (first < 0 || own < 0) return false;
  const Eigen::Matrix3d& R = chain.joints[1].rotation;
  int second = 0;  // the coordinate axis R carries the second joint's onto, ±
  R.col(own).cwiseAbs().maxCoeff(&second);
  if (second == first) return false;
  for (int k = 0; k < 3; ++k)  // the entries H R D flips: row `second` and column `own`, but not both
    if ((k != own && !negligible_entry(R, second, k)) || (k != second && !negligible_entry(R, k, own))) return false;
  return chain.joints[1].translation(3 - first - second) == 0.0;
}

// Whether every entry of R is 0 or ±1, exactly, one of them in each row and column: a rotation that carries
// coordinate axes onto coordinate axes, exactly.
bool signed_permutation(const Eigen::Matrix3d& R) {
  for (int r = 0; r < 3; ++r)
    if (coordinate_axis(R.row(r).transpose()) < 0 || coordinate_axis(R.col(r)) < 0) return false;
  return true;
}

// Whether a half-turn of joint k carries everything beyond it onto itself, some later joints reflected: the turn's
// axis is a coordinate axis through every later body's frame origin, each body from k on is half-turn symmetric about
// it, and each later placement is a signed permutation that carries it onto a coordinate axis of the next frame. A
// later joint across that axis is reflected (q_j -> -q_j, and its row and column of M change sign); one along it is
// not. The reflected joints, or nothing (docs/theory.md, "Half-turn symmetries", the tail). Exact, as
// half_turn_symmetric; the last body alone is the case k = n.
std::optional<std::vector<int>> tail_half_turn(const SerialChain& chain, int k) {
  if (chain.joints[static_cast<std::size_t>(k)].type != JointType::revolute) return std::nullopt;
  int c = coordinate_axis(chain.joints[static_cast<std::size_t>(k)].axis);
  std::vector<int> reflected;
  for (int j = k; c >= 0; ++j) {
    if (!half_turn_symmetric(chain.bodies[static_cast<std::size_t>(j)], Eigen::Vector3d::Unit(c))) break;
    if (j + 1 == chain.dof()) return reflected;
    const ChainJoint& next = chain.joints[static_cast<std::size_t>(j + 1)];
    if (next.type != JointType::revolute || next.translation((c + 1) % 3) != 0.0 ||
        next.translation((c + 2) % 3) != 0.0 || !signed_permutation(next.rotation))
      break;
    c = coordinate_axis(next.rotation.row(c).transpose());  // the turn's axis in the next frame, Rᵀ e_c
    if (next.axis(c) == 0.0)
      reflected.push_back(j + 1);
    else if (coordinate_axis(next.axis) != c)
      break;
  }
  return std::nullopt;
}

}  // namespace

bool commutes_with_flips(const Eigen::MatrixXd& X, const std::vector<int>& flipped) {
  std::vector<bool> sign(static_cast<std::size_t>(X.rows()), false);
  for (int j : flipped) sign[static_cast<std::size_t>(j)] = true;
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    for (Eigen::Index k = 0; k < X.cols(); ++k)
      if (sign[static_cast<std::size_t>(i)] != sign[static_cast<std::size_t>(k)] && X(i, k) != 0.0) return false;
  return true;
}

std::vector<HalfTurn> half_turn_symmetries(const Model& model) {
  const auto* chain = std::get_if<SerialChain>(&model.structure);
  if (!chain) return {};
  const std::vector<int> searched = configuration_joints(model);
  std::vector<HalfTurn> turns;
  for (int joint : searched) {
    if (joint == 1 && second_joint_half_turn(*chain) && commutes_with_flips(model.friction, {0})) {
      turns.push_back({1, {0}});
      continue;
    }
    const std::optional<std::vector<int>> reflected = tail_half_turn(*chain, joint);
    if (reflected && commutes_with_flips(model.friction, *reflected)) turns.push_back({joint, *reflected});
  }
  return turns;
}

std::vector<int> configuration_joints(const Model& model) {
  if (is_planar_2r(model)) return {1};
  std::vector<int> joints(static_cast<std::size_t>(model.dof() - 1));
  std::iota(joints.begin(), joints.end(), 1);
  // The last joint moves only the last body (the tool lumped into it); when that body is symmetric about the joint's
  // axis, nothing moves relative to anything else either: M and C do not depend on its position (docs/theory.md,
  // "The constants").
  const auto* chain = std::get_if<SerialChain>(&model.structure);
  if (chain && joints.size() > 1 && chain->joints.back().type == JointType::revolute &&
      symmetric_about(chain->bodies.back(), chain->joints.back().axis))
    joints.pop_back();
  return joints;
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
