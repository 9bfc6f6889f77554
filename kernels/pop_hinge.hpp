#pragma once
// The hinge test of a pop (issue 13). Many solved skeletons drive some joints about one axis
// only: CMU's knees, elbows, wrists and toes turn as q(t) = q_r Exp(theta(t) a) for a fixed
// sample q_r and unit axis a (a 1-DOF joint of the ASF, written as three Euler channels). Then
// every step q(t)^-1 q(t+1) = Exp((theta(t+1) - theta(t)) a) lies on the axis, however fast the
// joint turns, while a pop (spec "Noise models": q := q Exp(n), n of random direction) takes the
// sample off the hinge's curve. The distance of a unit quaternion q to the curve {q_r Exp(theta
// a)} is
//   d(q) = 2 asin(|u - (u . a) a|),  u the vector part of q_r^-1 q,
// (the nearest point of the curve maximizes |<q_r^-1 q, (cos(theta/2), sin(theta/2) a)>|, whose
// square is w^2 + (u . a)^2 = 1 - |u - (u . a) a|^2). It does not depend on the frame rate: at
// 24-30 fps, where a fast limb's detour overlaps a pop's (kernels/pop_detour.hpp), the hinge
// still tells them apart.
// A joint is a hinge when at least `share` of its moving steps (angle above `tolerance`) are
// within `tolerance` of one axis and `share` of its samples within `tolerance` of the curve; the
// axis and the reference are taken from steps and samples spread over the clip (the first that
// enough agree with), so a few pops do not sway them. The tolerance is far above the
// rounding of float samples (steps of an exact hinge stay within 1e-5 rad of it on the shared
// clips) and far below any capture's noise: a noisy joint, or a joint that really turns about
// several axes, is no hinge and is not tested.
// Flags: the samples farther than `tolerance` from the curve, in runs of at most `max_run`
// consecutive frames (a real motion that leaves the axis lasts longer; an exact hinge never
// leaves it) of which one is farther than `pop_angle`: a noise faint enough to leave the axis in
// sight (under about 0.5 mrad per axis) can still take a sample past the tolerance, never by 0.01
// rad, which the spec's pops of 0.3-1 rad about a random axis miss only when they turn within
// 2 degrees of the axis (0.06 % of them at 0.3 rad). The
// test reads the whole clip: the clip's segments (kernels/motion_split.hpp) do not matter to a
// hinge, so a pop on a frame that is a segment of its own (CMU's T-pose frame 0) is found too;
// project_onto_hinge then repairs what the segment's repair cannot reach. Cost: a noisy joint is
// ruled out on a probe of kHingeProbe steps (pop_hinge.cpp); measured in docs/pops.md,
// "Hinges".
#include <cstdint>
#include <span>

#include "core/quaternion.hpp"
#include "core/status.hpp"
#include "kernels/motion_io.hpp"

namespace mocap {

inline constexpr double kHingeTolerance = 2e-3;  // rad: on the axis / on the curve
inline constexpr double kHingeShare = 0.9;       // of the moving steps, on one axis
inline constexpr int kHingeMinSteps = 10;        // moving steps to call a joint a hinge
inline constexpr int kHingeMaxRun = 2;           // frames off the curve, at most, to be pops
inline constexpr double kHingePopAngle = 0.01;   // rad off the curve, in a run of pops
inline constexpr int kHingeCandidates = 9;       // steps whose axes are tried
inline constexpr int kHingeProbe = 64;           // steps of the first look (pop_hinge.cpp)

// One joint's hinge: the curve {reference Exp(theta axis)}.
struct Hinge {
  bool found = false;
  Vec3 axis;       // unit, in the joint's own frame
  Quat reference;  // a sample on the curve
};

// d(q) of the header.
double hinge_distance(const Hinge& hinge, const Quat& q);
// The point of the curve nearest q, on q's hemisphere.
Quat project_onto_hinge(const Hinge& hinge, const Quat& q);

struct PopHingeJob {
  RotationView rotations;              // [F][J], a whole clip
  std::span<const std::uint8_t> skip;  // optional, one per joint: nonzero is never tested
  double tolerance = kHingeTolerance;
  double share = kHingeShare;
  int max_run = kHingeMaxRun;
  double pop_angle = kHingePopAngle;
  // [F][J]: set to 1 at the samples the header flags; the others are left as they are.
  std::span<std::uint8_t> flags;
  // Optional, one per joint: each tested joint's hinge (found false where it is none).
  std::span<Hinge> hinges;
  // The joints tested, [joint_begin, joint_end) (-1: to the last); slices can run as tasks.
  int joint_begin = 0, joint_end = -1;

  Status validate() const;
  Status run() const;
};

}  // namespace mocap
