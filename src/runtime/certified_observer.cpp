#include "obsgain/runtime/certified_observer.hpp"

namespace obsgain {

const char* to_string(CertificateKind kind) {
  switch (kind) {
    case CertificateKind::paper: return "paper";
    case CertificateKind::tight: return "tight";
    case CertificateKind::polytopic: return "polytopic";
  }
  return "unknown";
}

Eigen::MatrixXd per_joint_matrix(const Eigen::Matrix2d& P2, int dof) {
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(2 * dof, 2 * dof);
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) P.block(r * dof, c * dof, dof, dof).diagonal().setConstant(P2(r, c));
  return P;
}

}  // namespace obsgain
