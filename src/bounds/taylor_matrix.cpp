#include "obsgain/bounds/taylor_matrix.hpp"

#include "obsgain/numerics/interval.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace obsgain {

namespace {

// Rounding of a double dot product of length n (or of a matrix product's entries): at most γ_n Σ|x_i||y_i|.
double gamma(int n) { return (n + 2) * kTaylorRoundoff * 1.01; }

// An upper bound of a non-negative quantity computed in floating point by a short sequence of operations.
double up(double x) { return x * kTaylorInflation + kTaylorUnderflow; }

// Templates rather than Eigen::Ref: a Ref may have any column stride, and Eigen then sums column by column, in another
// order than over a matrix's entries at once.
template <class Derived>
double frobenius(const Eigen::MatrixBase<Derived>& X) { return up(std::sqrt(up(X.squaredNorm()))); }

// ||X Y - fl(X Y)||_F for a product computed in double: <= γ_n || |X| |Y| ||_F <= γ_n ||X||_F ||Y||_F (n: X's
// columns), from the two norms rounded up.
double product_rounding(Eigen::Index n, double X_frobenius, double Y_frobenius) {
  return up(gamma(static_cast<int>(n)) * X_frobenius * Y_frobenius);
}
template <class Left, class Right>
double product_rounding(const Eigen::MatrixBase<Left>& X, const Eigen::MatrixBase<Right>& Y) {
  return product_rounding(X.cols(), frobenius(X), frobenius(Y));
}

// max over |t| <= 1 of l t + q t², a non-negative value, rounded up (a few operations, each within 2⁻⁵²).
double quadratic_maximum(double l, double q) {
  const double al = std::abs(l);
  const double value = q < 0.0 && al < -2.0 * q ? al * al / (-4.0 * q) : al + q;
  return up(std::max(0.0, value) * (1.0 + 8.0 * kTaylorRoundoff));
}

// Adds the coefficient of ε_k ε_l to the symmetric Q of εᵀQε: all of it on the diagonal, half to each side off it.
void add_pair_coefficient(Eigen::MatrixXd& Q, const std::pair<int, int>& pair, double coefficient) {
  const auto [k, l] = pair;
  if (k == l) {
    Q(k, k) += coefficient;
  } else {
    Q(k, l) += 0.5 * coefficient;
    Q(l, k) += 0.5 * coefficient;
  }
}

// ||Δ||_F from the entries' remainders, summed row by row.
double entries_frobenius(const Eigen::MatrixXd& r) {
  double squares = 0.0;
  for (Eigen::Index i = 0; i < r.rows(); ++i)
    for (Eigen::Index j = 0; j < r.cols(); ++j) squares += r(i, j) * r(i, j);
  return up(std::sqrt(up(squares)));
}

// An upper bound of max over the box of Σ_k l_k ε_k + Σ_{k,l} Q_kl ε_k ε_l (Q symmetric): each symbol's own
// quadratic maximised exactly, the cross terms by their moduli. At a maximum the linear terms vanish and the
// diagonal is negative: the bound is then about the cross terms, not the curvature's size.
double quadratic_polynomial_upper(const Eigen::VectorXd& l, const Eigen::MatrixXd& Q) {
  double bound = 0.0;
  for (Eigen::Index k = 0; k < l.size(); ++k) {
    bound += quadratic_maximum(l(k), Q(k, k));
    for (Eigen::Index j = 0; j < l.size(); ++j)
      if (j != k) bound += std::abs(Q(k, j));
  }
  return up(bound);
}

}  // namespace

std::vector<std::pair<int, int>> symbol_pairs(int symbols) {
  std::vector<std::pair<int, int>> pairs;
  for (int l = 0; l < symbols; ++l)
    for (int k = 0; k <= l; ++k) pairs.emplace_back(k, l);
  return pairs;
}

int pair_index(int k, int l) { return k <= l ? l * (l + 1) / 2 + k : k * (k + 1) / 2 + l; }

void TaylorMatrix::resize(Eigen::Index rows, Eigen::Index cols, int symbols) {
  shape(rows, cols, symbols);
  coefficients_.setZero();
}

void TaylorMatrix::shape(Eigen::Index rows, Eigen::Index cols, int symbols) {
  rows_ = rows;
  cols_ = cols;
  symbols_ = symbols;
  stride_ = (rows * cols + 1) / 2 * 2;
  coefficients_.resize(stride_ * parts());
  // The padding is zero, so that operations on many parts at once (parts(first, count)) find zeros there and leave
  // zeros.
  if (stride_ != rows * cols)
    for (int t = 0; t < parts(); ++t) coefficients_(t * stride_ + stride_ - 1) = 0.0;
}

namespace {

// Each part's Frobenius norm, rounded up (the centre's first).
Eigen::VectorXd part_frobenius(const TaylorMatrix& X) {
  Eigen::VectorXd norms(X.parts());
  for (int t = 0; t < X.parts(); ++t) norms(t) = frobenius(X.part(t));
  return norms;
}

// TaylorMatrix::frobenius_upper from the parts' norms, summed in its order (the same bits): for a caller that needs
// the norms themselves too.
double frobenius_upper(const Eigen::VectorXd& part_norms, double remainder) {
  double bound = part_norms(0) + remainder;
  for (Eigen::Index t = 1; t < part_norms.size(); ++t) bound += part_norms(t);
  return up(bound);
}

}  // namespace

double TaylorMatrix::frobenius_upper() const {
  double bound = frobenius(centre()) + remainder;
  for (int t = 1; t < parts(); ++t) bound += frobenius(part(t));
  return up(bound);
}

Eigen::MatrixXd TaylorMatrix::spread() const {
  const UpwardRounding upward;  // sums of non-negative terms, rounded up
  Eigen::MatrixXd s =
      entry_remainder.size() > 0 ? entry_remainder : Eigen::MatrixXd::Constant(rows(), cols(), remainder);
  for (int t = 1; t < parts(); ++t) s += part(t).cwiseAbs();
  return s;
}

double TaylorMatrix::variation_norm_upper() const {
  const UpwardRounding upward;  // sums and products of non-negative terms, rounded up
  Eigen::MatrixXd moduli = Eigen::MatrixXd::Zero(rows(), cols());
  for (int t = 1; t < parts(); ++t) moduli += part(t).cwiseAbs();
  return up(nonnegative_norm_upper(moduli) + remainder);
}

double every_choice_upper(const std::vector<TaylorMatrix>& X, const Eigen::VectorXd& V, const TaylorMatrix& R,
                          const Eigen::VectorXd& rows, const Eigen::VectorXd& columns) {
  const UpwardRounding upward;
  Eigen::MatrixXd E = R.centre().cwiseAbs() + R.spread();
  for (std::size_t j = 0; j < X.size(); ++j)
    E += std::abs(V(static_cast<Eigen::Index>(j))) * (X[j].centre().cwiseAbs() + X[j].spread());
  if (rows.size()) E = rows.asDiagonal() * E * columns.asDiagonal();  // products of positive numbers, rounded up
  // ||E||₂ is never above ||E||_F mathematically; the smaller of the two proven bounds.
  return std::min(frobenius(E), up(nonnegative_norm_upper(E)));
}

TaylorMatrix taylor_matrix(const Taylor* entries, int rows, int cols, int symbols) {
  TaylorMatrix X;
  X.shape(rows, cols, symbols);
  X.entry_remainder.resize(rows, cols);
  const int pairs = pair_count(symbols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) {
      const Taylor& x = entries[i * cols + j];
      X.centre()(i, j) = x.c;
      for (int k = 0; k < symbols; ++k) X.slope(k)(i, j) = x.slope(k);
      for (int p = 0; p < pairs; ++p) X.curvature(p)(i, j) = x.curvature(p);
      X.entry_remainder(i, j) = x.r;
    }
  X.remainder = entries_frobenius(X.entry_remainder);
  return X;
}

TaylorMatrix taylor_matrix(const std::vector<Taylor>& entries, int rows, int cols) {
  int symbols = 0;
  for (const Taylor& x : entries) symbols = std::max(symbols, x.symbols);
  return taylor_matrix(entries.data(), rows, cols, symbols);
}

std::vector<double> frobenius_uppers(const std::vector<TaylorMatrix>& terms) {
  std::vector<double> f;
  for (const TaylorMatrix& X : terms) f.push_back(X.frobenius_upper());
  return f;
}

