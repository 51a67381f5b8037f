#include "obsgain/numerics/processes.hpp"

#include "obsgain/numerics/distributed.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <optional>

namespace obsgain {

namespace {

// A child process that runs the tasks it is sent, one after the other, over one socket: the parent sends a task's
// index, the child answers with the result's size and bytes. One process per worker, not per task: a fork, with the
// new process's page faults and symbol look-ups, cost more than the short Ipopt polish it ran.
struct Worker {
  pid_t pid;
  int fd;
  int task = -1;  // the task it runs, -1 when it has none
  std::string bytes;
};

bool write_all(int fd, const char* data, std::size_t size) {
  for (std::size_t done = 0; done < size;) {
    const ssize_t n = send(fd, data + done, size - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

bool read_all(int fd, char* data, std::size_t size) {
  for (std::size_t done = 0; done < size;) {
    const ssize_t n = read(fd, data + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

// The child's loop: it leaves with _exit, so that no destructor, atexit handler or stdio flush of the parent's state
// runs twice; with 1 where a task threw, so that the parent runs that task again itself.
[[noreturn]] void serve(const std::function<std::string(int)>& task, int fd) {
  int index = 0;
  while (read_all(fd, reinterpret_cast<char*>(&index), sizeof index)) {
    std::string result;
    try {
      result = task(index);
    } catch (...) {
      _exit(1);
    }
    const std::uint64_t size = result.size();
    if (!write_all(fd, reinterpret_cast<const char*>(&size), sizeof size) || !write_all(fd, result.data(), result.size()))
      _exit(1);
  }
  _exit(0);
}

// The child inherits stdio's buffers, and a task may flush them (Ipopt does, as it ends): the parent's pending output
// is written before the fork, so never twice. It closes its copies of the parent's ends to the workers before it, so
// that each of them reads the end of its tasks when the parent closes its own.
std::optional<Worker> start(const std::function<std::string(int)>& task, const std::vector<Worker>& before) {
  std::fflush(nullptr);
  int fds[2];
  if (socketpair(AF_UNIX, SOCK_STREAM, 0, fds) != 0) return std::nullopt;
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    for (const Worker& w : before) close(w.fd);
    serve(task, fds[1]);
  }
  close(fds[1]);
  if (pid < 0) {
    close(fds[0]);
    return std::nullopt;
  }
  return Worker{pid, fds[0], -1, {}};
}

void stop(Worker& worker) {
  close(worker.fd);
  while (waitpid(worker.pid, nullptr, 0) < 0 && errno == EINTR) {
  }
}

bool send_task(Worker& worker, int index) {
  worker.task = index;
  worker.bytes.clear();
  return write_all(worker.fd, reinterpret_cast<const char*>(&index), sizeof index);
}

// Reads what is ready from a worker. False when the worker is gone (it died, or answered out of turn): its task then
// has no result. A whole answer is stored, and the worker then has no task.
bool collect(Worker& worker, std::vector<std::optional<std::string>>& results) {
  char buffer[4096];
  const ssize_t n = read(worker.fd, buffer, sizeof buffer);
  if (n < 0 && errno == EINTR) return true;
  if (n <= 0 || worker.task < 0) return false;
  worker.bytes.append(buffer, static_cast<std::size_t>(n));
  std::uint64_t size = 0;
  if (worker.bytes.size() < sizeof size) return true;
  std::memcpy(&size, worker.bytes.data(), sizeof size);
  if (worker.bytes.size() - sizeof size < size) return true;
  if (worker.bytes.size() - sizeof size > size) return false;
  results[static_cast<std::size_t>(worker.task)] = worker.bytes.substr(sizeof size);
  worker.task = -1;
  return true;
}

// Hands out the tasks to the workers, the next one to whichever is free first, until every task has been handed out
// and answered, or every worker is gone.
void run_on_workers(std::vector<Worker>& workers, int count, std::vector<std::optional<std::string>>& results) {
  int next = 0;
  std::vector<Worker> busy;
  for (Worker& w : workers) {
    if (next < count && send_task(w, next++))
      busy.push_back(std::move(w));
    else
      stop(w);
  }
  workers = std::move(busy);
  while (!workers.empty()) {
    std::vector<pollfd> ready;
    for (const Worker& w : workers) ready.push_back({w.fd, POLLIN, 0});
    if (poll(ready.data(), ready.size(), -1) < 0 && errno != EINTR) break;  // then the rest runs here
    for (std::size_t k = workers.size(); k-- > 0;) {
      Worker& w = workers[k];
      if (ready[k].revents == 0) continue;
      const bool alive = collect(w, results);
      if (alive && w.task >= 0) continue;
      if (!alive || next >= count || !send_task(w, next++)) {
        stop(w);
        workers.erase(workers.begin() + static_cast<std::ptrdiff_t>(k));
      }
    }
  }
  for (Worker& w : workers) stop(w);  // only after a failed poll: no result from these
}

}  // namespace

std::vector<std::string> map_in_processes(int count, int workers, const std::function<std::string(int)>& task) {
  std::vector<std::optional<std::string>> results(static_cast<std::size_t>(count));
  if (workers > 1 && count > 1 && distributed::size() == 1) {
    std::vector<Worker> running;
    for (int k = 0; k < std::min(workers, count); ++k)
      if (std::optional<Worker> worker = start(task, running)) running.push_back(std::move(*worker));
    run_on_workers(running, count, results);
  }
  std::vector<std::string> out(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    auto& r = results[static_cast<std::size_t>(i)];
    out[static_cast<std::size_t>(i)] = r ? std::move(*r) : task(i);
  }
  return out;
}

}  // namespace obsgain
