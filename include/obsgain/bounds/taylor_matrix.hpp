// Matrix functions over a box of configurations, as the proofs use them:
//   X(ε) = C + Σ_k G_k ε_k + Σ_{k<=l} H_kl ε_k ε_l + Δ   for every ε in [-1, 1]^m (one symbol per searched side),
// with ||Δ||₂ <= remainder. Built from the model's dynamics on second-order Taylor forms (numerics/taylor.hpp),
// combined with their rounding errors bounded, and bounded in norm with the second-order term's sign: near a
// maximum the bound's excess is third order in the box's width (docs/theory.md, "Certified bounds").
#pragma once

#include "obsgain/numerics/taylor.hpp"

#include <Eigen/Dense>

#include <utility>
#include <vector>

namespace obsgain {

// The products ε_k ε_l (k <= l < m) of m symbols, in the order TaylorMatrix::curvatures holds them: by the larger
// symbol, then the smaller (kPairs' order, for any number of symbols: a Taylor matrix may carry more than a form).
std::vector<std::pair<int, int>> symbol_pairs(int symbols);
// The position of ε_k ε_l in that order.
int pair_index(int k, int l);

// The parts sit one after the other in one vector, so that forming, copying or dropping a Taylor matrix is one
// allocation and one copy, not one per part (a six-joint box forms thousands of them: docs/history.md, the
// twenty-seventh round).
// Each part starts on a 16-byte boundary, as a matrix of its own would: Eigen's vectorised sums then add in the same
// order, and the bounds are the same to the last bit.
class TaylorMatrix {
 public:
  using Part = Eigen::Map<Eigen::MatrixXd, Eigen::Aligned16>;
  using ConstPart = Eigen::Map<const Eigen::MatrixXd, Eigen::Aligned16>;

  double remainder = 0.0;  // ||Δ||₂ <= remainder
  // |Δ_ij| <= entry_remainder(i, j) where known (from forms entry by entry; empty after combinations): λmin then
  // sees which entries the remainder sits in, not only its norm.
  Eigen::MatrixXd entry_remainder;

  TaylorMatrix() = default;
  // rows x cols over `symbols` symbols, every part zero.
  TaylorMatrix(Eigen::Index rows, Eigen::Index cols, int symbols) { resize(rows, cols, symbols); }
  // The shape, with every part zero; the storage is reused where it is large enough.
  void resize(Eigen::Index rows, Eigen::Index cols, int symbols);
  // The shape, the parts' values left unspecified: for a caller that writes every part.
  void shape(Eigen::Index rows, Eigen::Index cols, int symbols);

  Eigen::Index rows() const { return rows_; }
  Eigen::Index cols() const { return cols_; }
  int symbols() const { return symbols_; }
  // Its parts in one numbering: 0 the centre, then the slopes G_k, then the curvatures H_kl.
  int parts() const { return 1 + symbols_ + pair_count(symbols_); }
  int curvature_count() const { return pair_count(symbols_); }
  // Whether the parts lie side by side with no padding (rows x cols even): parts(0, parts()) is then one rows x
  // (cols parts()) matrix, column by column.
  bool packed() const { return stride_ == rows_ * cols_; }
  Part part(int t) { return {coefficients_.data() + t * stride_, rows_, cols_}; }
  ConstPart part(int t) const { return {coefficients_.data() + t * stride_, rows_, cols_}; }
  Part centre() { return part(0); }
  ConstPart centre() const { return part(0); }
  Part slope(int k) { return part(1 + k); }
  ConstPart slope(int k) const { return part(1 + k); }
  Part curvature(int p) { return part(1 + symbols_ + p); }
  ConstPart curvature(int p) const { return part(1 + symbols_ + p); }
  // Parts first, ..., first + count - 1 as one vector (with the zeros that pad each to its boundary): what is done to
  // every entry of many parts alike is one operation.
  Eigen::VectorBlock<Eigen::VectorXd> parts(int first, int count) {
    return coefficients_.segment(first * stride_, count * stride_);
  }
  Eigen::VectorBlock<const Eigen::VectorXd> parts(int first, int count) const {
    return coefficients_.segment(first * stride_, count * stride_);
  }

  // An upper bound of ||X(ε)||_F over the box (cheap, first order): ||C||_F + Σ ||G_k||_F + Σ ||H_kl||_F + remainder.
  double frobenius_upper() const;
  // |X(ε) - C| <= spread entrywise over the box, rounded up.
  Eigen::MatrixXd spread() const;
  // An upper bound of ||X(ε) - C||₂ over the box: the polynomial's variation is at most Σ |G_k| + Σ |H_kl| entry by
  // entry, and the spectral norm of a non-negative matrix bounds that of any matrix below it in moduli; its square is
  // the Perron root of that matrix's Gram matrix (perron_upper). Plus the remainder. Where the parts' moduli spread
  // over many entries it is far below their Frobenius norms' sum (docs/theory.md, "Cheap bounds of the choices").
  double variation_norm_upper() const;