namespace {

// Σ_j |w_j| |Δ_j| entry by entry, where every term's entries' remainders are known (empty otherwise): its Frobenius
// norm bounds the combination's Δ, and is at most Σ_j |w_j| ||Δ_j||_F, less where the terms' remainders sit in
// different entries (docs/theory.md, "Remainders entry by entry in the combinations").
// Whether every term's entries' remainders are known: the combinations then add remainders entry by entry.
bool entries_known(const std::vector<TaylorMatrix>& terms) {
  return std::all_of(terms.begin(), terms.end(),
                     [](const TaylorMatrix& X) { return X.entry_remainder.size() == X.rows() * X.cols(); });
}

Eigen::MatrixXd combined_entry_remainders(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights) {
  if (!entries_known(terms)) return {};
  const UpwardRounding upward;  // sums and products of non-negative terms, rounded up
  Eigen::MatrixXd E = Eigen::MatrixXd::Zero(terms[0].rows(), terms[0].cols());
  for (std::size_t j = 0; j < terms.size(); ++j) {
    const double w = std::abs(weights(static_cast<Eigen::Index>(j)));
    if (w != 0.0) E += w * terms[j].entry_remainder;
  }
  return E;
}

// γ_m Σ_j |w_j| ||X_j||_F, rounded up: a bound of the rounding of every entry's sum Σ_j w_j x_j (m terms, in any order
// of summation), `term_frobenius` the terms' ||X_j||_F.
double sum_rounding(const Eigen::VectorXd& weights, const std::vector<double>& term_frobenius) {
  double rounding = 0.0;
  for (std::size_t j = 0; j < term_frobenius.size(); ++j) {
    const double w = weights(static_cast<Eigen::Index>(j));
    if (w != 0.0) rounding += std::abs(w) * term_frobenius[j];
  }
  return up(gamma(static_cast<int>(term_frobenius.size())) * rounding);
}

// The coefficients of Σ_j w_j X_j over `symbols` symbols (at least the terms', the others not entering it), in X (its
// remainder not set).
void sum_coefficients(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights, int symbols,
                      TaylorMatrix& X) {
  X.resize(terms[0].rows(), terms[0].cols(), symbols);
  for (std::size_t j = 0; j < terms.size(); ++j) {
    const double w = weights(static_cast<Eigen::Index>(j));
    if (w == 0.0) continue;
    // The terms' symbols come first, and so do their pairs in symbol_pairs's order: the centre and slopes, then the
    // curvatures, each one run of X's parts.
    const TaylorMatrix& T = terms[j];
    const int s = T.symbols();
    X.parts(0, 1 + s) += w * T.parts(0, 1 + s);
    X.parts(1 + symbols, T.curvature_count()) += w * T.parts(1 + s, T.curvature_count());
  }
}

// Σ_j |w_j| ||Δ_j||_F, rounded up: the combination's remainder where its terms' entries' remainders are not known.
double summed_remainders(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights) {
  double sum = 0.0;
  for (std::size_t j = 0; j < terms.size(); ++j) sum += std::abs(weights(static_cast<Eigen::Index>(j))) * terms[j].remainder;
  return up(sum);
}

}  // namespace

TaylorMatrix linear_combination(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights,
                                const std::vector<double>& term_frobenius) {
  TaylorMatrix X;
  sum_coefficients(terms, weights, terms[0].symbols(), X);
  const double rounding = sum_rounding(weights, term_frobenius);
  const Eigen::MatrixXd E = combined_entry_remainders(terms, weights);
  X.remainder = up((E.size() ? frobenius(E) : summed_remainders(terms, weights)) + rounding);
  return X;
}

namespace {

// Part t of every term (TaylorMatrix::part), term j's as column j.
Eigen::MatrixXd part_columns(const std::vector<TaylorMatrix>& terms, int t) {
  Eigen::MatrixXd C(terms[0].rows() * terms[0].cols(), static_cast<Eigen::Index>(terms.size()));
  for (std::size_t j = 0; j < terms.size(); ++j) C.col(static_cast<Eigen::Index>(j)) = terms[j].part(t).reshaped();
  return C;
}

}  // namespace

// Each coefficient's ||Σ_j w_j C_j||_F² is wᵀ G w with G = CᵀC, C's columns the terms' coefficients: one Gram
// matrix per coefficient serves every column of W, and no combination is formed, so its sums leave no rounding in
// the remainder. Computed in floating point, wᵀ G w is within γ_(e + 2m + 2) (Σ_j |w_j| ||C_j||_F)² of the exact
// value (e entries, m terms: the Gram entries within γ_e ||C_j||_F ||C_k||_F, then a sum of 2m products per column
// of W), and that is added before the square root (docs/theory.md, "M⁻¹ over a box").
double largest_combination_frobenius_upper(const std::vector<TaylorMatrix>& terms, const Eigen::MatrixXd& W) {
  const auto m = static_cast<Eigen::Index>(terms.size());
  const Eigen::MatrixXd W_abs = W.cwiseAbs();
  Eigen::VectorXd remainders(m);
  for (Eigen::Index j = 0; j < m; ++j) remainders(j) = terms[static_cast<std::size_t>(j)].remainder;
  Eigen::RowVectorXd bound = (W_abs.transpose() * remainders).transpose();  // Σ_j |w_j| r_j
  const double rounding = 1.01 * gamma(static_cast<int>(terms[0].rows() * terms[0].cols() + 2 * m + 2));
  Eigen::VectorXd norms(m);
  for (int t = 0; t < terms[0].parts(); ++t) {
    const Eigen::MatrixXd C = part_columns(terms, t);
    for (Eigen::Index j = 0; j < m; ++j) norms(j) = up(std::sqrt(up(C.col(j).squaredNorm())));
    const Eigen::MatrixXd G = C.transpose() * C;
    const Eigen::RowVectorXd squares = W.cwiseProduct(G * W).colwise().sum();
    const Eigen::RowVectorXd sizes = (W_abs.transpose() * norms).transpose();  // Σ_j |w_j| ||C_j||_F
    for (Eigen::Index c = 0; c < W.cols(); ++c)
      bound(c) += up(std::sqrt(up(std::max(0.0, squares(c)) + up(rounding * up(sizes(c) * sizes(c))))));
  }
  return up(bound.maxCoeff());
}

SymbolicWeights symbolic_weights(const std::vector<TaylorMatrix>& terms, const std::vector<bool>& free) {
  SymbolicWeights s;
  const bool by_entry = entries_known(terms);
  const UpwardRounding upward;  // sums of non-negative terms
  for (std::size_t j = 0; j < terms.size(); ++j) {
    if (!free[j]) continue;
    const TaylorMatrix& T = terms[j];
    s.terms.push_back(j);
    if (by_entry) {
      Eigen::MatrixXd third = T.entry_remainder;
      for (int p = 0; p < T.curvature_count(); ++p) third += T.curvature(p).cwiseAbs();
      s.third_order.push_back(std::move(third));
    } else {
      double third = T.remainder;
      for (int p = 0; p < T.curvature_count(); ++p) third += frobenius(T.curvature(p));
      s.third_order_norm.push_back(third);
    }
  }
  return s;
}

namespace {

// The weights with the free ones (carried as symbols) set to zero.
Eigen::VectorXd fixed_weights(const Eigen::VectorXd& weights, const SymbolicWeights& symbolic) {
  Eigen::VectorXd fixed = weights;
  for (const std::size_t j : symbolic.terms) fixed(static_cast<Eigen::Index>(j)) = 0.0;
  return fixed;
}

// The free terms' parts of the combination, V_j ω_j X_j: its centre a slope of ω_j, its slopes curvatures with ω_j.
// X's coefficients there are zero before: the fixed terms have none.
void set_free_parts(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights,
                    const SymbolicWeights& symbolic, TaylorMatrix& X) {
  const int s = terms[0].symbols();
  for (std::size_t r = 0; r < symbolic.terms.size(); ++r) {
    const TaylorMatrix& T = terms[symbolic.terms[r]];
    const double V = std::abs(weights(static_cast<Eigen::Index>(symbolic.terms[r])));
    const int omega = s + static_cast<int>(r);
    X.slope(omega) = V * T.centre();
    for (int k = 0; k < s; ++k) X.curvature(pair_index(k, omega)) = V * T.slope(k);
  }
}

// The combination's remainder: Δ and the free terms' third-order terms V ω Σ_p H_p ε_p entry by entry where the
// entries' remainders are known (then |Σ_p H_p ε_p| <= Σ_p |H_p|), else in norm, and the sums' and products'
// rounding (`rounding`: the fixed terms' sums', sum_rounding). It depends on the |w_j| only.
double combination_remainder(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights,
                             const SymbolicWeights& symbolic, const std::vector<double>& term_frobenius,
                             double rounding) {
  const Eigen::VectorXd fixed = fixed_weights(weights, symbolic);
  Eigen::MatrixXd E = combined_entry_remainders(terms, fixed);
  double remainder = E.size() ? 0.0 : summed_remainders(terms, fixed);
  for (std::size_t r = 0; r < symbolic.terms.size(); ++r) {
    const double V = std::abs(weights(static_cast<Eigen::Index>(symbolic.terms[r])));
    // The products V x rounded within 2⁻⁵² of their moduli: at most 2⁻⁵² V ||X_j||_F over the centre and slopes.
    rounding += kTaylorRoundoff * V * term_frobenius[symbolic.terms[r]];
    const UpwardRounding upward;  // sums and products of non-negative terms
    if (E.size())
      E += V * symbolic.third_order[r];
    else
      remainder += V * symbolic.third_order_norm[r];
  }
  return up((E.size() ? frobenius(E) : remainder) + rounding);
}

}  // namespace

TaylorMatrix linear_combination(const std::vector<TaylorMatrix>& terms, const Eigen::VectorXd& weights,
                                const SymbolicWeights& symbolic, const std::vector<double>& term_frobenius) {
  if (symbolic.terms.empty()) return linear_combination(terms, weights, term_frobenius);
  TaylorMatrix X;
  const int all = terms[0].symbols() + static_cast<int>(symbolic.terms.size());
  const Eigen::VectorXd fixed = fixed_weights(weights, symbolic);
  sum_coefficients(terms, fixed, all, X);
  set_free_parts(terms, weights, symbolic, X);
  X.remainder = combination_remainder(terms, weights, symbolic, term_frobenius, sum_rounding(fixed, term_frobenius));
  return X;
}

