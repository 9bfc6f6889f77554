#include "core/quaternion.hpp"

#include <algorithm>

namespace mocap {

Quat normalized(Quat q) {
  const double n = std::sqrt(dot(q, q));
  if (n == 0.0) return Quat{};
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}

Vec3 log(Quat q) {
  if (q.w < 0) q = negate(q);
  const Vec3 v{q.x, q.y, q.z};
  const double s = norm(v);
  // angle = 2 atan2(s, w); the factor angle / s tends to 2 / w as s -> 0.
  double factor;
  if (s < 1e-8) {
    factor = 2.0 / q.w * (1.0 - s * s / (3.0 * q.w * q.w));
  } else {
    factor = 2.0 * std::atan2(s, q.w) / s;
  }
  return factor * v;
}

Quat exp(Vec3 v) {
  const double theta = norm(v);
  const double half = 0.5 * theta;
  // sin(theta/2) / theta, with its series below 1e-4 (error < 1e-18).
  const double k = theta < 1e-4 ? 0.5 - theta * theta / 48.0 : std::sin(half) / theta;
  return {std::cos(half), k * v.x, k * v.y, k * v.z};
}

double geodesic(Quat a, Quat b) {
  const double s = dot(a, b) >= 0 ? 1.0 : -1.0;
  const double dw = a.w - s * b.w, dx = a.x - s * b.x, dy = a.y - s * b.y, dz = a.z - s * b.z;
  const double chord = std::sqrt(dw * dw + dx * dx + dy * dy + dz * dz);
  return 4.0 * std::asin(std::min(1.0, 0.5 * chord));
}

double angle(Quat q) {
  return geodesic(Quat{}, q);
}

Vec3 rotate(Quat q, Vec3 v) {
  const Quat p{0, v.x, v.y, v.z};
  const Quat r = q * p * inverse(q);
  return {r.x, r.y, r.z};
}

void make_hemisphere_continuous(RotationSpan rotations) {
  for (int t = 1; t < rotations.frames; ++t) {
    for (int j = 0; j < rotations.joints; ++j) {
      const float* prev = rotations.at(t - 1, j);
      float* cur = rotations.at(t, j);
      const double d = double(prev[0]) * cur[0] + double(prev[1]) * cur[1] +
                       double(prev[2]) * cur[2] + double(prev[3]) * cur[3];
      if (d < 0)
        for (int c = 0; c < 4; ++c) cur[c] = -cur[c];
    }
  }
}

}  // namespace mocap
