// The constants of the theorem, computed over the joint domain Q and the velocity box V̄:
//   M0      = sup_q ||M(q)⁻¹||
//   B       = sup_{q, v ∈ V̄} ||∂A/∂v(q, v)||
//   L_paper = M0 (B + ||F||)                                   (the paper's Lipschitz constant)
//   L_joint = sup_{q, w ∈ V̄, D} ||M(q)⁻¹ (J(q, w) D + F)||      (docs/theory.md, never above L_paper)
//   L_T     = sup ||T M(q)⁻¹ (J(q, w) D + F) T⁻¹||   (similarity scaling: T full up to three joints, else
//                                                        diagonal; docs/theory.md)
// v (and D) enter through vertices only (the norms are convex in them), so numerical search runs over q:
// NLopt's DIRECT-L globally, then Ipopt polishes from the best points. Both values are reported.
#pragma once

#include "obsgain/bounds/branch_and_bound.hpp"
#include "obsgain/model/model.hpp"

#include <optional>
#include <string>
#include <vector>

namespace obsgain {

struct BoundOptions {
  int global_evaluations_per_dimension = 1500;  // DIRECT-L budget per searched joint
  // Ipopt starts: the global argmax plus the best sample points. 16: Newton's steps (numerics/optimize.hpp) end on a
  // lower peak than limited-memory ones from some starts (the published Jaco2's M0 6.5 % lower from 8 starts); from 16
  // every M0, B and L_joint estimate on ten arms is within 3e-5 of eight limited-memory polishes' or above, in less
  // time (docs/theory.md, "The constants").
  int polish_starts = 16;
  int samples_per_dimension = 64;               // sample points that seed the extra polish starts
  int threads = 0;  // the polishes run at once on this many cores (0: all), each in a process; the same results
  // Similarity scaling: the T that minimises L_T over the configurations the searches found worst is kept when its
  // estimate is at least this fraction below L_joint's (its certified search then races L_joint's for the budget).
  // Up to scaling_max_dof joints (the certified search's limit: beyond it every round of the search is long and
  // nothing is proven). T is a full matrix up to full_scaling_max_dof joints: D does not commute with it, so its
  // proof bounds every saturation pattern apart (2ⁿ per velocity vertex); a diagonal T commutes with D, and one
  // bound covers them all (docs/theory.md, "Similarity scaling").
  bool diagonal_scaling = true;  // false: no scaling is searched (full or diagonal)
  double scaling_min_gain = 0.05;
  // A diagonal T is chosen among those within this fraction of the lowest max ||T Φ T⁻¹|| on the worst configurations
  // for the smallest cond(T), by which the envelope constant k grows: the minimum is flat along joints that matter
  // little. 3e-3, of 3e-4, 1e-3, 3e-3 and 1e-2 measured on four designs: against 3e-4, k falls on each (by 5 to 68 %)
  // and θ moves within the noise of where a budget-limited search ends (docs/theory.md, "Similarity scaling").
  double scaling_slack = 3e-3;
  // Where the scaled certificate is named (--certificate scaled, or polytopic, which falls back to it), any T whose
  // estimate is below L_joint's is kept: the request accepts the envelope constant's factor cond(T) and the race of
  // the two proofs for the few per cent (docs/theory.md, "Similarity scaling").
  double named_scaling_min_gain = 0.0;
  int scaling_rounds = 4;  // find T on the worst configurations, search L_T, add its argmax, again
  int scaling_max_dof = 7;
  int full_scaling_max_dof = 3;
  double full_scaling_max_condition = 30.0;  // cond(T) <= it (the envelope constant k grows by cond(T))
};

// One supremum over (q, vertex): where it sits and how each optimiser found it.
struct BoundMaximum {
  double value = 0.0;         // the larger of the two optimisers' values
  double global_value = 0.0;  // NLopt DIRECT-L
  double polish_value = 0.0;  // Ipopt polish
  Eigen::VectorXd q;                  // argmax
  Eigen::VectorXd velocity_vertex;    // w ∈ vertices(V̄) at the argmax (empty for M0)
  Eigen::VectorXd saturation_pattern;  // diagonal of D at the argmax (L_joint only)
  int global_evaluations = 0;
  int polish_evaluations = 0;
};

// A certified bracket [lower, upper] of one supremum (certified_bounds.hpp fills it).
struct BoundBracket {
  double lower = 0.0, upper = 0.0;
  Eigen::VectorXd argmax;
  int boxes = 0;
  double seconds = 0.0, work = 0.0;  // wall time; counted work (reference seconds, branch_and_bound.hpp)
  SearchStop stop = SearchStop::gap;  // time: the wall-clock safety limit ended it (the bracket may differ between runs)
  std::vector<UpperAtWork> trace;     // the upper end as the work doubled (branch_and_bound.hpp)
};

// What the last doubling (or more) of a search's counted work did to its excess over the value attained, per
// doubling: (upper - lower) at the end over its value at the trace's last point of at most half the work, to the power
// 1 / (the doublings between them). An observation of this search, not a bound: a larger budget has closed the gap at
// about this pace on the arms measured (docs/theory.md, "How the gap closes with the budget"). std::nullopt for a
// search that reached its gap or has no such point.
std::optional<double> excess_per_doubling(const BoundBracket& bracket);

struct BoundReport {
  Eigen::VectorXd velocity_bounds;
  BoundMaximum M0, B, L_joint;
  double F_norm = 0.0;
  double L_paper = 0.0;
  bool certified = false;  // the values are the certified brackets' upper ends
  const char* method() const { return certified ? "certified" : "numeric"; }
  BoundBracket M0_bracket, B_bracket, L_joint_bracket;
  // Similarity scaling, when it was kept (scaling empty otherwise): T (n x n; upper triangular, or diagonal with
  // T(0, 0) = 1) and L_T = sup ||T Φ T⁻¹|| (L_scaled).
  Eigen::MatrixXd scaling;
  BoundMaximum L_scaled;
  BoundBracket L_scaled_bracket;
  double wall_seconds = 0.0;

