// A fixed set of worker threads that run an indexed loop: body(i) for every i in [0, count), each exactly once,
// the calling thread working too. Results written by index do not depend on which thread ran what, which is how
// the branch and bound and Monte Carlo stay deterministic for any thread count.
#pragma once

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace obsgain {

class ParallelFor {
 public:
  explicit ParallelFor(int threads);  // 0: all cores
  ~ParallelFor();
  ParallelFor(const ParallelFor&) = delete;
  ParallelFor& operator=(const ParallelFor&) = delete;

  // Returns when every body(i) has returned; rethrows the first exception one of them threw.
  void run(int count, const std::function<void(int)>& body);
  int threads() const { return static_cast<int>(workers_.size()) + 1; }

 private:
  void work();
  void drain(std::unique_lock<std::mutex>& lock);

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable start_, finished_;
  const std::function<void(int)>* body_ = nullptr;
  int count_ = 0, next_ = 0, busy_ = 0;
  unsigned generation_ = 0;
  bool quit_ = false;
  std::exception_ptr error_;
};

// The thread count a request means: 0 is every core (shared among the MPI ranks on this machine).
int resolve_threads(int requested);

}  // namespace obsgain
