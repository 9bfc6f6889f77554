#pragma once
// Physically impossible frame-to-frame jumps, and the segments of a clip between them, so that
// no filter smears a jump that is not motion across its neighbours (eval's --split-impossible).
//
// A step t -> t+1 is impossible when any joint turns by more than
//     min(max_speed * frame_time, max_step)     (geodesic angle, rad)
// Measured on the CMU "Motionbuilder-friendly" clips of ../shared/data/bvh (120 fps, 9 clips):
// the synthetic T-pose frame 0 lies 1.50 to 3.09 rad (86 to 177 degrees) from frame 1 at its
// worst joint; after it, the largest step of any joint in any clip is 0.71 rad (85 rad/s, a toe
// in 05_02), fast hands about 0.63 rad, except the LThumb of 06_14, which flips by pi (Euler
// channels passing gimbal lock in the conversion) 16 times. max_speed = 150 rad/s (1.25 rad per
// step at 120 fps) sits between the two with room on both sides, above the fastest human joint
// speeds reported (a pitcher's shoulder, about 120-160 rad/s, is the extreme) and above the
// eval's impulse pops (at most 1 rad). max_step caps the threshold at low frame rates, where
// max_speed * frame_time would exceed pi and nothing could ever be flagged.
// Sign flips of the quaternion (q vs -q) are not steps: the geodesic angle ignores them.
//
// Below about 60 fps the per-joint rule alone misses the T-pose: its worst joint turns less than
// max_step there, no more than a fast toe does. What sets it apart is that the whole body jumps
// at once. So a step is also impossible when the pose step, the mean over joints of
// min(angle, kPoseStepJointClamp) (the clamp keeps one flipping joint from counting as a whole
// body), exceeds
//     max(min_pose_step, max_pose_speed * frame_time)
// min_pose_step lies between the T-pose's pose step and real motion's down to 24 fps; below,
// max_pose_speed raises the threshold past real motion, and a T-pose may then go unflagged
// rather than real motion being cut (docs/eval.md has the measurements). The pose step needs a
// body: with fewer than kPoseStepMinJoints joints counted, one limb swinging or one joint popping
// is a large share of the mean, so the rule is not applied.
//
// Noise. Sensor noise turns every joint at every step: white noise of sigma rad per axis turns a
// joint by about 2.3 sigma a step, and the pose step by as much, so from about 0.09 rad every
// step's pose step passes min_pose_step, and at 0.24 rad one joint step in 270 passes 1.25 rad:
// the clip would be cut into pieces too short to filter. A jump stands out from the clip's own
// steps, so with at least kNoiseMinSteps steps a joint's threshold is at least kStepOverMedian x
// its median step and the pose step's at least kPoseStepOverMedian x the median pose step.
// Noise's steps spread little around their median (the pose step is a mean over joints; one
// joint's step, Maxwell-distributed, exceeds 4x its median with probability about 3e-8), and a
// real capture's medians are far below the thresholds, so its cuts do not change
// (docs/eval.md, "Noise and the split", has the measurements).
#include <cstdint>
#include <span>
#include <vector>

#include "core/status.hpp"
#include "core/tensor.hpp"

namespace mocap {

struct MotionSplitParams {
  double max_speed = 150.0;     // rad/s
  double max_step = 2.0;        // rad
  double min_pose_step = 0.2;   // rad, mean over joints
  double max_pose_speed = 4.5;  // rad/s, mean over joints

  Status validate() const;                         // all > 0 and finite
  double step_threshold(double frame_time) const;  // min(max_speed frame_time, max_step)
  // max(min_pose_step, max_pose_speed frame_time)
  double pose_step_threshold(double frame_time) const;
};

// Each joint's turn in a pose step counts up to this much (rad).
inline constexpr double kPoseStepJointClamp = 1.0;
// The pose step rule applies to clips with at least this many (not skipped) joints.
inline constexpr int kPoseStepMinJoints = 10;
// Header, "Noise": the thresholds' floors as multiples of the clip's median steps, applied from
// this many steps (fewer, and one jump would be much of the median).
inline constexpr double kStepOverMedian = 4.0;
inline constexpr double kPoseStepOverMedian = 1.5;
inline constexpr int kNoiseMinSteps = 8;

// Header, "Noise": factor x the median of `values` (reordered), the floor such a threshold rises
// to; 0 with fewer than kNoiseMinSteps values. Also the detour test's (kernels/pop_detour.hpp).
double noise_floor(double factor, std::vector<double>& values);

// One impossible step: frame t -> t + 1, at its fastest joint.
struct ImpossibleStep {
  int frame = 0;
  int joint = 0;
  double angle = 0;      // rad, of that joint
  double pose_step = 0;  // rad, the mean over joints
};

// Frames [begin, end) of a clip between impossible steps.
struct Segment {
  int begin = 0, end = 0;
  int frames() const { return end - begin; }
};

// The segments of [0, frames) cut after each step's frame (one segment when there is none;
// none for an empty clip).
std::vector<Segment> split_segments(int frames, const std::vector<ImpossibleStep>& steps);

// The impossible steps of `rotations`, in frame order, over the joints that `skip` (empty, or
// one entry per joint; any other size marks none) does not mark: flipping joints make such steps
// all the time without being motion. Requires valid params and frame_time > 0.
std::vector<ImpossibleStep> find_impossible_steps(RotationView rotations, double frame_time,
                                                  const MotionSplitParams& params,
                                                  std::span<const std::uint8_t> skip = {});

// Every joint's step angles geodesic(q[t][j], q[t+1][j]), [joint][step] (frames - 1 steps a
// joint): what classify_joint measures, kept so the test below need not measure it again.
struct StepAngles {
  std::span<const double> angles;
  int frames = 0, joints = 0;
  double at(int step, int joint) const {
    return angles[std::size_t(joint) * std::size_t(frames - 1) + std::size_t(step)];
  }
};

// The same steps from angles already measured (bit for bit what the overload above finds).
// `median_steps` (empty, or one per joint): each joint's median step angle when the caller has it
// already (JointQuality::median_step of the same angles), which is exactly the median the joint's
// noise floor takes.
std::vector<ImpossibleStep> find_impossible_steps(const StepAngles& angles, double frame_time,
                                                  const MotionSplitParams& params,
                                                  std::span<const std::uint8_t> skip = {},
                                                  std::span<const double> median_steps = {});

// Frames [begin, end) between impossible steps (default params) over the joints that `skip`
// does not mark.
std::vector<Segment> motion_segments(RotationView rotations, double frame_time,
                                     std::span<const std::uint8_t> skip);

}  // namespace mocap
