// A proven polytope of the perturbation's matrix. With δ = σ(v̂) − σ(v) = D e_v, D diagonal in [0, 1]ⁿ, and
// w = (σ(v̂) + σ(v)) / 2 in the velocity box, the error's perturbation is φ = Φ e_v with
// Φ(q, w, D) = −M(q)⁻¹ (J(q, w) D + F) (docs/theory.md, "The polytopic certificate"). Over one cell of the joint
// domain, every such Φ lies in conv(vertices) + Δ with |Δ_ij| <= radius(i, j): Φ is bilinear in (w, D), so at a
// fixed q its values lie in the hull of the 4ⁿ corners; the variation with q inside the cell, M⁻¹'s tail and
// the rounding are the entrywise radius. Cells merge into one, and corners into an entrywise box, above the joint
// counts PolytopeOptions names.
#pragma once

#include "obsgain/model/model.hpp"
#include "obsgain/numerics/interval.hpp"

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace obsgain {

// Every Φ over the cell is point(w, D) + Δ for some w in the velocity box, D in [0, 1]ⁿ and |Δ| <= radius, with
// point(w, D) = constant + Σ_j w_j slopes[j] D: bilinear, so it lies in the hull of its values at the corners,
// which are the vertices.
struct PolytopeCell {
  Eigen::MatrixXd constant;
  std::vector<Eigen::MatrixXd> slopes;  // empty for an entrywise box: point(w, D) = constant
  std::vector<Eigen::MatrixXd> vertices;
  Eigen::MatrixXd radius;  // entrywise, rounded up
  bool proven = false;     // false: M could not be proven invertible over the cell (too wide)
  std::vector<Interval> box;  // of the searched joints (PerturbationPolytope::joints); the whole domain if merged

  Eigen::MatrixXd point(const Eigen::VectorXd& w, const Eigen::VectorXd& D) const;
};

struct PolytopeOptions {
  int cells = 32;  // cells covering the searched joints (a grid, the same count along each)
  // Up to this many joints each cell keeps its own vertices; above, the cells merge into one (the SDP's size grows
  // with the vertices, not with the cells the bounds need).
  int separate_cells_up_to_dof = 2;
  // Up to this many joints the 4ⁿ corners in (w, D) are vertices; above, a cell is one entrywise box.
  int corners_up_to_dof = 4;
  int threads = 0;  // 0: all cores (the result does not depend on it)
};

struct PerturbationPolytope {
  int dof = 0;
  std::vector<PolytopeCell> cells;
  std::string unproven;  // why not every cell is proven, or empty
  int grid = 0;          // cells along each searched joint
  std::vector<int> joints;  // the searched joints: Φ depends on no other

  bool proven() const { return unproven.empty() && !cells.empty(); }
  int vertex_count() const;
};

PerturbationPolytope perturbation_polytope(const Model& model, const Eigen::VectorXd& velocity_bounds,
                                           const PolytopeOptions& options = {});

// The rounding of point(w, D) computed in double, entrywise: a sum of n + 1 products of at most
// Σ_j V_j |slopes[j]| + |constant|, each rounded with relative error (n + 2) u at most, doubled for directed rounding.
Eigen::MatrixXd point_rounding(const PolytopeCell& cell, const Eigen::VectorXd& velocity_bounds);

// Φ(q, w, D) in double: what the polytope must contain (tests, and the sampled studies of docs/theory.md).
Eigen::MatrixXd perturbation_matrix(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& w,
                                    const Eigen::VectorXd& D);

}  // namespace obsgain
