#include "app/cli.hpp"
#include "app/cluster.hpp"
#include "engine/run/process_memory.hpp"
#include "io/library_format.hpp"

int main(int argc, char** argv) {
  mocap::engine::keep_freed_memory_for_reuse();
  mocap::io::skip_hdf5_cleanup_at_exit();
  mocap::engine::cluster_init(&argc, &argv);
  const int status = mocap::engine::run_cli(argc, argv);
  mocap::engine::cluster_finalize();
  return status;
}
