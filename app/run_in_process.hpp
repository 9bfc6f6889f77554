#pragma once
// engine::run_job with what belongs to the process rather than the library: TBB's thread limit
// (--threads) and Ctrl-C, which stops reading new clips (app/interrupt.hpp).
#include "engine/run/job.hpp"

namespace mocap::engine {

RunSummary run_in_process(Job job);

}  // namespace mocap::engine
