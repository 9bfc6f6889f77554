#pragma once
// Without ground truth, say what cleaning changed in what a viewer sees: each clip's jitter and
// foot skating (spec "Metrics") before and after, from forward kinematics of the joints, and the
// clips where cleaning raised either. Before = the clip as read (before any conditioning); the
// skating of both is measured over the input's foot contacts.
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/clip.hpp"
#include "kernels/foot_contacts.hpp"
#include "kernels/motion_split.hpp"

namespace mocap::engine {

// A clip "got worse" above these ratios (issue targets: jitter 1.05x; skating 1.25x).
inline constexpr double kJitterWorse = 1.05;
inline constexpr double kSkatingWorse = 1.25;

struct MotionMeasure {
  double jitter = 0;   // RMS second difference of all joint positions, file units / frame^2
  double skating = 0;  // mean horizontal step of the feet over contact frames, file units
  int contact_steps = 0;
  int edge_frames = 0;  // left out at each end (of each segment)
  std::vector<FootChain> feet;
  std::vector<std::vector<ContactInterval>> contacts;  // per foot
};

// The clip's measure; with `input` given, its feet and contacts are used (the output is measured
// where the input was planted), else they are found on `clip`. With `segments` (the resolved
// ones, kernels/motion_split.hpp), jitter and skating are summed inside each segment of 3 frames
// or more, each with its own edges left out, as eval scores them: an impossible step (CMU's
// T-pose frame 0) is not motion, and would swamp both.
MotionMeasure measure_motion(const Clip& clip, const MotionMeasure* input = nullptr,
                             std::span<const Segment> segments = {});

struct MotionTally {
  nlohmann::json by_clip = nlohmann::json::array();
  std::vector<double> jitter_ratios, skating_ratios;

  std::size_t guarded = 0, fallbacks = 0;  // clips the guard saw, and those it made fall back

  // `kept`: what the guard kept (engine/clip/motion_guard.hpp), when it ran; `fell_back`: the
  // clip did not keep the first candidate.
  void add(const std::string& clip, const MotionMeasure& before, const MotionMeasure& after,
           std::optional<std::string_view> kept = std::nullopt, bool fell_back = false);
  // "motion": {clips, jitter_ratio_median, skating_ratio_median, worse: [...], by_clip}.
  void write_to(nlohmann::json& summary) const;
};

// The closing line's words: "  motion: jitter 0.97x, skating 1.02x (median over 300 clips); 2
// clips worse: a.bvh (jitter 1.31x), ..." ("" without "motion").
std::string describe_motion(const nlohmann::json& summary);

}  // namespace mocap::engine
