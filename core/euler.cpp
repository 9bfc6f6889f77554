#include "core/euler.hpp"

#include <cmath>
#include <cstdlib>

namespace mocap {
namespace {

constexpr int kAxes[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

Quat axis_rotation(int axis, double angle) {
  Quat q{std::cos(0.5 * angle), 0, 0, 0};
  const double s = std::sin(0.5 * angle);
  if (axis == 0) q.x = s;
  if (axis == 1) q.y = s;
  if (axis == 2) q.z = s;
  return q;
}

using Matrix = std::array<std::array<double, 3>, 3>;

Matrix to_matrix(Quat q) {
  const double w = q.w, x = q.x, y = q.y, z = q.z;
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
           {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
           {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}

// Signed rotation angle of q about a coordinate axis (q is a rotation about that axis).
double angle_about(int axis, Quat q) {
  const double comp = axis == 0 ? q.x : axis == 1 ? q.y : q.z;
  return 2.0 * std::atan2(comp, q.w);
}

double wrap_near(double value, double target) {
  const double two_pi = 2.0 * kPi;
  return value + two_pi * std::round((target - value) / two_pi);
}

}  // namespace

int order_axis(RotationOrder order, int i) {
  return kAxes[int(order)][i];
}

std::string_view to_string(RotationOrder order) {
  constexpr std::string_view names[6] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};
  return names[int(order)];
}

RotationOrder order_from_axes(int a0, int a1, int a2) {
  for (int o = 0; o < 6; ++o)
    if (kAxes[o][0] == a0 && kAxes[o][1] == a1 && kAxes[o][2] == a2) return RotationOrder(o);
  std::abort();  // callers pass a permutation of {0, 1, 2}
}

Quat euler_to_quat(RotationOrder order, const EulerAngles& angles) {
  const int* axes = kAxes[int(order)];
  return axis_rotation(axes[0], angles[0]) * axis_rotation(axes[1], angles[1]) *
         axis_rotation(axes[2], angles[2]);
}

EulerAngles quat_to_euler(RotationOrder order, Quat q, const std::optional<EulerAngles>& previous) {
  const int i = kAxes[int(order)][0], j = kAxes[int(order)][1], k = kAxes[int(order)][2];
  // Even permutations of (x, y, z) have sign +1. For R = R_i(a) R_j(b) R_k(c):
  // R[i][k] = sgn sin b, R[j][k] / R[k][k] and R[i][j] / R[i][i] give a and c.
  const double sgn =
      (order == RotationOrder::XYZ || order == RotationOrder::YZX || order == RotationOrder::ZXY)
          ? 1.0
          : -1.0;
  const Matrix r = to_matrix(normalized(q));
  const double cos_b = std::hypot(r[i][i], r[i][j]);
  double b = std::atan2(sgn * r[i][k], cos_b);
  double a, c;
  if (cos_b > 1e-7) {
    a = std::atan2(-sgn * r[j][k], r[k][k]);
    c = std::atan2(-sgn * r[i][j], r[i][i]);
  } else {
    // Gimbal lock: only a combination of a and c is defined. Keep c and solve a exactly from
    // R_i(a) = q R_k(c)^-1 R_j(b)^-1.
    c = previous ? (*previous)[2] : 0.0;
    const Quat rest = normalized(q) * inverse(axis_rotation(k, c)) * inverse(axis_rotation(j, b));
    a = angle_about(i, rest);
  }
  if (!previous) return {a, b, c};
  // The other solution of the same rotation is (a + pi, pi - b, c + pi); take the one nearest
  // the previous frame after shifting each angle by multiples of 2 pi.
  const EulerAngles& p = *previous;
  EulerAngles first{wrap_near(a, p[0]), wrap_near(b, p[1]), wrap_near(c, p[2])};
  EulerAngles second{wrap_near(a + kPi, p[0]), wrap_near(kPi - b, p[1]), wrap_near(c + kPi, p[2])};
  auto distance = [&](const EulerAngles& e) {
    return std::abs(e[0] - p[0]) + std::abs(e[1] - p[1]) + std::abs(e[2] - p[2]);
  };
  return distance(second) < distance(first) ? second : first;
}

}  // namespace mocap
