// The heap kept for reuse (numerics/heap.hpp): a loop that allocates and frees a megabyte in small blocks, as each box
// of the branch and bound does with its forms, faults its pages in once, not once per round.
#include "obsgain/numerics/heap.hpp"

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <memory>
#include <vector>

namespace {

long minor_faults() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return usage.ru_minflt;
}

// Under glibc's default policy the 64 rounds fault about 64 x 256 pages (the freed top of the heap goes back to
// the kernel after each); kept, the first round's 256 and a few more.
TEST(Heap, FreedMemoryIsReusedWithoutFaultingItInAgain) {
#if defined(__SANITIZE_ADDRESS__) || !defined(__GLIBC__)
  GTEST_SKIP() << "AddressSanitizer owns malloc (or no glibc): the plain build counts";
#endif
  obsgain::keep_freed_memory();
  constexpr int kRounds = 64, kBlocks = 256, kBlockBytes = 4096;
  const long before = minor_faults();
  for (int round = 0; round < kRounds; ++round) {
    std::vector<std::unique_ptr<char[]>> blocks;
    blocks.reserve(kBlocks);
    for (int b = 0; b < kBlocks; ++b) {
      blocks.emplace_back(new char[kBlockBytes]);
      for (int i = 0; i < kBlockBytes; i += 512) blocks.back()[i] = static_cast<char>(round + i);
    }
  }
  EXPECT_LT(minor_faults() - before, 4 * kBlocks);
}

}  // namespace
