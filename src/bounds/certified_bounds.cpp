#include "obsgain/bounds/certified_bounds.hpp"

#include "obsgain/bounds/box_bounds.hpp"
#include "obsgain/bounds/joint_search.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/numerics/affine.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace obsgain {

namespace {

// The deadline of a bound that gets `share` of what is left of the budget when it starts.
std::chrono::steady_clock::time_point share_of_budget(const CertifiedOptions& options,
                                                      std::chrono::steady_clock::time_point start, double share) {
  if (options.budget_seconds <= 0.0) return std::chrono::steady_clock::time_point::max();
  const auto now = std::chrono::steady_clock::now();
  const double left = std::max(0.0, options.budget_seconds - std::chrono::duration<double>(now - start).count());
  return now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(share * left));
}

JointSearchOptions search_options(const CertifiedOptions& options, std::chrono::steady_clock::time_point deadline,
                                  const char* name) {
  JointSearchOptions o;
  o.relative_gap = options.relative_gap;
  o.max_boxes = options.max_boxes;
  o.deadline = deadline;
  o.threads = options.threads;
  o.name = name;
  o.progress = options.progress;
  return o;
}

}  // namespace

std::string certification_unavailable(const Model& model) {
  if (static_cast<int>(configuration_joints(model).size()) > kAffineSymbols)
    return fmt::format("model '{}' depends on {} joint positions; certified bounds search at most {}", model.name,
                       configuration_joints(model).size(), kAffineSymbols);
  return {};
}

std::optional<CertifiedBounds> certify_bounds(const Model& model, const BoundReport& numeric,
                                              const CertifiedOptions& options) {
  if (!certification_unavailable(model).empty()) return std::nullopt;
  const Eigen::VectorXd& V = numeric.velocity_bounds;
  const JointSearch s = joint_search(model, configuration_joints(model));
  const BoxBounds boxes(model, s, V);
  const auto start = std::chrono::steady_clock::now();
  // The budget goes to what the design rests on first: L_joint for the default certificate, M0 and B (L_paper)
  // for the paper's Lipschitz constant; what a bound leaves unused passes to the next.
  const bool joint = options.focus == LipschitzFocus::joint;
  CertifiedBounds result;
  const auto run_L = [&](double share) {
    result.L_joint = search_joints(s, [&](const auto& box, double lower) { return boxes.joint_lipschitz(box, lower); },
                                   [&](const Eigen::VectorXd& q) { return max_joint_lipschitz_norm(model, q, V); },
                                   numeric.L_joint.q, search_options(options, share_of_budget(options, start, share), "L_joint"));
  };
  if (joint) run_L(0.75);
  result.M0 = search_joints(s, [&](const auto& box, double) { return boxes.inverse_inertia(box); },
                            [&](const Eigen::VectorXd& q) { return inverse_inertia_norm(model, q); }, numeric.M0.q,
                            search_options(options, share_of_budget(options, start, joint ? 0.6 : 0.5), "M0"));
  result.B = search_joints(s, [&](const auto& box, double lower) { return boxes.jacobian(box, lower); },
                           [&](const Eigen::VectorXd& q) { return max_coriolis_jacobian_norm(model, q, V); }, numeric.B.q,
                           search_options(options, share_of_budget(options, start, joint ? 1.0 : 0.8), "B"));
  if (!joint) run_L(1.0);
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
}

}  // namespace obsgain
