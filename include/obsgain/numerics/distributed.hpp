// The ranks of one job started by mpirun or srun (docs/cluster.md), or one rank: obsgain built without MPI, or a
// program not started by an MPI launcher (nothing is initialised then, and nothing costs anything).
//
// Every rank runs the same computation; only the indexed loops that dominate it (a branch and bound round's
// boxes, the Monte Carlo trials) are split into contiguous slices, one per rank, whose results are then shared by
// all ranks in index order. Results written by index do not depend on who computed them: the answer is the same
// for any rank count, as it is for any thread count (parallel.hpp).
#pragma once

#include <utility>
#include <vector>

namespace obsgain::distributed {

// MPI for the lifetime of a program (its main): initialised when an MPI launcher started it, finalised at the end.
class Session {
 public:
  Session(int& argc, char**& argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

int rank();  // 0 without MPI
int size();  // 1 without MPI
// Ranks sharing this machine's cores (the threads a rank uses by default divide them).
int local_size();
// The rank that prints and writes files.
inline bool output_rank() { return rank() == 0; }

// [begin, end) of `count` items for `rank` of `size`: contiguous, balanced, in rank order.
std::pair<int, int> slice(int count, int rank, int size);

// `values` holds `width` doubles per item for `count` items, this rank's slice filled in; afterwards every rank's
// slice, on every rank. Collective: every rank calls it with the same count and width.
void share_slices(std::vector<double>& values, int count, int width);

// Ends the whole job with `code` (MPI_Abort): an error one rank meets alone (a file it cannot write) must not leave
// the others waiting in a collective. Without MPI: std::exit.
[[noreturn]] void abort_job(int code);

// True on every rank when it is true on any (a wall-clock limit reached by one rank stops all). Collective.
bool any(bool flag);

}  // namespace obsgain::distributed