namespace {

// The sums of one half of the fixed terms over `symbols` symbols, one per sign pattern the vertices give them, and
// which of them each vertex takes. The patterns in the order the vertices first show them.
struct HalfSums {
  std::vector<TaylorMatrix> sums;
  std::vector<std::size_t> of_vertex;
};

HalfSums half_sums(const std::vector<TaylorMatrix>& terms, const std::vector<Eigen::VectorXd>& vertices,
                   const std::vector<std::size_t>& half, int symbols) {
  HalfSums h;
  std::vector<unsigned> patterns;
  for (const Eigen::VectorXd& w : vertices) {
    unsigned pattern = 0;
    for (std::size_t e = 0; e < half.size(); ++e)
      if (w(static_cast<Eigen::Index>(half[e])) > 0.0) pattern |= 1u << e;
    const auto found = std::find(patterns.begin(), patterns.end(), pattern);
    h.of_vertex.push_back(static_cast<std::size_t>(found - patterns.begin()));
    if (found != patterns.end()) continue;
    patterns.push_back(pattern);
    Eigen::VectorXd weights = Eigen::VectorXd::Zero(w.size());
    for (const std::size_t j : half) weights(static_cast<Eigen::Index>(j)) = w(static_cast<Eigen::Index>(j));
    h.sums.emplace_back();
    sum_coefficients(terms, weights, symbols, h.sums.back());
  }
  return h;
}

}  // namespace

std::vector<TaylorMatrix> vertex_combinations(const std::vector<TaylorMatrix>& terms,
                                              const std::vector<Eigen::VectorXd>& vertices,
                                              const SymbolicWeights& symbolic, const std::vector<double>& frobenius) {
  if (vertices.empty()) return {};
  for (const Eigen::VectorXd& w : vertices)
    if (!(w.cwiseAbs().array() == vertices.front().cwiseAbs().array()).all())
      throw std::logic_error("vertex_combinations: the weights' moduli differ between vertices");
  std::vector<bool> free(terms.size(), false);
  for (const std::size_t j : symbolic.terms) free[j] = true;
  std::vector<std::size_t> fixed;
  for (std::size_t j = 0; j < terms.size(); ++j)
    if (!free[j]) fixed.push_back(j);
  const auto middle = fixed.begin() + static_cast<std::ptrdiff_t>((fixed.size() + 1) / 2);
  const int symbols = terms[0].symbols() + static_cast<int>(symbolic.terms.size());
  HalfSums lead = half_sums(terms, vertices, {fixed.begin(), middle}, symbols);
  const HalfSums rest = half_sums(terms, vertices, {middle, fixed.end()}, symbols);
  // The free terms' parts, the same at every vertex, ride on the first half's sums, where they add to zeros.
  for (TaylorMatrix& sum : lead.sums) set_free_parts(terms, vertices.front(), symbolic, sum);
  // Σ_j w_j X_j summed by halves is within the same γ_m Σ_j |w_j| ||X_j||_F (sum_rounding: any order of summation), and
  // the free parts' sums are exact: the remainder is one combination's, the same at every vertex.
  const double rounding = sum_rounding(fixed_weights(vertices.front(), symbolic), frobenius);
  const double remainder = combination_remainder(terms, vertices.front(), symbolic, frobenius, rounding);
  std::vector<TaylorMatrix> combinations(vertices.size());
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    TaylorMatrix& X = combinations[v];
    const TaylorMatrix& a = lead.sums[lead.of_vertex[v]];
    X.shape(a.rows(), a.cols(), symbols);
    X.parts(0, X.parts()) = a.parts(0, a.parts()) + rest.sums[rest.of_vertex[v]].parts(0, a.parts());
    X.remainder = remainder;
  }
  return combinations;
}

TaylorMatrix with_symbols(const TaylorMatrix& X, int symbols) {
  TaylorMatrix Y(X.rows(), X.cols(), symbols);
  const int s = X.symbols();
  Y.parts(0, 1 + s) = X.parts(0, 1 + s);
  Y.parts(1 + symbols, X.curvature_count()) = X.parts(1 + s, X.curvature_count());
  Y.remainder = X.remainder;
  Y.entry_remainder = X.entry_remainder;
  return Y;
}

void scaled_sum(const TaylorMatrix& X, const Eigen::VectorXd& d, const TaylorMatrix& Y, double frobenius,
                TaylorMatrix& out) {
  out.shape(X.rows(), X.cols(), X.symbols());
  for (int t = 0; t < X.parts(); ++t) {
    out.part(t).noalias() = X.part(t) * d.asDiagonal();
    out.part(t) += Y.part(t);
  }
  // Each entry x d + y is rounded twice, each time within 2⁻⁵² of its modulus: ||·||_F of the error <= 2 · 2⁻⁵² ·
  // (||X D||_F + ||Y||_F) per term, and ||X D||_F <= ||X||_F for d in [0, 1].
  out.remainder = up(X.remainder * d.cwiseAbs().maxCoeff() + Y.remainder + 2.0 * kTaylorRoundoff * frobenius);
  out.entry_remainder.resize(0, 0);  // known as a norm only from here
}

TaylorMatrix sandwiched(const Eigen::MatrixXd& L, const TaylorMatrix& X, const Eigen::MatrixXd& R) {
  const Eigen::MatrixXd I_left = Eigen::MatrixXd::Identity(X.rows(), X.rows());
  const Eigen::MatrixXd I_right = Eigen::MatrixXd::Identity(X.cols(), X.cols());
  const Eigen::MatrixXd& left = L.size() ? L : I_left;
  const Eigen::MatrixXd& right = R.size() ? R : I_right;
  const double left_frobenius = frobenius(left), right_frobenius = frobenius(right);
  double rounding = 0.0;
  // fl(fl(L T) R): the first product errs by at most γ_n ||L||_F ||T||_F, which R stretches by ||R||_F; the second by
  // γ_n ||fl(L T)||_F ||R||_F.
  TaylorMatrix out;
  out.shape(left.rows(), right.cols(), X.symbols());
  for (int t = 0; t < X.parts(); ++t) {
    const Eigen::MatrixXd LT = left * X.part(t);
    rounding += product_rounding(left, X.part(t)) * right_frobenius + product_rounding(LT, right);
    out.part(t).noalias() = LT * right;
  }
  out.remainder = up(up(left_frobenius * X.remainder * right_frobenius) + up(rounding));
  return out;
}

TaylorMatrix pattern_envelope(const TaylorMatrix& X, const TaylorMatrix& Y, double frobenius) {
  TaylorMatrix out;
  out.shape(X.cols() + Y.cols(), X.rows(), X.symbols());
  for (int t = 0; t < X.parts(); ++t) {
    out.part(t).topRows(X.cols()) = (X.part(t) + Y.part(t)).transpose();
    out.part(t).bottomRows(Y.cols()) = Y.part(t).transpose();
  }
  // The remainders [ΔX + ΔY, ΔY] in norm (||[A; B]||² <= ||A||² + ||B||²), and each entry x + y rounded within 2⁻⁵² of
  // its modulus.
  const double top = up(X.remainder + Y.remainder);
  out.remainder = up(up(std::sqrt(up(top * top + up(Y.remainder * Y.remainder)))) + kTaylorRoundoff * frobenius);
  return out;
}

