#include "kernels/noise_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "kernels/median.hpp"
#include "kernels/quaternion.hpp"

namespace mocap {

NoiseEstimate estimate_noise(RotationView rotations, std::span<const std::uint8_t> skip_joints) {
  const int frames = rotations.frames;
  NoiseEstimate result;
  if (rotations.empty() || frames < 3) return result;

  std::vector<Vec3> steps(std::size_t(frames) - 1);
  std::vector<double> work, components, joint_sigmas;
  for (int j = 0; j < rotations.joints; ++j) {
    if (!skip_joints.empty() && skip_joints[std::size_t(j)]) continue;
    work.clear();
    for (int t = 0; t + 1 < frames; ++t) {
      const Quat a = load_quat(rotations.at(t, j)), b = load_quat(rotations.at(t + 1, j));
      steps[std::size_t(t)] = log(inverse(a) * b);
      work.push_back(geodesic(a, b));
    }
    if (!(median(work) > kMovingJointStep)) continue;

    components.clear();
    for (std::size_t t = 1; t < steps.size(); ++t) {
      const Vec3 c = steps[t] - steps[t - 1];
      components.insert(components.end(), {c.x, c.y, c.z});
    }
    work = components;
    const double center = median(work);
    for (double& c : components) c = std::abs(c - center);
    joint_sigmas.push_back(1.4826 * median(components) / std::sqrt(6.0));
  }
  if (joint_sigmas.empty()) return result;
  result.moving_joints = int(joint_sigmas.size());
  result.sigma = median(joint_sigmas);
  return result;
}

}  // namespace mocap
