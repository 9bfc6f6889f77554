#pragma once
// How the process's heap treats freed blocks. Every clip allocates tensors of a few MB, and the
// kernels (nlpm's chunk curves and band, the pop stage's and the foot lock's planes) working
// blocks of a few hundred KB per shard; with glibc's defaults such blocks are mmap'ed fresh and
// returned on free, so every shard pays its page faults and zero-filling again
// (docs/performance.md). A process-wide choice: the program and the kernel benchmark make it at
// start, so that the benchmark measures the kernels as the program runs them; the Python module
// makes it at import unless MOCAP_CLEAN_HOST_ALLOCATOR=1 (README "Python").

namespace mocap::engine {

// Keeps freed blocks up to 32 MB in the heap for reuse (larger ones are still mapped apart), and
// trims the heap only past 64 MB free. Call once, before any thread starts.
void keep_freed_memory_for_reuse();

}  // namespace mocap::engine