namespace {

// X's polynomial part in a basis V, Y(ε) = X(ε) V = Ĉ + Σ_k ĝ_k ε_k + Σ_p ĥ_p ε_p, with what the products lose to
// rounding as a perturbation of norm <= rho. The slopes ĝ_k and then the curvatures ĥ_p side by side in one matrix, so
// that what is done to every part is one product (the search's hot path: small products one by one cost several
// times their arithmetic).
struct BasisTerms {
  Eigen::MatrixXd C, parts;
  int slopes = 0, curvatures = 0;
  double rho = 0.0;
  Eigen::Index n() const { return C.cols(); }
  // Column i of `count` parts from part `first` on, side by side (a view: the column's stride through the parts).
  Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>> column(int first, int count, Eigen::Index i) const {
    return {parts.data() + (first * n() + i) * C.rows(), C.rows(), count, Eigen::OuterStride<>(n() * C.rows())};
  }
};

// `part_norms`: part_frobenius(X).
BasisTerms in_basis(const TaylorMatrix& X, const Eigen::VectorXd& part_norms, const Eigen::MatrixXd& V) {
  const double V_frobenius = frobenius(V);
  const Eigen::Index n = V.cols(), rows = X.rows(), count = X.parts() - 1;
  BasisTerms t{X.centre() * V, Eigen::MatrixXd(rows, n * count), X.symbols(), X.curvature_count(),
               product_rounding(X.cols(), part_norms(0), V_frobenius)};
  // The parts one below the other, multiplied by V at once, then side by side.
  Eigen::MatrixXd stacked(rows * count, X.cols());
  for (Eigen::Index part = 0; part < count; ++part) {
    stacked.middleRows(part * rows, rows) = X.part(static_cast<int>(part + 1));
    t.rho += product_rounding(X.cols(), part_norms(part + 1), V_frobenius);
  }
  Eigen::MatrixXd products(stacked.rows(), n);  // column by column: one long product each, no blocking for an n of 2-8
  for (Eigen::Index j = 0; j < n; ++j) products.col(j).noalias() = stacked * V.col(j);
  for (Eigen::Index part = 0; part < count; ++part)
    t.parts.middleCols(part * n, n) = products.middleRows(part * rows, rows);
  t.rho = up(t.rho);
  return t;
}

// The Gram matrix of Y(ε), entry by entry: |Ĝ_ij(ε)| <= bound(i, j) over the box (for i = j an upper bound of Ĝ_ii
// itself). Ĝ_ij = ĉ_i·ĉ_j + Σ_k (ĉ_i·ĝ_jk + ĝ_ik·ĉ_j) ε_k + [Σ_p (ĉ_i·ĥ_jp + ĥ_ip·ĉ_j) ε_p + (Σ_k ĝ_ik ε_k)·(Σ_k ĝ_jk ε_k)]
// + higher orders, bounded with the columns' first- and second-order sizes s_i = Σ_k ||ĝ_ik||, t_i = Σ_p ||ĥ_ip||.
// Also returns the parts' products with the centre's columns, Q (gathered_gram_bounds).
Eigen::MatrixXd gram_bounds(const BasisTerms& t, Eigen::VectorXd& s, Eigen::VectorXd& h, Eigen::MatrixXd& Q) {
  const auto n = t.n();
  const int rows = static_cast<int>(t.C.rows());
  const Eigen::MatrixXd P = t.C.transpose() * t.C;
  // Q: (part)_iᵀ ĉ_j, every part's block one below the other (the transposes of ĉ_iᵀ (part)_j), column by column.
  Q.resize(t.parts.cols(), n);
  for (Eigen::Index j = 0; j < n; ++j) Q.col(j).noalias() = t.parts.transpose() * t.C.col(j);
  const Eigen::RowVectorXd squares = t.parts.colwise().squaredNorm();
  Eigen::MatrixXd mixed = Eigen::MatrixXd::Zero(n, n);
  s = Eigen::VectorXd::Zero(n);
  h = Eigen::VectorXd::Zero(n);
  double terms = 0.0;  // Σ ||ĝ_k||_F + Σ ||ĥ_p||_F
  for (int part = 0; part < t.slopes + t.curvatures; ++part) {
    const auto block = Q.middleRows(part * n, n);
    mixed += (block + block.transpose()).cwiseAbs();
    const auto column_squares = squares.segment(part * n, n);
    (part < t.slopes ? s : h) += column_squares.cwiseSqrt().transpose();
    terms += up(std::sqrt(up(column_squares.sum())));
  }
  // Every entry's products Σ_r x_r y_r are rounded within γ_rows Σ_r |x_r||y_r| <= γ_rows ||x|| ||y||: at most
  // γ_rows (||Ĉ||_F² + 2 ||Ĉ||_F Σ ||terms||_F) for any entry.
  const double C_frobenius = frobenius(t.C);
  const double rounding = gamma(rows) * C_frobenius * (C_frobenius + 2.0 * terms);
  const Eigen::MatrixXd bound = (P.cwiseAbs() + mixed + s * s.transpose() + s * h.transpose() + h * s.transpose() +
                                 h * h.transpose()).array() + rounding;
  s = s.unaryExpr([](double x) { return up(x * (1.0 + 1e-12)); });  // the column norms, rounded
  h = h.unaryExpr([](double x) { return up(x * (1.0 + 1e-12)); });
  return bound.unaryExpr([](double x) { return up(x * (1.0 + 1e-12)); });
}

// max over the monomials ν_t in [-1, 1] of ||Σ_t ν_t p_t|| for the columns p_t of P, from their Gram matrix:
// sqrt(Σ_{t,u} |p_t·p_u|), its entries formed within γ_rows (Σ_t ||p_t||)² <= γ_rows sizes² in all ("sizes":
// Σ_t ||p_t|| rounded up), and never above `sizes` (the triangle inequality).
template <class Parts>
double gram_sum_upper(const Parts& P, double sizes) {
  const Eigen::Index count = P.cols();
  if (count == 0) return 0.0;  // no parts (a box of no sides): nothing varies, and Eigen takes no empty rank update
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(count, count);
  gram.selfadjointView<Eigen::Lower>().rankUpdate(P.transpose());
  const UpwardRounding upward;
  double sum = 0.0;  // twice the strict lower triangle's moduli and the diagonal
  for (Eigen::Index j = 0; j < count; ++j) {
    sum += gram(j, j);
    for (Eigen::Index i = j + 1; i < count; ++i) sum += 2.0 * std::abs(gram(i, j));
  }
  const double squares = sum + gamma(static_cast<int>(P.rows())) * up(sizes * sizes);
  return std::min(sizes, up(std::sqrt(up(squares))));
}

// An upper bound of Ĝ_00(ε) = ||y_0(ε)||² that keeps the sign of its second-order term, but for its third- and
// fourth-order terms: σ² + Σ_k l_k ε_k + εᵀQε, l_k = 2 ĉ_0·ĝ_0k, Q = [ĝ_0k·ĝ_0l] + the curvatures 2 ĉ_0·ĥ_0p. The rest,
// 2 (Σ_k ĝ_0k ε_k)·(Σ_p ĥ_0p ε_p) + ||Σ_p ĥ_0p ε_p||², is at most 2 L_0 H_0 + H_0² with L_0 and H_0 bounds of the two
// parts' norms (the sizes s_0 and h_0, or gram_sum_upper).
double top_gram_second_order_upper(const BasisTerms& t, double s0) {
  const int m = t.slopes;
  const auto pairs = symbol_pairs(m);
  const Eigen::VectorXd c0 = t.C.col(0);
  const auto g0 = t.column(0, m, 0), h0 = t.column(m, t.curvatures, 0);
  const Eigen::VectorXd l = 2.0 * (g0.transpose() * c0), curvature = 2.0 * (h0.transpose() * c0);
  Eigen::MatrixXd Q = g0.transpose() * g0;
  for (std::size_t p = 0; p < pairs.size(); ++p)
    add_pair_coefficient(Q, pairs[p], curvature(static_cast<Eigen::Index>(p)));
  const UpwardRounding upward;
  const double sigma2 = c0.squaredNorm();
  double linear_abs = 0.0;  // Σ_k |ĉ_0|·|ĝ_0k|: l's rounding, whatever cancels in l itself
  for (int k = 0; k < m; ++k) linear_abs += c0.cwiseAbs().dot(g0.col(k).cwiseAbs());
  const double curvature_abs = (h0.cwiseAbs().transpose() * c0.cwiseAbs()).sum();
  const double magnitudes = c0.cwiseAbs().squaredNorm() + 2.0 * linear_abs + s0 * s0 + 2.0 * curvature_abs;
  const double rounding = gamma(static_cast<int>(t.C.rows()) + 2 * m + 2) * magnitudes;
  return up(sigma2 + quadratic_polynomial_upper(l, Q) + rounding);
}

// Upper bounds of |Ĝ_ij(ε)| = |y_i(ε)·y_j(ε)| (of Ĝ_ii itself on the diagonal) that gather each monomial's coefficient
// before taking its modulus: ĉ_i·ĉ_j, the slope ĉ_i·ĝ_jk + ĝ_ik·ĉ_j of ε_k, and for the pair p = (k, l)
// ĉ_i·ĥ_jp + ĥ_ip·ĉ_j + ĝ_ik·ĝ_jl + ĝ_il·ĝ_jk (ĝ_ik·ĝ_jk when k = l); the cubic and quartic terms by the parts' norms,
// L_i H_j + H_i L_j + H_i H_j (L_i, H_i: bounds of ||Σ_k ĝ_ik ε_k|| and ||Σ_p ĥ_ip ε_p||). gram_bounds adds the
// product of the slopes' parts term by term (s_i s_j), which does not see these sums cancel: on the iiwa 14's worst
// open box (docs/theory.md, "The Gram matrix gathered") the top column's ||(Ĝ_i0)_i||² is bounded by 9.1 against
// gram_bounds' 27.5 (sampled 1.09), and the norm by 3.513 against 3.944 (sampled 2.93). `Q` as gram_bounds returns
// it. Each coefficient is a sum of at most four products of columns (`rows` entries each), rounded in any order within
// γ_(4 rows + 4) of the sum of their terms' moduli, and those moduli, summed over the coefficients and ĉ_i·ĉ_j, are at
// most ||ĉ_i|| ||ĉ_j|| + ||ĉ_i|| (s_j + h_j) + (s_i + h_i) ||ĉ_j|| + s_i s_j.
Eigen::MatrixXd gathered_gram_bounds(const BasisTerms& t, const Eigen::MatrixXd& Q, const Eigen::VectorXd& s,
                                     const Eigen::VectorXd& h, const Eigen::VectorXd& L, const Eigen::VectorXd& H) {
  const Eigen::Index n = t.n(), m = t.slopes;
  const auto pairs = symbol_pairs(t.slopes);
  const auto slopes = t.parts.leftCols(n * m);
  // ĝ_ik·ĝ_jl at (k n + i, l n + j), the lower triangle only (read through `slope_product`): half the products.
  Eigen::MatrixXd by_slopes = Eigen::MatrixXd::Zero(n * m, n * m);
  if (m > 0) by_slopes.selfadjointView<Eigen::Lower>().rankUpdate(slopes.transpose());  // Eigen takes no empty update
  const auto slope_product = [&](Eigen::Index a, Eigen::Index b) { return a >= b ? by_slopes(a, b) : by_slopes(b, a); };
  const Eigen::MatrixXd P = t.C.transpose() * t.C;
  const int inner = 4 * static_cast<int>(t.C.rows()) + 4;
  const UpwardRounding upward;
  Eigen::VectorXd centre_norms(n);
  for (Eigen::Index i = 0; i < n; ++i) centre_norms(i) = std::sqrt(t.C.col(i).squaredNorm());
  Eigen::MatrixXd bound(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j <= i; ++j) {
      double sum = std::abs(P(i, j));
      for (Eigen::Index k = 0; k < m; ++k) sum += std::abs(Q(k * n + i, j) + Q(k * n + j, i));
      for (std::size_t p = 0; p < pairs.size(); ++p) {
        const Eigen::Index k = pairs[p].first, l = pairs[p].second, row = (m + static_cast<Eigen::Index>(p)) * n;
        double coefficient = Q(row + i, j) + Q(row + j, i) + slope_product(k * n + i, l * n + j);
        if (k != l) coefficient += slope_product(l * n + i, k * n + j);
        sum += std::abs(coefficient);
      }
      const double moduli = centre_norms(i) * centre_norms(j) + centre_norms(i) * (s(j) + h(j)) +
                            (s(i) + h(i)) * centre_norms(j) + s(i) * s(j);
      bound(i, j) = bound(j, i) =
          up(sum + L(i) * H(j) + H(i) * L(j) + H(i) * H(j) + gamma(inner) * up(moduli * (1.0 + 1e-12)));
    }
  return bound;
}

// λmax of a symmetric matrix from bounds on its first row and the rest: for any unit z, λmax <= the largest
// eigenvalue of [[a, b], [b, c]] with a >= zᵀGz, b >= ||(I - zzᵀ)Gz||, c >= λmax of G on z⊥ (docs/theory.md).
Interval two_by_two_upper(const Interval& a, const Interval& b2, const Interval& c) {
  return (a + c) / 2.0 + boost::numeric::sqrt(boost::numeric::square((a - c) / 2.0) + b2);
}

// The right singular vectors of C (leading first) and their non-orthogonality δ, bounded (δ >= 0.5: unusable).
Eigen::MatrixXd singular_basis(const TaylorMatrix::ConstPart& C, double& delta) {
  const Eigen::MatrixXd V = symmetric_eigen(C.transpose() * C).vectors.rowwise().reverse();
  const auto n = V.cols();
  const Eigen::MatrixXd Vt = V.transpose(), W = V.transpose() * V - Eigen::MatrixXd::Identity(n, n);
  delta = up(frobenius(W) + product_rounding(Vt, V));
  return V;
}

}  // namespace

