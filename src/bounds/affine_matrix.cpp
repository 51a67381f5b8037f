#include "obsgain/bounds/affine_matrix.hpp"

#include "obsgain/numerics/interval.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace obsgain {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Rounding of a double dot product of length n (or of a matrix product's entries): at most γ_n Σ|x_i||y_i|.
double gamma(int n) { return (n + 2) * kRoundoff * 1.01; }

// An upper bound of a non-negative quantity computed in floating point by a short sequence of operations.
double up(double x) { return x * kAffineInflation + kUnderflow; }

double frobenius(const Eigen::MatrixXd& X) { return up(std::sqrt(up(X.squaredNorm()))); }

// ||X Y - fl(X Y)||_F for a product computed in double.
double product_rounding(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y) {
  return up(gamma(static_cast<int>(X.cols())) * frobenius(X.cwiseAbs() * Y.cwiseAbs()));
}

}  // namespace

double AffineMatrix::frobenius_upper() const {
  double bound = frobenius(centre) + remainder;
  for (const auto& G : slopes) bound += frobenius(G);
  return up(bound);
}

double every_choice_upper(const std::vector<AffineMatrix>& X, const Eigen::VectorXd& V, const AffineMatrix& R) {
  const auto moduli = [](const AffineMatrix& Y) {
    Eigen::MatrixXd E = Y.centre.cwiseAbs();
    for (const auto& G : Y.slopes) E += G.cwiseAbs();
    return E;
  };
  Eigen::MatrixXd E = moduli(R);
  double remainders = R.remainder;
  for (std::size_t j = 0; j < X.size(); ++j) {
    const double v = std::abs(V(static_cast<Eigen::Index>(j)));
    E += v * moduli(X[j]);
    remainders += v * X[j].remainder;
  }
  // Sums of non-negative terms: their rounding is relative, covered by up() (gamma for the longest sum).
  return up(up(frobenius(E) * (1.0 + gamma(static_cast<int>(X.size() * (R.slopes.size() + 2))))) + up(remainders));
}

AffineMatrix affine_matrix(const Affine* entries, int rows, int cols, int symbols) {
  AffineMatrix X;
  X.centre.resize(rows, cols);
  X.slopes.assign(static_cast<std::size_t>(symbols), Eigen::MatrixXd(rows, cols));
  X.entry_remainder.resize(rows, cols);
  double squares = 0.0;
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) {
      const Affine& x = entries[i * cols + j];
      X.centre(i, j) = x.c;
      for (int k = 0; k < symbols; ++k) X.slopes[k](i, j) = x.a[k];
      X.entry_remainder(i, j) = x.r;
      squares += x.r * x.r;
    }
  X.remainder = up(std::sqrt(up(squares)));
  return X;
}

AffineMatrix linear_combination(const std::vector<AffineMatrix>& terms, const Eigen::VectorXd& weights) {
  AffineMatrix X;
  X.centre = Eigen::MatrixXd::Zero(terms[0].centre.rows(), terms[0].centre.cols());
  X.slopes.assign(terms[0].slopes.size(), X.centre);
  double rounding = 0.0;  // Σ_j |w_j| ||X_j||_F, times γ: the rounding of every entry's sum
  for (std::size_t j = 0; j < terms.size(); ++j) {
    const double w = weights(static_cast<Eigen::Index>(j));
    if (w == 0.0) continue;
    X.centre += w * terms[j].centre;
    for (std::size_t k = 0; k < X.slopes.size(); ++k) X.slopes[k] += w * terms[j].slopes[k];
    X.remainder += std::abs(w) * terms[j].remainder;
    rounding += std::abs(w) * terms[j].frobenius_upper();
  }
  X.remainder = up(X.remainder + gamma(static_cast<int>(terms.size())) * rounding);
  return X;
}

AffineMatrix scale_columns(const AffineMatrix& X, const Eigen::VectorXd& d) {
  AffineMatrix Y = X;
  Y.centre = X.centre * d.asDiagonal();
  for (auto& G : Y.slopes) G = G * d.asDiagonal();
  Y.remainder = up(X.remainder * d.cwiseAbs().maxCoeff() + kRoundoff * Y.frobenius_upper());
  Y.entry_remainder.resize(0, 0);  // known as a norm only from here
  return Y;
}

AffineMatrix sum(const AffineMatrix& X, const AffineMatrix& Y) {
  AffineMatrix Z;
  Z.centre = X.centre + Y.centre;
  for (std::size_t k = 0; k < X.slopes.size(); ++k) Z.slopes.push_back(X.slopes[k] + Y.slopes[k]);
  Z.remainder = up(X.remainder + Y.remainder + kRoundoff * (X.frobenius_upper() + Y.frobenius_upper()));
  return Z;
}

