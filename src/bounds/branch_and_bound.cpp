#include "obsgain/bounds/branch_and_bound.hpp"

#include "obsgain/numerics/distributed.hpp"
#include "obsgain/numerics/heap.hpp"
#include "obsgain/numerics/parallel.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
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

// Bounds one child against the bracket as it stood after the round's values.
void evaluate_child(const BranchAndBoundProblem& problem, const QueuedBox& parent, double lower, Child& child) {
  const UpwardRounding upward;
  child.bound = problem.bound(child.x, lower);
  // A child's supremum cannot exceed its parent's bound.
  child.bound.upper = std::min(parent.upper, child.bound.upper);
}

// The children in the order the ranks take them: every size-th from each rank's first, so that the two halves of a
// parent (about the same cost) go to different ranks and every rank's share of a round costs about the same.
std::vector<std::size_t> dealt(std::size_t count) {
  const auto ranks = static_cast<std::size_t>(distributed::size());
  std::vector<std::size_t> order;
  for (std::size_t first = 0; first < ranks; ++first)
    for (std::size_t c = first; c < count; c += ranks) order.push_back(c);
  return order;
}

// What a rank sends of a child it evaluated: upper bound, work, split weights (the box itself every rank computes
// from its parent). Position p of the exchange holds child order[p].
void share_children(std::vector<Child>& children, const std::vector<std::size_t>& order, int begin, int end,
                    std::size_t dimension) {
  const int width = 2 + static_cast<int>(dimension), count = static_cast<int>(children.size());
  std::vector<double> values(static_cast<std::size_t>(count * width));
  for (int p = begin; p < end; ++p) {
    const Child& child = children[order[static_cast<std::size_t>(p)]];
    double* out = &values[static_cast<std::size_t>(p * width)];
    out[0] = child.bound.upper;
    out[1] = child.bound.work;
    // A box that is split has one weight per side; a discarded one may have fewer (never read).
    const auto& weight = child.bound.split_weight;
    std::copy_n(weight.begin(), std::min(weight.size(), dimension), out + 2);
  }
  distributed::share_slices(values, count, width);
  for (int p = 0; p < count; ++p) {
    if (p >= begin && p < end) continue;
    Child& child = children[order[static_cast<std::size_t>(p)]];
    const double* in = &values[static_cast<std::size_t>(p * width)];
    child.bound.upper = in[0];
    child.bound.work = in[1];
    child.bound.split_weight.assign(in + 2, in + width);
  }
}

// The values attained at the midpoints of the round's parents, in parent order: the threads of this rank its slice
// of them, then the ranks exchange their slices. The boxes split are the ones whose bounds are largest, so this is
// where a value above the attained one is to be found; a box never split gets no value (docs/theory.md, "Lower
// ends").
std::vector<double> midpoint_values(const BranchAndBoundProblem& problem, const std::vector<QueuedBox>& parents,
                                    ParallelFor& pool) {
  const auto count = static_cast<int>(parents.size());
  std::vector<double> values(parents.size());
  const auto [begin, end] = distributed::slice(count, distributed::rank(), distributed::size());
  pool.run(end - begin, [&](int k) {
    const auto p = static_cast<std::size_t>(begin + k);
    values[p] = problem.value(midpoint(parents[p].x));
  });
  if (distributed::size() > 1) distributed::share_slices(values, count, 1);
  return values;
}

// Bounds the children of one round in parallel, each against the same attained value `lower`: the threads of this
// rank its share of them, then the ranks exchange their shares (numerics/distributed.hpp).
std::vector<Child> evaluate_round(const BranchAndBoundProblem& problem, const std::vector<QueuedBox>& parents,
                                  double lower, ParallelFor& pool) {
  std::vector<Child> children(2 * parents.size());
  for (std::size_t c = 0; c < children.size(); ++c) children[c].x = half(parents[c / 2], static_cast<int>(c % 2));
  const std::vector<std::size_t> order = dealt(children.size());
  const auto [begin, end] = distributed::slice(static_cast<int>(children.size()), distributed::rank(), distributed::size());
  pool.run(end - begin, [&](int k) {
    const std::size_t c = order[static_cast<std::size_t>(begin + k)];
    evaluate_child(problem, parents[c / 2], lower, children[c]);
  });
  if (distributed::size() > 1) share_children(children, order, begin, end, problem.domain.size());
  return children;
}

// The first box: the whole domain, and the seed's value attained.
void begin(const BranchAndBoundProblem& problem, const Eigen::VectorXd& seed, BranchAndBoundResult& r, Queue& queue,
           std::uint64_t& next_id) {
  r.argmax = seed;
  r.lower = problem.value(seed);
  const UpwardRounding upward;
  BoxBound first = problem.bound(problem.domain, r.lower);
  r.work = first.work;
  queue.push({problem.domain, first.upper, std::move(first.split_weight), next_id++});
  r.boxes = 1;
}

