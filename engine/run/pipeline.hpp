#pragma once
// The task graph every command runs on (TBB flow graph):
//
//   reader (serial) -> limiter -> split into shards -> kernels (parallel) -> join per clip
//     -> sequencer (clip order) -> writer (serial) -> frees a slot in the limiter
//
// File and HDF5 access stay in the serial reader and writer (Debian's HDF5 is not thread-safe);
// the kernels run in parallel in between. The limiter bounds the clips in flight, so memory
// does not grow with the size of the library. The writer sees clips in input order whatever the
// thread count, so outputs are identical for any number of threads.
#include <any>
#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "core/clip.hpp"
#include "engine/clip/shard_work.hpp"
#include "kernels/motion_io.hpp"

namespace mocap::engine {

// One clip travelling through the graph.
struct WorkItem {
  std::size_t index = 0;
  std::string name;  // how the clip is named in messages (its source path)
  Clip input;
  Clip output;
  std::string error;  // non-empty: the clip failed and is skipped by later stages
  std::atomic<int> shards_left{0};
  std::any context;  // what the command's stages keep per clip (e.g. resolved parameters)

  // Records the first failure; safe from concurrent shards.
  void fail(const std::string& message) {
    std::lock_guard lock(error_mutex);
    if (error.empty()) error = message.empty() ? "failed" : message;
  }

 private:
  std::mutex error_mutex;
};

// One piece of a clip's work: a slice of the output (joint block or time block).
struct PipelineStages {
  std::size_t count = 0;
  // Fill item.input (and item.name) for item.index, or set item.error. Serial.
  std::function<void(WorkItem&)> read;
  // Prepare item.output and return its shards (at least one). Parallel across clips.
  std::function<std::vector<Shard>(WorkItem&)> split;
  // Compute one shard. Parallel; shards of one clip write disjoint parts of item.output.
  std::function<void(WorkItem&, const Shard&)> process;
  // After all shards of a clip (optional). Parallel across clips.
  std::function<void(WorkItem&)> finish;
  // Consume the finished clip, in index order. Serial.
  std::function<void(WorkItem&)> write;
};

struct PipelineOptions {
  int max_clips_in_flight = 0;  // 0 = 4 x threads
  const std::atomic<bool>* cancel =
      nullptr;  // when set, no new clip is read; in-flight clips finish
};

// Runs the graph in the calling thread's TBB arena (limit threads with a tbb::global_control or
// task_arena around the call). Returns the number of clips read.
std::size_t run_pipeline(const PipelineStages& stages, const PipelineOptions& options);

}  // namespace mocap::engine
