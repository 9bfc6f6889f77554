#include "kernels/joint_motion.hpp"

#include <algorithm>

#include "core/quaternion.hpp"

namespace mocap {

std::vector<double> lagged_acceleration_power(RotationView rotations, int lag,
                                              std::span<const Segment> segments) {
  std::vector<double> power(std::size_t(std::max(rotations.joints, 0)), 0.0);
  if (rotations.empty() || lag < 1) return power;
  const Segment whole{0, rotations.frames};
  const std::span<const Segment> ranges = segments.empty() ? std::span(&whole, 1) : segments;
  std::vector<Vec3> steps;
  for (int j = 0; j < rotations.joints; ++j) {
    double sum = 0;
    long count = 0;
    for (const Segment& seg : ranges) {
      const int n = seg.frames() - 2 * lag;  // t in [begin, begin + n)
      if (n <= 0) continue;
      steps.resize(std::size_t(seg.frames() - lag));
      for (int t = seg.begin; t + lag < seg.end; ++t)
        steps[std::size_t(t - seg.begin)] =
            log(inverse(load_quat(rotations.at(t, j))) * load_quat(rotations.at(t + lag, j)));
      for (int i = 0; i < n; ++i) {
        const Vec3 a = steps[std::size_t(i + lag)] - steps[std::size_t(i)];
        sum += dot(a, a);
      }
      count += 3L * n;
    }
    power[std::size_t(j)] = count > 0 ? sum / double(count) : 0.0;
  }
  return power;
}

}  // namespace mocap
