#include "obsgain/bounds/branch_and_bound.hpp"

#include "obsgain/numerics/parallel.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <queue>

namespace obsgain {

namespace {

// Boxes split per round: fixed, so that the search does not depend on the thread count.
constexpr int kRoundBoxes = 32;

struct QueuedBox {
  std::vector<Interval> x;
  double upper = 0.0;
  std::vector<double> weight;
  std::uint64_t id = 0;
};

// The largest bound first; among equal bounds the oldest box.
struct LowerPriority {
  bool operator()(const QueuedBox& a, const QueuedBox& b) const {
    return a.upper < b.upper || (a.upper == b.upper && a.id > b.id);
  }
};

using Queue = std::priority_queue<QueuedBox, std::vector<QueuedBox>, LowerPriority>;

struct Child {
  std::vector<Interval> x;
  Eigen::VectorXd midpoint;
  double value = 0.0;
  BoxBound bound;
};

// Child `which` (0 or 1) of `box`: split at the centre of the side of largest weight (the first on ties).
std::vector<Interval> half(const QueuedBox& box, int which) {
  std::size_t side = 0;
  for (std::size_t k = 1; k < box.x.size(); ++k)
    if (box.weight[k] > box.weight[side]) side = k;
  std::vector<Interval> x = box.x;
  const double middle = centre(box.x[side]);
  x[side] = which == 0 ? Interval(box.x[side].lower(), middle) : Interval(middle, box.x[side].upper());
  return x;
}

Eigen::VectorXd midpoint(const std::vector<Interval>& x) {
  Eigen::VectorXd m(static_cast<Eigen::Index>(x.size()));
  for (std::size_t k = 0; k < x.size(); ++k) m(static_cast<Eigen::Index>(k)) = centre(x[k]);
  return m;
}

double relative_gap(double lower, double upper) {
  if (!std::isfinite(upper)) return 1.0;  // a box not yet shown bounded
  return upper > 0.0 ? (upper - lower) / upper : 0.0;
}

void report(const BranchAndBoundOptions& options, const BranchAndBoundResult& r, double upper,
            std::chrono::steady_clock::time_point start) {
  const auto now = std::chrono::steady_clock::now();
  SearchProgress p;
  p.bound = options.name;
  p.boxes = r.boxes;
  p.lower = std::min(r.lower, upper);  // as in the result: the attained value is a float estimate, within ulps
  p.upper = upper;
  p.relative_gap = relative_gap(p.lower, upper);
  p.target_gap = options.relative_gap;
  p.seconds = std::chrono::duration<double>(now - start).count();
  p.work = r.work;
  p.work_budget = options.work_budget;
  options.progress(p);
}

// Evaluates the children of one round in parallel, each against the bracket as the round began.
std::vector<Child> evaluate_round(const BranchAndBoundProblem& problem, const std::vector<QueuedBox>& parents,
                                  double lower, ParallelFor& pool) {
  std::vector<Child> children(2 * parents.size());
  pool.run(static_cast<int>(children.size()), [&](int c) {
    const UpwardRounding upward;
    const QueuedBox& parent = parents[static_cast<std::size_t>(c / 2)];
    Child& child = children[static_cast<std::size_t>(c)];
    child.x = half(parent, c % 2);
    child.midpoint = midpoint(child.x);
    child.value = problem.value(child.midpoint);
    child.bound = problem.bound(child.x, std::max(lower, child.value));
    // A child's supremum cannot exceed its parent's bound.
    child.bound.upper = std::min(parent.upper, child.bound.upper);
  });
  return children;
}

}  // namespace

BranchAndBoundResult branch_and_bound(const BranchAndBoundProblem& problem, const Eigen::VectorXd& seed,
                                      const BranchAndBoundOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  auto next_report = start + std::chrono::seconds(1);
  BranchAndBoundResult r;
  r.argmax = seed;
  r.lower = problem.value(seed);
  Queue queue;
  std::uint64_t next_id = 0;
  {
    const UpwardRounding upward;
    BoxBound first = problem.bound(problem.domain, r.lower);
    r.work = first.work;
    queue.push({problem.domain, first.upper, std::move(first.split_weight), next_id++});
  }
  r.boxes = 1;
  double pruned_upper = 0.0;  // the largest bound of a discarded box: below the attained value, but proven
  ParallelFor pool(options.threads);
  while (true) {
    // A box of no sides (nothing to search) is a point: its bound is final.
    if (queue.empty() || problem.domain.empty() || relative_gap(r.lower, queue.top().upper) <= options.relative_gap) {
      r.stop = SearchStop::gap;
      break;
    }
    if (r.boxes >= options.max_boxes) {
      r.stop = SearchStop::boxes;
      break;
    }
    if (r.work >= options.work_budget) {
      r.stop = SearchStop::budget;
      break;
    }
    if (std::chrono::steady_clock::now() >= options.deadline) {
      r.stop = SearchStop::time;
      break;
    }
    std::vector<QueuedBox> parents;
    while (!queue.empty() && static_cast<int>(parents.size()) < kRoundBoxes) {
      parents.push_back(queue.top());
      queue.pop();
    }
    std::vector<Child> children = evaluate_round(problem, parents, r.lower, pool);
    for (const Child& child : children)
      if (child.value > r.lower) {
        r.lower = child.value;
        r.argmax = child.midpoint;
      }
    for (Child& child : children) {
      r.work += child.bound.work;
      if (child.bound.upper > r.lower)
        queue.push({std::move(child.x), child.bound.upper, std::move(child.bound.split_weight), next_id++});
      else
        pruned_upper = std::max(pruned_upper, child.bound.upper);
    }
    r.boxes += static_cast<int>(children.size());
    if (options.progress && std::chrono::steady_clock::now() >= next_report) {
      next_report = std::chrono::steady_clock::now() + std::chrono::milliseconds(250);
      report(options, r, std::max(queue.empty() ? 0.0 : queue.top().upper, pruned_upper), start);
    }
  }
  // Every part of the domain is in the queue or was discarded with a proven bound below the attained value.
  r.upper = std::max(queue.empty() ? 0.0 : queue.top().upper, pruned_upper);
  r.lower = std::min(r.lower, r.upper);  // the attained value is a float estimate: ulps
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace obsgain