// λmax of Ĝ(ε) from the top direction (the centre's leading right singular vector): a from the signed second-order
// expansion of Ĝ_00, b and c from the entry bounds (c by perron_upper: weighted Gershgorin). The excess is b²/(a - c),
// the cross terms of the second-order part and the third-order terms.
double norm_upper(const TaylorMatrix& X, double floor) {
  const Eigen::VectorXd part_norms = part_frobenius(X);
  const double cheap = frobenius_upper(part_norms, X.remainder);
  if (cheap <= floor || !std::isfinite(cheap)) return cheap;
  double delta = 0.0;
  const Eigen::MatrixXd V = singular_basis(X.centre(), delta);
  if (!(delta < 0.5)) return cheap;
  const BasisTerms t = in_basis(X, part_norms, V);
  Eigen::VectorXd s, h;
  Eigen::MatrixXd Q;
  const Eigen::MatrixXd bound = gram_bounds(t, s, h, Q);
  const auto n = bound.cols();
  const UpwardRounding upward;
  const auto sigma = [&](const Interval& a, const Eigen::MatrixXd& B) {
    using boost::numeric::sqrt;
    Interval b2(0.0);
    for (Eigen::Index i = 1; i < n; ++i) b2 += boost::numeric::square(Interval(B(i, 0)));
    const Interval c(perron_upper(B.bottomRightCorner(n - 1, n - 1)));
    return ((sqrt(two_by_two_upper(a, b2, c)) + Interval(t.rho)) / sqrt(Interval(1.0) - Interval(delta)) +
            Interval(X.remainder)).upper();
  };
  // First from gram_bounds' entries and the parts' sizes; where that does not settle the question, from the gathered
  // entries and y_0's parts' norms by their Gram matrices (docs/theory.md, "The Gram matrix gathered").
  const double second_order = top_gram_second_order_upper(t, s(0));
  const auto top = [&](double L0, double H0) {
    return Interval(std::min(bound(0, 0), up(second_order + 2.0 * L0 * H0 + H0 * H0)));
  };
  const double coarse = std::min(cheap, sigma(top(s(0), h(0)), bound));
  if (coarse <= floor) return coarse;
  Eigen::VectorXd L = s, H = h;
  L(0) = gram_sum_upper(t.column(0, t.slopes, 0), s(0));
  H(0) = gram_sum_upper(t.column(t.slopes, t.curvatures, 0), h(0));
  const Eigen::MatrixXd gathered = bound.cwiseMin(gathered_gram_bounds(t, Q, s, h, L, H));
  return std::min(coarse, sigma(top(L(0), H(0)), gathered));
}

namespace {

// A lower bound of T_00(ε) = v_0ᵀ X(ε) v_0 over the box, keeping the sign of its second-order terms.
double top_entry_lower(double centre, const Eigen::VectorXd& slopes, const Eigen::VectorXd& curvatures, int m) {
  const auto pairs = symbol_pairs(m);
  Eigen::MatrixXd Q = Eigen::MatrixXd::Zero(m, m);
  for (std::size_t p = 0; p < pairs.size(); ++p)
    add_pair_coefficient(Q, pairs[p], -curvatures(static_cast<Eigen::Index>(p)));
  const UpwardRounding upward;
  return -(-centre + quadratic_polynomial_upper(-slopes, Q));
}

}  // namespace

double smallest_eigenvalue_lower(const TaylorMatrix& X) {
  const int n = static_cast<int>(X.cols()), m = X.symbols();
  const Eigen::MatrixXd V = symmetric_eigen(0.5 * (X.centre() + X.centre().transpose())).vectors;  // smallest first
  const Eigen::MatrixXd Vt = V.transpose(), W = V.transpose() * V - Eigen::MatrixXd::Identity(n, n);
  const double delta = up(frobenius(W) + product_rounding(Vt, V));
  if (!(delta < 0.5)) return -kInfinity;
  // T(ε) = Vᵀ X_poly(ε) V: centre, slopes and curvatures, with the products' rounding as a perturbation of norm <= rho.
  const auto rounding = [&](const TaylorMatrix::ConstPart& Y) {
    const Eigen::MatrixXd VtY = V.transpose() * Y;
    return up(product_rounding(Vt, Y) * frobenius(V) + product_rounding(VtY, V));
  };
  const Eigen::MatrixXd T = V.transpose() * X.centre() * V;
  double rho = rounding(X.centre());
  Eigen::MatrixXd spread = Eigen::MatrixXd::Zero(n, n);  // Σ_k |T_k(i, j)| + Σ_p |T_p(i, j)|
  Eigen::VectorXd top_slopes(m), top_curvatures(X.curvature_count());
  Eigen::MatrixXd Tt;
  for (int t = 1; t < X.parts(); ++t) {
    Tt.noalias() = V.transpose() * X.part(t) * V;
    (t <= m ? top_slopes(t - 1) : top_curvatures(t - 1 - m)) = Tt(0, 0);
    spread += Tt.cwiseAbs();
    rho += rounding(X.part(t));
  }
  // The remainder in the same basis, entry by entry where its entries are known: |VᵀΔV| <= |V|ᵀ|Δ||V| (rounded up).
  const bool by_entry = X.entry_remainder.size() == X.rows() * X.cols();
  Eigen::MatrixXd remainder = Eigen::MatrixXd::Zero(n, n);
  if (by_entry)
    remainder = (V.cwiseAbs().transpose() * X.entry_remainder * V.cwiseAbs()).unaryExpr([&](double x) {
      return up(x * (1.0 + gamma(2 * n)));
    });
  spread += remainder;
  const Eigen::MatrixXd magnitude = T.cwiseAbs() + spread;  // |T_ij(ε)| <= magnitude(i, j)
  const Interval a = Interval(top_entry_lower(T(0, 0), top_slopes, top_curvatures, m)) - Interval(remainder(0, 0));
  Interval b2(0.0);
  Eigen::VectorXd diagonal(n - 1);  // lower bounds of T_ii(ε), i >= 1
  for (int i = 1; i < n; ++i) {
    b2 += boost::numeric::square(Interval(magnitude(i, 0)));
    diagonal(i - 1) = (Interval(T(i, i)) - Interval(spread(i, i))).lower();
  }
  const Interval c(weighted_gershgorin_lower(diagonal, magnitude.bottomRightCorner(n - 1, n - 1)));
  using boost::numeric::sqrt;
  const Interval lambda = (n == 1 ? a : (a + c) / 2.0 - sqrt(boost::numeric::square((c - a) / 2.0) + b2)) - Interval(up(rho));
  const double scale = lambda.lower() >= 0.0 ? (Interval(1.0) / (Interval(1.0) + Interval(delta))).lower()
                                             : (Interval(1.0) / (Interval(1.0) - Interval(delta))).upper();
  return (Interval(lambda.lower()) * Interval(scale) - Interval(by_entry ? 0.0 : X.remainder)).lower();
}

