#pragma once

namespace mocap::engine {

// The mocap-clean command line. Exit status 0 ok, 1 some clips failed, 2 usage / nothing done.
int run_cli(int argc, char** argv);

}  // namespace mocap::engine
