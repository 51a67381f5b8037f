#include "obsgain/bounds/enclosures.hpp"

#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/spectrum.hpp"

#include <algorithm>

namespace obsgain {

namespace {

int directions(const std::vector<DualInterval>& q) {
  int d = 0;
  for (const DualInterval& x : q) d = std::max(d, x.directions);
  return d;
}

// Splits row-major duals into value and derivative enclosures.
MatrixEnclosure split(const std::vector<DualInterval>& flat, int rows, int cols, int count) {
  MatrixEnclosure e;
  e.value.resize(rows, cols);
  e.derivative.assign(static_cast<std::size_t>(count), IntervalMatrix(rows, cols));
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) {
      const DualInterval& x = flat[static_cast<std::size_t>(i * cols + j)];
      e.value(i, j) = x.value;
      for (int k = 0; k < count; ++k) e.derivative[k](i, j) = x.derivative[k];
    }
  return e;
}

using boost::numeric::square;

// The interval matrix as its midpoint (exact doubles) and the Frobenius norm of its radius, rounded up.
struct MidRadius {
  Eigen::MatrixXd mid;
  double radius = 0.0;
};

MidRadius mid_radius(const IntervalMatrix& X) {
  MidRadius m{Eigen::MatrixXd(X.rows(), X.cols()), 0.0};
  const UpwardRounding upward;
  Interval radius2(0.0);
  for (Eigen::Index i = 0; i < X.size(); ++i) {
    m.mid(i) = centre(X(i));
    radius2 += square(Interval(std::max(X(i).upper() - m.mid(i), m.mid(i) - X(i).lower())));
  }
  m.radius = boost::numeric::sqrt(radius2).upper();
  return m;
}

}  // namespace

// Weyl: ||X|| <= ||mid X|| + ||rad X||_F for every X in the interval matrix; for 2 x 2 also the closed form of
// λmax(XᵀX) = (p + r)/2 + sqrt(((p - r)/2)² + s²) with XᵀX = [[p, s], [s, r]] (it wins on wide boxes).
double norm_upper_bound(const IntervalMatrix& X) {
  const MidRadius m = mid_radius(X);
  const UpwardRounding upward;
  double bound = (Interval(spectral_norm_upper(m.mid)) + Interval(m.radius)).upper();
  if (X.rows() == 2 && X.cols() == 2) {
    const Interval p = square(X(0, 0)) + square(X(1, 0)), r = square(X(0, 1)) + square(X(1, 1));
    const Interval s = X(0, 0) * X(0, 1) + X(1, 0) * X(1, 1);
    const Interval lambda = (p + r) / 2.0 + boost::numeric::sqrt(square((p - r) / 2.0) + square(s));
    bound = std::min(bound, boost::numeric::sqrt(lambda).upper());
  }
  return bound;
}

// Weyl: λmin(M) >= λmin(mid M) - ||rad M||_F; for 2 x 2 the closed form.
double smallest_eigenvalue_lower_bound(const IntervalMatrix& M) {
  const UpwardRounding upward;
  if (M.rows() == 2) {
    const Interval a = M(0, 0), b = M(0, 1), c = M(1, 1);
    return ((a + c) / 2.0 - boost::numeric::sqrt(square((a - c) / 2.0) + square(b))).lower();
  }
  const MidRadius m = mid_radius(M);
  return (Interval(smallest_eigenvalue_lower(0.5 * (m.mid + m.mid.transpose()))) - Interval(m.radius)).lower();
}

MatrixEnclosure mass_matrix_enclosure(const Model& model, const std::vector<DualInterval>& q) {
  const int n = model.dof();
  std::vector<DualInterval> flat(static_cast<std::size_t>(n * n));
  mass_matrix_of(model, q.data(), flat.data());
  return split(flat, n, n, directions(q));
}

std::vector<MatrixEnclosure> coriolis_tensor_enclosures(const Model& model, const std::vector<DualInterval>& q) {
  const int n = model.dof();
  std::vector<DualInterval> flat(static_cast<std::size_t>(n * n * n));
  coriolis_tensors_of(model, q.data(), flat.data());
  std::vector<MatrixEnclosure> N;
  for (int i = 0; i < n; ++i)
    N.push_back(split(std::vector<DualInterval>(flat.begin() + i * n * n, flat.begin() + (i + 1) * n * n), n, n,
                      directions(q)));
  return N;
}

MatrixEnclosure gravity_enclosure(const Model& model, const std::vector<DualInterval>& q) {
  const int n = model.dof();
  std::vector<DualInterval> flat(static_cast<std::size_t>(n));
  gravity_of(model, q.data(), flat.data());
  return split(flat, n, 1, directions(q));
}

}  // namespace obsgain
