#include "obsgain/certificate/lyapunov.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <gtest/gtest.h>

#include <random>

namespace {

TEST(Lyapunov, ClosedFormTwoByTwo) {
  // Gᵀ S + S G = -I with G = [[-α, 1], [-β, 0]]: S = [[(1 + β)/(2α), -1/2], [-1/2, (1 + β + α²)/(2αβ)]].
  for (const auto& [a, b] : {std::pair{1.0, 1.0}, {1.572303, 1.0}, {0.3, 7.0}, {12.0, 0.05}}) {
    const Eigen::MatrixXd S = obsgain::solve_lyapunov(obsgain::observer_matrix(a, b), Eigen::Matrix2d::Identity());
    Eigen::Matrix2d expected;
    expected << (1 + b) / (2 * a), -0.5, -0.5, (1 + b + a * a) / (2 * a * b);
    EXPECT_LE((S - expected).norm(), 1e-13 * expected.norm()) << "alpha " << a << " beta " << b;
  }
}

TEST(Lyapunov, PaperNormAndResidual) {
  const obsgain::LyapunovSolution s = obsgain::observer_lyapunov(1.0, 1.0, 2);
  EXPECT_NEAR(s.S_norm, (5.0 + std::sqrt(5.0)) / 4.0, 1e-14);
  EXPECT_NEAR(s.S_norm, 1.8090170, 1e-7);
  EXPECT_LT(s.residual, 1e-12);
  EXPECT_EQ(s.S.rows(), 4);
}

// Bartels–Stewart on general Hurwitz matrices with real and complex eigenvalues, sizes 1 to 9.
TEST(Lyapunov, RandomHurwitzMatricesHaveTinyResiduals) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  for (int n = 1; n <= 9; ++n) {
    for (int trial = 0; trial < 5; ++trial) {
      Eigen::MatrixXd G(n, n);
      for (int i = 0; i < n * n; ++i) G.data()[i] = normal(rng);
      const double shift = obsgain::complex_schur(G.cast<std::complex<double>>()).T.diagonal().real().maxCoeff() + 0.5;
      G -= shift * Eigen::MatrixXd::Identity(n, n);
      Eigen::MatrixXd R(n, n);
      for (int i = 0; i < n * n; ++i) R.data()[i] = normal(rng);
      const Eigen::MatrixXd Q = R * R.transpose() + Eigen::MatrixXd::Identity(n, n);
      const Eigen::MatrixXd S = obsgain::solve_lyapunov(G, Q);
      EXPECT_LT(obsgain::lyapunov_residual(G, Q, S), 1e-12) << "n = " << n;
      EXPECT_GT(obsgain::symmetric_eigenvalues(S)(0), 0.0);
    }
  }
}

TEST(Lyapunov, KroneckerLiftEqualsTheFullSolve) {
  const obsgain::LyapunovSolution lifted = obsgain::observer_lyapunov(1.3, 0.7, 3);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(6, 6);
  const Eigen::Matrix2d G2 = obsgain::observer_matrix(1.3, 0.7);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) G.block(3 * i, 3 * j, 3, 3) = G2(i, j) * Eigen::MatrixXd::Identity(3, 3);
  const Eigen::MatrixXd full = obsgain::solve_lyapunov(G, Eigen::MatrixXd::Identity(6, 6));
  EXPECT_LE((full - lifted.S).norm(), 1e-13 * full.norm());
}

}  // namespace
