#include "kernels/motion_split.hpp"

#include <algorithm>
#include <cmath>

#include "core/format.hpp"
#include "core/quaternion.hpp"

namespace mocap {

Status MotionSplitParams::validate() const {
  if (!(max_speed > 0) || !std::isfinite(max_speed))
    return Status::error(format("max speed must be > 0 rad/s, got %g", max_speed));
  if (!(max_step > 0) || !std::isfinite(max_step))
    return Status::error(format("max step must be > 0 rad, got %g", max_step));
  return {};
}

double MotionSplitParams::step_threshold(double frame_time) const {
  return std::min(max_speed * frame_time, max_step);
}

std::vector<ImpossibleStep> find_impossible_steps(RotationView rotations, double frame_time,
                                                  const MotionSplitParams& params) {
  std::vector<ImpossibleStep> steps;
  const double threshold = params.step_threshold(frame_time);
  for (int t = 0; t + 1 < rotations.frames; ++t) {
    ImpossibleStep worst{t, -1, 0.0};
    for (int j = 0; j < rotations.joints; ++j) {
      const double d = geodesic(load_quat(rotations.at(t, j)), load_quat(rotations.at(t + 1, j)));
      if (d > threshold && d > worst.angle) worst = {t, j, d};
    }
    if (worst.joint >= 0) steps.push_back(worst);
  }
  return steps;
}

std::vector<Segment> split_segments(int frames, const std::vector<ImpossibleStep>& steps) {
  std::vector<Segment> segments;
  int begin = 0;
  for (const ImpossibleStep& s : steps) {
    segments.push_back({begin, s.frame + 1});
    begin = s.frame + 1;
  }
  if (begin < frames) segments.push_back({begin, frames});
  return segments;
}

std::vector<Segment> motion_segments(RotationView rotations, double frame_time,
                                     std::span<const std::uint8_t> skip) {
  const double limit = MotionSplitParams{}.step_threshold(frame_time);
  std::vector<ImpossibleStep> steps;
  for (int t = 0; t + 1 < rotations.frames; ++t)
    for (int j = 0; j < rotations.joints; ++j) {
      if (!skip.empty() && skip[std::size_t(j)]) continue;
      const double angle =
          geodesic(load_quat(rotations.at(t, j)), load_quat(rotations.at(t + 1, j)));
      if (angle > limit) {
        steps.push_back({t, j, angle});
        break;
      }
    }
  return split_segments(rotations.frames, steps);
}

}  // namespace mocap
