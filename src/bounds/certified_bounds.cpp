#include "obsgain/bounds/certified_bounds.hpp"

#include "obsgain/bounds/box_bounds.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/taylor.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <tuple>
#include <utility>

namespace obsgain {

namespace {

// The searches of one certification: each gets a share of the work budget left when it starts, and all stop at the
// wall-clock safety limit.
class BudgetShares {
 public:
  explicit BudgetShares(const CertifiedOptions& options) : options_(options) {
    if (options.budget_seconds <= 0.0) return;
    const double limit = options.wall_limit_seconds.value_or(3.0 * options.budget_seconds + 30.0);
    deadline_ = std::chrono::steady_clock::now() +
                std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(limit));
  }
  BranchAndBoundOptions next(double share, const char* name) const {
    BranchAndBoundOptions o;
    o.relative_gap = options_.relative_gap;
    o.max_boxes = options_.max_boxes;
    o.work_budget = options_.budget_seconds > 0.0 ? share * std::max(0.0, options_.budget_seconds - used_) : kInfinity;
    o.deadline = deadline_;
    o.threads = options_.threads;
    o.name = name;
    o.progress = options_.progress;
    return o;
  }
  void spent(const BoundBracket& b) { used_ += b.work; }

 private:
  const CertifiedOptions& options_;
  std::chrono::steady_clock::time_point deadline_ = std::chrono::steady_clock::time_point::max();
  double used_ = 0.0;
};

// L_joint or L_T, searched in stages: `run` searches to the options' budget (from `options.resume` when given) and
// hands over the state it stops in (when given where), from which a larger budget goes on exactly as one search with
// it from the start would have; `finish` records a bracket as final in the checkpoint, where its stage left it
// unrecorded (journaled_search records a stage ended by anything but its budget).
struct StagedSearch {
  std::function<BoundBracket(const BranchAndBoundOptions&, SearchState* stopped_in)> run;
  std::function<void(const BoundBracket&)> finish;
};

// L_joint and L_T on the options' budget (docs/theory.md, "The budget"). They race: each first gets `race_share` of
// it; then the one whose proven upper end is lower (the one the design uses: the scaled certificate only where L_T's
// is below L_joint's) goes on with what the other left, and the other stops there. A resumed job takes the brackets
// finished as they are: a leader that went on has already done its rest.
std::pair<BoundBracket, BoundBracket> race(const StagedSearch& joint, const StagedSearch& scaled,
                                           BranchAndBoundOptions part, double race_share) {
  const double whole = part.work_budget;
  part.work_budget = race_share * whole;
  SearchState joint_state, scaled_state;
  BoundBracket J = joint.run(part, &joint_state), T = scaled.run(part, &scaled_state);
  const bool scaled_leads = T.upper < J.upper;
  BoundBracket& leader = scaled_leads ? T : J;
  BoundBracket& other = scaled_leads ? J : T;
  const StagedSearch& leading = scaled_leads ? scaled : joint;
  if (other.stop == SearchStop::budget) {
    other.stop = SearchStop::race;
    (scaled_leads ? joint : scaled).finish(other);
  }
  part.work_budget = whole - other.work;
  if (leader.stop == SearchStop::budget && leader.work < part.work_budget) {
    part.resume = scaled_leads ? &scaled_state : &joint_state;
    const double seconds = leader.seconds;
    leader = leading.run(part, nullptr);  // its last stage: the state it ends in is not needed
    leader.seconds += seconds;
  }
  leading.finish(leader);
  return {J, T};
}

// The model's symmetries under which L_T is invariant too: ||T P Φ P T⁻¹|| = ||T Φ T⁻¹|| where T commutes with P (a
// diagonal T always does). M0, B and L_joint are invariant under every one (docs/theory.md, "Chain symmetries").
std::vector<ChainSymmetry> invariant_symmetries(const Model& model, const Eigen::MatrixXd& scaling) {
  std::vector<ChainSymmetry> symmetries;
  for (const ChainSymmetry& g : chain_symmetries(model))
    if (scaling.size() == 0 || commutes_with_flips(scaling, g.negated)) symmetries.push_back(g);
  return symmetries;
}

}  // namespace

