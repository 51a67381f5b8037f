// Matrix functions over a box of configurations, as the proofs use them: X(ε) = C + Σ_k G_k ε_k + Δ for every ε in
// [-1, 1]^m (one symbol per searched side of the box), with ||Δ||₂ <= remainder. Built from the model's dynamics on
// affine forms (numerics/affine.hpp), combined with their rounding errors bounded, and bounded in norm to second
// order in the box's width (docs/theory.md, "Certified bounds").
#pragma once

#include "obsgain/numerics/affine.hpp"

#include <Eigen/Dense>

#include <vector>

namespace obsgain {

struct AffineMatrix {
  Eigen::MatrixXd centre;
  std::vector<Eigen::MatrixXd> slopes;  // G_k, one per noise symbol in use
  double remainder = 0.0;               // ||Δ||₂ <= remainder
  // |Δ_ij| <= entry_remainder(i, j) where known (from forms entry by entry; empty after combinations): λmin then
  // sees which entries the remainder sits in, not only its norm.
  Eigen::MatrixXd entry_remainder;

  int symbols() const { return static_cast<int>(slopes.size()); }
  // An upper bound of ||X(ε)||_F over the box (cheap, first order): ||C||_F + Σ ||G_k||_F + remainder.
  double frobenius_upper() const;
};

// From a row-major array of affine forms: entries' remainders become a Frobenius bound of Δ.
AffineMatrix affine_matrix(const Affine* entries, int rows, int cols, int symbols);

// Σ_j weight_j X_j (each X_j of one size), with the rounding of the sums in the remainder.
AffineMatrix linear_combination(const std::vector<AffineMatrix>& terms, const Eigen::VectorXd& weights);
// X D for a diagonal D (columns scaled by d_j), and X + Y.
AffineMatrix scale_columns(const AffineMatrix& X, const Eigen::VectorXd& d);
AffineMatrix sum(const AffineMatrix& X, const AffineMatrix& Y);

// An upper bound of ||Σ_j w_j X_j D + R|| for every |w_j| <= V_j and diagonal D in [0, 1]ⁿ at once, from entry
// moduli: Σ_j V_j (|C_j| + Σ_k |G_jk|) + |C_R| + Σ_k |G_Rk| in Frobenius norm, plus the remainders. No enumeration
// of vertices or patterns: the cheap test that a box cannot beat a value attained elsewhere.
double every_choice_upper(const std::vector<AffineMatrix>& X, const Eigen::VectorXd& V, const AffineMatrix& R);

// Proven bounds over the box. `floor`: the caller only needs to know whether the bound exceeds it; once a cheap
// bound is below it, the finer ones are skipped (the value returned is then still an upper bound).
double norm_upper(const AffineMatrix& X, double floor);
// λmin of a symmetric X, from below.
double smallest_eigenvalue_lower(const AffineMatrix& X);

// M(ε)⁻¹ over the box, for a symmetric M(ε) (row-major n x n forms): with K ≈ L⁻¹ from the Cholesky factor of M's
// centre, Y = K M Kᵀ = I + E, ||E(ε)||₂ <= η < 1 proves M invertible on the box, and
// M⁻¹ = Kᵀ (I - E) K + Kᵀ E² (I + E)⁻¹ K: the first term as forms, the second of norm <= ||K||² η² / (1 - η) (the
// tail). `proven` is false when the box is too wide for η < 1.
struct AffineInverse {
  std::vector<Affine> entries;
  double tail = 0.0;
  bool proven = false;
};
AffineInverse inverse(const std::vector<Affine>& M, int n);

// Row-major products of affine forms: (rows x inner) by (inner x cols), rounding included in the forms.
std::vector<Affine> product(const std::vector<Affine>& A, const std::vector<Affine>& B, int rows, int inner, int cols);

// An upper bound of max_ε ||X(ε)||_F for row-major forms: sqrt Σ (|c| + radius)², rounded up.
double frobenius_upper(const std::vector<Affine>& X);

}  // namespace obsgain
