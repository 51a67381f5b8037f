// Files the tests read and write.
#pragma once

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

namespace obsgain_test {

#ifdef OBSGAIN_EXAMPLES_DIR
// The shipped example robots (examples/).
inline const std::string examples = OBSGAIN_EXAMPLES_DIR;
#endif

inline std::string read_text(const std::string& path) {
  std::ifstream file(path);
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

// Writes `text` to the test's temporary directory and returns the path. The name is prefixed with the process id:
// ctest runs tests in parallel processes that share the directory, and two writing one name raced (one read the file
// while the other truncated it).
inline std::string write_temp_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + std::to_string(getpid()) + "_" + name;
  std::ofstream(path, std::ios::trunc) << text;
  return path;
}

}  // namespace obsgain_test
