#pragma once
// One run of the engine: clips from a source, through the filter (and an optional per-clip
// transform such as added noise), into a sink, on the task graph of engine/run/pipeline.hpp.
#include <functional>
#include <string>
#include <vector>

#include "engine/clip/filter_settings.hpp"
#include "engine/run/clip_sink.hpp"
#include "engine/run/clip_source.hpp"
#include "engine/run/review_report.hpp"
#include "engine/run/run_options.hpp"
#include "engine/run/run_summary.hpp"

namespace mocap::engine {

struct Job {
  std::string label;  // "clean", "filter", ... (summary and progress bar)
  ClipSource* source = nullptr;
  ClipSink* sink = nullptr;
  std::vector<std::size_t> selection;  // source indices to run; empty = all
  FilterSettings filter;               // method none: clips pass unchanged
  // Applied to each filtered clip before the sink (parallel across clips; must be a pure
  // function of the clip and its index in the source, so results do not depend on threads).
  std::function<Status(Clip&, std::size_t source_index)> transform;
  RunOptions run;
  ReviewReport* review = nullptr;  // --report: each written clip goes on the review page
};

RunSummary run_job(const Job& job);

}  // namespace mocap::engine
