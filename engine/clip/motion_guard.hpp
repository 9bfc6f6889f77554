#pragma once
// "Never makes a capture worse", checked on what a viewer sees and what can be measured without
// ground truth (docs/positions.md, "Never worse"): the joint positions' jitter and the feet's
// skating over the input's contacts (engine/clip/motion_check.hpp). After --method auto's filter
// and the foot lock, a clip that comes out with more jitter or more skating than the clip as read
// falls back to the first of these that raises neither:
//   filtered and locked -> filtered -> input (pops repaired) locked -> input (pops repaired)
//   -> the clip as read (which raises nothing by definition).
// Both are measured inside the resolved segments, as eval scores them. When the pop stage
// repaired samples and the repaired input raises neither measure over the clip as read, the
// first three must not raise the repaired input's instead: a pop's jitter would hide what the
// filter adds around it (docs/positions.md, "Never worse").
// The one step after the filter (and auto's hinges) for `clean` (engine/run/job.cpp), the Python
// module and eval alike, so that they lock and fall back the same way; with `guard` false it is
// the foot lock alone.
// Why it is needed: below 60 fps the noise estimate of a clean capture (0.003-0.010 rad on the
// shared clips at 30 fps) overlaps that of 0.008 rad of added noise (0.009-0.012), so the rule
// cannot tell a clean fast clip from a noisy one, and bof's range weights, which change with the
// motion's speed, add jitter to clean motion (1.04-1.19x); pinning a clean capture's feet moves
// its legs (jitter up to 1.09x). On a noisy capture the filter removes far more jitter than its
// range weights can add, so the guard keeps it: it only ever acts where the input was already
// smooth.
#include <cstdint>
#include <string_view>
#include <vector>

#include "core/clip.hpp"
#include "core/status.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/clip/motion_check.hpp"
#include "kernels/motion_split.hpp"

namespace mocap::engine {

// What the clip kept, in the guard's order of preference.
enum class Kept : std::uint8_t { filtered_locked, filtered, input_locked, input, as_read };
std::string_view to_string(Kept kept);

// The skating measure's relative rounding: positions are floats, so a foot's step 0.01 units long
// on a coordinate of 50 is known to about 4e-4 of itself (averaged over a clip's steps, to about
// 1e-5), and a clip whose locked feet follow the input's (kernels/foot_lock.hpp, "Contacts")
// measures its skating equal to the input's within that (measured: 1.0000008x and 1.00002x).
inline constexpr double kMeasureRounding = 1e-4;

// True when `after` has more jitter than `before`, or more foot skating by more than
// kMeasureRounding of it (both measured over the same contacts: measure_motion(after_clip,
// &before)).
bool raises_motion(const MotionMeasure& after, const MotionMeasure& before);

struct MotionGuardJob {
  // Inputs.
  // The clip after the pop stage, before the filter; required with the guard.
  const Clip* input = nullptr;
  const Clip* raw = nullptr;  // the clip as read; nullptr: the input is the last resort
  // The clip as read, measure_motion(raw, nullptr, *segments): contacts included. Required
  // with the guard; without it, nullptr leaves `after` unmeasured.
  const MotionMeasure* before = nullptr;
  const std::vector<Segment>* segments = nullptr;  // resolved segments (may be empty)
  ClipFeet* feet = nullptr;  // contacts found on `input`; nullptr: no foot lock
  bool guard = true;         // false: filtered (and locked) whatever it measures: the lock alone
  // Optional: the lock's working memory, reused across clips (lock_feet's `scratch`).
  FootLockScratch* lock_scratch = nullptr;
  // In and out: the filtered clip; replaced by the candidate kept.
  Clip* output = nullptr;
  // Outputs.
  Kept kept = Kept::filtered_locked;
  MotionMeasure after;  // of the clip kept

  Status validate() const;
  // After run(): whether the clip kept something other than the first candidate.
  bool fell_back() const { return kept != (feet ? Kept::filtered_locked : Kept::filtered); }
  // Locks (when `feet`), measures (when `before`), and with the guard falls back as the header
  // says. `feet` ends as locked for
  // the candidate kept (or with `locked` false and no stats when it kept an unlocked one).
  Status run();
};

}  // namespace mocap::engine
