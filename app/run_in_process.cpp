#include "app/run_in_process.hpp"

#include "app/interrupt.hpp"

namespace mocap::engine {

ThreadLimit::ThreadLimit(int threads) {
  if (threads > 0) limit_.emplace(tbb::global_control::max_allowed_parallelism, threads);
}

int ThreadLimit::active() {
  return int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

RunSummary run_in_process(Job job) {
  const ThreadLimit limit(job.run.threads);
  job.run.cancel = &install_interrupt_handler();
  return run_job(job);
}

}  // namespace mocap::engine
