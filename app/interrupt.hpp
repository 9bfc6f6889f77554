#pragma once
// Ctrl-C handling for long runs: the first SIGINT/SIGTERM asks the graph to stop reading new
// clips (the clips in flight are finished and written); a second one ends the process at once.
#include <atomic>

namespace mocap::engine {

// Installs the handlers (idempotent) and returns the flag they set.
const std::atomic<bool>& install_interrupt_handler();
bool interrupted();

}  // namespace mocap::engine
