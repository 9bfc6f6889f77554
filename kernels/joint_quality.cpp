#include "kernels/joint_quality.hpp"

#include <algorithm>

#include "core/quaternion.hpp"
#include "kernels/median.hpp"
#include "kernels/noise_estimate.hpp"

namespace mocap {

std::string_view to_string(JointClass joint_class) {
  switch (joint_class) {
    case JointClass::moving:
      return "moving";
    case JointClass::constant:
      return "constant";
    case JointClass::rounding:
      return "rounding";
    case JointClass::flipping:
      return "flipping";
  }
  return "?";
}

std::vector<double> median_steps(std::span<const JointQuality> joints) {
  std::vector<double> medians;
  medians.reserve(joints.size());
  for (const JointQuality& q : joints) medians.push_back(q.median_step);
  return medians;
}

std::vector<std::uint8_t> flipping_joints(std::span<const JointQuality> joints) {
  std::vector<std::uint8_t> flipping;
  flipping.reserve(joints.size());
  for (const JointQuality& q : joints) flipping.push_back(q.joint_class == JointClass::flipping);
  return flipping;
}

JointQuality classify_joint(RotationView rotations, int joint, std::span<double> steps_out) {
  JointQuality quality;
  const int steps_count = rotations.frames - 1;
  if (steps_count < 1) return quality;
  std::vector<double> steps(std::size_t(steps_count), 0.0);
  Quat previous = load_quat(rotations.at(0, joint));
  for (int t = 0; t < steps_count; ++t) {
    const Quat next = load_quat(rotations.at(t + 1, joint));
    const double step = geodesic(previous, next);
    steps[std::size_t(t)] = step;
    quality.max_step = std::max(quality.max_step, step);
    quality.near_pi_steps += step >= kFlipStep;
    previous = next;
  }
  quality.near_pi_fraction = double(quality.near_pi_steps) / double(steps_count);
  if (steps_out.size() == steps.size()) std::copy(steps.begin(), steps.end(), steps_out.begin());

  quality.median_step = median(steps);

  if (quality.near_pi_steps >= kFlippingMinSteps && quality.near_pi_fraction >= kFlippingFraction)
    quality.joint_class = JointClass::flipping;
  else if (quality.median_step == 0)
    quality.joint_class = JointClass::constant;
  else if (quality.median_step <= kMovingJointStep)
    quality.joint_class = JointClass::rounding;
  else
    quality.joint_class = JointClass::moving;
  return quality;
}

std::vector<JointQuality> classify_joints(RotationView rotations) {
  std::vector<JointQuality> qualities(std::size_t(std::max(rotations.joints, 0)));
  for (int j = 0; j < rotations.joints; ++j)
    qualities[std::size_t(j)] = classify_joint(rotations, j);
  return qualities;
}

}  // namespace mocap
