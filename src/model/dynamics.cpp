#include "obsgain/model/dynamics.hpp"

#include <algorithm>
#include <cmath>
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

// A diagonal of ±1: the map of a frame that a chain symmetry applies (a half-turn about a coordinate axis, a mirror
// across a coordinate plane, or -I).
using Signs = Eigen::Vector3d;

// Whether the map E leaves a body's spatial inertia unchanged: no coordinate of the centre of mass that E negates, no
// product of inertia between coordinates it treats apart. Exact: a body only nearly symmetric is not taken.
bool symmetric_under(const RigidBody& body, const Signs& E) {
  for (int r = 0; r < 3; ++r) {
    if (E(r) < 0.0 && body.com(r) != 0.0) return false;
    for (int c = 0; c < 3; ++c)
      if (E(r) != E(c) && body.inertia(r, c) != 0.0) return false;
  }
  return true;
}

// Whether a placement's entry (r, c) is negligible in every combination that multiplies it (chain_dynamics.hpp,
// combine): its row in R v, its column in Rᵀ v. Every enclosure of the chain then sees only its modulus.
bool negligible_entry(const Eigen::Matrix3d& R, int r, int c) {
  return chain_detail::negligible_coefficient(R(r, c), R.row(r).cwiseAbs().maxCoeff()) &&
         chain_detail::negligible_coefficient(R(r, c), R.col(c).cwiseAbs().maxCoeff());
}

// E carried through a placement's rotation R into the next frame: E' with E R E' = R' where R' differs from R only in
// the signs of negligible entries (0 or negligible_entry), so that the model with R' is bounded by the same numbers,
// bit for bit (docs/theory.md, "Chain symmetries"). E'(c) is E at the row of column c's largest entry.
std::optional<Signs> carried(const Signs& E, const Eigen::Matrix3d& R) {
  Signs next;
  for (int c = 0; c < 3; ++c) {
    int r = 0;
    R.col(c).cwiseAbs().maxCoeff(&r);
    next(c) = E(r);
  }
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (E(r) != next(c) && !negligible_entry(R, r, c)) return std::nullopt;
  return next;
}

// Whether E fixes a placement's translation t. Beyond the first body, exactly; into it, up to a shift along the first
// joint's axis a₁, which the first joint's rotation about a fixed axis does not see.
bool fixes(const Signs& E, const Eigen::Vector3d& t, const Eigen::Vector3d& first_axis, bool first) {
  for (int c = 0; c < 3; ++c)
    if (E(c) < 0.0 && t(c) != 0.0 && !(first && coordinate_axis(first_axis) == c)) return false;
  return true;
}

// A chain symmetry under construction: the path from the first joint to joint j.
struct ChainWalk {
  const SerialChain& chain;
  ChainSymmetry path;
  std::vector<ChainSymmetry> found;
};

