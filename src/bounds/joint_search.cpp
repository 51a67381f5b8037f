#include "obsgain/bounds/joint_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace obsgain {

Eigen::VectorXd JointSearch::configuration(const Eigen::VectorXd& x) const {
  Eigen::VectorXd q = fixed_q;
  for (std::size_t k = 0; k < joints.size(); ++k) q(joints[k]) = x(static_cast<Eigen::Index>(k));
  return q;
}

Eigen::VectorXd JointSearch::coordinates(const Eigen::VectorXd& q) const {
  Eigen::VectorXd x(static_cast<Eigen::Index>(joints.size()));
  for (std::size_t k = 0; k < joints.size(); ++k) x(static_cast<Eigen::Index>(k)) = q(joints[k]);
  return x;
}

JointSearch joint_search(const Model& model, const std::vector<int>& joints) {
  JointSearch s;
  s.joints = joints;
  s.fixed_q = Eigen::VectorXd::Zero(model.dof());
  const double pi_up = std::nextafter(std::numbers::pi, std::numeric_limits<double>::infinity());
  for (int j : joints) {
    const JointDomain& joint = model.joints[static_cast<std::size_t>(j)];
    s.domain.push_back(joint.continuous ? Interval(-pi_up, pi_up) : Interval(joint.lower, joint.upper));
  }
  return s;
}

namespace {

// Where a joint is in the search's sides, or -1.
int side_of(const JointSearch& search, int joint) {
  const auto side = std::find(search.joints.begin(), search.joints.end(), joint);
  return side == search.joints.end() ? -1 : static_cast<int>(side - search.joints.begin());
}

// Whether the turn's reflections (q_j -> -q_j) keep every searched joint inside its domain as it stands.
bool reflects_within(const JointSearch& search, const HalfTurn& turn) {
  for (int joint : turn.flipped) {
    const int side = side_of(search, joint);
    if (side >= 0 && search.domain[static_cast<std::size_t>(side)].lower() !=
                         -search.domain[static_cast<std::size_t>(side)].upper())
      return false;
  }
  return true;
}

}  // namespace

JointSearch folded(JointSearch search, const std::vector<HalfTurn>& turns) {
  const double pi_up = std::nextafter(std::numbers::pi, std::numeric_limits<double>::infinity());
  for (const HalfTurn& turn : turns) {
    const int side = side_of(search, turn.joint);
    if (side < 0 || !reflects_within(search, turn)) continue;
    Interval& domain = search.domain[static_cast<std::size_t>(side)];
    // lo + π rounded up: the cut side reaches at least a half-turn.
    const double end = std::nextafter(domain.lower() + pi_up, std::numeric_limits<double>::infinity());
    if (end < domain.upper()) domain = Interval(domain.lower(), end);
  }
  return search;
}

BoundBracket search_joints(const JointSearch& search, const std::function<BoxBound(const std::vector<Interval>&, double)>& bound,
                           const std::function<double(const Eigen::VectorXd&)>& value, const Eigen::VectorXd& seed,
                           const BranchAndBoundOptions& options, double value_work) {
  BranchAndBoundProblem problem;
  problem.domain = search.domain;
  problem.bound = bound;
  problem.value = [&](const Eigen::VectorXd& x) { return value(search.configuration(x)); };
  problem.value_work = value_work;
  const BranchAndBoundResult r = branch_and_bound(problem, search.coordinates(seed), options);
  return {r.lower, r.upper, search.configuration(r.argmax), r.boxes, r.seconds, r.work, r.stop};
}

}  // namespace obsgain
