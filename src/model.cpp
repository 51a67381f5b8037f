#include "obsgain/model.hpp"

#include <cmath>
#include <numeric>
#include <sstream>

namespace obsgain {

void Dynamics::coriolis_tensors(const Eigen::Ref<const Eigen::VectorXd>& q, std::vector<Eigen::MatrixXd>& N) const {
  const int n = dof();
  N.resize(n);
  for (auto& Ni : N) Ni.setZero(n, n);
  // A_i(q, ·) is a quadratic form, so its values at e_j and e_j + e_k determine N_i exactly.
  std::vector<Eigen::VectorXd> diagonal(n, Eigen::VectorXd(n));
  Eigen::VectorXd v = Eigen::VectorXd::Zero(n);
  for (int j = 0; j < n; ++j) {
    v.setZero();
    v(j) = 1.0;
    coriolis(q, v, diagonal[j]);
    for (int i = 0; i < n; ++i) N[i](j, j) = diagonal[j](i);
  }
  Eigen::VectorXd A(n);
  for (int j = 0; j < n; ++j) {
    for (int k = j + 1; k < n; ++k) {
      v.setZero();
      v(j) = 1.0;
      v(k) = 1.0;
      coriolis(q, v, A);
      for (int i = 0; i < n; ++i) {
        const double off = 0.5 * (A(i) - diagonal[j](i) - diagonal[k](i));
        N[i](j, k) = off;
        N[i](k, j) = off;
      }
    }
  }
}

void Dynamics::coriolis_bilinear(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& x,
                                 const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Ref<Eigen::VectorXd> out) const {
  // Per-thread scratch: sized once, so that the simulation's inner loop does not allocate.
  thread_local Eigen::VectorXd argument, difference;
  argument = x + y;
  coriolis(q, argument, out);
  argument = x - y;
  difference.resize(out.size());
  coriolis(q, argument, difference);
  out = 0.25 * (out - difference);
}

std::vector<int> Dynamics::configuration_joints() const {
  std::vector<int> joints(dof());
  std::iota(joints.begin(), joints.end(), 0);
  return joints;
}

Eigen::MatrixXd coriolis_jacobian(const std::vector<Eigen::MatrixXd>& N, const Eigen::Ref<const Eigen::VectorXd>& w) {
  const int n = static_cast<int>(N.size());
  Eigen::MatrixXd J(n, n);
  for (int i = 0; i < n; ++i) J.row(i) = 2.0 * (N[i] * w).transpose();
  return J;
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
  if (!model.dynamics) throw InputError("model '" + model.name + "' has no dynamics");
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