  bool scaled() const { return scaling.size() > 0; }
};

BoundReport compute_bounds(const Model& model, const Eigen::VectorXd& velocity_bounds,
                           const BoundOptions& options = {});

// The pieces the searches evaluate, exposed for tests and cross-checks on grids.
double inverse_inertia_norm(const Model& model, const Eigen::VectorXd& q);  // ||M(q)⁻¹||
double coriolis_jacobian_norm(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& w);  // ||J(q, w)||
// ||T M⁻¹(J D + F) T⁻¹|| with T = scaling, n x n (empty: T = I, ||M⁻¹(J D + F)||).
double joint_lipschitz_norm(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& w,
                            const Eigen::VectorXd& saturation_pattern, const Eigen::MatrixXd& scaling = {});

// The objectives at one configuration, maximised over their discrete choices (what the searches and the
// certified branch and bound's attained values evaluate): max over vertices w of ||J(q, w)||, and max over
// vertices w and saturation patterns D of ||S M⁻¹(J D + F) T⁻¹|| (scaling empty: T = I).
double max_coriolis_jacobian_norm(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& velocity_bounds);
double max_joint_lipschitz_norm(const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& velocity_bounds,
                                const Eigen::MatrixXd& scaling = {});

// The diagonal T (scaling(0) = 1, cond(T) <= 10³) that minimises max ||T Φ T⁻¹|| over the matrices given: with
// W = TᵀT diagonal, ||T Φ T⁻¹|| <= t iff Φᵀ W Φ ≼ t² W, so the smallest t is a bisection (relative 1e-6) of
// semidefinite feasibility problems in W's diagonal, a global minimum. With a slack, of the T within that fraction of
// the minimum, one of the smallest cond(T): a bisection on the bound κ of I ≼ W ≼ κ I (docs/theory.md, "Similarity
// scaling"). Both answers move continuously with the matrices.
Eigen::VectorXd best_diagonal_scaling(const std::vector<Eigen::MatrixXd>& matrices, double slack = 0.0);

// The upper triangular T with cond(T) <= max_condition that minimises max ||T Φ T⁻¹|| over the matrices given:
// with W = TᵀT, ||T Φ T⁻¹|| <= t iff Φᵀ W Φ ≼ t² W, linear in W for each t, so the smallest t is a bisection of
// semidefinite feasibility problems (numerics/sdp), a global minimum (docs/theory.md, "Similarity scaling").
Eigen::MatrixXd best_similarity(const std::vector<Eigen::MatrixXd>& matrices, double max_condition);

// The 2^n vertices of the box with half-widths V, one per column.
Eigen::MatrixXd box_vertices(const Eigen::VectorXd& velocity_bounds);

}  // namespace obsgain
