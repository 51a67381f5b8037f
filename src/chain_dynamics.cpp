#include "obsgain/certified_bounds.hpp"
#include "obsgain/serial_chain.hpp"

#include <fmt/format.h>

namespace obsgain {

RigidBody lump(const RigidBody& body, const RigidBody& part, const Eigen::Matrix3d& rotation,
               const Eigen::Vector3d& translation) {
  const double mass = body.mass + part.mass;
  if (mass <= 0.0) return body;
  const Eigen::Vector3d part_com = rotation * part.com + translation;
  const Eigen::Vector3d com = (body.mass * body.com + part.mass * part_com) / mass;
  // Parallel-axis theorem: I_about_c = I_own + m (|d|² I - d dᵀ) with d the offset of each body's centre from c.
  const auto shifted = [](double m, const Eigen::Vector3d& d) {
    return Eigen::Matrix3d(m * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose()));
  };
  RigidBody result;
  result.mass = mass;
  result.com = com;
  result.inertia = body.inertia + shifted(body.mass, body.com - com) + rotation * part.inertia * rotation.transpose() +
                   shifted(part.mass, part_com - com);
  return result;
}

void validate_chain(const SerialChain& chain, const std::string& source) {
  const int n = chain.dof();
  if (n == 0) throw InputError(source + ": the chain has no moving joint");
  if (n > kMaxChainJoints)
    throw InputError(fmt::format("{}: the chain has {} moving joints; obsgain handles at most {}", source, n, kMaxChainJoints));
  if (static_cast<int>(chain.bodies.size()) != n || chain.armature.size() != n)
    throw InputError(fmt::format("{}: {} joints need {} bodies and {} armature values", source, n, n, n));
  for (int i = 0; i < n; ++i) {
    const ChainJoint& joint = chain.joints[i];
    const RigidBody& body = chain.bodies[i];
    if (!joint.rotation.allFinite() || !joint.translation.allFinite() || !joint.axis.allFinite() ||
        std::abs(joint.axis.norm() - 1.0) > 1e-9)
      throw InputError(fmt::format("{}: joint '{}' needs a finite placement and a unit axis", source, joint.name));
    if (!std::isfinite(body.mass) || body.mass < 0.0 || !body.com.allFinite() || !body.inertia.allFinite())
      throw InputError(fmt::format("{}: the body moved by joint '{}' has mass {} (must be finite and >= 0)", source,
                                   joint.name, body.mass));
    const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(body.inertia).eigenvalues()(0);
    if (smallest < -1e-9 * std::max(1.0, body.inertia.norm()))
      throw InputError(fmt::format("{}: the body moved by joint '{}' has an inertia that is not positive semidefinite "
                                   "(smallest principal moment {:.6g})",
                                   source, joint.name, smallest));
    if (!std::isfinite(chain.armature[i]) || chain.armature[i] < 0.0)
      throw InputError(fmt::format("{}: joint '{}' has armature {} (must be >= 0)", source, joint.name, chain.armature[i]));
  }
  if (!chain.gravity.allFinite()) throw InputError(source + ": gravity must be finite");
}

namespace {

class ChainDynamics final : public Dynamics, public IntervalDynamics {
 public:
  explicit ChainDynamics(SerialChain chain) : chain_(std::move(chain)) {
    // Rounding in the lumped inertias may leave a principal moment a hair below zero; a body's angular
    // velocity has norm <= sqrt(n) |q'|, so such a deficit costs the floor at most n times itself.
    double deficit = 0.0;
    for (const RigidBody& body : chain_.bodies)
      deficit += std::max(0.0, -Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(body.inertia).eigenvalues()(0));
    const double armature = chain_.armature.size() > 0 ? chain_.armature.minCoeff() : 0.0;
    inertia_floor_ = std::max(0.0, armature - 2.0 * dof() * deficit - 1e-12 * armature);
  }

  int dof() const override { return chain_.dof(); }

  void mass_matrix(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::MatrixXd> M) const override {
    ChainKinematics<double> k;
    chain_kinematics(chain_, q.data(), k);
    std::array<double, kMaxChainJoints * kMaxChainJoints> flat;
    chain_mass_matrix(chain_, k, flat.data());
    const int n = dof();
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) M(i, j) = flat[i * n + j];
  }

  void coriolis(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
                Eigen::Ref<Eigen::VectorXd> A) const override {
    evaluate(q, v.data(), false, A);
  }

  void gravity(const Eigen::Ref<const Eigen::VectorXd>& q, Eigen::Ref<Eigen::VectorXd> g) const override {
    std::array<double, kMaxChainJoints> zero{};
    evaluate(q, zero.data(), true, g);
  }

