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

}  // namespace

BoundBracket journaled_search(const CertifiedOptions& options, const std::string& request, BranchAndBoundOptions search,
                              const std::function<BoundBracket(const BranchAndBoundOptions&)>& run) {
  SearchJournal* journal = options.journal.get();
  if (journal == nullptr) return run(search);
  const std::string name = search.name;
  if (const auto done = journal->finished(name, request)) return *done;
  search.resume = journal->state(name, request);
  search.save = [journal, name, request](const SearchState& state) { journal->save(name, request, state); };
  search.save_seconds = options.checkpoint_seconds;
  const BoundBracket bracket = run(search);
  journal->finish(name, request, bracket);
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
  const JointSearch s = joint_search(model, configuration_joints(model));
  const BoxBounds boxes(model, s, V);
  // The budget goes to what the design rests on first: L_joint for the default certificate, M0 and B (L_paper)
  // for the paper's Lipschitz constant; what a bound leaves unused passes to the next.
  const bool joint = options.focus == LipschitzFocus::joint;
  BudgetShares budget(options);
  // A request names the scaling T of L_T (empty for the others): a checkpoint of another T is not taken.
  const auto search = [&](double share, const char* name, const auto& bound, const auto& value, const Eigen::VectorXd& seed,
                          const Eigen::MatrixXd& scaling = {}, double value_work = 0.0) {
    const BoundBracket b = journaled_search(options, search_request(model, V, options, scaling), budget.next(share, name),
                                            [&](const BranchAndBoundOptions& o) { return search_joints(s, bound, value, seed, o, value_work); });
    budget.spent(b);
    return b;
  };
  CertifiedBounds result;
  // L_joint (scaling empty) or L_T.
  const auto lipschitz = [&](double share, const char* name, const BoxBounds& b, const Eigen::MatrixXd& scaling,
                             const Eigen::VectorXd& seed) {
    return search(share, name, [&](const auto& box, double lower) { return b.joint_lipschitz(box, lower); },
                  [&](const Eigen::VectorXd& q) { return max_joint_lipschitz_norm(model, q, V, scaling); }, seed, scaling,
                  b.value_work());
  };
  const BoxBounds scaled_boxes(model, s, V, numeric.scaling);
  const auto run_L = [&](double joint_share, double scaled_share) {
    result.L_joint = lipschitz(joint_share, "L_joint", boxes, {}, numeric.L_joint.q);
    if (numeric.scaled())
      result.L_scaled = lipschitz(scaled_share, "L_scaled", scaled_boxes, numeric.scaling, numeric.L_scaled.q);
  };
  if (joint) run_L(numeric.scaled() ? 0.475 : 0.95, 0.8);
  result.M0 = search(joint ? 0.6 : 0.5, "M0", [&](const auto& box, double) { return boxes.inverse_inertia(box); },
                     [&](const Eigen::VectorXd& q) { return inverse_inertia_norm(model, q); }, numeric.M0.q);
  result.B = search(joint ? 1.0 : 0.8, "B", [&](const auto& box, double lower) { return boxes.jacobian(box, lower); },
                    [&](const Eigen::VectorXd& q) { return max_coriolis_jacobian_norm(model, q, V); }, numeric.B.q);
  if (!joint) run_L(1.0, 1.0);
  return result;
}

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
  report.L_joint.value = report.L_joint_bracket.upper;
  report.wall_seconds += certified.M0.seconds + certified.B.seconds + certified.L_joint.seconds;
  if (certified.L_scaled) {
    // ||T Φ T⁻¹|| <= ||T|| ||Φ|| ||T⁻¹|| <= ||T|| ||Y|| ||(T Y)⁻¹|| ||Φ||: the proven L_joint, stretched, bounds L_T too.
    report.L_scaled_bracket = *certified.L_scaled;
    const Similarity S = similarity(report.scaling);
    const double stretched = (Interval(report.L_joint.value) * Interval(S.stretch) * Interval(S.restore)).upper();
    report.L_scaled_bracket.upper = std::min(report.L_scaled_bracket.upper, stretched);
    report.L_scaled.value = report.L_scaled_bracket.upper;
    report.wall_seconds += certified.L_scaled->seconds;
  }
}

}  // namespace obsgain