namespace {

// A Taylor matrix whose entries' remainders are known, with each entry's sizes as its form's (Taylor::linear_size,
// quadratic_size): Σ|a_k|, Σ|b_p| and |c| + both, summed entry by entry in the forms' order.
struct CoefficientMatrices {
  const TaylorMatrix& X;
  Eigen::MatrixXd linear, quadratic, total;
};

CoefficientMatrices coefficient_matrices(const TaylorMatrix& X) {
  const auto rounded_up = [](double x) { return up(x); };
  CoefficientMatrices m{X, Eigen::MatrixXd::Zero(X.rows(), X.cols()), Eigen::MatrixXd::Zero(X.rows(), X.cols()), {}};
  for (int k = 0; k < X.symbols(); ++k) m.linear += X.slope(k).cwiseAbs();
  for (int p = 0; p < X.curvature_count(); ++p) m.quadratic += X.curvature(p).cwiseAbs();
  m.linear = m.linear.unaryExpr(rounded_up);
  m.quadratic = m.quadratic.unaryExpr(rounded_up);
  m.total = (X.centre().cwiseAbs() + m.linear + m.quadratic).unaryExpr(rounded_up);
  return m;
}

// Each entry's remainder rounded up, and ||Δ||_F from them.
void set_entry_remainders(TaylorMatrix& X, const Eigen::MatrixXd& remainder) {
  X.entry_remainder = remainder.unaryExpr([](double x) { return up(x); });
  X.remainder = entries_frobenius(X.entry_remainder);
}

// X itself where it has at least `symbols` symbols, else X with zero parts for the others (in `padded`).
const TaylorMatrix& over_symbols(const TaylorMatrix& X, int symbols, TaylorMatrix& padded) {
  if (X.symbols() >= symbols) return X;
  padded = with_symbols(X, symbols);
  return padded;
}

// The cubic monomials ε_i ε_j ε_l (i <= j <= l) of m symbols, ordered by l and then by the pair (i, j) in kPairs'
// order: those of the first m symbols are the first m (m + 1) (m + 2) / 6.
int triple_index(int k, int first, int second) {
  int t[3] = {k, first, second};
  std::sort(t, t + 3);
  return t[2] * (t[2] + 1) * (t[2] + 2) / 6 + kPairs.index[t[0]][t[1]];
}

// An entrywise bound of the cubic part of A B, Σ_(k,p) ε_k μ_p (A_k B_p + A_p B_k) (slopes by curvatures, μ_p the
// pair's monomial): each cubic monomial's coefficient matrix is formed, and their moduli summed. Where the inner sums
// cancel, this is below the products of the entries' sizes, Σ_m Σ_k |a_imk| Σ_p |b_mjp| (E² in M⁻¹'s series on the
// iiwa 14's worst open box after the sixteenth round: its bound of L_joint 8.73 -> 8.41; docs/theory.md, "Cubic terms
// of a product"). Every product a_imk b_mjp enters one coefficient, of at most 6 · inner of them (a monomial
// ε_i ε_j ε_l is reached from three slopes, each by both orders): their rounding is within γ_(6 inner)
// (|A|_1 |B|_2 + |A|_2 |B|_1), and their underflow within 2⁻¹⁰⁷⁴ each. The coefficient matrices sit side by side in
// one matrix, one allocation. `square`: b is a, and a's coefficient matrices are symmetric (E² below), so that
// A_p B_k = A_p A_k = (A_k A_p)ᵀ: the same products, summed in the same order, transposed.
Eigen::MatrixXd cubic_upper(const CoefficientMatrices& a, const CoefficientMatrices& b, int symbols, bool square) {
  const auto rows = a.X.rows(), inner = a.X.cols(), cols = b.X.cols();
  const int pairs = pair_count(symbols);
  Eigen::MatrixXd stacked_b(inner, cols * pairs), stacked_a(square ? 0 : rows * pairs, inner);
  for (int p = 0; p < pairs; ++p) {
    stacked_b.middleCols(p * cols, cols) = b.X.part(1 + symbols + p);
    if (!square) stacked_a.middleRows(p * rows, rows) = a.X.part(1 + symbols + p);
  }
  const int count = symbols * (symbols + 1) * (symbols + 2) / 6;
  Eigen::MatrixXd monomials = Eigen::MatrixXd::Zero(rows, cols * count);
  Eigen::MatrixXd slope_first, slope_second;
  for (int k = 0; k < symbols; ++k) {
    slope_first.noalias() = a.X.part(1 + k) * stacked_b;  // A_k B_p, side by side
    if (!square) slope_second.noalias() = stacked_a * b.X.part(1 + k);  // A_p B_k, one above the other
    for (int p = 0; p < pairs; ++p) {
      auto monomial = monomials.middleCols(triple_index(k, kPairs.first[p], kPairs.second[p]) * cols, cols);
      const auto first = slope_first.middleCols(p * cols, cols);
      if (square)
        monomial += first + first.transpose();
      else
        monomial += first + slope_second.middleRows(p * rows, rows);
    }
  }
  const UpwardRounding upward;
  Eigen::MatrixXd cubic = gamma(6 * static_cast<int>(inner)) * (a.linear * b.quadratic + a.quadratic * b.linear);
  for (int t = 0; t < count; ++t) cubic += monomials.middleCols(t * cols, cols).cwiseAbs();
  return cubic.array() + std::ldexp(6.0 * static_cast<double>(inner) * count, -1074);
}

// A B's coefficient matrices up to the second order (product below). `square`: B is A, with symmetric coefficient
// matrices, so that A_k A_0 = (A_0 A_k)ᵀ and A_l A_k = (A_k A_l)ᵀ, the same products summed in the same order: each
// coefficient is S + Sᵀ, one matrix product where the general case takes two.
void second_order_parts(const TaylorMatrix& a, const TaylorMatrix& b, bool square, TaylorMatrix& c) {
  const int symbols = c.symbols();
  Eigen::MatrixXd S;
  // x y + u v into `part`, or added to it; u v is (x y)ᵀ where `square`.
  const auto both = [&](TaylorMatrix::Part part, const auto& x, const auto& y, const auto& u, const auto& v, bool add) {
    if (square) {
      S.noalias() = x * y;
      if (add)
        part += S;
      else
        part = S;
      part += S.transpose();
      return;
    }
    if (add)
      part.noalias() += x * y;
    else
      part.noalias() = x * y;
    part.noalias() += u * v;
  };
  c.part(0).noalias() = a.part(0) * b.part(0);
  for (int k = 0; k < symbols; ++k) both(c.part(1 + k), a.part(0), b.part(1 + k), a.part(1 + k), b.part(0), false);
  for (int p = 0; p < pair_count(symbols); ++p) {
    const int k = kPairs.first[p], l = kPairs.second[p], t = 1 + symbols + p;
    both(c.part(t), a.part(0), b.part(t), a.part(t), b.part(0), false);
    if (k != l)
      both(c.part(t), a.part(1 + k), b.part(1 + l), a.part(1 + l), b.part(1 + k), true);
    else
      c.part(t).noalias() += a.part(1 + k) * b.part(1 + l);
  }
}

// The coefficients of every entry at once, as matrix products: C_0 = A_0 B_0, C_k = A_0 B_k + A_k B_0, C_kl = A_0 B_kl +
// A_kl B_0 + A_k B_l + A_l B_k (A_k B_k on the diagonal); the cubic terms by the entries' sizes or monomial by monomial
// (cubic_upper), the quartic terms and every product with a remainder as one form's product bounds them (operator*), by
// products of the entries' sizes rounded upward. Each coefficient of an entry is a sum of at most 4 · inner products
// of one term of A and one of B, each product in one coefficient only: their rounding, in any order of summation, is
// within γ_{4 inner} Σ_m total(A)_im total(B)_mj, and their underflow (at most 4 · 8 · 120 products of 2⁻¹⁰⁷⁴ per
// entry) within the 2⁻¹⁰⁶⁰ that up() adds.
TaylorMatrix product_of(const TaylorMatrix& A, const TaylorMatrix& B, CubicTerms cubic_terms, bool square) {
  for (const TaylorMatrix* X : {&A, &B})
    if (X->entry_remainder.rows() != X->rows() || X->entry_remainder.cols() != X->cols())
      throw std::logic_error("product: a factor's entries' remainders are not known");
  const int symbols = std::max(A.symbols(), B.symbols());
  const auto inner = static_cast<int>(A.cols());
  TaylorMatrix padded_a, padded_b;
  const CoefficientMatrices a = coefficient_matrices(over_symbols(A, symbols, padded_a));
  // E E's second factor is its first: its sizes are taken once.
  const CoefficientMatrices b = square ? a : coefficient_matrices(over_symbols(B, symbols, padded_b));
  // S + Sᵀ is A A only for symmetric coefficient matrices: anything else would be an unsound product.
  for (int t = 0; square && t < a.X.parts(); ++t)
    if (!(a.X.part(t).array() == a.X.part(t).transpose().array()).all())
      throw std::logic_error("symmetric_square: the forms' coefficient matrices are not symmetric");
  Eigen::MatrixXd cubic;
  if (cubic_terms == CubicTerms::by_monomials) cubic = cubic_upper(a, b, symbols, square);
  TaylorMatrix c;
  c.shape(A.rows(), B.cols(), symbols);
  second_order_parts(a.X, b.X, square, c);
  Eigen::MatrixXd remainder;
  {
    const UpwardRounding upward;  // sums and products of non-negative terms, each rounded up
    const Eigen::MatrixXd& ar = a.X.entry_remainder;
    const Eigen::MatrixXd& br = b.X.entry_remainder;
    if (cubic_terms == CubicTerms::by_sizes) cubic = a.linear * b.quadratic + a.quadratic * b.linear;
    remainder = cubic + a.quadratic * b.quadratic + a.total * br + ar * b.total + ar * br +
                gamma(4 * inner) * (a.total * b.total);
  }
  set_entry_remainders(c, remainder);
  return c;
}

}  // namespace