BoundBracket journaled_search(const CertifiedOptions& options, const std::string& request, BranchAndBoundOptions search,
                              const std::function<BoundBracket(const BranchAndBoundOptions&)>& run, bool final) {
  SearchJournal* journal = options.journal.get();
  if (journal == nullptr) return run(search);
  const std::string name = search.name;
  if (const auto done = journal->finished(name, request)) return *done;
  if (!search.resume) search.resume = journal->state(name, request);  // a later stage resumes from its own stop
  search.save = [journal, name, request](const SearchState& state) { journal->save(name, request, state); };
  search.save_seconds = options.checkpoint_seconds;
  const BoundBracket bracket = run(search);
  if (final || bracket.stop != SearchStop::budget) journal->finish(name, request, bracket);
  return bracket;
}

std::string search_request(const Model& model, const Eigen::VectorXd& velocity_bounds, const CertifiedOptions& options,
                           const Eigen::MatrixXd& extra) {
  std::string request = fmt::format("{} ({}) V", model.name, model.fingerprint);
  for (const double V : velocity_bounds) request += fmt::format(" {}", V);
  for (Eigen::Index k = 0; k < extra.size(); ++k) request += fmt::format(" {}", extra.data()[k]);
  return request + fmt::format(" gap {} budget {} focus {} boxes {}", options.relative_gap, options.budget_seconds,
                               options.focus == LipschitzFocus::joint ? "joint" : "paper", options.max_boxes);
}

std::string certification_unavailable(const Model& model) {
  if (static_cast<int>(configuration_joints(model).size()) > kMaxDirections)
    return fmt::format("model '{}' depends on {} joint positions; certified bounds search at most {}", model.name,
                       configuration_joints(model).size(), kMaxDirections);
  return {};
}

std::optional<CertifiedBounds> certify_bounds(const Model& model, const BoundReport& numeric,
                                              const CertifiedOptions& options) {
  if (!certification_unavailable(model).empty()) return std::nullopt;
  const Eigen::VectorXd& V = numeric.velocity_bounds;
  const JointSearch s =
      folded(joint_search(model, configuration_joints(model)), invariant_symmetries(model, numeric.scaling));
  const BoxBounds boxes(model, s, V);
  // The budget goes to what the design rests on first: L_joint for the default certificate, M0 and B (L_paper)
  // for the paper's Lipschitz constant; what a bound leaves unused passes to the next.
  const bool joint = options.focus == LipschitzFocus::joint;
  BudgetShares budget(options);
  // A request names the scaling T of L_T (empty for the others): a checkpoint of another T is not taken.
  const auto search = [&](const BranchAndBoundOptions& o, const auto& bound, const auto& value, const Eigen::VectorXd& seed,
                          const Eigen::MatrixXd& scaling = {}, double value_work = 0.0, bool final = true) {
    return journaled_search(options, search_request(model, V, options, scaling), o,
                            [&](const BranchAndBoundOptions& b) { return search_joints(s, bound, value, seed, b, value_work); },
                            final);
  };
  CertifiedBounds result;
  // L_joint (scaling empty) or L_T.
  const auto lipschitz = [&](const char* name, const BoxBounds* b, const Eigen::MatrixXd& scaling,
                             const Eigen::VectorXd& seed) {
    StagedSearch staged;
    staged.run = [&search, &model, &V, name, b, scaling, seed](const BranchAndBoundOptions& o, SearchState* stopped_in) {
      BranchAndBoundOptions stage = o;
      stage.name = name;
      if (stopped_in) stage.stopped = [stopped_in](SearchState&& state) { *stopped_in = std::move(state); };
      return search(stage, [b](const auto& box, double lower) { return b->joint_lipschitz(box, lower); },
                    [&](const Eigen::VectorXd& q) { return max_joint_lipschitz_norm(model, q, V, scaling); }, seed, scaling,
                    b->value_work(), false);
    };
    staged.finish = [&options, name, request = search_request(model, V, options, scaling)](const BoundBracket& bracket) {
      const bool unrecorded = bracket.stop == SearchStop::budget || bracket.stop == SearchStop::race;
      if (options.journal && unrecorded) options.journal->finish(name, request, bracket);
    };
    return staged;
  };
  const BoxBounds scaled_boxes(model, s, V, numeric.scaling);
  const auto run_L = [&](double share) {
    const StagedSearch joint = lipschitz("L_joint", &boxes, {}, numeric.L_joint.q);
    if (!numeric.scaled()) {
      result.L_joint = joint.run(budget.next(share, "L_joint"), nullptr);
      joint.finish(result.L_joint);
      budget.spent(result.L_joint);
      return;
    }
    const StagedSearch scaled = lipschitz("L_scaled", &scaled_boxes, numeric.scaling, numeric.L_scaled.q);
    std::tie(result.L_joint, result.L_scaled) = race(joint, scaled, budget.next(share, ""), options.race_share);
    budget.spent(result.L_joint);
    budget.spent(*result.L_scaled);
  };
  if (joint) run_L(0.95);
  result.M0 = search(budget.next(joint ? 0.6 : 0.5, "M0"), [&](const auto& box, double) { return boxes.inverse_inertia(box); },
                     [&](const Eigen::VectorXd& q) { return inverse_inertia_norm(model, q); }, numeric.M0.q);
  budget.spent(result.M0);
  result.B = search(budget.next(joint ? 1.0 : 0.8, "B"), [&](const auto& box, double lower) { return boxes.jacobian(box, lower); },
                    [&](const Eigen::VectorXd& q) { return max_coriolis_jacobian_norm(model, q, V); }, numeric.B.q);
  budget.spent(result.B);
  if (!joint) run_L(1.0);
  return result;
}

