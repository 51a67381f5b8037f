#include "obsgain/numerics/spectrum.hpp"

#include "obsgain/numerics/interval.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace obsgain {

Eigen::VectorXd symmetric_eigenvalues(const Eigen::MatrixXd& S) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(S, Eigen::EigenvaluesOnly).eigenvalues();
}

SymmetricEigen symmetric_eigen(const Eigen::MatrixXd& S) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(S);
  return {eigen.eigenvalues(), eigen.eigenvectors()};
}

double perron_upper(const Eigen::MatrixXd& B) {
  // Weights from a few power iterations: each only sharpens them, and the bound holds for any positive x. Where B's
  // spectrum is symmetric (a bipartite pattern) the iterates alternate; the sum of the last two does not.
  constexpr int kSteps = 8;
  if (B.size() == 0) return 0.0;
  Eigen::VectorXd x = Eigen::VectorXd::Ones(B.rows()), previous = x;
  for (int step = 0; step < kSteps; ++step) {
    const Eigen::VectorXd y = B * x;
    const double top = y.maxCoeff();
    if (!(top > 0.0) || !std::isfinite(top)) break;
    previous = x;
    x = (y / top).array() + 1e-6;  // positive: a zero weight would divide by 0
  }
  const UpwardRounding upward;
  const auto ratio = [&](const Eigen::VectorXd& w) {
    const Eigen::VectorXd y = B * w;
    double r = 0.0;
    for (Eigen::Index i = 0; i < B.rows(); ++i) r = std::max(r, y(i) / w(i));
    return r;
  };
  const double rows = B.rowwise().sum().maxCoeff(), best = std::min(ratio(x), ratio(x + previous));
  return std::isfinite(best) ? std::min(best, rows) : rows;
}

double nonnegative_norm_upper(const Eigen::MatrixXd& S) {
  const UpwardRounding upward;
  const Eigen::MatrixXd gram =
      S.rows() >= S.cols() ? Eigen::MatrixXd(S.transpose() * S) : Eigen::MatrixXd(S * S.transpose());
  return std::sqrt(perron_upper(gram));
}

double weighted_gershgorin_lower(const Eigen::VectorXd& d, const Eigen::MatrixXd& B) {
  const auto n = d.size();
  if (n == 0) return kInfinity;
  const double t = d.maxCoeff();
  const UpwardRounding upward;
  Eigen::MatrixXd K = B.cwiseMax(B.transpose());
  double gershgorin = kInfinity;
  for (Eigen::Index i = 0; i < n; ++i) {
    K(i, i) = (Interval(t) - Interval(d(i))).upper();
    double row = 0.0;
    for (Eigen::Index j = 0; j < n; ++j) row += j == i ? 0.0 : B(i, j);
    gershgorin = std::min(gershgorin, (Interval(d(i)) - Interval(row)).lower());
  }
  return std::max(gershgorin, (Interval(t) - Interval(perron_upper(K))).lower());
}

double spectral_norm(const Eigen::Ref<const Eigen::MatrixXd>& A) {
  return std::sqrt(symmetric_eigenvalues(A * A.transpose()).maxCoeff());
}

RealSchurForm real_schur(const Eigen::MatrixXd& G) {
  const Eigen::RealSchur<Eigen::MatrixXd> schur(G);
  return {schur.matrixT(), schur.matrixU()};
}

ComplexSchurForm complex_schur(const Eigen::MatrixXcd& H) {
  const Eigen::ComplexSchur<Eigen::MatrixXcd> schur(H);
  return {schur.matrixT(), schur.matrixU()};
}

double largest_eigenvalue_upper(const Eigen::MatrixXd& S) {
  const Eigen::VectorXd lambda = symmetric_eigenvalues(S);
  const UpwardRounding upward;
  return (Interval(lambda(lambda.size() - 1)) + Interval(kEigenPad) * Interval(lambda.cwiseAbs().maxCoeff())).upper();
}

