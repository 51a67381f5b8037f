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

constexpr double kUp = std::numeric_limits<double>::infinity();

// The sides of the search whose joints g moves, in order.
std::vector<std::size_t> moved_sides(const JointSearch& search, const ChainSymmetry& g) {
  std::vector<std::size_t> sides;
  for (std::size_t k = 0; k < search.joints.size(); ++k)
    if (g.moves(search.joints[k])) sides.push_back(k);
  return sides;
}

bool same(const Interval& a, const Interval& b) { return a.lower() == b.lower() && a.upper() == b.upper(); }

// Whether g maps a side's domain, as it stands, onto itself: a turn needs the whole circle, a negation alone a domain
// symmetric about 0.
bool maps_onto_itself(const JointSearch& search, const ChainSymmetry& g, std::size_t side, const Interval& circle) {
  const Interval& domain = search.domain[side];
  if (g.turns(search.joints[side])) return same(domain, circle);
  return domain.lower() == -domain.upper();
}

// What a reflection q -> -q + c (c = π where the joint is turned too, else 0) leaves of a side's domain: one side of
// its fixed point. On the circle, [-π, 0] or [-π/2, π/2]; on the half-circle [-π, 0] a turn of the joint alone left,
// composed with that turn (q -> -q - π), [-π, -π/2]; on limits symmetric about 0 with c = 0, [lo, 0]. Rounded outward.
Interval mirrored_cut(const Interval& domain, bool turned, bool circle, bool half_circle) {
  const double half_pi_up = std::nextafter(std::numbers::pi / 2.0, kUp);
  if (circle) return turned ? Interval(-half_pi_up, half_pi_up) : Interval(domain.lower(), 0.0);
  if (half_circle) return Interval(domain.lower(), std::nextafter(-std::numbers::pi / 2.0, kUp));
  if (!turned && domain.lower() == -domain.upper()) return Interval(domain.lower(), 0.0);
  return domain;
}

// The order the symmetries are taken in: as given, but for a joint whose domain is not the whole circle, its mirror
// before its turn. On the circle the turn leaves a half-circle the mirror halves again; on limits symmetric about 0
// the mirror halves them, where the turn would leave a domain the mirror cannot cut.
std::vector<ChainSymmetry> taken_order(const JointSearch& search, std::vector<ChainSymmetry> symmetries,
                                       const Interval& circle) {
  const auto first_side = [&](const ChainSymmetry& g) {
    const std::vector<std::size_t> sides = moved_sides(search, g);
    return sides.empty() ? search.joints.size() : sides.front();
  };
  for (std::size_t i = 0; i + 1 < symmetries.size(); ++i) {
    const std::size_t side = first_side(symmetries[i]);
    if (side < search.joints.size() && side == first_side(symmetries[i + 1]) &&
        !symmetries[i].negates(search.joints[side]) && symmetries[i + 1].negates(search.joints[side]) &&
        !same(search.domain[side], circle))
      std::swap(symmetries[i], symmetries[i + 1]);
  }
  return symmetries;
}

}  // namespace

JointSearch folded(JointSearch search, const std::vector<ChainSymmetry>& symmetries) {
  const double pi_up = std::nextafter(std::numbers::pi, kUp);
  const Interval circle(-pi_up, pi_up);
  std::vector<bool> half_circle(search.joints.size(), false);  // the circle cut to [-π, 0] by a turn of its joint alone
  for (const ChainSymmetry& g : taken_order(search, symmetries, circle)) {
    const std::vector<std::size_t> sides = moved_sides(search, g);
    if (sides.empty() || !std::all_of(sides.begin() + 1, sides.end(), [&](std::size_t side) {
          return maps_onto_itself(search, g, side, circle);
        }))
      continue;
    const std::size_t side = sides.front();
    const int joint = search.joints[side];
    Interval& domain = search.domain[side];
    const bool was_circle = same(domain, circle);
    if (g.negates(joint)) {
      domain = mirrored_cut(domain, g.turns(joint), was_circle, half_circle[side]);
      half_circle[side] = false;
      continue;
    }
    // lo + π rounded up: the cut side reaches at least a half-turn.
    const double end = std::nextafter(domain.lower() + pi_up, kUp);
    if (end < domain.upper()) domain = Interval(domain.lower(), end);
    half_circle[side] = was_circle && sides.size() == 1;
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
  return {r.lower, r.upper, search.configuration(r.argmax), r.boxes, r.seconds, r.work, r.stop, r.trace};
}

}  // namespace obsgain