TaylorMatrix product(const TaylorMatrix& A, const TaylorMatrix& B, CubicTerms cubic_terms) {
  return product_of(A, B, cubic_terms, false);
}

TaylorMatrix symmetric_square(const TaylorMatrix& E, CubicTerms cubic_terms) {
  return product_of(E, E, cubic_terms, true);
}

namespace {

// K ≈ L⁻¹ with M's centre = L Lᵀ; empty when the centre is not positive definite.
Eigen::MatrixXd inverse_cholesky_factor(const std::vector<Taylor>& M, int n) {
  Eigen::MatrixXd centre(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) centre(i, j) = 0.5 * (M[i * n + j].c + M[j * n + i].c);
  const Eigen::LLT<Eigen::MatrixXd> llt(centre);
  if (llt.info() != Eigen::Success) return {};
  const Eigen::MatrixXd L = llt.matrixL();
  return L.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n));
}

// K X (K a double matrix), coefficient by coefficient as matrix products. Each coefficient of an entry is a sum of
// K.cols() products K_ik x_kj, rounded within γ Σ_k |K_ik| |x_kj|: over the coefficients, γ (|K| total(X))_ij.
TaylorMatrix left_multiply(const Eigen::MatrixXd& K, const TaylorMatrix& X) {
  const CoefficientMatrices x = coefficient_matrices(X);
  const auto n = X.cols();
  TaylorMatrix y;
  y.shape(K.rows(), n, X.symbols());
  if (X.packed() && y.packed()) {
    // Side by side the parts are one matrix, and K times it one product.
    const auto from = X.parts(0, X.parts());
    auto to = y.parts(0, y.parts());
    Eigen::Map<Eigen::MatrixXd>(to.data(), K.rows(), n * y.parts()).noalias() =
        K * Eigen::Map<const Eigen::MatrixXd>(from.data(), K.cols(), n * y.parts());
  } else {
    for (int t = 0; t < y.parts(); ++t) y.part(t).noalias() = K * X.part(t);
  }
  Eigen::MatrixXd remainder;
  {
    const UpwardRounding upward;
    const Eigen::MatrixXd K_abs = K.cwiseAbs();
    remainder = K_abs * X.entry_remainder + gamma(static_cast<int>(K.cols())) * (K_abs * x.total);
  }
  set_entry_remainders(y, remainder);
  return y;
}

TaylorMatrix transposed(const TaylorMatrix& X) {
  TaylorMatrix Y;
  Y.shape(X.cols(), X.rows(), X.symbols());
  for (int t = 0; t < X.parts(); ++t) Y.part(t) = X.part(t).transpose();
  Y.entry_remainder = X.entry_remainder.transpose();
  Y.remainder = entries_frobenius(Y.entry_remainder);
  return Y;
}

// The upper triangle's entries, every part and remainder, copied to the lower.
void mirror_upper(TaylorMatrix& Y) {
  for (Eigen::Index i = 0; i < Y.rows(); ++i)
    for (Eigen::Index j = i + 1; j < Y.cols(); ++j) {
      for (int t = 0; t < Y.parts(); ++t) Y.part(t)(j, i) = Y.part(t)(i, j);
      Y.entry_remainder(j, i) = Y.entry_remainder(i, j);
    }
  Y.remainder = entries_frobenius(Y.entry_remainder);
}

// Entry (i, j) is the exact zero as a form (Taylor::is_zero): no symbols, and its centre and remainder 0.
bool zero_entry(const TaylorMatrix& X, Eigen::Index i, Eigen::Index j) {
  return X.symbols() == 0 && X.centre()(i, j) == 0.0 && X.entry_remainder(i, j) == 0.0;
}

// Σ_t |X_t| entry by entry over the parts in their order (centre, slopes, curvatures), as a form sums its
// coefficients' moduli.
Eigen::MatrixXd coefficient_moduli(const TaylorMatrix& X) {
  Eigen::MatrixXd moduli = X.centre().cwiseAbs();
  for (int t = 1; t < X.parts(); ++t) moduli += X.part(t).cwiseAbs();
  return moduli;
}

// Entry (i, j) times S(i, j), as scale_into scales its form: by 0 and ±1 exactly, else each product within 2⁻⁵² of
// its modulus, in the entry's remainder.
void scale_entries(TaylorMatrix& X, const Eigen::MatrixXd& S) {
  const Eigen::MatrixXd moduli = coefficient_moduli(X);
  bool every_form = X.symbols() > 0;  // no entry is the exact zero, whose product is itself
  for (Eigen::Index j = 0; j < X.cols(); ++j)
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      const double s = S(i, j), as = std::abs(s);
      double& r = X.entry_remainder(i, j);
      if (s == 0.0) every_form = false;
      if (s == 1.0 || s == -1.0 || zero_entry(X, i, j)) continue;
      r = s == 0.0 ? 0.0 : up(as * r + kTaylorRoundoff * up(as * up(moduli(i, j)) * (1.0 + kTaylorRoundoff)));
    }
  if (every_form) {
    for (int t = 0; t < X.parts(); ++t) X.part(t).array() *= S.array();
  } else {
    for (Eigen::Index j = 0; j < X.cols(); ++j)
      for (Eigen::Index i = 0; i < X.rows(); ++i)
        if (!zero_entry(X, i, j) || S(i, j) == 0.0)
          for (int t = 0; t < X.parts(); ++t) X.part(t)(i, j) = S(i, j) == 0.0 ? 0.0 : S(i, j) * X.part(t)(i, j);
  }
  X.remainder = entries_frobenius(X.entry_remainder);
}

// X_ii + a, as add_into adds the constant's form: the centre's sum rounded within 2⁻⁵² of its modulus.
void add_to_diagonal(TaylorMatrix& X, double a) {
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    double& c = X.centre()(i, i);
    double& r = X.entry_remainder(i, i);
    if (zero_entry(X, i, i)) {
      c = a;  // exact: the constant
      continue;
    }
    c = c + a;
    r = up(r + kTaylorRoundoff * up(std::abs(c)));
  }
  X.remainder = entries_frobenius(X.entry_remainder);
}

// X - Y over the same symbols, as subtract_into subtracts each entry's forms: each coefficient's difference rounded
// within 2⁻⁵² of its modulus.
TaylorMatrix difference(const TaylorMatrix& X, const TaylorMatrix& Y) {
  if (X.symbols() != Y.symbols()) throw std::logic_error("difference: the Taylor matrices' symbols differ");
  TaylorMatrix Z = X;
  Z.parts(0, Z.parts()) -= Y.parts(0, Y.parts());
  const Eigen::MatrixXd moduli = coefficient_moduli(Z);
  for (Eigen::Index j = 0; j < X.cols(); ++j)
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      const double x = X.entry_remainder(i, j), y = Y.entry_remainder(i, j);
      // The exact zero's difference is the other form, exactly.
      Z.entry_remainder(i, j) = zero_entry(Y, i, j)   ? x
                                : zero_entry(X, i, j) ? y
                                                      : up(x + y + kTaylorRoundoff * up(moduli(i, j)));
    }
  Z.remainder = entries_frobenius(Z.entry_remainder);
  return Z;
}

// ||X(ε)||₂ over the box by the triangle inequality, term by term: ||C||₂ + Σ_k ||G_k||₂ + Σ_p ||H_p||_F + remainder.
// Where X's centre vanishes (E = K M Kᵀ - I below) norm_upper's top direction is the centre's and means nothing; this
// bound follows the slopes' own norms instead (arm7, a box of ±0.15 rad at L_joint's maximiser: ||E|| sampled 0.135,
// norm_upper 0.252, this 0.205; docs/theory.md, "M⁻¹ over a box"). The eigensolvers run in the default rounding; the
// few sums before the upward ones are within up()'s inflation.
double termwise_norm_upper(const TaylorMatrix& X, double centre) {
  double terms = centre;
  for (int k = 0; k < X.symbols(); ++k) terms += spectral_norm_upper(X.slope(k));
  const UpwardRounding upward;
  for (int p = 0; p < X.curvature_count(); ++p) terms += frobenius(X.curvature(p));
  return up(terms + X.remainder);
}

