#include <malloc.h>

#include "app/cli.hpp"
#include "app/cluster.hpp"
#include "io/library_format.hpp"

namespace {

// Every clip allocates tensors of a few MB (and the foot lock and pop stage their working
// planes); with glibc's defaults such blocks are mmap'ed fresh and returned on free, so each clip
// pays its page faults and zero-filling again. Kept in the heap instead, the next clip reuses
// them (README "Performance": about half the minor page faults). Bounded: blocks above 32 MB
// are still mapped apart, and the heap gives memory back past 64 MB free.
void keep_freed_memory_for_reuse() {
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 64 << 20);
}

}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory_for_reuse();
  mocap::io::skip_hdf5_cleanup_at_exit();
  mocap::engine::cluster_init(&argc, &argv);
  const int status = mocap::engine::run_cli(argc, argv);
  mocap::engine::cluster_finalize();
  return status;
}
