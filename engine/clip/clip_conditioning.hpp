#pragma once
// What the engine does to a clip before any filter (not part of the spec's filters): finds its
// garbage joints (constant, moving only by float rounding, or flipping by about pi: uncaptured)
// and repairs its pops (kernels/pop_repair.hpp), leaving the garbage joints as they came. Also
// the tally of what it found over a run, for the --json summary and the closing line.
#include <cstddef>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/clip.hpp"
#include "engine/clip/filter_settings.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/pop_repair.hpp"

namespace mocap::engine {

struct ClipConditioning {
  std::vector<JointQuality> joints;       // per joint, as classified
  std::vector<std::uint8_t> garbage;      // per joint: 1 = garbage
  std::vector<int> pops;                  // per joint: pops found (detect) or repaired (repair)
  bool repaired = false;                  // the pops were repaired (not only counted)
  std::vector<std::int32_t> pop_samples;  // [N][2]: frame, joint of each pop, frame order
  std::vector<Segment> segments;          // the pop test's: between impossible steps
  // After a repair that changed samples: the joints' classes and the segments of the repaired
  // rotations, as resolve_for_clip would measure them (only the changed joints measured again).
  std::vector<JointQuality> repaired_joints;
  std::vector<Segment> repaired_segments;
  bool any_garbage() const;
  std::size_t pop_count() const;
  // What resolve_for_clip may reuse: the classes and segments of the rotations as they leave
  // the conditioning (repaired or not).
  ClipFacts facts() const;
};

// Classifies the joints of `rotations` and finds (detect) or repairs (repair, in place) its pops:
// one test finds the flags, then the stage decides whether to repair them. A flipping joint is
// tested (and repaired) between its flips, and only where the stage repairs. The pop test runs
// between impossible steps (a jump no joint can make, kernels/motion_split.hpp, measured on the
// joints that are not garbage): the synthetic T-pose frame 0 of CMU conversions is a frame of its
// own, not a pop. With `parents` (one per joint, -1 for a root; empty: unknown), below
// kPopsRepairMinFps the detour test adds flags (kernels/pop_detour.hpp) and each flag must pass the
// skeleton test (kernels/pop_skeleton.hpp); `auto` there repairs a clip whose flags number at least
// kManyPopsFlagged of its samples, from kAutoRepairMinFps up, and only counts the others
// (and every clip without `parents`). At kPopsRepairMinFps and above, a clip with that many flags
// (and `parents`) gets the detour test's flags too, each kept only where no skeleton neighbour
// moves with it. At every rate the hinge test (kernels/pop_hinge.hpp) adds the pops that take a
// joint driven about one axis off its curve, over the whole clip; a flagged hinge sample that no
// segment's repair reaches (a segment of one frame) is repaired onto the curve.
ClipConditioning condition_rotations(PopsMode mode, RotationSpan rotations, double frame_time,
                                     std::span<const int> parents = {});

// The pop test's parameters at a frame rate: kernels/pop_repair.hpp's defaults at
// kPopsRepairMinFps and above; below, runs of at most 2 (a window of 4 neighbours a side, 133 ms
// at 30 fps where 5 spanned 167 ms) and a flag 8 times further from its fit than the fit's own
// error (6 above). Calibrated with `eval --pop-stage repair` on the 9 shared clips at 30 fps over
// max_run 1-3, local threshold 4-16, threshold 6-10 and reach 2-3 (docs/pops.md,
// "The test's parameters below 60 fps").
PopRepairParams pop_params_at(double frame_time);

// condition_rotations on the clip, but nothing at all for method none (a copy) or pops off (the
// spec's filter alone: no garbage joints are reported either).
ClipConditioning condition_clip(const FilterSettings& settings, Clip& clip);

// Over a run: pops per joint name, and the garbage joints of each clip.
struct ConditioningTally {
  PopsMode mode = PopsMode::off;
  bool keep_garbage = true;
  std::size_t pops = 0, repaired = 0, clips_with_pops = 0, garbage_joints = 0,
              clips_with_garbage = 0;
  std::map<std::string, std::size_t> pops_by_joint;
  nlohmann::json garbage = nlohmann::json::array();  // [{clip, joints: [{joint, class}]}]

  void add(const std::string& clip, const Clip& data, const ClipConditioning& c);
  // Adds "pops" and "garbage_joints" to a --json summary.
  void write_to(nlohmann::json& summary) const;
};

// The closing line's words for a summary holding them ("" when it holds none): "pops: 41
// repaired in 7 clips (LeftHand 9, ...); garbage joints: 2 in 1 clip, kept as they came".
std::string describe_conditioning(const nlohmann::json& summary);

}  // namespace mocap::engine
