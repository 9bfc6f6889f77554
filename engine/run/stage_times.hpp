#pragma once
// Where a run's time goes (issue 15): seconds of work per stage, summed over clips and threads,
// so with two threads the stages add up to about twice the wall time. Reported in --json as
// "stages"; docs/performance.md quotes it.
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>

namespace mocap::engine {

class StageTimes {
 public:
  enum Stage {
    read,       // file or HDF5 access (serial; a library's chunks as stored)
    parse,      // BVH parsing or a library's chunk decoding (parallel across clips)
    check,      // value checks and sign continuity
    condition,  // joint classification and the pop stage
    resolve,    // noise estimates and automatic parameters
    contacts,   // foot contact detection
    filter,     // the method's kernel jobs, all shards
    lock,       // foot locking
    metrics,    // jitter and skating before and after
    guard,      // with --guard on: locking, the measure after and any fallback, together
    prepare,    // BVH formatting or chunk compression
    write,      // output files (serial)
    review,     // --report: the review page's data
    kStages
  };

  // Times the enclosing scope into `stage`.
  class Scope {
   public:
    Scope(StageTimes& times, Stage stage)
        : times_(times), stage_(stage), start_(std::chrono::steady_clock::now()) {}
    ~Scope() { times_.add(stage_, std::chrono::steady_clock::now() - start_); }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    StageTimes& times_;
    Stage stage_;
    std::chrono::steady_clock::time_point start_;
  };

  void add(Stage stage, std::chrono::steady_clock::duration elapsed) {
    nanoseconds_[stage].fetch_add(
        std::chrono::duration_cast<std::chrono::nanoseconds>(elapsed).count(),
        std::memory_order_relaxed);
  }
  // {"read": seconds, ...} for every stage.
  nlohmann::json to_json() const;

 private:
  std::array<std::atomic<std::int64_t>, kStages> nanoseconds_{};
};

}  // namespace mocap::engine
