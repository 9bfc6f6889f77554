#include "app/cli.hpp"
#include "app/cluster.hpp"
#include "io/library_format.hpp"

int main(int argc, char** argv) {
  mocap::io::skip_hdf5_cleanup_at_exit();
  mocap::engine::cluster_init(&argc, &argv);
  const int status = mocap::engine::run_cli(argc, argv);
  mocap::engine::cluster_finalize();
  return status;
}
