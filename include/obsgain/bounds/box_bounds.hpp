// What the branch and bound asks of one box of the searched joints: proven upper bounds of M0 = sup ||M⁻¹||,
// B = sup ||J(q, w)|| and L_joint = sup ||M⁻¹(J(q, w) D + F)|| over the box (w over the velocity box's vertices, D
// over the saturation patterns), from the model's dynamics on second-order Taylor forms; and how much splitting
// each side would tighten them.
#pragma once

#include "obsgain/bounds/branch_and_bound.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/bounds/perturbation_polytope.hpp"
#include "obsgain/bounds/taylor_matrix.hpp"
#include "obsgain/model/model.hpp"

#include <Eigen/Dense>

#include <optional>
#include <utility>
#include <vector>

namespace obsgain {

// What the work on one box costs, counted rather than timed so that a budget of work stops every run at the same
// box: seconds of wall time on the reference machine (two cores like the suite's), fitted to timings of each step
// on n joints whose forms carry `symbols` symbols, of the model as CountedModel sees it (docs/theory.md, "The budget").
struct BoxCosts {
  double inertia;     // M over the box as Taylor forms, and its derivatives on intervals
  double forms;       // M with its derivatives and the Christoffel tensors, as forms
  double products;    // M⁻¹ and the products M⁻¹J_j
  double failed_inverse;  // M⁻¹ attempted on a box too wide for it
  double vertex;      // one velocity vertex's A(w) and its envelope (`symbols` then counts the velocity's too)
  double refinement;  // one fine norm or eigenvalue bound of an n x n form
  double gram;        // one norm bound of an n x n form from its parts' Gram matrix (M⁻¹'s series takes two)
  double choice;      // one pattern's cheap bound, or a centre's Cholesky test
  // Where the choices are enumerated (choices_upper), timed apart from the rest of a box (docs/theory.md, "The budget"):
  double vertex_test;        // a velocity vertex's centre test, with its variation's norm
  double vertex_refinement;  // a velocity vertex's fine norm bound (its envelope's, with friction)
  double pattern;            // one saturation pattern's cheap bound or centre test, where they are taken one by one
  double pattern_refinement;  // one saturation pattern's fine norm bound
  double point;       // the value attained at a point (every vertex and pattern, in double)
  double jacobian_vertex;  // one vertex's J(w) = Σ_j w_j J_j and its cheap bound (B's search)
  double inertia_route;    // the cheap bounds of J(w) at every vertex at once (the inertia floor's route)
};

// What the count sees of a model besides its joints and the forms' symbols.
struct CountedModel {
  bool frictionless = false;  // F = 0: half of the velocity vertices are taken (BoxBounds below)
  // The share of the bodies' centre-of-mass coordinates (in their joints' frames) that are not zero: every product
  // by a zero is skipped in the forms, and a centre on the joint's axis leaves most of them zero.
  double centre_offsets = 0.0;
};
CountedModel counted_model(const Model& model);
BoxCosts box_costs(int n, int symbols, const CountedModel& model);

// A similarity T for L_T = sup ||T Φ T⁻¹|| (docs/theory.md, "Similarity scaling"). The forms are scaled to T X Y,
// Y ≈ T⁻¹ computed in double (each product's rounding bounded by the forms), and
// ||T X T⁻¹|| = ||T X Y · (T Y)⁻¹|| <= ||T X Y|| · restore. A diagonal T = diag(t) scales the forms entry by entry,
// Y = diag(s) with s_k = 1/t_k rounded.
struct Similarity {
  Eigen::MatrixXd rows, columns;  // T and Y
  bool diagonal = true;
  double restore = 1.0;           // ||(T Y)⁻¹|| rounded up: max_k 1 / (s_k t_k) when diagonal, else 1 / (1 - ||T Y - I||)
  double stretch = 1.0;           // ||T|| ||Y||, rounded up: ||T X Y|| <= stretch ||X||
};
Similarity similarity(const Eigen::MatrixXd& T);

// One way through the inertia floor, for a box too wide for M⁻¹'s series (docs/theory.md, "M⁻¹ over a box"): with
// G = diag(g), g > 0, and T = diag(t), T Φ G = (T G)(G M G)⁻¹(G (J(w) D + F) G) (D commutes with G), so
// ||T Φ G|| <= factor · max_k t_k g_k (||G J(w) G|| + ||G F G||) / λmin(G M G), with λmin(G M G) from its forms or
// `floor`, proven for every q (bounds/inertia_floor.hpp). ||Φ||'s own route: g = t = 1. L_T's bound is of ||T Φ Y||
// with Y = diag(s) (Similarity): its routes are ||Φ||'s times the stretch, and G = Y.
struct FloorRoute {
  Eigen::VectorXd g, t;
  double floor = 0.0;
  double factor = 1.0;  // the stretch ||T|| ||Y||, where ||Φ||'s route (g = t = 1) bounds ||T Φ Y||
};

// Φ's terms over a box, for a proof that keeps them apart (certificate/polytopic_search.hpp): for every q in the box,
// w in the velocity box and δ = D e_v, Φ e_v = −(A(w) δ + R e_v) − U (J(w) δ + F e_v) with A(w) = Σ_j w_j A_j and
// ||U|| <= M⁻¹'s tail (bounds/taylor_matrix.hpp).
struct PerturbationForms {
  bool proven = false;          // M proven invertible over the box (else nothing below is set but the weights)
  std::vector<TaylorMatrix> A;  // M⁻¹ J_j
  TaylorMatrix R;               // M⁻¹ F
  // ||U [F, J(w)]|| <= tail for every q in the box and w in the velocity box.
  double tail = 0.0;
  std::vector<double> split_weight;
  BoxCosts costs;
};

struct BoxForms;
// J_j = ∂A/∂v at v = e_j over the box as Taylor matrices, (J_j)_ik = 2 N_i[j][k] from the forms' Christoffel tensors:
// J(q, w) = Σ_j w_j J_j (docs/theory.md, "The constants").
std::vector<TaylorMatrix> unit_jacobians(const BoxForms& d);

class BoxBounds {
 public:
  // Keeps references to the model and the search: they must outlive it. `scaling` (non-empty, n x n): joint_lipschitz
  // bounds L_T for T = scaling instead of L_joint.
  BoxBounds(const Model& model, const JointSearch& search, const Eigen::VectorXd& velocity_bounds,
            const Eigen::MatrixXd& scaling = {});

