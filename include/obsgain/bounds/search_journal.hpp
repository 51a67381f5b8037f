// Checkpoints of long searches (--checkpoint FILE, --resume FILE; docs/cluster.md). The journal holds, for each
// search by name, the request it answers (the model's fingerprint, the boxes, the gap and the budget) with its
// finished bracket or its state between two rounds. A resumed job takes the finished brackets as they are and
// continues the running search from its state: it ends with the same proof, to the bit, as a job never stopped.
// A checkpoint saved for another model or another request, or by an obsgain whose searches follow other rules, is
// refused.
#pragma once

#include "obsgain/bounds/bounds.hpp"
#include "obsgain/bounds/branch_and_bound.hpp"

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace obsgain {

// The rules by which the searches bound and split a box, numbered. A checkpoint saved under other rules would go on
// under these: the job would end with brackets neither version gives from the start, so it is refused. Raise it with
// every change that moves a box's bound, the side split next, the work it counts or how the searches share the budget
// (tests/bounds/test_certified_bounds.cpp pins one box of each bound, and fails when one moves), and with every change
// to what a checkpoint holds (29: the upper end's trace, branch_and_bound.hpp; no box moved).
inline constexpr int kSearchRules = 29;

class SearchJournal {
 public:
  // Saves to `path` (rank 0 writes; atomically, by renaming a complete file). With `resume`, first reads what the
  // file holds: InputError when it cannot be read or is not a checkpoint. Without, writes an empty checkpoint at
  // once: a path that cannot be written is refused before any search runs.
  SearchJournal(std::string path, bool resume);

  // The search `name` under `request`: its finished bracket, or its saved state (null: none). InputError when the
  // checkpoint holds `name` for another request.
  std::optional<BoundBracket> finished(const std::string& name, const std::string& request) const;
  const SearchState* state(const std::string& name, const std::string& request) const;

  // Records and writes the file.
  void save(const std::string& name, const std::string& request, const SearchState& state);
  void finish(const std::string& name, const std::string& request, const BoundBracket& bracket);

  const std::string& path() const { return path_; }

 private:
  struct Entry {
    std::string request;
    std::optional<BoundBracket> finished;
    std::optional<SearchState> state;
  };
  const Entry* entry(const std::string& name, const std::string& request) const;
  void read();
  void write() const;

  std::string path_;
  std::map<std::string, Entry> entries_;
  mutable std::mutex mutex_;
};

// The journal --checkpoint FILE (a new one) or --resume FILE (continued) asks for; null for neither. InputError
// when both are given.
std::shared_ptr<SearchJournal> open_search_journal(const std::string& checkpoint, const std::string& resume);

}  // namespace obsgain