 private:
  Eigen::VectorXd coefficients_;
  Eigen::Index rows_ = 0, cols_ = 0, stride_ = 0;  // stride_: rows_ cols_ rounded up to an even count of doubles
  int symbols_ = 0;
};

// From a row-major array of forms: entries' remainders become a Frobenius bound of Δ.
TaylorMatrix taylor_matrix(const Taylor* entries, int rows, int cols, int symbols);
// The same over the forms' own symbols (the most any of them has).
TaylorMatrix taylor_matrix(const std::vector<Taylor>& entries, int rows, int cols);

// Σ_j weight_j X_j (each X_j of one size), with the rounding of the sums in the remainder; `frobenius`: the terms'
// frobenius_upper(), computed once for the many combinations of the same terms. Where every term's entry_remainder is
// known the remainder is ||Σ_j |w_j| |Δ_j| ||_F, entry by entry, else Σ_j |w_j| ||Δ_j||.
TaylorMatrix linear_combination(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights,
                                const std::vector<double>& frobenius);
// An upper bound of max over W's columns w of linear_combination(terms, w, ·).frobenius_upper(), without forming the
// combinations (one Gram matrix of the terms per coefficient): the cheap bound of many combinations at once, the
// inertia floor's route (bounds/box_bounds.cpp).
double largest_combination_frobenius_upper(const std::vector<TaylorMatrix>& terms, const Eigen::MatrixXd& W);
// Terms whose weights are carried as symbols (`free[j]`), with what each adds to every combination's remainder, formed
// once for the many combinations of the same terms: its curvatures and remainder, Σ_p |H_jp| + |Δ_j| entry by entry
// where every term's entries' remainders are known (`third_order`), else Σ_p ||H_jp||_F + ||Δ_j|| (`third_order_norm`),
// rounded up, in the order of `terms`.
struct SymbolicWeights {
  std::vector<std::size_t> terms;  // the free ones
  std::vector<Eigen::MatrixXd> third_order;
  std::vector<double> third_order_norm;
};
SymbolicWeights symbolic_weights(const std::vector<TaylorMatrix>& terms, const std::vector<bool>& free);
// The same with some weights free: Σ_j w_j X_j over the fixed ones, plus Σ_j V_j ω_j X_j over the free ones
// (V_j = |weights(j)|), each ω_j ∈ [-1, 1] a symbol of its own after X's: its term's centre is a slope, its slopes are
// curvatures with ω_j, and its curvatures (third order) join the remainder (entry by entry with the remainders, where
// those are known). Every weight in [-V_j, V_j] at once, for the price of a few symbols.
TaylorMatrix linear_combination(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights,
                                const SymbolicWeights& symbolic, const std::vector<double>& frobenius);
// linear_combination(terms, w, symbolic, frobenius) for every w of `vertices`, the vertices of one box: every |w_j| the
// same (std::logic_error otherwise). The weights not free are split into two halves, each half's sums formed once per
// sign pattern it takes, and each combination is the sum of its two halves': two sums per coefficient where the
// combinations one by one take one per term. Their rounding is within the same γ (any order of summation), and the
// remainders, which depend on the |w_j| only, are formed once.
std::vector<TaylorMatrix> vertex_combinations(const std::vector<TaylorMatrix>& terms,
                                              const std::vector<Eigen::VectorXd>& vertices,
                                              const SymbolicWeights& symbolic, const std::vector<double>& frobenius);
// X over `symbols` symbols, the ones beyond its own not entering it.
TaylorMatrix with_symbols(const TaylorMatrix& X, int symbols);
// Their frobenius_upper(), for linear_combination.
std::vector<double> frobenius_uppers(const std::vector<TaylorMatrix>& terms);
// X D + Y for a diagonal D with entries in [0, 1] (X's columns kept or scaled down), written into `out` (whose storage
// is reused); `frobenius`: X.frobenius_upper() + Y.frobenius_upper(), which bounds the sums' rounding.
void scaled_sum(const TaylorMatrix& X, const Eigen::VectorXd& d, const TaylorMatrix& Y, double frobenius, TaylorMatrix& out);
// [X + Y, Y]ᵀ (2n x n for n x n terms), whose norm bounds ||X D + Y|| for every diagonal D with entries in [0, 1] at
// once: (X D + Y)(X D + Y)ᵀ ≼ (X + Y)(X + Y)ᵀ + Y Yᵀ column by column (docs/theory.md, "Every saturation pattern at
// once"). `frobenius`: X.frobenius_upper() + Y.frobenius_upper(), which bounds the sum's rounding.
TaylorMatrix pattern_envelope(const TaylorMatrix& X, const TaylorMatrix& Y, double frobenius);

// L X(ε) R for double matrices L and R (empty: the identity), every product's rounding and the remainder carried in
// norm (||L Δ R|| <= ||L||_F ||Δ|| ||R||_F): the similarity S X S⁻¹ of the forms (bounds/box_bounds.hpp).
TaylorMatrix sandwiched(const Eigen::MatrixXd& L, const TaylorMatrix& X, const Eigen::MatrixXd& R);

// An upper bound of ||Σ_j w_j X_j D + R|| for every |w_j| <= V_j and diagonal D in [0, 1]ⁿ at once, from entry
// moduli: the spectral norm of Σ_j V_j |X_j| + |R| (each over the box), which bounds that of every matrix below it in
// moduli, by the Perron root of its Gram matrix (its Frobenius norm where that is smaller). No enumeration of vertices
// or patterns: the cheap test that a box cannot beat a value attained elsewhere. With `rows` and `columns` (non-empty,
// positive), of diag(rows) (Σ_j w_j X_j D + R) diag(columns) instead: the moduli scaled entry by entry.
double every_choice_upper(const std::vector<TaylorMatrix>& X, const Eigen::VectorXd& V, const TaylorMatrix& R,
                          const Eigen::VectorXd& rows = {}, const Eigen::VectorXd& columns = {});

// Proven bounds over the box. `floor`: the caller only needs to know whether the bound exceeds it; once a cheap
// bound is below it, the finer ones are skipped (the value returned is then still an upper bound).
double norm_upper(const TaylorMatrix& X, double floor);
// λmin of a symmetric X, from below.
double smallest_eigenvalue_lower(const TaylorMatrix& X);

// M(ε)⁻¹ over the box, for a symmetric M(ε) (row-major n x n forms): with K ≈ L⁻¹ from the Cholesky factor of M's
// centre, Y = K M Kᵀ; Y = I + E with ||E(ε)||₂ <= η < 1 (after a scaling c of Y where it varies more) proves M
// invertible on the box, and M⁻¹ = c Kᵀ (I - E + E²) K - c Kᵀ E³ (I + E)⁻¹ K: the first term as forms (exact to
// second order), the second of norm <= c ||E K||² η / (1 - η) (the tail). `proven` is false when the box is too
// wide for η < 1.
struct TaylorInverse {
  TaylorMatrix entries;
  double tail = 0.0;
  bool proven = false;
  // The tail's factors, for tail_upper: Kᵀ E as a Taylor matrix, and c η / (1 - η).
  TaylorMatrix KtE;
  double tail_factor = 0.0;
};
TaylorInverse inverse(const std::vector<Taylor>& M, int n, int symbols);

// An upper bound of ||diag(a) U diag(b)|| for the tail U = c (E K)ᵀ E (I + E)⁻¹ (E K) of a proven inverse:
// c η / (1 - η) ||diag(a) Kᵀ E|| ||diag(b) Kᵀ E||, two norm bounds of n x n forms. For a similarity T = diag(a),
// b ≈ 1/a, it keeps T inside the tail instead of multiplying the tail by ||T|| ||T⁻¹|| (docs/theory.md, "Similarity
// scaling"; bounding the two norms part by part in Frobenius norm instead, cheaper, was measured and not kept).
double tail_upper(const TaylorInverse& inverse, const Eigen::VectorXd& a, const Eigen::VectorXd& b, int symbols);

// How a product of forms bounds its cubic terms (slopes by curvatures): by the products of the entries' sizes, or
// monomial by monomial, which sees where the inner sums cancel and costs s pair_count(s) products of the factors'
// coefficient matrices more (docs/theory.md, "Cubic terms of a product").
enum class CubicTerms { by_sizes, by_monomials };
// Products of Taylor matrices whose entries' remainders are known (entry_remainder; std::logic_error otherwise), over
// the symbols of both, rounding included in the entries' remainders.
TaylorMatrix product(const TaylorMatrix& A, const TaylorMatrix& B, CubicTerms cubic_terms = CubicTerms::by_sizes);
// E E for a square E whose coefficient matrices are symmetric (E_ij and E_ji the same forms): each coefficient of the
// product is S + Sᵀ for one matrix product S, the same products summed in the same order as `product` sums them, so
// the same forms for half the matrix products.
TaylorMatrix symmetric_square(const TaylorMatrix& E, CubicTerms cubic_terms = CubicTerms::by_sizes);
// X = diag(a) X diag(b), entry by entry as a form is scaled (numerics/taylor.hpp, scale_into), a first: by 0 and ±1
// exactly, else each product's rounding in the entry's remainder.
void scale_diagonally(TaylorMatrix& X, const Eigen::VectorXd& a, const Eigen::VectorXd& b);
// Columns of Taylor matrices of one height and one count of symbols, (matrix, column) in the order given, side by
// side with their entries' remainders.
TaylorMatrix gathered_columns(const std::vector<std::pair<const TaylorMatrix*, int>>& columns);

}  // namespace obsgain