// Follows E (in joint j's frame, before its rotation) down the chain. E Rot(a, q) E = Rot(a, σ q) where E a = λ a and
// σ = det(E) λ: the joint's position is negated where σ = -1, and may be turned by π too (Rot(a, q + π) = Rot(a, q) D,
// D the half-turn about a), which hands D E to its body instead of E. Every body from the second on must be symmetric
// under what it is handed; the first rotates about a fixed axis, and its kinetic energy sees only that axis. A
// prismatic joint is passed only where E is the identity (its R a is not read through combine).
void walk(ChainWalk& w, int j, const Signs& E) {
  const ChainJoint& joint = w.chain.joints[static_cast<std::size_t>(j)];
  const bool revolute = joint.type == JointType::revolute;
  if (!revolute && E != Signs::Ones()) return;  // a prismatic joint only where nothing is mapped
  double lambda = 0.0;
  for (int c = 0; c < 3; ++c)
    if (joint.axis(c) != 0.0) {
      if (lambda != 0.0 && lambda != E(c)) return;
      lambda = E(c);
    }
  const bool negated = E.prod() * lambda < 0.0;
  const int axis = coordinate_axis(joint.axis);
  for (const bool turned : {false, true}) {
    if (turned && (j == 0 || axis < 0 || !revolute)) continue;  // turning the first joint moves nothing relative
    Signs body = E;
    if (turned) body = -E, body(axis) = E(axis);
    if (j > 0 && !symmetric_under(w.chain.bodies[static_cast<std::size_t>(j)], body)) continue;
    w.path.frames.push_back(E);
    if (negated) w.path.negated.push_back(j);
    if (turned) w.path.turned.push_back(j);
    if (j + 1 == w.chain.dof()) {
      w.found.push_back(w.path);
    } else {
      const ChainJoint& next = w.chain.joints[static_cast<std::size_t>(j + 1)];
      const std::optional<Signs> E_next = carried(body, next.rotation);
      if (E_next && fixes(body, next.translation, w.chain.joints[0].axis, j == 0)) walk(w, j + 1, *E_next);
    }
    w.path.frames.pop_back();
    if (negated) w.path.negated.pop_back();
    if (turned) w.path.turned.pop_back();
  }
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

std::vector<ChainSymmetry> chain_symmetries(const Model& model) {
  const auto* chain = std::get_if<SerialChain>(&model.structure);
  if (!chain || chain->dof() < 2) return {};
  ChainWalk w{*chain, {}, {}};
  for (int mask = 0; mask < 8; ++mask)  // every diagonal of ±1 the first joint's frame may be mapped by
    walk(w, 0, Signs(mask & 1 ? -1.0 : 1.0, mask & 2 ? -1.0 : 1.0, mask & 4 ? -1.0 : 1.0));
  const std::vector<int> searched = configuration_joints(model);
  const auto moved = [&](const ChainSymmetry& g) {  // the searched joints g moves, in order
    std::vector<int> joints;
    for (int j : searched)
      if (g.moves(j)) joints.push_back(j);
    return joints;
  };
  // Per searched joint, the turn (not negating it) and the mirror (negating it) that move no searched joint before it,
  // each the one that moves fewest joints (then the first in the walk's order).
  std::vector<ChainSymmetry> chosen;
  for (int joint : searched)
    for (const bool mirror : {false, true}) {
      const ChainSymmetry* best = nullptr;
      std::size_t best_moved = 0, best_size = 0;
      for (const ChainSymmetry& g : w.found) {
        const std::vector<int> joints = moved(g);
        if (joints.empty() || joints.front() != joint || g.negates(joint) != mirror ||
            !commutes_with_flips(model.friction, g.negated))
          continue;
        const std::size_t size = g.negated.size() + g.turned.size();
        if (!best || joints.size() < best_moved || (joints.size() == best_moved && size < best_size))
          best = &g, best_moved = joints.size(), best_size = size;
      }
      if (best) chosen.push_back(*best);
    }
  return chosen;
}

namespace {

// Whether joint k slides along a coordinate direction that every revolute joint before it turns about, at every
// configuration: every placement up to it maps that direction to itself (up to sign), exactly, as a product by 0 and
// ±1 does. Sliding then moves the bodies after it along that direction, which no turn before it sees (a SCARA's quill,
// a gantry's axes): the kinetic energy, M and C do not depend on its position (docs/theory.md, "The constants").
bool slides_along_every_turn_before(const SerialChain& chain, std::size_t k) {
  const ChainJoint& slide = chain.joints[k];
  const int c = coordinate_axis(slide.axis);
  if (slide.type != JointType::prismatic || c < 0) return false;
  const Eigen::Vector3d direction = Eigen::Vector3d::Unit(c);
  for (std::size_t i = 0; i <= k; ++i) {
    const ChainJoint& joint = chain.joints[i];
    if (coordinate_axis(joint.rotation * direction) != c) return false;
    if (i < k && joint.type == JointType::revolute && coordinate_axis(joint.axis) != c) return false;
  }
  return true;
}

}  // namespace

std::vector<int> configuration_joints(const Model& model) {
  if (is_planar_2r(model)) return {1};
  const auto* chain = std::get_if<SerialChain>(&model.structure);
  std::vector<int> joints;
  for (int k = 1; k < model.dof(); ++k)
    if (!chain || !slides_along_every_turn_before(*chain, static_cast<std::size_t>(k))) joints.push_back(k);
  // The last joint moves only the last body (the tool lumped into it); when that body is symmetric about the joint's
  // axis, nothing moves relative to anything else either: M and C do not depend on its position (docs/theory.md,
  // "The constants").
  const bool last_searched = !joints.empty() && joints.back() == model.dof() - 1;
  if (chain && joints.size() > 1 && last_searched && chain->joints.back().type == JointType::revolute &&
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
