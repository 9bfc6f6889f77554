#include "kernels/position_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/quaternion.hpp"

namespace mocap {
namespace {

double mean(double sum, double n) {
  return n > 0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

Vec3 second_difference(TensorView<const float, 3> p, int t, int j) {
  return load_vec3(p.at(t + 1, j)) - 2.0 * load_vec3(p.at(t, j)) + load_vec3(p.at(t - 1, j));
}

FrameRange clamp(FrameRange r, int frames) {
  return {std::max(r.first, 0), std::min(r.last, frames)};
}

}  // namespace

void PositionSums::add(const PositionSums& o) {
  error += o.error;
  error_n += o.error_n;
  jitter_sq += o.jitter_sq;
  jitter_n += o.jitter_n;
  accel_error_sq += o.accel_error_sq;
  accel_n += o.accel_n;
  skate += o.skate;
  skate_n += o.skate_n;
}

double PositionSums::mpjpe() const {
  return mean(error, error_n);
}
double PositionSums::jitter() const {
  return std::sqrt(mean(jitter_sq, jitter_n));
}
double PositionSums::accel_error() const {
  return std::sqrt(mean(accel_error_sq, accel_n));
}
double PositionSums::skating() const {
  return mean(skate, skate_n);
}

void add_position_error(TensorView<const float, 3> result, TensorView<const float, 3> truth,
                        FrameRange range, PositionSums& sums) {
  if (!result.same_shape(truth)) return;
  const FrameRange r = clamp(range, result.frames);
  for (int t = r.first; t < r.last; ++t)
    for (int j = 0; j < result.joints; ++j) {
      sums.error += norm(load_vec3(result.at(t, j)) - load_vec3(truth.at(t, j)));
      sums.error_n += 1;
    }
}

void add_jitter(TensorView<const float, 3> positions, FrameRange range, PositionSums& sums) {
  const FrameRange r = clamp(range, positions.frames);
  for (int t = std::max(r.first, 1); t < std::min(r.last, positions.frames - 1); ++t)
    for (int j = 0; j < positions.joints; ++j) {
      const Vec3 a = second_difference(positions, t, j);
      sums.jitter_sq += dot(a, a);
      sums.jitter_n += 1;
    }
}

void add_acceleration_error(TensorView<const float, 3> result, TensorView<const float, 3> truth,
                            FrameRange range, PositionSums& sums) {
  if (!result.same_shape(truth)) return;
  const FrameRange r = clamp(range, result.frames);
  for (int t = std::max(r.first, 1); t < std::min(r.last, result.frames - 1); ++t)
    for (int j = 0; j < result.joints; ++j) {
      const Vec3 d = second_difference(result, t, j) - second_difference(truth, t, j);
      sums.accel_error_sq += dot(d, d);
      sums.accel_n += 1;
    }
}

void add_skating(TensorView<const float, 3> positions, int point,
                 const std::vector<ContactInterval>& contacts, FrameRange range,
                 PositionSums& sums) {
  if (point < 0 || point >= positions.joints) return;
  const FrameRange r = clamp(range, positions.frames);
  for (const ContactInterval& c : contacts)
    for (int t = std::max(c.begin, r.first); t + 1 < std::min(c.end, r.last); ++t) {
      const Vec3 a = load_vec3(positions.at(t, point)), b = load_vec3(positions.at(t + 1, point));
      const double dx = b.x - a.x, dz = b.z - a.z;
      sums.skate += std::sqrt(dx * dx + dz * dz);
      sums.skate_n += 1;
    }
}

int score_edge_frames(int frames, double frame_time) {
  return std::min(int(std::ceil(kScoreEdgeSeconds / frame_time)), frames / 4);
}

FrameRange scored_frames(int begin, int end, double frame_time) {
  const int edge = score_edge_frames(end - begin, frame_time);
  return {begin + edge, end - edge};
}

}  // namespace mocap
