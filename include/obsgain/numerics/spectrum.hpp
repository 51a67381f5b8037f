// Proven bounds of a symmetric matrix's extreme eigenvalues, the matrix given exactly in floating point. The
// eigensolver is backward stable: its eigenvalues are exact for a matrix within a small multiple of n ε ||S|| of
// S, far below the relative pad kEigenPad for the sizes obsgain handles (n <= 32; docs/theory.md, "The constants").
#pragma once

#include "obsgain/numerics/interval.hpp"

#include <Eigen/Dense>

namespace obsgain {

inline constexpr double kEigenPad = 1e-12;

// Eigen's eigensolvers take seconds to compile in every file that instantiates them (about 10 s of a 2-core build
// each): the library instantiates them once, here, and every caller goes through these.
Eigen::VectorXd symmetric_eigenvalues(const Eigen::MatrixXd& S);  // ascending; S read from its lower triangle
struct SymmetricEigen {
  Eigen::VectorXd values;   // ascending
  Eigen::MatrixXd vectors;  // orthonormal columns, in the values' order
};
SymmetricEigen symmetric_eigen(const Eigen::MatrixXd& S);
// An upper bound of the spectral radius of a non-negative matrix B, so of λmax of every symmetric G with |G| <= B
// entry by entry (ρ(G) <= ρ(|G|) <= ρ(B), Perron–Frobenius): max_i (B x)_i / x_i for any positive x (Collatz–Wielandt;
// Gershgorin's bound of D⁻¹ B D, D = diag(x)), x from a few power iterations in floating point and the ratios formed
// rounding upward (B x of non-negative terms is then at least its exact value). Never above the largest row sum
// (x = 1, Gershgorin's bound of B).
double perron_upper(const Eigen::MatrixXd& B);
// An upper bound of ||S||₂ for a non-negative S, so of ||A||₂ for every A with |A| <= S entry by entry
// (uᵀAv <= |u|ᵀS|v|): the root of perron_upper of the smaller of SᵀS and SSᵀ, formed and rooted rounding upward.
double nonnegative_norm_upper(const Eigen::MatrixXd& S);
// A lower bound of λmin of every symmetric S with S_ii >= d_i and |S_ij| <= B_ij (i != j; B's diagonal not read): for
// unit z, zᵀSz >= Σ d_i z_i² - |z|ᵀB|z| = t - |z|ᵀK|z| with t = max d_i and K = diag(t - d) + B off the diagonal, so
// λmin >= t - ρ(max(K, Kᵀ)), bounded by perron_upper (a weighted Gershgorin bound; never below the plain one,
// min_i d_i - Σ_j B_ij, which is also taken). +∞ for the empty matrix.
double weighted_gershgorin_lower(const Eigen::VectorXd& d, const Eigen::MatrixXd& B);
// ||A||₂ in floating point, as Eigen's operatorNorm computes it (an estimate: spectral_norm_upper bounds it).
double spectral_norm(const Eigen::Ref<const Eigen::MatrixXd>& A);
// G = U T Uᵀ, T quasi upper triangular, U orthogonal.
struct RealSchurForm {
  Eigen::MatrixXd T, U;
};
RealSchurForm real_schur(const Eigen::MatrixXd& G);
// H = U T U*, T upper triangular, U unitary.
struct ComplexSchurForm {
  Eigen::MatrixXcd T, U;
};
ComplexSchurForm complex_schur(const Eigen::MatrixXcd& H);

// cond(T) = σmax(T) / σmin(T) of an invertible T: max |t_ii| / min |t_ii| for a diagonal T, else from the
// eigenvalues of TᵀT, padded by kEigenPad so that it is not below the true value.
double condition_number(const Eigen::MatrixXd& T);

double largest_eigenvalue_upper(const Eigen::MatrixXd& S);
double smallest_eigenvalue_lower(const Eigen::MatrixXd& S);
// ||B||₂ = sqrt(λmax(G)), G the smaller of BᵀB and BBᵀ, formed in floating point: each entry within γ_k Σ_r |b_ri||b_rj|
// of its value (k the inner dimension, γ_k = 1.01 (k + 2) 2⁻⁵² in any rounding mode), so the formed G lies within
// γ_k ||B||_F² (plus underflow) of the true one in norm, which is added under the square root. An eigenproblem of the
// smaller side, not of the (rows + cols)-square dilation [[0, B], [Bᵀ, 0]]: a fraction of the work, and the bound
// is larger by about γ_k ||B||_F² / (2 ||B||₂²) relative, 1e-14 for the sizes obsgain handles.
double spectral_norm_upper(const Eigen::Ref<const Eigen::MatrixXd>& B);

using IntervalMatrix = Eigen::Matrix<Interval, Eigen::Dynamic, Eigen::Dynamic>;
// The largest eigenvalue of every symmetric matrix inside X (read from its lower triangle), bounded above: Weyl's
// inequality on X's midpoint and the Frobenius norm of its radius.
double largest_eigenvalue_upper_over(const IntervalMatrix& X);
// True only if every symmetric matrix inside X is positive definite: a Cholesky factorisation in interval arithmetic
// (outward rounding) whose pivots stay positive, after a diagonal scaling by powers of two (exact). X is read as
// symmetric from its lower triangle.
bool positive_definite_proven(const IntervalMatrix& X);

}  // namespace obsgain
