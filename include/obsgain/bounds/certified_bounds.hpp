// Certified brackets [lower, upper] for M0, B and L_joint: a deterministic best-first branch and bound over the
// searched joints, on all cores, with the model's dynamics evaluated on second-order Taylor forms over each box.
// `lower` is a value attained at a point; `upper` provably bounds the supremum (rounding bounded throughout, exact
// vertex reduction in v and D, norm bounds that keep the sign of the second-order term; docs/theory.md).
#pragma once

#include "obsgain/bounds/bounds.hpp"
#include "obsgain/bounds/branch_and_bound.hpp"
#include "obsgain/bounds/search_journal.hpp"

#include <memory>
#include <optional>
#include <string>

namespace obsgain {

// Which constant the design rests on, so that the search spends its budget there first: L_joint (the default
// certificate), or M0 and B (the paper's Lipschitz constant L_paper = M0 (B + ||F||)).
enum class LipschitzFocus { joint, paper };

struct CertifiedOptions {
  double relative_gap = 1e-6;  // stop a bound when upper - lower <= relative_gap * upper
  // The work for the three bounds together, counted in reference seconds (about the wall time on the reference
  // two-core machine): the search stops at the same box on every machine and for any thread count, so the same
  // command gives the same bounds. 0 = until the gap is reached.
  double budget_seconds = 120;
  // A safety net for a machine far slower than the reference: every search also stops after this many wall
  // seconds from the start (the bracket may then differ between runs, and says so). Default 3 × budget + 30 s.
  std::optional<double> wall_limit_seconds;
  LipschitzFocus focus = LipschitzFocus::joint;  // the focus gets 95 % of the budget; what it leaves passes on
  // L_joint and L_T (where the numeric search kept a similarity scaling) race for their part of the budget: each first
  // gets this share of it, then the one with the lower proven upper end, the one the design uses, goes on with the
  // rest (docs/theory.md, "The budget").
  double race_share = 0.1;
  int max_boxes = 2000000;      // per bound; reaching it leaves a wider (still valid) bracket
  int threads = 0;              // 0: all cores
  ProgressCallback progress;    // optional
  // Checkpoints (search_journal.hpp): each search saves its state there every `checkpoint_seconds`, and continues
  // from what the journal holds for it.
  std::shared_ptr<SearchJournal> journal;
  double checkpoint_seconds = 5.0;
};

struct CertifiedBounds {
  BoundBracket M0, B, L_joint;
  std::optional<BoundBracket> L_scaled;  // when the numeric report kept a similarity scaling
};

// Why a model cannot be certified, or empty when it can.
std::string certification_unavailable(const Model& model);

// Seeds its lower bounds with the numerical search's maxima. With a scaling in the report, L_T races L_joint for its
// part of the budget (CertifiedOptions::race_share). std::nullopt when the model cannot be evaluated on intervals
// (certification_unavailable says why).
std::optional<CertifiedBounds> certify_bounds(const Model& model, const BoundReport& numeric,
                                              const CertifiedOptions& options = {});

// C_q = sup ||∂h/∂q|| over the joint domain, a in the acceleration box and v in the velocity box, with
// h(q) = M(q) a + A(q, v) + g(q): how far the model's prediction of the torque moves when it is evaluated at a
// measured rather than the true position (the sampled observer's certificate, deployment.hpp). The budget is
// options.budget_seconds (counted work, as above); std::nullopt when sensitivity_unavailable says why not.
std::string sensitivity_unavailable(const Model& model);
std::optional<BoundBracket> certify_position_sensitivity(const Model& model, const Eigen::VectorXd& velocity_bounds,
                                                         const Eigen::VectorXd& acceleration_bounds,
                                                         const CertifiedOptions& options);

// A search of `options` through its journal when it has one: a finished bracket is taken as it is, a saved state
// continued, and the search's progress saved. `request`: what the search answers (search_request).
// `final` false: a stage that a larger budget may continue; the journal then records its bracket as finished only when
// something else than the budget ended it.
BoundBracket journaled_search(const CertifiedOptions& options, const std::string& request, BranchAndBoundOptions search,
                              const std::function<BoundBracket(const BranchAndBoundOptions&)>& run, bool final = true);
// The request a search answers, for its checkpoint: the model (name and file fingerprint), the boxes, the gap and the
// budget, and `extra` (the acceleration box of C_q, the scaling T of L_T; its entries in order).
std::string search_request(const Model& model, const Eigen::VectorXd& velocity_bounds, const CertifiedOptions& options,
                           const Eigen::MatrixXd& extra = {});

// Replaces the report's M0, B, L_joint (and L_paper) by the brackets' upper ends: θ* then rests on
// provable bounds.
void apply_certified_bounds(BoundReport& report, const CertifiedBounds& certified);

}  // namespace obsgain
