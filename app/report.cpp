#include "app/report.hpp"

#include <fmt/core.h>

#include <cstdio>
#include <nlohmann/json.hpp>

#include "engine/clip/clip_conditioning.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/clip/motion_check.hpp"
#include "engine/run/automatic_tally.hpp"

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
  fmt::print(
      stderr,
      "{}: {} clips, {} frames, {} joint-frames in {:.2f} s ({:.2f} M joint-frames/s, {} "
      "threads){}{}\n{}",
      summary.command, summary.clips, summary.frames, summary.joint_frames, summary.seconds,
      summary.seconds > 0 ? double(summary.joint_frames) / summary.seconds / 1e6 : 0.0,
      summary.threads,
      summary.failed.empty() ? "" : fmt::format(", {} failed", summary.failed.size()),
      summary.interrupted ? ", interrupted" : "",
      describe_conditioning(j) + describe_automatic(j) + describe_feet(j) + describe_motion(j));
}

}  // namespace mocap::engine
