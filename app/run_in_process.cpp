#include "app/run_in_process.hpp"

#include <tbb/global_control.h>

#include <optional>

#include "app/interrupt.hpp"

namespace mocap::engine {

RunSummary run_in_process(Job job) {
  std::optional<tbb::global_control> limit;
  if (job.run.threads > 0)
    limit.emplace(tbb::global_control::max_allowed_parallelism, job.run.threads);
  job.run.cancel = &install_interrupt_handler();
  return run_job(job);
}

}  // namespace mocap::engine