  // `lower`: a value attained elsewhere; a choice whose bound cannot exceed it is not refined.
  BoxBound inverse_inertia(const std::vector<Interval>& box) const;
  BoxBound jacobian(const std::vector<Interval>& box, double lower) const;
  BoxBound joint_lipschitz(const std::vector<Interval>& box, double lower) const;
  // What the value attained at one point counts (every vertex and pattern, in double): the branch and bound takes it
  // at the midpoint of every box it splits.
  double value_work() const;
  // Φ over the box as a polytope cell (perturbation_polytope.hpp), without its vertices.
  PolytopeCell perturbation_cell(const std::vector<Interval>& box) const;
  PerturbationForms perturbation_forms(const std::vector<Interval>& box) const;

 private:
  const Model& model_;
  const JointSearch& search_;
  Eigen::VectorXd velocity_bounds_;
  Eigen::MatrixXd vertices_;
  // J(q, -w) = -J(q, w): the vertices with w_n < 0 repeat the others for ||J||, and for ||M⁻¹(J D + F)|| too when
  // F = 0 (the full pattern D = I is then the maximum, ||A D|| <= ||A||, and the only one needed).
  unsigned count_, half_;
  CountedModel counted_;
  double inertia_floor_;  // λmin(M(q)) >= it for every q (bounds/inertia_floor.hpp)
  std::optional<Similarity> scaling_;
  std::vector<FloorRoute> routes_;

  // The inertia floor's routes for a box too wide for M⁻¹'s series (box_bounds.cpp): the one likeliest to be lowest
  // with a value it cannot go below, and its bound.
  std::pair<const FloorRoute*, double> likeliest_route(const BoxForms& d, const std::vector<TaylorMatrix>& J) const;
  BoxBound inertia_route(const FloorRoute& route, const BoxForms& d, const std::vector<TaylorMatrix>& J) const;
};

}  // namespace obsgain
