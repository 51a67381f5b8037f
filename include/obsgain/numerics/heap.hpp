// How the process keeps the memory it frees. A box of the branch and bound allocates and frees megabytes of forms (19 MB
// in 4,900 blocks on the iiwa, 3.4 MB in use at once); glibc's malloc returns the top of its heap to the kernel once
// more than 128 KB of it is free, so every box paid for page faults on memory it had just given back
// (docs/architecture.md, "Memory").
#pragma once

namespace obsgain {

// Freed memory stays with the process, up to 32 MB at the top of each of malloc's arenas, for the next box to reuse.
// Process-wide, idempotent, and a no-op outside glibc; no number depends on it.
void keep_freed_memory();

}  // namespace obsgain
