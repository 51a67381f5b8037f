// Proven bounds of a symmetric matrix's extreme eigenvalues, the matrix given exactly in floating point. The
// eigensolver is backward stable: its eigenvalues are exact for a matrix within a small multiple of n ε ||S|| of
// S, far below the relative pad kEigenPad for the sizes obsgain handles (n <= 32; docs/theory.md, "The constants").
#pragma once

#include "obsgain/numerics/interval.hpp"

#include <Eigen/Dense>

namespace obsgain {

inline constexpr double kEigenPad = 1e-12;

double largest_eigenvalue_upper(const Eigen::MatrixXd& S);
double smallest_eigenvalue_lower(const Eigen::MatrixXd& S);
// ||B||₂, from the symmetric dilation [[0, B], [Bᵀ, 0]].
double spectral_norm_upper(const Eigen::MatrixXd& B);

using IntervalMatrix = Eigen::Matrix<Interval, Eigen::Dynamic, Eigen::Dynamic>;
// The largest eigenvalue of every symmetric matrix inside X (read from its lower triangle), bounded above: Weyl's
// inequality on X's midpoint and the Frobenius norm of its radius.
double largest_eigenvalue_upper_over(const IntervalMatrix& X);
// True only if every symmetric matrix inside X is positive definite: a Cholesky factorisation in interval arithmetic
// (outward rounding) whose pivots stay positive, after a diagonal scaling by powers of two (exact). X is read as
// symmetric from its lower triangle.
bool positive_definite_proven(const IntervalMatrix& X);

}  // namespace obsgain
