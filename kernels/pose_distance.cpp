#include "kernels/pose_distance.hpp"

#include <algorithm>
#include <limits>

namespace mocap {

std::optional<NlpmSpace> parse_nlpm_space(std::string_view name) {
  if (name == "tangent") return NlpmSpace::tangent;
  if (name == "log") return NlpmSpace::log;
  return std::nullopt;
}

std::string_view to_string(NlpmSpace space) {
  return space == NlpmSpace::tangent ? "tangent" : "log";
}

void PoseTrack::load(RotationView rotations, std::span<const int> distance_joints,
                     Boundary boundary, NlpmSpace space, long first, long count, double cap) {
  first_ = first;
  count_ = count;
  joints_ = int(distance_joints.size());
  space_ = space;
  cap_squared_ = cap > 0 ? cap * cap : std::numeric_limits<double>::infinity();
  samples_.resize(std::size_t(count) * std::size_t(joints_));
  for (long i = 0; i < count; ++i) {
    for (int k = 0; k < joints_; ++k) {
      const Quat q = extended_rotation(rotations, distance_joints[k], first + i, boundary);
      Quat& sample = samples_[std::size_t(i) * std::size_t(joints_) + std::size_t(k)];
      if (space == NlpmSpace::tangent) {
        sample = q;
      } else {
        const Vec3 v = log(q);
        sample = {0.0, v.x, v.y, v.z};
      }
    }
  }
}

double PoseTrack::distance(long u, long v) const {
  const Quat* a = samples_.data() + std::size_t(u - first_) * std::size_t(joints_);
  const Quat* b = samples_.data() + std::size_t(v - first_) * std::size_t(joints_);
  double sum = 0;
  if (space_ == NlpmSpace::tangent) {
    for (int k = 0; k < joints_; ++k) {
      const double d = geodesic(a[k], b[k]);
      sum += std::min(d * d, cap_squared_);
    }
  } else {
    // Differences of Log vectors: a - b and b - a square to the same value, so e stays symmetric.
    for (int k = 0; k < joints_; ++k) {
      const double dx = a[k].x - b[k].x, dy = a[k].y - b[k].y, dz = a[k].z - b[k].z;
      sum += dx * dx + dy * dy + dz * dz;
    }
  }
  return sum / double(joints_);
}

void PoseDistanceBand::compute(const PoseTrack& track, long u_begin, long u_end, int max_delta) {
  u_begin_ = u_begin;
  u_end_ = u_end;
  max_delta_ = max_delta;
  const std::size_t width = std::size_t(max_delta) + 1;
  values_.resize(std::size_t(u_end - u_begin) * width);
  for (long u = u_begin; u < u_end; ++u) {
    double* row = values_.data() + std::size_t(u - u_begin) * width;
    row[0] = 0.0;  // e(u, u)
    for (int delta = 1; delta <= max_delta; ++delta) row[delta] = track.distance(u, u + delta);
  }
}

}  // namespace mocap
