// A branch and bound over some of a model's joints, the others held fixed: the box of their domains, the way from
// the searched coordinates to a full configuration, and the search itself with a bracket as its result.
#pragma once

#include "obsgain/bounds/bounds.hpp"
#include "obsgain/bounds/branch_and_bound.hpp"
#include "obsgain/model/dynamics.hpp"
#include "obsgain/model/model.hpp"

#include <functional>
#include <vector>

namespace obsgain {

struct JointSearch {
  std::vector<int> joints;        // the searched joints, in the order of the box's sides
  Eigen::VectorXd fixed_q;        // every joint's value outside the search
  std::vector<Interval> domain;   // the searched joints' domains
  Eigen::VectorXd configuration(const Eigen::VectorXd& x) const;  // searched coordinates -> full q
  Eigen::VectorXd coordinates(const Eigen::VectorXd& q) const;    // full q -> searched coordinates
};

// The joints' domains: inside their limits, one period (widened by an ulp) for continuous ones.
JointSearch joint_search(const Model& model, const std::vector<int>& joints);

// The search cut by the chain's symmetries (model/dynamics.hpp, ChainSymmetry), taken in order: each cuts the first
// searched joint it moves, a turn to the first half-turn [lo, lo + π] of its domain, a mirror to one side of its fixed
// point, where every other searched joint it moves keeps its domain as it stands (a turn needs the whole circle, a
// negation a domain symmetric about 0). Every q of the domain is then the image of a q' in the cut one under the
// symmetries (docs/theory.md, "Chain symmetries"). Domains narrower than the cut are kept.
JointSearch folded(JointSearch search, const std::vector<ChainSymmetry>& symmetries);

// sup of value(q) over the search: `bound(box, lower)` proves an upper bound over a box of the searched
// coordinates; `value(q)` evaluates at a full configuration and counts `value_work`; `seed` (a full configuration) is
// tried first.
BoundBracket search_joints(const JointSearch& search, const std::function<BoxBound(const std::vector<Interval>&, double)>& bound,
                           const std::function<double(const Eigen::VectorXd&)>& value, const Eigen::VectorXd& seed,
                           const BranchAndBoundOptions& options, double value_work = 0.0);

}  // namespace obsgain
