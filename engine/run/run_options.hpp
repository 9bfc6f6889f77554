#pragma once
// What every run of the engine is told by its caller, beside the filter settings.
#include <atomic>

namespace mocap::engine {

struct RunOptions {
  // Worker threads: 0 = all cores. The engine does not set TBB's process-wide limit itself; the
  // program does (app/run_in_process.hpp), and run_job reports the limit in force.
  int threads = 0;
  bool json = false;     // the caller prints a machine-readable summary (no progress bar)
  bool progress = true;  // a progress bar on stderr, when it is a terminal
  // Once *cancel is true, no new clip is read; the clips in flight are finished and written.
  const std::atomic<bool>* cancel = nullptr;
};

}  // namespace mocap::engine
