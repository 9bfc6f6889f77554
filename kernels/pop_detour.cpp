#include "kernels/pop_detour.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mocap {

double pop_detour(const Quat& before, const Quat& at, const Quat& after) {
  return pop_detour(geodesic(before, at), geodesic(at, after), geodesic(before, after));
}

double pop_detour_threshold(double frame_time) {
  const double scale = kPopDetourFps * frame_time;
  return scale > 1 ? kPopDetour * scale * scale : kPopDetour;
}

Status PopDetourJob::validate() const {
  if (Status s = validate_sample_flags("pop detour test", rotations, skip, flags); !s) return s;
  if (!(threshold > 0) || !std::isfinite(threshold))
    return Status::error("pop detour test: threshold must be a finite angle > 0 rad");
  if (Status s = validate_joint_slice("pop detour test", joint_begin, joint_end, rotations.joints);
      !s)
    return s;
  if (steps && (steps->joints != rotations.joints || step_offset < 0 ||
                (rotations.frames > 1 && step_offset + rotations.frames > steps->frames)))
    return Status::error("pop detour test: the step angles do not cover the rotations' frames");
  if (!median_detours.empty() && median_detours.size() != std::size_t(rotations.joints))
    return Status::error("pop detour test: median_detours must have one entry per joint");
  return {};
}

Status PopDetourJob::run() const {
  if (Status s = validate(); !s) return s;
  const int F = rotations.frames, J = rotations.joints;
  const int end = joint_end < 0 ? J : joint_end;
  std::vector<double> step(std::size_t(std::max(F - 1, 0))), detour(std::size_t(std::max(F, 0))),
      work;
  for (int j = joint_begin; j < end; ++j) {
    if (!skip.empty() && skip[std::size_t(j)]) continue;
    for (int t = 0; t + 1 < F; ++t)
      step[std::size_t(t)] =
          steps ? steps->at(step_offset + t, j)
                : geodesic(load_quat(rotations.at(t, j)), load_quat(rotations.at(t + 1, j)));
    for (int t = 1; t + 1 < F; ++t)
      detour[std::size_t(t)] = pop_detour(
          step[std::size_t(t - 1)], step[std::size_t(t)],
          geodesic(load_quat(rotations.at(t - 1, j)), load_quat(rotations.at(t + 1, j))));
    // Header, "Noise": at least kDetourOverMedian x the joint's median detour.
    work.clear();  // E(t) of 1 <= t < F - 1
    if (F > 2) work.assign(detour.begin() + 1, detour.begin() + (F - 1));
    const double median_detour = noise_floor(1.0, work);
    if (!median_detours.empty()) median_detours[std::size_t(j)] = median_detour;
    const double limit = std::max(threshold, kDetourOverMedian * median_detour);
    for (int t = 2; t + 2 < F; ++t) {
      const double e = detour[std::size_t(t)];
      if (!(e > limit) || e < detour[std::size_t(t - 1)] || !(e > detour[std::size_t(t + 1)]))
        continue;
      flags[std::size_t(t) * std::size_t(J) + std::size_t(j)] = 1;
    }
  }
  return {};
}

}  // namespace mocap
