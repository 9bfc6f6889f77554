#pragma once
// What belongs to the process rather than the library: TBB's thread limit (--threads) and Ctrl-C,
// which stops reading new clips (app/interrupt.hpp).
#include <tbb/global_control.h>

#include <optional>

#include "engine/run/job.hpp"

namespace mocap::engine {

// TBB's process-wide limit of worker threads while it lives: `threads`, or all cores for 0.
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  // The limit in force (what a summary reports).
  static int active();

 private:
  std::optional<tbb::global_control> limit_;
};

// engine::run_job under the job's thread limit, with Ctrl-C wired to its cancel flag.
RunSummary run_in_process(Job job);

}  // namespace mocap::engine
