// A best-first interval branch and bound for sup_x f(x) over a box: the boxes with the largest upper bounds are
// split, children that cannot beat the best value attained are discarded (their proven bounds kept), and the
// bracket [attained, largest open or discarded bound] is a proof for the whole box whenever it stops.
//
// Deterministic: the search runs in synchronous rounds. Each round takes a fixed number of the best boxes (ties
// broken by creation order), evaluates f at their midpoints and merges those values in box order, then bounds their
// children in parallel against the value attained so far and merges them in box order. The bracket is therefore the
// same for any thread count, on every run, unless the wall-clock limit ends the search (the result then says so).
#pragma once

#include "obsgain/numerics/interval.hpp"

#include <Eigen/Dense>

#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace obsgain {

// Where a running search stands: told about four times a second once a search has run for a second.
struct SearchProgress {
  const char* bound = "";  // "M0", "B", "L_joint", "C_q"
  int boxes = 0;
  double lower = 0.0, upper = 0.0;  // the bracket so far
  double relative_gap = 0.0, target_gap = 0.0;
  double seconds = 0.0;
  double work = 0.0, work_budget = 0.0;  // counted work so far, and where the search stops (infinite: none)
};

using ProgressCallback = std::function<void(const SearchProgress&)>;

// What ended a search.
// budget: the counted work reached the budget (deterministic); time: the wall-clock limit, a safety net only (the
// bracket may then differ between runs); race: its first share of a budget it raced another search for, which then
// had the lower upper end and went on (certified_bounds.hpp).
enum class SearchStop { gap, boxes, budget, time, race };

// The proven upper end when the counted work first passed 2^k reference seconds (k from -20 on): how fast the
// search closed its gap, which tells what a larger budget would buy (excess_per_doubling, bounds.hpp).
struct UpperAtWork {
  double work = 0.0, upper = 0.0;
};

// A search between two rounds: everything it needs to continue exactly as it would have (checkpoints,
// docs/cluster.md).
struct SearchState {
  struct Box {
    std::vector<Interval> x;
    double upper = 0.0;
    std::vector<double> weight;  // split weights
    std::uint64_t id = 0;        // creation order (breaks ties between equal bounds)
  };
  std::vector<Box> boxes;  // the open boxes
  double lower = 0.0, pruned_upper = 0.0, work = 0.0;
  Eigen::VectorXd argmax;
  int evaluated = 0;
  std::uint64_t next_id = 0;
  std::vector<UpperAtWork> trace;
};

struct BranchAndBoundOptions {
  double relative_gap = 1e-6;  // stop when upper - lower <= relative_gap * upper
  int max_boxes = 2000000;     // stop after this many boxes (deterministic)
  double work_budget = std::numeric_limits<double>::infinity();  // stop once the boxes' counted work reaches it
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();  // wall clock
  int threads = 0;             // 0: all cores
  const char* name = "";
  ProgressCallback progress;   // optional; called from the coordinating thread (an exception it throws ends the search)
  // Checkpoints: `save` is handed the state between two rounds every `save_seconds` (on the output rank only), and
  // a search given `resume` continues from that state: it then ends exactly as the search that saved it would have.
  std::function<void(const SearchState&)> save;
  double save_seconds = 5.0;
  const SearchState* resume = nullptr;
  // Handed the state the search stops in (on every rank), so that it can be continued with a larger budget: resumed
  // from it, it ends exactly as one search with that budget would have.
  std::function<void(SearchState&&)> stopped;
};

// An upper bound of f over one box, and how much each side contributes to the bound's excess (the side with the
// largest weight is split next; a side of weight 0 never is).
// `work`: what the evaluation cost, counted (not timed) in reference seconds, so that a budget of work ends the
// search at the same box on every machine and for any thread count (docs/theory.md, "The budget").
struct BoxBound {
  double upper = 0.0;
  std::vector<double> split_weight;
  double work = 0.0;
};

struct BranchAndBoundProblem {
  std::vector<Interval> domain;
  // A proven upper bound of f over `box`. `lower` is the best value attained so far: the bound may stop refining
  // as soon as it is sure to be below it (it must still be an upper bound).
  std::function<BoxBound(const std::vector<Interval>& box, double lower)> bound;
  // f at a point (a value attained: a lower bound of the supremum), taken at the midpoint of every box split.
  std::function<double(const Eigen::VectorXd& x)> value;
  double value_work = 0.0;  // what one evaluation of `value` counts (as BoxBound::work)
};

struct BranchAndBoundResult {
  double lower = 0.0, upper = 0.0;
  Eigen::VectorXd argmax;  // where `lower` is attained
  int boxes = 0;
  double seconds = 0.0, work = 0.0;
  SearchStop stop = SearchStop::gap;
  std::vector<UpperAtWork> trace;
};

// `seed`: a point where f is large (the numerical search's argmax), evaluated first.
BranchAndBoundResult branch_and_bound(const BranchAndBoundProblem& problem, const Eigen::VectorXd& seed,
                                      const BranchAndBoundOptions& options);

}  // namespace obsgain
