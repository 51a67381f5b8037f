// Tasks in child processes (numerics/processes.hpp): results in index order, from other processes, and every task
// whose child gives no result run again here, so that its exception reaches the caller as it would in one process.
#include "obsgain/numerics/processes.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <fcntl.h>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace {

TEST(Processes, ResultsComeBackInIndexOrderFromChildProcesses) {
  const pid_t parent = getpid();
  const std::vector<std::string> out = obsgain::map_in_processes(12, 3, [](int i) {
    return std::to_string(i * i) + " " + std::to_string(getpid());
  });
  ASSERT_EQ(out.size(), 12u);
  std::set<std::string> pids;
  for (int i = 0; i < 12; ++i) {
    const std::size_t space = out[static_cast<std::size_t>(i)].find(' ');
    EXPECT_EQ(out[static_cast<std::size_t>(i)].substr(0, space), std::to_string(i * i));
    pids.insert(out[static_cast<std::size_t>(i)].substr(space + 1));
  }
  EXPECT_EQ(pids.count(std::to_string(parent)), 0u);  // every task ran in a child
  EXPECT_EQ(pids.size(), 3u);                          // three children, each given tasks until none are left
  // One worker: every task here.
  const std::vector<std::string> here = obsgain::map_in_processes(3, 1, [](int) { return std::to_string(getpid()); });
  for (const std::string& pid : here) EXPECT_EQ(pid, std::to_string(parent));
}

TEST(Processes, AChildWithoutAResultIsRunAgainHereAndItsExceptionReachesTheCaller) {
  const pid_t parent = getpid();
  // Task 2 dies in its child (no result); here it completes.
  const std::vector<std::string> out = obsgain::map_in_processes(5, 2, [parent](int i) {
    if (i == 2 && getpid() != parent) _exit(9);
    return std::string(i == 2 ? "here" : "child");
  });
  EXPECT_EQ(out, (std::vector<std::string>{"child", "child", "here", "child", "child"}));
  // Task 3 throws wherever it runs: the caller gets its exception, with its type and message.
  try {
    obsgain::map_in_processes(5, 2, [](int i) -> std::string {
      if (i == 3) throw std::invalid_argument("task 3 refuses");
      return "ok";
    });
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "task 3 refuses");
  }
  // An empty result is a result.
  EXPECT_EQ(obsgain::map_in_processes(2, 2, [](int) { return std::string(); }), (std::vector<std::string>{"", ""}));
}

// Output the parent has not written yet is written once, though every child flushes stdio's buffers (as Ipopt does
// when it ends): stdout is sent to a file, a line without its newline left pending, and four tasks flush.
TEST(Processes, OutputPendingInTheParentIsWrittenOnceNotByEveryChild) {
  const std::string path = ::testing::TempDir() + "processes_stdout.txt";
  std::fflush(stdout);
  const int saved = dup(1);
  const int file = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(saved, 0);
  ASSERT_GE(file, 0);
  ASSERT_EQ(dup2(file, 1), 1);
  std::fputs("pending in the parent", stdout);  // no newline: stdio keeps it, line-buffered or not
  obsgain::map_in_processes(4, 2, [](int) {
    std::fflush(stdout);
    return std::string("ok");
  });
  std::fflush(stdout);
  ASSERT_EQ(dup2(saved, 1), 1);
  close(saved);
  close(file);
  std::ifstream in(path);
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  EXPECT_EQ(text, "pending in the parent");
}

}  // namespace
