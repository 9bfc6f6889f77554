#include "kernels/noise_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/median.hpp"
#include "kernels/point_smoothing.hpp"

namespace mocap {

NoiseEstimate estimate_noise(RotationView rotations, std::span<const std::uint8_t> skip_joints,
                             std::span<const double> median_steps) {
  const int frames = rotations.frames;
  NoiseEstimate result;
  if (rotations.empty() || frames < 3) return result;

  // Spans that are not one entry per joint are left out (header): never read past their end.
  const std::size_t J = std::size_t(rotations.joints);
  if (skip_joints.size() != J) skip_joints = {};
  if (median_steps.size() != J) median_steps = {};
  std::vector<Vec3> steps(std::size_t(frames) - 1);
  std::vector<double> work, components, joint_sigmas;
  for (int j = 0; j < rotations.joints; ++j) {
    if (!skip_joints.empty() && skip_joints[std::size_t(j)]) continue;
    const bool known = !median_steps.empty();
    if (known && !(median_steps[std::size_t(j)] > kMovingJointStep)) continue;
    work.clear();
    for (int t = 0; t + 1 < frames; ++t) {
      const Quat a = load_quat(rotations.at(t, j)), b = load_quat(rotations.at(t + 1, j));
      steps[std::size_t(t)] = log(inverse(a) * b);
      if (!known) work.push_back(geodesic(a, b));
    }
    if (!known && !(median(work) > kMovingJointStep)) continue;

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

namespace mocap {

TranslationNoise estimate_translation_noise(TranslationView translations,
                                            std::span<const std::uint8_t> translated_joints,
                                            double frame_time) {
  TranslationNoise out;
  const int frames = translations.frames;
  if (translations.empty() || frames < 4 || !(frame_time > 0)) return out;
  const double smoothing = 0.1 / frame_time;        // frames
  const int reach = int(std::ceil(3 * smoothing));  // smooth_mirrored's
  for (int j = 0; j < translations.joints; ++j) {
    if (std::size_t(j) >= translated_joints.size() || translated_joints[std::size_t(j)] == 0)
      continue;
    std::vector<double> c;
    c.reserve(std::size_t(frames) * 3);
    for (int t = 1; t + 2 < frames; ++t)
      for (int k = 0; k < 3; ++k)
        c.push_back(translations.at(t + 2, j)[k] - 3.0 * translations.at(t + 1, j)[k] +
                    3.0 * translations.at(t, j)[k] - translations.at(t - 1, j)[k]);
    std::vector<double> scratch = c;
    const double centre = median(scratch);
    for (double& v : c) v = std::abs(v - centre);
    const double sigma = 1.4826 * median(c) / std::sqrt(20.0);
    if (!(sigma > out.sigma) && out.sigma > 0) continue;
    // The smoothed trajectory (mirrored at the ends), then its RMS second difference.
    std::vector<Vec3> points(static_cast<std::size_t>(frames));
    for (int t = 0; t < frames; ++t) points[std::size_t(t)] = load_vec3(translations.at(t, j));
    const std::vector<Vec3> smooth = smooth_mirrored(points, smoothing);
    double sum = 0;
    int n = 0;
    // Away from the ends, where the mirror folds the trajectory back.
    for (int t = std::max(1, reach); t + 1 < frames - reach; ++t) {
      const Vec3 a =
          smooth[std::size_t(t + 1)] - 2.0 * smooth[std::size_t(t)] + smooth[std::size_t(t - 1)];
      sum += dot(a, a);
      n += 3;
    }
    out.sigma = sigma;
    out.accel = n > 0 ? std::sqrt(sum / n) : -1.0;
  }
  return out;
}

}  // namespace mocap
