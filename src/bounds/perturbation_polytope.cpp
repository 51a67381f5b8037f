#include "obsgain/bounds/perturbation_polytope.hpp"

#include "obsgain/bounds/box_bounds.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/parallel.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

namespace obsgain {

Eigen::MatrixXd PolytopeCell::point(const Eigen::VectorXd& w, const Eigen::VectorXd& D) const {
  Eigen::MatrixXd Phi = constant;
  for (std::size_t j = 0; j < slopes.size(); ++j) Phi.noalias() += w(static_cast<Eigen::Index>(j)) * slopes[j] * D.asDiagonal();
  return Phi;
}

Eigen::MatrixXd point_rounding(const PolytopeCell& cell, const Eigen::VectorXd& velocity_bounds) {
  const UpwardRounding upward;
  Eigen::MatrixXd magnitude = cell.constant.cwiseAbs();
  for (std::size_t j = 0; j < cell.slopes.size(); ++j)
    magnitude += velocity_bounds(static_cast<Eigen::Index>(j)) * cell.slopes[j].cwiseAbs();
  const double n = static_cast<double>(cell.constant.rows());
  return 2.0 * (n + 3.0) * std::numeric_limits<double>::epsilon() * magnitude;
}

int PerturbationPolytope::vertex_count() const {
  int count = 0;
  for (const PolytopeCell& cell : cells) count += static_cast<int>(cell.vertices.size());
  return count;
}

Eigen::MatrixXd perturbation_matrix(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& w,
                                    const Eigen::VectorXd& D) {
  const int n = model.dof();
  Eigen::MatrixXd M(n, n);
  mass_matrix(model, q, M);
  std::vector<Eigen::MatrixXd> N;
  coriolis_tensors(model, q, N);
  const Eigen::MatrixXd JD = coriolis_jacobian(N, w) * D.asDiagonal();
  return -M.llt().solve(JD + model.friction);
}

namespace {

// Cell `index` of a grid with `grid` cells along each searched joint.
std::vector<Interval> grid_cell(const JointSearch& s, int grid, int index) {
  std::vector<Interval> box;
  for (const Interval& side : s.domain) {
    const int k = index % grid;
    index /= grid;
    const double width = (side.upper() - side.lower()) / grid;
    const double lo = k == 0 ? side.lower() : side.lower() + k * width;
    const double hi = k == grid - 1 ? side.upper() : side.lower() + (k + 1) * width;
    box.emplace_back(lo, hi);  // neighbours share their end points: the cells cover the domain
  }
  return box;
}

// The cell's point(w, D) at every corner (w, D), each once.
std::vector<Eigen::MatrixXd> corners(const PolytopeCell& cell, const Eigen::VectorXd& velocity_bounds) {
  const auto n = cell.constant.rows();
  std::vector<Eigen::MatrixXd> vertices;
  for (unsigned bits = 0; bits < (1u << n); ++bits) {
    Eigen::VectorXd D(n);
    for (Eigen::Index j = 0; j < n; ++j) D(j) = (bits >> j) & 1u;
    for (unsigned signs = 0; signs < (1u << n); ++signs) {
      Eigen::VectorXd w = velocity_bounds;
      for (Eigen::Index j = 0; j < n; ++j) w(j) = (signs >> j) & 1u ? -w(j) : w(j);
      Eigen::MatrixXd Phi = cell.point(w, D);  // with D = 0 every w gives the same: only distinct ones are kept
      if (std::find(vertices.begin(), vertices.end(), Phi) == vertices.end()) vertices.push_back(std::move(Phi));
    }
  }
  return vertices;
}

// The cell as one entrywise box: |Σ_j w_j slopes[j] D| <= Σ_j V_j |slopes[j]| joins the radius.
PolytopeCell entrywise_box(PolytopeCell cell, const Eigen::VectorXd& velocity_bounds) {
  const UpwardRounding upward;
  for (std::size_t j = 0; j < cell.slopes.size(); ++j)
    cell.radius += velocity_bounds(static_cast<Eigen::Index>(j)) * cell.slopes[j].cwiseAbs();
  cell.slopes.clear();
  cell.vertices = {cell.constant};
  return cell;
}

// Centre of the hull of one term over the cells (entrywise), and each cell's distance from it (rounded up).
Eigen::MatrixXd hull_centre(const std::vector<PolytopeCell>& cells, const std::function<const Eigen::MatrixXd&(const PolytopeCell&)>& term) {
  Eigen::MatrixXd lower = term(cells[0]), upper = lower;
  for (const PolytopeCell& cell : cells) {
    lower = lower.cwiseMin(term(cell));
    upper = upper.cwiseMax(term(cell));
  }
  return 0.5 * lower + 0.5 * upper;
}

// One cell holding every cell: the hull's centre of each term, and a radius that covers each cell's deviation
// from it, |Δconstant| + Σ_j V_j |Δslopes[j]|, on top of its own radius (D <= 1), rounded up.
PolytopeCell merged(const std::vector<PolytopeCell>& cells, const Eigen::VectorXd& velocity_bounds,
                    const std::vector<Interval>& domain) {
  PolytopeCell hull;
  hull.constant = hull_centre(cells, [](const PolytopeCell& c) -> const Eigen::MatrixXd& { return c.constant; });
  for (std::size_t j = 0; j < cells[0].slopes.size(); ++j)
    hull.slopes.push_back(hull_centre(cells, [j](const PolytopeCell& c) -> const Eigen::MatrixXd& { return c.slopes[j]; }));
  const UpwardRounding upward;
  hull.radius = Eigen::MatrixXd::Zero(hull.constant.rows(), hull.constant.cols());
  for (const PolytopeCell& cell : cells) {
    // |a - b| rounded up: the larger of the two upward differences.
    const auto distance = [](const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).cwiseMax(b - a); };
    Eigen::MatrixXd radius = cell.radius + distance(cell.constant, hull.constant);
    for (std::size_t j = 0; j < hull.slopes.size(); ++j)
      radius += velocity_bounds(static_cast<Eigen::Index>(j)) * distance(cell.slopes[j], hull.slopes[j]);
    hull.radius = hull.radius.cwiseMax(radius);
  }
  hull.radius += point_rounding(hull, velocity_bounds);
  hull.proven = true;
  hull.box = domain;
  return hull;
}

}  // namespace