// ||X(ε)||₂ <= ||C||₂ + ||Σ_t μ_t P_t||_F + remainder, P_t the slopes and curvatures and μ_t their monomials, each in
// [-1, 1]: ||Σ_t μ_t P_t||_F² = μᵀ Γ μ <= Σ_{t,u} |Γ_tu|, Γ the parts' Gram matrix (gram_sum_upper, each part a
// column of its e entries). Where the parts point in different directions, as E's do over a
// box wide in many joints, this is near the root of the sum of their squares where the term-by-term bound adds them
// (the iiwa 14's worst open box at the end of the fifteenth round's search: ||E|| sampled 0.28, proven 0.58 term by
// term and 0.41 from the Gram matrix; docs/theory.md, "M⁻¹ over a box"). `centre`: ||C||₂, bounded above.
double gram_norm_upper(const TaylorMatrix& X, double centre) {
  const int parts = X.parts() - 1;
  Eigen::MatrixXd P(X.rows() * X.cols(), parts);
  for (int t = 0; t < parts; ++t) P.col(t) = X.part(t + 1).reshaped();
  double sizes = 0.0;
  {
    const UpwardRounding upward;
    for (int t = 0; t < parts; ++t) sizes += std::sqrt(P.col(t).squaredNorm());
  }
  const double variation = gram_sum_upper(P, sizes);
  const UpwardRounding upward;
  return up(centre + variation + X.remainder);
}

// A value termwise_norm_upper(X, ·) cannot go below: each slope's ||G_k||₂ is at least ||G_k||_F / √min(rows, cols) and
// its largest column's norm, and the rest is termwise's own sum (in the default rounding, which rounds no sum above the
// upward one, and shrunk by 1e-12 for the norms' own rounding).
double termwise_lower(const TaylorMatrix& X, double centre) {
  double terms = centre + X.remainder;
  const double root_rank = std::sqrt(static_cast<double>(std::min(X.rows(), X.cols())));
  for (int k = 0; k < X.symbols(); ++k)
    terms += std::max(X.slope(k).norm() / root_rank, X.slope(k).colwise().norm().maxCoeff());
  for (int p = 0; p < X.curvature_count(); ++p) terms += X.curvature(p).norm();
  return terms * (1.0 - 1e-12);
}

// The smaller of the two proven bounds of ||X(ε)||₂ over the box, for the zero-centred E and Kᵀ E (scaled). In default
// designs the Gram bound was the smaller in every one of about 130,000 calls on five six- and seven-joint arms and in
// all but 8 of arm6's 32,484 (by at most 6 %); the term-by-term bound won half of arm3's calls and almost every one on
// two joints (docs/history.md, the forty-second round). Its eigensolvers run only where a bound of its value from
// below does not already exceed the Gram bound: the smaller is then the same. norm_upper is not taken: on 6- and
// 7-joint arms it was never the smallest in the searches' first 20,000-46,000 calls (arm3: 14 of 3,401, by at most
// 13 %), and it cost a fine norm bound each (docs/theory.md, "M⁻¹ over a box").
double inverse_norm_upper(const TaylorMatrix& X) {
  const double centre = spectral_norm_upper(X.centre());  // in the default rounding, as its eigensolver expects
  const double gram = gram_norm_upper(X, centre);
  if (termwise_lower(X, centre) >= gram) return gram;
  return std::min(termwise_norm_upper(X, centre), gram);
}

}  // namespace

TaylorInverse inverse(const std::vector<Taylor>& M, int n, int symbols) {
  TaylorInverse result;
  const Eigen::MatrixXd K = inverse_cholesky_factor(M, n);
  if (K.size() == 0) return result;
  // Y = K M Kᵀ = K (K M)ᵀ (M symmetric) and M⁻¹ = Kᵀ Y⁻¹ K = c Kᵀ (I + E)⁻¹ K with E = c Y - I for any c > 0. c = 1
  // where ||Y - I|| < 1; on a box where Y varies more, c = 2 / (λ_lo + λ_hi) centres Y's proven spectrum [λ_lo, λ_hi] on
  // 1, and ||E|| < 1 wherever Y is proven positive definite (docs/theory.md, "M⁻¹ over a box").
  TaylorMatrix Y = left_multiply(K, transposed(left_multiply(K, taylor_matrix(M, n, n))));
  // Y is symmetric, and its forms Y_ij and Y_ji enclose the same function over the box, each formed by other sums: the
  // upper triangle's serve for both, so that E's coefficient matrices are symmetric and E² takes half the matrix
  // products (product_of's `square`).
  mirror_upper(Y);
  const auto shifted = [&](double c) {
    TaylorMatrix E = Y;
    if (c != 1.0) scale_entries(E, Eigen::MatrixXd::Constant(n, n, c));
    add_to_diagonal(E, -1.0);
    return E;
  };
  TaylorMatrix padded;
  double c = 1.0;
  TaylorMatrix E = shifted(c);
  double eta = inverse_norm_upper(over_symbols(E, symbols, padded));
  if (!(eta < 1.0)) {
    const double low = smallest_eigenvalue_lower(over_symbols(Y, symbols, padded));
    if (!(low > 0.0) || !std::isfinite(eta)) return result;
    c = 2.0 / (low + 1.0 + eta);  // λmax(Y) <= 1 + ||Y - I||
    E = shifted(c);
    eta = inverse_norm_upper(over_symbols(E, symbols, padded));
    if (!(eta < 1.0)) return result;
  }
  // c Kᵀ (I - E + E²) K.
  TaylorMatrix Z = difference(symmetric_square(E, CubicTerms::by_monomials), E);
  add_to_diagonal(Z, 1.0);
  const Eigen::MatrixXd Kt = K.transpose();
  result.entries = left_multiply(Kt, transposed(left_multiply(Kt, transposed(Z))));
  if (c != 1.0) scale_entries(result.entries, Eigen::MatrixXd::Constant(n, n, c));
  // c Kᵀ E³ (I + E)⁻¹ K = c (E K)ᵀ · E (I + E)⁻¹ · (E K), and ||E (I + E)⁻¹|| <= η / (1 - η) for the symmetric E: the
  // tail is c ||E K||² η / (1 - η), which sees that E K is small where M varies only in its heavy directions
  // (||E K|| <= η ||K||). ||E K|| = ||(E K)ᵀ|| = ||Kᵀ E|| for the symmetric E that every member of the forms is.
  result.KtE = left_multiply(Kt, E);
  const double EK_norm = inverse_norm_upper(over_symbols(result.KtE, symbols, padded));
  const UpwardRounding upward;
  const Interval e(eta);
  result.tail = (Interval(c) * Interval(EK_norm) * Interval(EK_norm) * e / (Interval(1.0) - e)).upper();
  result.tail_factor = (Interval(c) * e / (Interval(1.0) - e)).upper();
  result.proven = true;
  return result;
}

void scale_diagonally(TaylorMatrix& X, const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  scale_entries(X, a.rowwise().replicate(X.cols()));
  scale_entries(X, b.transpose().colwise().replicate(X.rows()));
}

TaylorMatrix gathered_columns(const std::vector<std::pair<const TaylorMatrix*, int>>& columns) {
  const TaylorMatrix& first = *columns.front().first;
  TaylorMatrix Y;
  Y.shape(first.rows(), static_cast<Eigen::Index>(columns.size()), first.symbols());
  Y.entry_remainder.resize(Y.rows(), Y.cols());
  const Eigen::Index rows = Y.rows();
  for (std::size_t k = 0; k < columns.size();) {
    const auto& [X, column] = columns[k];
    if (X->rows() != rows || X->symbols() != Y.symbols())
      throw std::logic_error("gathered_columns: the Taylor matrices' heights or symbols differ");
    // Neighbouring columns of one matrix are copied as one block, part by part.
    std::size_t run = 1;
    const auto continues = [&](std::size_t r) {
      return columns[k + r].first == X && columns[k + r].second == column + static_cast<int>(r);
    };
    while (k + run < columns.size() && continues(run)) ++run;
    const auto count = static_cast<Eigen::Index>(run), to = static_cast<Eigen::Index>(k);
    for (int t = 0; t < Y.parts(); ++t)
      std::copy_n(X->part(t).data() + column * rows, count * rows, Y.part(t).data() + to * rows);
    Y.entry_remainder.middleCols(to, count) = X->entry_remainder.middleCols(column, count);
    k += run;
  }
  Y.remainder = entries_frobenius(Y.entry_remainder);
  return Y;
}

double tail_upper(const TaylorInverse& inverse, const Eigen::VectorXd& a, const Eigen::VectorXd& b, int symbols) {
  TaylorMatrix padded;
  const auto norm = [&](const Eigen::VectorXd& d) {
    TaylorMatrix X = inverse.KtE;
    scale_entries(X, d.rowwise().replicate(X.cols()));  // diag(d) Kᵀ E
    return inverse_norm_upper(over_symbols(X, symbols, padded));
  };
  const double Ka = norm(a), Kb = norm(b);
  const UpwardRounding upward;
  return (Interval(inverse.tail_factor) * Interval(Ka) * Interval(Kb)).upper();
}

}  // namespace obsgain
