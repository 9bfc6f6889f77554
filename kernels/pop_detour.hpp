#pragma once
// The detour test of a pop (issue 13), for the frame rates where find_pops' quadratic no longer
// follows fast limbs (below 60 fps, engine/clip/clip_conditioning.cpp). A pop (the spec's `impulse`
// model, ../shared/spec/filters.md "Noise models": q := q Exp(n) on one joint) leaves the joint's
// curve at one frame and comes back at the next; real motion, however fast, goes on from where it
// is. The detour of sample t of joint j is what the two steps through it add to the direct step
// from its neighbour before to its neighbour after:
//   E(t) = theta(q[t-1], q[t]) + theta(q[t], q[t+1]) - theta(q[t-1], q[t+1]),
// theta the geodesic angle (core/quaternion.hpp). E >= 0 by the triangle inequality of the
// rotation metric; a turn at constant speed about one axis has E = 0 whatever its speed; a pop of
// angle p on a joint that holds still has E = 2p (0.6-2 rad for the spec's pops). Where find_pops'
// fit error grows with fast motion and hides a pop, E stays near 0 for the motion and large for
// the pop. A limb that reverses in one frame has a large E too; the skeleton test that follows
// (kernels/pop_skeleton.hpp) takes a sample for coherent motion where a neighbour moves with it.
// A pop on a fast joint also gives the frames beside it a detour (up to twice the joint's step),
// so only the largest detour of its neighbourhood is flagged; and a pop on an end frame, which has
// no detour of its own, shows as one on the frame next to it, so the two frames at each end are
// left to find_pops.
// Calibrated with `eval --pop-stage repair` at 30 and 24 fps on ../shared/data/bvh (docs/pops.md).
// Noise. Sensor noise gives every sample a detour (white noise of sigma rad per axis: a joint's
// median E about 2 sigma), so under heavy noise the threshold flagged noise: with at least
// kNoiseMinSteps detours, a joint's threshold is at least kDetourOverMedian x its median E. A
// capture's median E is far below (docs/eval.md, "Noise and the split"), so its flags do not
// change.
#include <cstdint>
#include <span>

#include "core/quaternion.hpp"
#include "core/status.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/motion_split.hpp"

namespace mocap {

inline constexpr double kPopDetour = 0.6;  // rad, at kPopDetourFps and above
inline constexpr double kPopDetourFps = 30;
inline constexpr double kDetourOverMedian = 4.0;  // header, "Noise"
// The threshold at a frame time (s): kPopDetour at kPopDetourFps and above; below, scaled by
// (kPopDetourFps x frame_time)^2, since a real motion's detour is the turn of its velocity over a
// frame, which grows as the square of the frame time (a pop's does not).
double pop_detour_threshold(double frame_time);

// E(t) above from its three angles: theta(q[t-1], q[t]), theta(q[t], q[t+1]) and
// theta(q[t-1], q[t+1]) (the job takes the first two from the joint classification's steps).
inline double pop_detour(double step_in, double step_out, double direct) {
  return step_in + step_out - direct;
}
// E(t) above for three samples of one joint at t - 1, t and t + 1.
double pop_detour(const Quat& before, const Quat& at, const Quat& after);

struct PopDetourJob {
  RotationView rotations;              // [F][J], one segment of a clip
  std::span<const std::uint8_t> skip;  // optional, one per joint: nonzero is never flagged
  double threshold = kPopDetour;       // rad: a sample is flagged where E(t) > threshold
  // [F][J]: flags[t][j] set to 1 where E(t) of joint j exceeds the threshold, E(t - 1) <= E(t)
  // and E(t + 1) < E(t), for 2 <= t < F - 2; the others are left as they are (the flags of
  // find_pops come in here).
  std::span<std::uint8_t> flags;
  // The joints tested, [joint_begin, joint_end) (-1: to the last); the job writes only their
  // flags, so slices can run as parallel tasks.
  int joint_begin = 0, joint_end = -1;
  // Optional: the step angles theta(q[t], q[t+1]) already measured on these very rotations (the
  // joint classification's, kernels/motion_split.hpp), step t of the job read as
  // steps->at(step_offset + t, j); without them the job measures them (the same bits).
  const StepAngles* steps = nullptr;
  int step_offset = 0;
  // Optional, one per joint: receives each tested joint's median detour E(t), 1 <= t < F - 1
  // (0 with fewer than kNoiseMinSteps of them), the median the "Noise" floor scales; the skeleton
  // test's strong detours (kernels/pop_skeleton.hpp) read it instead of measuring it again.
  std::span<double> median_detours;

  Status validate() const;
  Status run() const;
};

}  // namespace mocap
