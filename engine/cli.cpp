#include "engine/cli.hpp"

#include <CLI/CLI.hpp>

namespace mocap::engine {

int run_cli(int argc, char** argv) {
  CLI::App app{"mocap-clean: clean whole motion-capture libraries"};
  app.require_subcommand(1);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  return 0;
}

}  // namespace mocap::engine
