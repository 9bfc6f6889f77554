#include "engine/cli.hpp"

int main(int argc, char** argv) {
  return mocap::engine::run_cli(argc, argv);
}
