#include "engine/run/process_memory.hpp"

#include <malloc.h>

namespace mocap::engine {

void keep_freed_memory_for_reuse() {
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
}

}  // namespace mocap::engine