  // The kinematics (every joint's sin and cos) once, then the Newton–Euler passes: the bound search calls this
  // at every configuration.
  void coriolis_tensors(const Eigen::Ref<const Eigen::VectorXd>& q, std::vector<Eigen::MatrixXd>& N) const override {
    const int n = dof();
    ChainKinematics<double> k;
    chain_kinematics(chain_, q.data(), k);
    std::array<double, kMaxChainJoints * kMaxChainJoints * kMaxChainJoints> flat;
    chain_coriolis_tensors(chain_, k, flat.data());
    N.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      N[i].resize(n, n);
      for (int j = 0; j < n; ++j)
        for (int l = 0; l < n; ++l) N[i](j, l) = flat[(i * n + j) * n + l];
    }
  }

  // (A(x + y) - A(x - y)) / 4 with one kinematics for both passes (the simulation's every step).
  void coriolis_bilinear(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& x,
                         const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::VectorXd> out) const override {
    const int n = dof();
    ChainKinematics<double> k;
    chain_kinematics(chain_, q.data(), k);
    std::array<double, kMaxChainJoints> sum{}, difference{}, zero{}, plus{}, minus{};
    for (int i = 0; i < n; ++i) {
      sum[i] = x(i) + y(i);
      difference[i] = x(i) - y(i);
    }
    inverse_dynamics(chain_, k, sum.data(), zero.data(), false, plus.data());
    inverse_dynamics(chain_, k, difference.data(), zero.data(), false, minus.data());
    for (int i = 0; i < n; ++i) out(i) = 0.25 * (plus[i] - minus[i]);
  }

  // Rotating or translating the whole chain about its first joint moves no body relative to another, so the
  // kinetic energy, hence M and C, do not depend on q1.
  std::vector<int> configuration_joints() const override {
    std::vector<int> joints;
    for (int i = 1; i < dof(); ++i) joints.push_back(i);
    return joints;
  }

  MatrixEnclosure mass_matrix(const std::vector<DualInterval>& q) const override {
    const int n = dof();
    ChainKinematics<DualInterval> k;
    chain_kinematics(chain_, q.data(), k);
    std::vector<DualInterval> flat(static_cast<std::size_t>(n * n));
    chain_mass_matrix(chain_, k, flat.data());
    return enclosure_of(Eigen::Map<const Eigen::Matrix<DualInterval, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
                            flat.data(), n, n),
                        directions(q));
  }

  double inertia_floor() const override { return inertia_floor_; }

  std::vector<MatrixEnclosure> coriolis_tensors(const std::vector<DualInterval>& q) const override {
    const int n = dof();
    ChainKinematics<DualInterval> k;
    chain_kinematics(chain_, q.data(), k);
    std::vector<DualInterval> flat(static_cast<std::size_t>(n * n * n));
    chain_coriolis_tensors(chain_, k, flat.data());
    std::vector<MatrixEnclosure> N;
    for (int i = 0; i < n; ++i)
      N.push_back(enclosure_of(Eigen::Map<const Eigen::Matrix<DualInterval, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
                                   flat.data() + i * n * n, n, n),
                               directions(q)));
    return N;
  }

  MatrixEnclosure gravity(const std::vector<DualInterval>& q) const override {
    const int n = dof();
    ChainKinematics<DualInterval> k;
    chain_kinematics(chain_, q.data(), k);
    std::array<double, kMaxChainJoints> zero{};
    std::vector<DualInterval> tau(static_cast<std::size_t>(n));
    inverse_dynamics(chain_, k, zero.data(), zero.data(), true, tau.data());
    return enclosure_of(Eigen::Map<const Eigen::Matrix<DualInterval, Eigen::Dynamic, 1>>(tau.data(), n), directions(q));
  }

 private:
  void evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const double* qd, bool with_gravity,
                Eigen::Ref<Eigen::VectorXd> out) const {
    ChainKinematics<double> k;
    chain_kinematics(chain_, q.data(), k);
    std::array<double, kMaxChainJoints> zero{}, tau{};
    inverse_dynamics(chain_, k, qd, zero.data(), with_gravity, tau.data());
    for (int i = 0; i < dof(); ++i) out(i) = tau[i];
  }

  static int directions(const std::vector<DualInterval>& q) {
    int d = 0;
    for (const DualInterval& x : q) d = std::max(d, x.directions);
    return d;
  }

  SerialChain chain_;
  double inertia_floor_ = 0.0;
};

}  // namespace

std::shared_ptr<const Dynamics> make_chain_dynamics(SerialChain chain) {
  return std::make_shared<const ChainDynamics>(std::move(chain));
}

}  // namespace obsgain
