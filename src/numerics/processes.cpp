#include "obsgain/numerics/processes.hpp"

#include "obsgain/numerics/distributed.hpp"

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <optional>

namespace obsgain {

namespace {

struct Child {
  pid_t pid;
  int fd;  // the read end of the pipe the child writes its result to
  int index;
  std::string bytes;
};

bool write_all(int fd, const std::string& bytes) {
  for (std::size_t done = 0; done < bytes.size();) {
    const ssize_t n = write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

// The child runs the task and leaves with _exit: no destructor, atexit handler or stdio flush of the parent's state
// runs twice. Exit code 0 only with its whole result written. The child inherits stdio's buffers, and a task may
// flush them (Ipopt does, as it ends): the parent's pending output is written before the fork, so never twice.
std::optional<Child> start(const std::function<std::string(int)>& task, int index) {
  std::fflush(nullptr);
  int fds[2];
  if (pipe(fds) != 0) return std::nullopt;
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return std::nullopt;
  }
  if (pid == 0) {
    close(fds[0]);
    bool written = false;
    try {
      written = write_all(fds[1], task(index));
    } catch (...) {
    }
    _exit(written ? 0 : 1);
  }
  close(fds[1]);
  return Child{pid, fds[0], index, {}};
}

// Reads what is ready from a child; at the end of its output, reaps it. True when it is done.
bool collect(Child& child, std::vector<std::optional<std::string>>& results) {
  char buffer[4096];
  const ssize_t n = read(child.fd, buffer, sizeof buffer);
  if (n > 0) {
    child.bytes.append(buffer, static_cast<std::size_t>(n));
    return false;
  }
  if (n < 0 && errno == EINTR) return false;
  close(child.fd);
  int status = 0;
  pid_t reaped = -1;
  while ((reaped = waitpid(child.pid, &status, 0)) < 0 && errno == EINTR) {
  }
  // A status not known (SIGCHLD ignored by the host program reaps children itself) is no result either.
  if (n == 0 && reaped == child.pid && WIFEXITED(status) && WEXITSTATUS(status) == 0)
    results[static_cast<std::size_t>(child.index)] = std::move(child.bytes);
  return true;
}

}  // namespace

std::vector<std::string> map_in_processes(int count, int workers, const std::function<std::string(int)>& task) {
  std::vector<std::optional<std::string>> results(static_cast<std::size_t>(count));
  if (workers > 1 && count > 1 && distributed::size() == 1) {
    std::vector<Child> running;
    for (int next = 0; next < count || !running.empty();) {
      for (; next < count && static_cast<int>(running.size()) < workers; ++next)
        if (std::optional<Child> child = start(task, next)) running.push_back(std::move(*child));
      if (running.empty()) continue;
      std::vector<pollfd> ready;
      for (const Child& c : running) ready.push_back({c.fd, POLLIN, 0});
      if (poll(ready.data(), ready.size(), -1) < 0 && errno != EINTR) break;  // then the rest runs here
      for (std::size_t k = running.size(); k-- > 0;)
        if (ready[k].revents != 0 && collect(running[k], results))
          running.erase(running.begin() + static_cast<std::ptrdiff_t>(k));
    }
    for (Child& c : running) {  // only after a failed poll: no result from these
      close(c.fd);
      waitpid(c.pid, nullptr, 0);
    }
  }
  std::vector<std::string> out(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    auto& r = results[static_cast<std::size_t>(i)];
    out[static_cast<std::size_t>(i)] = r ? std::move(*r) : task(i);
  }
  return out;
}

}  // namespace obsgain