namespace {

// The Gram matrix of X_lin(ε) V = Ĉ + Σ_k ĝ_k ε_k, entry by entry: |Ĝ_ij(ε)| <= bound(i, j) over the box (for i = j
// an upper bound of Ĝ_ii itself). Ĝ_ij = c_i·c_j + Σ_k (c_i·g_jk + g_ik·c_j) ε_k + (Σ_k g_ik ε_k)·(Σ_k g_jk ε_k).
Eigen::MatrixXd gram_bounds(const Eigen::MatrixXd& C, const std::vector<Eigen::MatrixXd>& G) {
  const auto n = C.cols();
  const int rows = static_cast<int>(C.rows());
  const Eigen::MatrixXd P = C.transpose() * C, Pabs = C.cwiseAbs().transpose() * C.cwiseAbs();
  Eigen::MatrixXd first = Eigen::MatrixXd::Zero(n, n), first_abs = first;
  Eigen::VectorXd spread = Eigen::VectorXd::Zero(n);  // Σ_k ||g_ik||
  for (const auto& g : G) {
    const Eigen::MatrixXd Q = C.transpose() * g;  // Q(i, j) = c_i·g_jk
    first += (Q + Q.transpose()).cwiseAbs();
    first_abs += C.cwiseAbs().transpose() * g.cwiseAbs();
    spread += g.colwise().norm().transpose();
  }
  const Eigen::MatrixXd rounding = gamma(rows) * (Pabs + 2.0 * (first_abs + first_abs.transpose()));
  Eigen::MatrixXd bound = P.cwiseAbs() + first + spread * spread.transpose() + rounding;
  return bound.unaryExpr([](double x) { return up(x * (1.0 + 1e-12)); });  // the spread's norms, rounded
}

}  // namespace

// λmax of Ĝ(ε) from the top direction e1 (the leading right singular vector of the centre): for any unit z,
// λmax <= the largest eigenvalue of [[a, b], [b, c]] with a = zᵀĜz, b = ||(I - zzᵀ)Ĝz||, c = λmax of Ĝ on z⊥
// (docs/theory.md); here a, b and c from the entry bounds, c by Gershgorin. The excess is b²/(a - c): second order.
double norm_upper(const AffineMatrix& X, double floor) {
  const double cheap = X.frobenius_upper();
  if (cheap <= floor || !std::isfinite(cheap)) return cheap;
  const int n = static_cast<int>(X.centre.cols());
  // A basis from the centre's Gram matrix, leading direction first; its non-orthogonality δ is bounded.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(X.centre.transpose() * X.centre);
  const Eigen::MatrixXd V = eigen.eigenvectors().rowwise().reverse();
  const Eigen::MatrixXd W = V.transpose() * V - Eigen::MatrixXd::Identity(n, n);
  const double delta = up(frobenius(W) + product_rounding(V.transpose(), V));
  if (!(delta < 0.5)) return cheap;
  const Eigen::MatrixXd C = X.centre * V;
  double rho = product_rounding(X.centre, V);  // what the products below lose to rounding, as a perturbation
  std::vector<Eigen::MatrixXd> G;
  for (const auto& slope : X.slopes) {
    G.push_back(slope * V);
    rho += product_rounding(slope, V);
  }
  const Eigen::MatrixXd bound = gram_bounds(C, G);
  const Interval a(bound(0, 0));
  Interval b2(0.0), c(0.0);
  for (int i = 1; i < n; ++i) {
    b2 += boost::numeric::square(Interval(bound(i, 0)));
    Interval row(bound(i, i));
    for (int j = 1; j < n; ++j)
      if (j != i) row += Interval(bound(i, j));
    c = Interval(std::max(c.upper(), row.upper()));
  }
  using boost::numeric::sqrt;
  const Interval lambda = (a + c) / 2.0 + sqrt(boost::numeric::square((a - c) / 2.0) + b2);
  const Interval sigma = (sqrt(lambda) + Interval(rho)) / sqrt(Interval(1.0) - Interval(delta)) + Interval(X.remainder);
  return std::min(cheap, sigma.upper());
}

