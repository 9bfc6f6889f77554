#include "kernels/motion_split.hpp"

#include <algorithm>
#include <cmath>

#include "core/format.hpp"
#include "core/quaternion.hpp"
#include "kernels/median.hpp"

namespace mocap {

Status MotionSplitParams::validate() const {
  if (!(max_speed > 0) || !std::isfinite(max_speed))
    return Status::error(format("max speed must be > 0 rad/s, got %g", max_speed));
  if (!(max_step > 0) || !std::isfinite(max_step))
    return Status::error(format("max step must be > 0 rad, got %g", max_step));
  if (!(min_pose_step > 0) || !std::isfinite(min_pose_step))
    return Status::error(format("min pose step must be > 0 rad, got %g", min_pose_step));
  if (!(max_pose_speed > 0) || !std::isfinite(max_pose_speed))
    return Status::error(format("max pose speed must be > 0 rad/s, got %g", max_pose_speed));
  return {};
}

double MotionSplitParams::step_threshold(double frame_time) const {
  return std::min(max_speed * frame_time, max_step);
}

double MotionSplitParams::pose_step_threshold(double frame_time) const {
  return std::max(min_pose_step, max_pose_speed * frame_time);
}

namespace {

// The test over step angles from `angle(t, j)`, joint by joint in order for each step. The
// thresholds rise with the clip's own steps (header, "Noise"): a joint's to kStepOverMedian x its
// median step, the pose step's to kPoseStepOverMedian x the median pose step.
template <typename Angle>
std::vector<ImpossibleStep> impossible_steps(int frames, int joints, const Angle& angle,
                                             double frame_time, const MotionSplitParams& params,
                                             std::span<const std::uint8_t> skip,
                                             std::span<const double> median_steps = {}) {
  std::vector<ImpossibleStep> steps;
  // A skip that is not one entry per joint marks none (as a misfit median_steps is measured).
  if (skip.size() != std::size_t(std::max(joints, 0))) skip = {};
  const auto counted_joint = [&](int j) { return skip.empty() || !skip[std::size_t(j)]; };
  std::vector<double> threshold(std::size_t(std::max(joints, 0)),
                                params.step_threshold(frame_time));
  double pose_threshold = params.pose_step_threshold(frame_time);
  if (frames - 1 >= kNoiseMinSteps) {  // else no floor: skip the pass
    std::vector<double> work(std::size_t(frames - 1)), pose(std::size_t(frames - 1), 0.0);
    int counted = 0;
    for (int j = 0; j < joints; ++j) {
      if (!counted_joint(j)) continue;
      ++counted;
      for (int t = 0; t + 1 < frames; ++t) {
        work[std::size_t(t)] = angle(t, j);
        pose[std::size_t(t)] += std::min(work[std::size_t(t)], kPoseStepJointClamp);
      }
      // noise_floor's factor x median; work holds frames - 1 >= kNoiseMinSteps values
      const double floor = median_steps.empty() ? noise_floor(kStepOverMedian, work)
                                                : kStepOverMedian * median_steps[std::size_t(j)];
      threshold[std::size_t(j)] = std::max(threshold[std::size_t(j)], floor);
    }
    if (counted > 0)  // the pose steps' sums: their median over counted is the means'
      pose_threshold = std::max(pose_threshold, noise_floor(kPoseStepOverMedian, pose) / counted);
  }
  for (int t = 0; t + 1 < frames; ++t) {
    ImpossibleStep worst{t, -1, 0.0, 0.0};
    double clamped_sum = 0;
    int counted = 0;
    bool over = false;
    for (int j = 0; j < joints; ++j) {
      if (!counted_joint(j)) continue;
      const double d = angle(t, j);
      if (d > worst.angle || worst.joint < 0) {
        worst.joint = j;
        worst.angle = d;
      }
      over = over || d > threshold[std::size_t(j)];
      clamped_sum += std::min(d, kPoseStepJointClamp);
      ++counted;
    }
    if (counted == 0) continue;
    worst.pose_step = clamped_sum / counted;
    const bool body_jump = counted >= kPoseStepMinJoints && worst.pose_step > pose_threshold;
    if (over || body_jump) steps.push_back(worst);
  }
  return steps;
}

}  // namespace

std::vector<ImpossibleStep> find_impossible_steps(RotationView rotations, double frame_time,
                                                  const MotionSplitParams& params,
                                                  std::span<const std::uint8_t> skip) {
  return impossible_steps(
      rotations.frames, rotations.joints,
      [&](int t, int j) {
        return geodesic(load_quat(rotations.at(t, j)), load_quat(rotations.at(t + 1, j)));
      },
      frame_time, params, skip);
}

std::vector<ImpossibleStep> find_impossible_steps(const StepAngles& angles, double frame_time,
                                                  const MotionSplitParams& params,
                                                  std::span<const std::uint8_t> skip,
                                                  std::span<const double> median_steps) {
  if (!median_steps.empty() && median_steps.size() != std::size_t(angles.joints))
    median_steps = {};  // not one per joint: measured here
  return impossible_steps(
      angles.frames, angles.joints, [&](int t, int j) { return angles.at(t, j); }, frame_time,
      params, skip, median_steps);
}

double noise_floor(double factor, std::vector<double>& values) {
  return values.size() >= std::size_t(kNoiseMinSteps) ? factor * median(values) : 0.0;
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
  return split_segments(rotations.frames,
                        find_impossible_steps(rotations, frame_time, MotionSplitParams{}, skip));
}

}  // namespace mocap
