// Independent tasks in child processes, for code that cannot share a process's threads: Ipopt's linear solver
// (MUMPS) keeps global state and is not thread-safe, so the numeric search's local polishes, each an Ipopt run,
// go to child processes (fork) instead of threads.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace obsgain {

// task(i) for every i in [0, count), on up to `workers` child processes, each running the tasks handed to it one after
// the other (the next task to whichever is free first) and sending back the bytes each returns; the results in index
// order. A task is run here instead, in index order after the children are done, where no child could be started or
// its child ended without its result (it threw, or died; the tasks not yet handed out go to the other children): so an
// exception, or whatever else the task does, happens here as it would one after the other. With workers <= 1, or under
// MPI with more than one rank (whose ranks already share the cores, and whose transports may not survive a fork),
// every task runs here.
std::vector<std::string> map_in_processes(int count, int workers, const std::function<std::string(int)>& task);

}  // namespace obsgain