double smallest_eigenvalue_lower(const AffineMatrix& X) {
  const int n = static_cast<int>(X.centre.cols());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(0.5 * (X.centre + X.centre.transpose()));
  const Eigen::MatrixXd& V = eigen.eigenvectors();  // smallest first
  const Eigen::MatrixXd W = V.transpose() * V - Eigen::MatrixXd::Identity(n, n);
  const double delta = up(frobenius(W) + product_rounding(V.transpose(), V));
  if (!(delta < 0.5)) return -kInfinity;
  // T(ε) = Vᵀ X_lin(ε) V: centre and slopes, with the products' rounding as a perturbation of norm <= rho.
  const Eigen::MatrixXd T = V.transpose() * X.centre * V;
  double rho = up(product_rounding(V.transpose(), X.centre) * frobenius(V) + product_rounding(V.transpose() * X.centre, V));
  Eigen::MatrixXd spread = Eigen::MatrixXd::Zero(n, n);  // Σ_k |T_k(i, j)|
  for (const auto& slope : X.slopes) {
    spread += (V.transpose() * slope * V).cwiseAbs();
    rho += up(product_rounding(V.transpose(), slope) * frobenius(V) + product_rounding(V.transpose() * slope, V));
  }
  // The remainder in the same basis, entry by entry where its entries are known: |VᵀΔV| <= |V|ᵀ|Δ||V| (rounded up).
  const bool by_entry = X.entry_remainder.size() == X.centre.size();
  if (by_entry) spread += (V.cwiseAbs().transpose() * X.entry_remainder * V.cwiseAbs()).unaryExpr([&](double x) {
      return up(x * (1.0 + gamma(2 * n)));
    });
  const Eigen::MatrixXd magnitude = T.cwiseAbs() + spread;  // |T_ij(ε)| <= magnitude(i, j)
  const Interval a = Interval(T(0, 0)) - Interval(spread(0, 0));
  Interval b2(0.0), c(kInfinity);
  for (int i = 1; i < n; ++i) {
    b2 += boost::numeric::square(Interval(magnitude(i, 0)));
    Interval row = Interval(T(i, i)) - Interval(spread(i, i));
    for (int j = 1; j < n; ++j)
      if (j != i) row -= Interval(magnitude(i, j));
    c = Interval(std::min(c.lower(), row.lower()));
  }
  using boost::numeric::sqrt;
  const Interval lambda = (n == 1 ? a : (a + c) / 2.0 - sqrt(boost::numeric::square((c - a) / 2.0) + b2)) - Interval(rho);
  const double scale = lambda.lower() >= 0.0 ? (Interval(1.0) / (Interval(1.0) + Interval(delta))).lower()
                                             : (Interval(1.0) / (Interval(1.0) - Interval(delta))).upper();
  return (Interval(lambda.lower()) * Interval(scale) - Interval(by_entry ? 0.0 : X.remainder)).lower();
}

std::vector<Affine> product(const std::vector<Affine>& A, const std::vector<Affine>& B, int rows, int inner, int cols) {
  std::vector<Affine> C(static_cast<std::size_t>(rows * cols));
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) {
      Affine sum;
      for (int k = 0; k < inner; ++k) sum += A[i * inner + k] * B[k * cols + j];
      C[i * cols + j] = sum;
    }
  return C;
}

double frobenius_upper(const std::vector<Affine>& X) {
  double squares = 0.0;
  for (const Affine& x : X) {
    const double magnitude = up(std::abs(x.c) + x.radius());
    squares += magnitude * magnitude;
  }
  return up(std::sqrt(up(squares)));
}

namespace {

// K ≈ L⁻¹ with M's centre = L Lᵀ; empty when the centre is not positive definite.
Eigen::MatrixXd inverse_cholesky_factor(const std::vector<Affine>& M, int n) {
  Eigen::MatrixXd centre(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) centre(i, j) = 0.5 * (M[i * n + j].c + M[j * n + i].c);
  const Eigen::LLT<Eigen::MatrixXd> llt(centre);
  if (llt.info() != Eigen::Success) return {};
  const Eigen::MatrixXd L = llt.matrixL();
  return L.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(n, n));
}

// K X (K a double matrix) as forms.
std::vector<Affine> left_multiply(const Eigen::MatrixXd& K, const std::vector<Affine>& X, int n) {
  std::vector<Affine> Y(static_cast<std::size_t>(K.rows() * n));
  for (Eigen::Index i = 0; i < K.rows(); ++i)
    for (int j = 0; j < n; ++j) {
      Affine sum;
      for (Eigen::Index k = 0; k < K.cols(); ++k)
        if (K(i, k) != 0.0) sum += K(i, k) * X[k * n + j];
      Y[i * n + j] = sum;
    }
  return Y;
}

std::vector<Affine> transpose(const std::vector<Affine>& X, int n) {
  std::vector<Affine> Y(X.size());
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) Y[j * n + i] = X[i * n + j];
  return Y;
}

}  // namespace

AffineInverse inverse(const std::vector<Affine>& M, int n) {
  AffineInverse result;
  const Eigen::MatrixXd K = inverse_cholesky_factor(M, n);
  if (K.size() == 0) return result;
  // Y = K M Kᵀ = K (K M)ᵀ (M symmetric), E = Y - I.
  std::vector<Affine> E = left_multiply(K, transpose(left_multiply(K, M, n), n), n);
  for (int i = 0; i < n; ++i) E[i * n + i] = E[i * n + i] - 1.0;
  const double eta = frobenius_upper(E);
  if (!(eta < 1.0)) return result;
  // Kᵀ (I - E) K.
  std::vector<Affine> Z(E.size());
  for (std::size_t i = 0; i < E.size(); ++i) Z[i] = -E[i];
  for (int i = 0; i < n; ++i) Z[i * n + i] = Z[i * n + i] + 1.0;
  const Eigen::MatrixXd Kt = K.transpose();
  result.entries = left_multiply(Kt, transpose(left_multiply(Kt, transpose(Z, n), n), n), n);
  const double K_norm = spectral_norm_upper(K);
  const UpwardRounding upward;
  result.tail = (Interval(K_norm) * Interval(K_norm) * Interval(eta) * Interval(eta) / (Interval(1.0) - Interval(eta))).upper();
  result.proven = true;
  return result;
}

}  // namespace obsgain
