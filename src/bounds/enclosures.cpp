#include "obsgain/bounds/enclosures.hpp"

#include "obsgain/model/dynamics.hpp"

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

}  // namespace

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
