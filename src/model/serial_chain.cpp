#include "obsgain/model/serial_chain.hpp"

#include <algorithm>

namespace obsgain {

double chain_inertia_floor(const SerialChain& chain) {
  // Rounding in the lumped inertias may leave a principal moment a hair below zero; a body's angular velocity has
  // norm <= sqrt(n) |q'|, so such a deficit costs the floor at most n times itself.
  double deficit = 0.0;
  for (const RigidBody& body : chain.bodies)
    deficit += std::max(0.0, -Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(body.inertia).eigenvalues()(0));
  const double armature = chain.armature.size() > 0 ? chain.armature.minCoeff() : 0.0;
  return std::max(0.0, armature - 2.0 * chain.dof() * deficit - 1e-12 * armature);
}

}  // namespace obsgain
