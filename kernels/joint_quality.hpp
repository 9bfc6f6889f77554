#pragma once
// Which joints of a clip carry real motion. Real libraries hold joints that were never captured:
// constant ones, ones that move only by float rounding (a Daz conversion carries 22), and ones
// whose Euler channels flip the rotation by nearly pi every few frames (CMU 131_03's RThumb).
// Filters and the pop repair leave such joints alone, and the spec's noise estimate
// (../shared/spec/filters.md, "Noise level estimate") already excludes the non-moving ones by its
// median-step rule, kMovingJointStep; this classification uses the same rule so both agree.
//
// Rule, per joint, over the F - 1 frame-to-frame steps s_t = d(q_t, q_{t+1}) (spec "Conventions"):
//   flipping  when at least kFlippingMinSteps steps and a fraction kFlippingFraction of all steps
//             are >= kFlipStep rad. Real motion steps at most ~0.45 rad per frame (30 fps) and the
//             spec's pops at most 1 rad, so a step within 0.5 rad of pi is no motion; the count
//             keeps one synthetic first frame (the CMU converters' T-pose) from counting.
//   constant  otherwise, when the median step is exactly 0 (at least half the steps change
//   nothing); rounding  otherwise, when the median step is <= kMovingJointStep (1e-5 rad): float
//   rounding; moving    otherwise.
// Medians are robust to sparse pops: a clip with the spec's impulse noise classifies as its
// clean version does. A clip of one frame has no steps: every joint is constant.
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "core/tensor.hpp"

namespace mocap {

enum class JointClass { moving, constant, rounding, flipping };

// "moving", "constant", "rounding", "flipping".
std::string_view to_string(JointClass joint_class);

// Not motion: the joints a filter or the pop repair should leave as they came.
inline bool is_garbage(JointClass joint_class) {
  return joint_class != JointClass::moving;
}

inline constexpr double kFlipStep = 3.14159265358979323846 - 0.5;  // rad
inline constexpr double kFlippingFraction = 0.01;
inline constexpr int kFlippingMinSteps = 3;

struct JointQuality {
  JointClass joint_class = JointClass::constant;
  double median_step = 0;       // rad; median of an even count is the mean of the middle two
  double max_step = 0;          // rad
  int near_pi_steps = 0;        // steps >= kFlipStep
  double near_pi_fraction = 0;  // near_pi_steps / (F - 1); 0 when F == 1
};

// One entry per joint. Costs one geodesic distance per step and one nth_element per joint.
std::vector<JointQuality> classify_joints(RotationView rotations);
// Each joint's median_step, in joint order: what the noise estimate and the impossible-step
// split would otherwise take again of the same step angles.
std::vector<double> median_steps(std::span<const JointQuality> joints);
// 1 for each flipping joint, 0 for the others, in joint order: the mask the impossible-step
// split and the pop stage skip (a flip is not motion).
std::vector<std::uint8_t> flipping_joints(std::span<const JointQuality> joints);
// `steps` (optional, frames - 1 entries): receives the joint's step angles geodesic(q[t], q[t+1]),
// which the impossible-step test (kernels/motion_split.hpp, StepAngles) reads again.
JointQuality classify_joint(RotationView rotations, int joint, std::span<double> steps = {});

}  // namespace mocap