PerturbationPolytope perturbation_polytope(const Model& model, const Eigen::VectorXd& velocity_bounds,
                                           const PolytopeOptions& options) {
  PerturbationPolytope polytope;
  polytope.dof = model.dof();
  const JointSearch s = joint_search(model, configuration_joints(model));
  polytope.joints = s.joints;
  const BoxBounds boxes(model, s, velocity_bounds);
  const int m = static_cast<int>(s.joints.size());
  polytope.grid = m == 0 ? 1 : std::max(1, static_cast<int>(std::floor(std::pow(options.cells, 1.0 / m) + 1e-9)));
  const int count = static_cast<int>(std::lround(std::pow(polytope.grid, m)));
  std::vector<PolytopeCell> cells(static_cast<std::size_t>(count));
  ParallelFor pool(options.threads);
  pool.run(count, [&](int i) { cells[i] = boxes.perturbation_cell(grid_cell(s, polytope.grid, i)); });
  for (int i = 0; i < count; ++i)
    if (!cells[i].proven) {
      polytope.unproven = fmt::format("M is not proven invertible over a cell of the {}-cell grid (more cells would help)", count);
      return polytope;
    }
  if (model.dof() > options.separate_cells_up_to_dof) cells = {merged(cells, velocity_bounds, s.domain)};
  for (PolytopeCell& cell : cells)
    if (model.dof() <= options.corners_up_to_dof) cell.vertices = corners(cell, velocity_bounds);
    else cell = entrywise_box(std::move(cell), velocity_bounds);
  polytope.cells = std::move(cells);
  return polytope;
}

}  // namespace obsgain
