#include "obsgain/numerics/parallel.hpp"

#include "obsgain/numerics/distributed.hpp"

#include <algorithm>

namespace obsgain {

int resolve_threads(int requested) {
  if (requested > 0) return requested;
  // Ranks on one machine share its cores (docs/cluster.md).
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, cores / distributed::local_size());
}

ParallelFor::ParallelFor(int threads) {
  for (int i = 1; i < resolve_threads(threads); ++i) workers_.emplace_back([this] { work(); });
}

ParallelFor::~ParallelFor() {
  {
    const std::lock_guard lock(mutex_);
    quit_ = true;
  }
  start_.notify_all();
  for (auto& worker : workers_) worker.join();
}

// Takes indices until none is left; the lock is held on entry and on return, never while a body runs.
void ParallelFor::drain(std::unique_lock<std::mutex>& lock) {
  while (next_ < count_) {
    const int i = next_++;
    ++busy_;
    lock.unlock();
    std::exception_ptr error;
    try {
      (*body_)(i);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    if (error && !error_) error_ = error;
    --busy_;
  }
  if (busy_ == 0) finished_.notify_all();
}

void ParallelFor::work() {
  unsigned seen = 0;
  std::unique_lock lock(mutex_);
  while (true) {
    start_.wait(lock, [&] { return quit_ || generation_ != seen; });
    if (quit_) return;
    seen = generation_;
    drain(lock);
  }
}

void ParallelFor::run(int count, const std::function<void(int)>& body) {
  std::unique_lock lock(mutex_);
  body_ = &body;
  count_ = count;
  next_ = 0;
  error_ = nullptr;
  ++generation_;
  start_.notify_all();
  drain(lock);
  finished_.wait(lock, [&] { return next_ >= count_ && busy_ == 0; });
  body_ = nullptr;
  if (error_) std::rethrow_exception(error_);
}

}  // namespace obsgain
