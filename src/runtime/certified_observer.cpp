#include "obsgain/runtime/certified_observer.hpp"

namespace obsgain {

const char* to_string(CertificateKind kind) {
  switch (kind) {
    case CertificateKind::paper: return "paper";
    case CertificateKind::tight: return "tight";
    case CertificateKind::scaled: return "scaled";
    case CertificateKind::polytopic: return "polytopic";
  }
  return "unknown";
}

std::optional<CertificateKind> certificate_kind(const std::string& name) {
  for (const CertificateKind kind :
       {CertificateKind::paper, CertificateKind::tight, CertificateKind::scaled, CertificateKind::polytopic})
    if (name == to_string(kind)) return kind;
  return std::nullopt;
}

Eigen::MatrixXd per_joint_matrix(const Eigen::Matrix2d& P2, int dof) {
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(2 * dof, 2 * dof);
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) P.block(r * dof, c * dof, dof, dof).diagonal().setConstant(P2(r, c));
  return P;
}

Eigen::MatrixXd scaled_per_joint_matrix(const Eigen::Matrix2d& P2, const Eigen::MatrixXd& scaling) {
  const auto dof = scaling.rows();
  const Eigen::MatrixXd W = scaling.transpose() * scaling;
  Eigen::MatrixXd P(2 * dof, 2 * dof);
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) P.block(r * dof, c * dof, dof, dof) = P2(r, c) * W;
  return P;
}

}  // namespace obsgain