void restore(const SearchState& state, BranchAndBoundResult& r, Queue& queue, double& pruned_upper,
             std::uint64_t& next_id) {
  r.lower = state.lower;
  r.argmax = state.argmax;
  r.work = state.work;
  r.boxes = state.evaluated;
  pruned_upper = state.pruned_upper;
  next_id = state.next_id;
  r.trace = state.trace;
  for (const SearchState::Box& box : state.boxes) queue.push({box.x, box.upper, box.weight, box.id});
}

SearchState snapshot(Queue queue, const BranchAndBoundResult& r, double pruned_upper, std::uint64_t next_id) {
  SearchState state{{}, r.lower, pruned_upper, r.work, r.argmax, r.boxes, next_id, r.trace};
  state.boxes.reserve(queue.size());
  for (; !queue.empty(); queue.pop()) {
    const QueuedBox& box = queue.top();
    state.boxes.push_back({box.x, box.upper, box.weight, box.id});
  }
  return state;
}

// The bracket's upper end: every part of the domain is in the queue or was discarded with a proven bound below the
// attained value.
double proven_upper(const Queue& queue, double pruned_upper) {
  return std::max(queue.empty() ? 0.0 : queue.top().upper, pruned_upper);
}

// The upper end at the end of the first round whose work passes the next power of two (from 2^-20 reference seconds):
// counted work, so the same points for any thread count and after a resume.
void trace_upper(BranchAndBoundResult& r, double upper) {
  double mark = std::ldexp(1.0, -20);
  while (!r.trace.empty() && mark <= r.trace.back().work) mark *= 2.0;
  if (r.work >= mark) r.trace.push_back({r.work, upper});
}

// Why the search stops before the next round, if it does.
std::optional<SearchStop> stop_reason(const BranchAndBoundProblem& problem, const BranchAndBoundOptions& options,
                                      const BranchAndBoundResult& r, const Queue& queue) {
  // A box of no sides (nothing to search) is a point: its bound is final.
  if (queue.empty() || problem.domain.empty() || relative_gap(r.lower, queue.top().upper) <= options.relative_gap)
    return SearchStop::gap;
  if (r.boxes >= options.max_boxes) return SearchStop::boxes;
  if (r.work >= options.work_budget) return SearchStop::budget;
  // Every rank stops in the same round: the wall clock is the one input the ranks do not share.
  if (distributed::any(std::chrono::steady_clock::now() >= options.deadline)) return SearchStop::time;
  return std::nullopt;
}

}  // namespace

BranchAndBoundResult branch_and_bound(const BranchAndBoundProblem& problem, const Eigen::VectorXd& seed,
                                      const BranchAndBoundOptions& options) {
  keep_freed_memory();
  const auto start = std::chrono::steady_clock::now();
  auto next_report = start + std::chrono::seconds(1);
  auto next_save = start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                               std::chrono::duration<double>(options.save_seconds));
  BranchAndBoundResult r;
  Queue queue;
  std::uint64_t next_id = 0;
  double pruned_upper = 0.0;  // the largest bound of a discarded box: below the attained value, but proven
  if (options.resume)
    restore(*options.resume, r, queue, pruned_upper, next_id);
  else
    begin(problem, seed, r, queue, next_id);
  ParallelFor pool(options.threads);
  while (true) {
    if (const auto stop = stop_reason(problem, options, r, queue)) {
      r.stop = *stop;
      break;
    }
    std::vector<QueuedBox> parents;
    while (!queue.empty() && static_cast<int>(parents.size()) < kRoundBoxes) {
      parents.push_back(queue.top());
      queue.pop();
    }
    const std::vector<double> values = midpoint_values(problem, parents, pool);
    for (std::size_t p = 0; p < parents.size(); ++p) {
      r.work += problem.value_work;
      if (values[p] > r.lower) {
        r.lower = values[p];
        r.argmax = midpoint(parents[p].x);
      }
    }
    std::vector<Child> children = evaluate_round(problem, parents, r.lower, pool);
    for (Child& child : children) {
      r.work += child.bound.work;
      if (child.bound.upper > r.lower)
        queue.push({std::move(child.x), child.bound.upper, std::move(child.bound.split_weight), next_id++});
      else
        pruned_upper = std::max(pruned_upper, child.bound.upper);
    }
    r.boxes += static_cast<int>(children.size());
    trace_upper(r, proven_upper(queue, pruned_upper));
    if (options.save && distributed::output_rank() && std::chrono::steady_clock::now() >= next_save) {
      options.save(snapshot(queue, r, pruned_upper, next_id));
      next_save = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                          std::chrono::duration<double>(options.save_seconds));
    }
    if (options.progress && distributed::output_rank() && std::chrono::steady_clock::now() >= next_report) {
      next_report = std::chrono::steady_clock::now() + std::chrono::milliseconds(250);
      report(options, r, proven_upper(queue, pruned_upper), start);
    }
  }
  r.upper = proven_upper(queue, pruned_upper);
  if (options.stopped) options.stopped(snapshot(std::move(queue), r, pruned_upper, next_id));
  r.lower = std::min(r.lower, r.upper);  // the attained value is a float estimate: ulps
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace obsgain
