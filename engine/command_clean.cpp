// `mocap-clean clean`: BVH files in, filtered BVH files out, through the same task graph as the
// library commands.
#include <fmt/core.h>

#include "engine/automatic_tally.hpp"
#include "engine/clip_conditioning.hpp"
#include "engine/commands.hpp"
#include "engine/foot_stage.hpp"
#include "engine/job.hpp"

namespace mocap::engine {

void report(const RunSummary& summary, bool json) {
  std::fflush(stdout);
  for (const auto& f : summary.failed) {
    // A reader's error already begins with the file's path and line; do not name the file twice.
    const bool names_itself = f.error.find(f.clip + ":") != std::string::npos;
    if (names_itself)
      fmt::print(stderr, "mocap-clean: {}\n", f.error);
    else
      fmt::print(stderr, "mocap-clean: {}: {}\n", f.clip, f.error);
  }
  const nlohmann::json j = summary.to_json();
  if (json) {
    fmt::print("{}\n", j.dump());
    return;
  }
  fmt::print(stderr,
             "{}: {} clips, {} frames, {} joint-frames in {:.2f} s ({:.2f} M joint-frames/s, {} "
             "threads){}{}\n{}",
             summary.command, summary.clips, summary.frames, summary.joint_frames, summary.seconds,
             summary.seconds > 0 ? double(summary.joint_frames) / summary.seconds / 1e6 : 0.0,
             summary.threads,
             summary.failed.empty() ? "" : fmt::format(", {} failed", summary.failed.size()),
             summary.interrupted ? ", interrupted" : "",
             describe_conditioning(j) + describe_automatic(j) + describe_feet(j));
}

RunSummary clean_files(const std::vector<SourceFile>& files, const std::string& output_dir,
                       const FilterSettings& settings, const RunOptions& run) {
  BvhSource source(files);
  BvhFolderSink sink(output_dir);
  Job job;
  job.label = "clean";
  job.source = &source;
  job.sink = &sink;
  job.filter = settings;
  job.run = run;
  RunSummary summary = run_job(job);
  summary.extra["method"] = std::string(to_string(settings.method));
  summary.extra["parameters"] = settings.to_json();
  return summary;
}

int run_clean(const CleanCommand& command) {
  // The output folder may sit inside a source folder, or be one: an earlier run's output is not
  // input, and no input is overwritten.
  const SourceList sources = collect_bvh_sources(command.sources, command.output_dir);
  for (const auto& e : sources.errors) fmt::print(stderr, "mocap-clean: clean: {}\n", e);
  if (!sources.errors.empty()) return 2;
  if (sources.files.empty()) {
    fmt::print(stderr, "mocap-clean: clean: no .bvh files found in the given sources\n");
    return 2;
  }
  const FilterSettings settings = command.filter.settings();
  if (const Status s = settings.validate(); !s.ok()) {
    fmt::print(stderr, "mocap-clean: clean: {}\n", s.message());
    return 2;
  }
  const RunSummary summary = clean_files(sources.files, command.output_dir, settings, command.run);
  report(summary, command.run.json);
  return summary.exit_status();
}

}  // namespace mocap::engine