double smallest_eigenvalue_lower(const Eigen::MatrixXd& S) {
  const Eigen::VectorXd lambda = symmetric_eigenvalues(S);
  const UpwardRounding upward;
  return (Interval(lambda(0)) - Interval(kEigenPad) * Interval(lambda.cwiseAbs().maxCoeff())).lower();
}

double spectral_norm_upper(const Eigen::Ref<const Eigen::MatrixXd>& B) {
  if (B.isZero(0.0)) return 0.0;  // exactly (also empty)
  const bool tall = B.rows() >= B.cols();
  const Eigen::MatrixXd G = tall ? Eigen::MatrixXd(B.transpose() * B) : Eigen::MatrixXd(B * B.transpose());
  const double lambda = largest_eigenvalue_upper(G);
  if (std::isnan(lambda)) return std::numeric_limits<double>::infinity();
  const double top = std::max(0.0, lambda);
  const double inner = static_cast<double>(tall ? B.rows() : B.cols()), size = static_cast<double>(G.size());
  const UpwardRounding upward;
  // ||B||_F², every term non-negative and rounded up; the Gram matrix's rounding in norm, underflow included.
  const double frobenius_squared = B.squaredNorm();
  const Interval rounding = Interval(1.01 * (inner + 2.0) * 0x1p-52) * Interval(frobenius_squared) +
                            Interval(inner * size * 0x1p-1074);
  return sqrt(Interval(top) + rounding).upper();
}

}  // namespace obsgain

namespace obsgain {

double largest_eigenvalue_upper_over(const IntervalMatrix& X) {
  const Eigen::Index n = X.rows();
  Eigen::MatrixXd middle(n, n);
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = j; i < n; ++i) middle(i, j) = middle(j, i) = 0.5 * (X(i, j).lower() + X(i, j).upper());
  const double top = largest_eigenvalue_upper(middle);  // in the default rounding, as the solver expects
  const UpwardRounding upward;
  // Each entry of X - middle lies within max(upper - middle, middle - lower), computed upwards.
  Interval radius2(0.0);
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = 0; i < n; ++i) {
      const Interval& x = X(std::max(i, j), std::min(i, j));
      const double r = std::max((Interval(x.upper()) - Interval(middle(i, j))).upper(),
                                (Interval(middle(i, j)) - Interval(x.lower())).upper());
      radius2 += square(Interval(r));
    }
  return (Interval(top) + sqrt(radius2)).upper();
}

bool positive_definite_proven(const IntervalMatrix& X) {
  const Eigen::Index n = X.rows();
  // D X D with D_ii = 2^-e_i, X_ii ~ 4^e_i: a congruence, so definiteness is unchanged, and exact in binary.
  Eigen::VectorXd scale(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(X(i, i).lower() > 0.0)) return false;
    int exponent = 0;
    std::frexp(X(i, i).upper(), &exponent);
    scale(i) = std::ldexp(1.0, -exponent / 2);
  }
  IntervalMatrix L = IntervalMatrix::Zero(n, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    Interval pivot = X(j, j) * Interval(scale(j) * scale(j));
    for (Eigen::Index k = 0; k < j; ++k) pivot -= square(L(j, k));
    if (!(pivot.lower() > 0.0)) return false;
    L(j, j) = sqrt(pivot);
    for (Eigen::Index i = j + 1; i < n; ++i) {
      Interval entry = X(i, j) * Interval(scale(i) * scale(j));
      for (Eigen::Index k = 0; k < j; ++k) entry -= L(i, k) * L(j, k);
      L(i, j) = entry / L(j, j);
    }
  }
  return true;
}

double condition_number(const Eigen::MatrixXd& T) {
  if (T.isDiagonal(0.0)) return T.diagonal().cwiseAbs().maxCoeff() / T.diagonal().cwiseAbs().minCoeff();
  const Eigen::VectorXd squares = symmetric_eigenvalues(T.transpose() * T);
  return std::sqrt(squares.maxCoeff() * (1.0 + kEigenPad) / (squares.minCoeff() * (1.0 - kEigenPad)));
}

}  // namespace obsgain
