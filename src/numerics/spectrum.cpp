#include "obsgain/numerics/spectrum.hpp"

#include "obsgain/numerics/interval.hpp"

namespace obsgain {

namespace {

Eigen::VectorXd eigenvalues(const Eigen::MatrixXd& S) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(S, Eigen::EigenvaluesOnly).eigenvalues();
}

}  // namespace

double largest_eigenvalue_upper(const Eigen::MatrixXd& S) {
  const Eigen::VectorXd lambda = eigenvalues(S);
  const UpwardRounding upward;
  return (Interval(lambda(lambda.size() - 1)) + Interval(kEigenPad) * Interval(lambda.cwiseAbs().maxCoeff())).upper();
}

double smallest_eigenvalue_lower(const Eigen::MatrixXd& S) {
  const Eigen::VectorXd lambda = eigenvalues(S);
  const UpwardRounding upward;
  return (Interval(lambda(0)) - Interval(kEigenPad) * Interval(lambda.cwiseAbs().maxCoeff())).lower();
}

double spectral_norm_upper(const Eigen::MatrixXd& B) {
  Eigen::MatrixXd dilation = Eigen::MatrixXd::Zero(B.rows() + B.cols(), B.rows() + B.cols());
  dilation.topRightCorner(B.rows(), B.cols()) = B;
  dilation.bottomLeftCorner(B.cols(), B.rows()) = B.transpose();
  return largest_eigenvalue_upper(dilation);
}

}  // namespace obsgain
