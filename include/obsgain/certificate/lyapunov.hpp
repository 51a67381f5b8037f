// The Lyapunov equation of the paper's proof: Gᵀ S + S G = -Q with G = [[-α, 1], [-β, 0]] ⊗ I_n.
#pragma once

#include <Eigen/Dense>

namespace obsgain {

// Solves Gᵀ S + S G = -Q for any size by Bartels–Stewart on the real Schur form of G. G must be Hurwitz
// (more precisely: no two eigenvalues of G may sum to zero).
Eigen::MatrixXd solve_lyapunov(const Eigen::MatrixXd& G, const Eigen::MatrixXd& Q);

// ||Gᵀ S + S G + Q|| / ||Q|| (Frobenius).
double lyapunov_residual(const Eigen::MatrixXd& G, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& S);

// The per-joint block G2 = [[-α, 1], [-β, 0]] of the scaled error dynamics.
Eigen::Matrix2d observer_matrix(double alpha, double beta);

struct LyapunovSolution {
  Eigen::Matrix2d S2;   // per-joint block: S = S2 ⊗ I_n
  Eigen::MatrixXd S;    // full 2n x 2n solution
  double S_norm = 0.0;  // ||S|| = ||S2|| (Kronecker product with I_n keeps the spectrum)
  double residual = 0.0;  // of the full 2n x 2n equation
};

// S for G = G2 ⊗ I_n with Q = I: solves the 2 x 2 equation and lifts it, then checks the full equation.
LyapunovSolution observer_lyapunov(double alpha, double beta, int dof);

}  // namespace obsgain
