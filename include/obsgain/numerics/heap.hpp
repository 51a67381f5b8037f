// How the process keeps the memory it frees. A box of the branch and bound allocates and frees about a megabyte of
// forms; glibc's malloc returns the top of its heap to the kernel once more than 128 KB of it is free, so every box
// paid for page faults on memory it had just given back (docs/architecture.md, "Memory").
#pragma once

namespace obsgain {

// Freed memory stays with the process, up to 32 MB at the top of each of malloc's arenas, for the next box to reuse.
// Process-wide, idempotent, and a no-op outside glibc; no number depends on it.
void keep_freed_memory();

}  // namespace obsgain