namespace {

// A bracket whose upper end another proven bound lowered: its attained value, a double evaluation, may lie above
// the new upper end by its rounding error, which is the whole value where the constant is zero but for rounding (two
// coaxial joints: C = 0; docs/theory.md, "Lower ends"). The branch and bound clamps its own brackets alike.
void keep_below_upper_end(BoundBracket& bracket) { bracket.lower = std::min(bracket.lower, bracket.upper); }

}  // namespace

void apply_certified_bounds(BoundReport& report, const CertifiedBounds& certified) {
  report.certified = true;
  report.M0_bracket = certified.M0;
  report.B_bracket = certified.B;
  report.L_joint_bracket = certified.L_joint;
  report.M0.value = certified.M0.upper;
  report.B.value = certified.B.upper;
  report.L_paper = (Interval(report.M0.value) * (Interval(report.B.value) + Interval(report.F_norm))).upper();
  // L_joint <= L_paper holds for every q, w, D (docs/theory.md, "The constants"): a proven L_paper bounds L_joint
  // too, and is the smaller of the two when the branch and bound of L_joint ran out of budget on a wide domain.
  if (report.L_paper < report.L_joint_bracket.upper) report.L_joint_bracket.upper = report.L_paper;
  keep_below_upper_end(report.L_joint_bracket);
  report.L_joint.value = report.L_joint_bracket.upper;
  report.wall_seconds += certified.M0.seconds + certified.B.seconds + certified.L_joint.seconds;
  if (certified.L_scaled) {
    // ||T Φ T⁻¹|| <= ||T|| ||Φ|| ||T⁻¹|| <= ||T|| ||Y|| ||(T Y)⁻¹|| ||Φ||: the proven L_joint, stretched, bounds L_T too.
    report.L_scaled_bracket = *certified.L_scaled;
    const Similarity S = similarity(report.scaling);
    const double stretched = (Interval(report.L_joint.value) * Interval(S.stretch) * Interval(S.restore)).upper();
    report.L_scaled_bracket.upper = std::min(report.L_scaled_bracket.upper, stretched);
    keep_below_upper_end(report.L_scaled_bracket);
    report.L_scaled.value = report.L_scaled_bracket.upper;
    report.wall_seconds += certified.L_scaled->seconds;
  }
}

}  // namespace obsgain
