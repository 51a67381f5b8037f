#include "obsgain/certificate/lyapunov.hpp"

#include "obsgain/model/model.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <unsupported/Eigen/KroneckerProduct>

namespace obsgain {

Eigen::MatrixXd solve_lyapunov(const Eigen::MatrixXd& G, const Eigen::MatrixXd& Q) {
  const Eigen::Index n = G.rows();
  // G = U T Uᵀ with T quasi upper triangular; S = U Y Uᵀ turns the equation into Tᵀ Y + Y T = C.
  const RealSchurForm schur = real_schur(G);
  const Eigen::MatrixXd& T = schur.T;
  const Eigen::MatrixXd& U = schur.U;
  const Eigen::MatrixXd C = -U.transpose() * Q * U;
  const Eigen::MatrixXd Tt = T.transpose();
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);

  // Column block j of Y T involves only blocks k <= j of Y: sweep left to right.
  Eigen::MatrixXd Y = Eigen::MatrixXd::Zero(n, n);
  Eigen::Index j = 0;
  while (j < n) {
    const bool pair = j + 1 < n && T(j + 1, j) != 0.0;
    const Eigen::Index width = pair ? 2 : 1;
    Eigen::MatrixXd rhs = C.middleCols(j, width) - Y.leftCols(j) * T.block(0, j, j, width);
    if (!pair) {
      Y.col(j) = (Tt + T(j, j) * I).partialPivLu().solve(rhs);
    } else {
      // Tᵀ Y_j + Y_j T_jj = rhs for an n x 2 block: (I2 ⊗ Tᵀ + T_jjᵀ ⊗ I) vec(Y_j) = vec(rhs).
      const Eigen::Matrix2d Tjj = T.block<2, 2>(j, j);
      const Eigen::MatrixXd K = Eigen::kroneckerProduct(Eigen::Matrix2d::Identity(), Tt) +
                                Eigen::kroneckerProduct(Tjj.transpose(), I);
      const Eigen::VectorXd y = K.partialPivLu().solve(Eigen::Map<const Eigen::VectorXd>(rhs.data(), 2 * n));
      Y.middleCols(j, 2) = Eigen::Map<const Eigen::MatrixXd>(y.data(), n, 2);
    }
    j += width;
  }
  const Eigen::MatrixXd S = U * Y * U.transpose();
  return 0.5 * (S + S.transpose());
}

double lyapunov_residual(const Eigen::MatrixXd& G, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& S) {
  return (G.transpose() * S + S * G + Q).norm() / Q.norm();
}

Eigen::Matrix2d observer_matrix(double alpha, double beta) {
  Eigen::Matrix2d G;
  G << -alpha, 1.0, -beta, 0.0;
  return G;
}

LyapunovSolution observer_lyapunov(double alpha, double beta, int dof) {
  if (!(alpha > 0.0) || !(beta > 0.0)) throw InputError("observer shape needs alpha > 0 and beta > 0");
  LyapunovSolution solution;
  const Eigen::Matrix2d G2 = observer_matrix(alpha, beta);
  solution.S2 = solve_lyapunov(G2, Eigen::Matrix2d::Identity());
  const Eigen::MatrixXd In = Eigen::MatrixXd::Identity(dof, dof);
  solution.S = Eigen::kroneckerProduct(solution.S2, In);
  const Eigen::MatrixXd G = Eigen::kroneckerProduct(G2, In);
  solution.residual = lyapunov_residual(G, Eigen::MatrixXd::Identity(2 * dof, 2 * dof), solution.S);
  solution.S_norm = symmetric_eigenvalues(solution.S2)(1);
  return solution;
}

}  // namespace obsgain
