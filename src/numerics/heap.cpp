#include "obsgain/numerics/heap.hpp"

#include <mutex>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace obsgain {

void keep_freed_memory() {
#if defined(__GLIBC__)
  static std::once_flag once;
  std::call_once(once, [] {
    constexpr int kMegabyte = 1 << 20;
    // An explicit trim threshold turns off glibc's adaptive one, which also fixes the size from which blocks are
    // mapped on their own: 4 MB keeps every block a box takes on the heap, where its pages are reused.
    mallopt(M_MMAP_THRESHOLD, 4 * kMegabyte);
    mallopt(M_TRIM_THRESHOLD, 32 * kMegabyte);
    mallopt(M_TOP_PAD, 16 * kMegabyte);  // the heap grows in steps of 16 MB, not page by page
  });
#endif
}

}  // namespace obsgain
