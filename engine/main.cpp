#include "engine/cli.hpp"
#include "engine/cluster.hpp"

int main(int argc, char** argv) {
  mocap::engine::cluster_init(&argc, &argv);
  const int status = mocap::engine::run_cli(argc, argv);
  mocap::engine::cluster_finalize();
  return status;
}
