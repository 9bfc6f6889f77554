#pragma once
// The quaternion core of ../shared/spec/filters.md, "Conventions": unit quaternions (w, x, y, z),
// Hamilton product, Log/Exp as full-angle rotation vectors, the geodesic distance.
// Double precision; tensors are stored as float and converted at load/store.
#include <cmath>

#include "core/tensor.hpp"

namespace mocap {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};

struct Quat {
  double w = 1, x = 0, y = 0, z = 0;
};

inline constexpr double kPi = 3.14159265358979323846;

inline Vec3 operator+(Vec3 a, Vec3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline Vec3 operator-(Vec3 a, Vec3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline Vec3 operator*(double s, Vec3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
inline Vec3& operator+=(Vec3& a, Vec3 b) {
  return a = a + b;
}
inline double dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline double norm(Vec3 a) {
  return std::sqrt(dot(a, a));
}

inline double dot(Quat a, Quat b) {
  return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
}
inline Quat negate(Quat q) {
  return {-q.w, -q.x, -q.y, -q.z};
}

// Hamilton product a * b: rotate by b first, then by a.
inline Quat operator*(Quat a, Quat b) {
  return {
      a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
      a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

// Inverse of a unit quaternion (its conjugate).
inline Quat inverse(Quat q) {
  return {q.w, -q.x, -q.y, -q.z};
}

Quat normalized(Quat q);

// Log(q): rotation vector, axis * angle, angle in [0, pi] (q is taken with w >= 0 first).
// Accurate near 0 (series) and near pi (atan2), where the axis is ambiguous.
Vec3 log(Quat q);

// Exp(v) = (cos(|v|/2), sin(|v|/2) v/|v|), accurate for |v| -> 0.
Quat exp(Vec3 v);

// Geodesic distance: the angle of a^-1 b in [0, pi], as 4 asin(|a - s b| / 2), s = sign(a.b),
// which stays accurate for small angles (2 acos|a.b| does not).
double geodesic(Quat a, Quat b);

// Rotation angle of q in [0, pi].
double angle(Quat q);

// The rotation of vector v by q.
Vec3 rotate(Quat q, Vec3 v);

inline Quat load_quat(const float* p) {
  return {p[0], p[1], p[2], p[3]};
}
inline void store_quat(Quat q, float* p) {
  p[0] = float(q.w);
  p[1] = float(q.x);
  p[2] = float(q.y);
  p[3] = float(q.z);
}
inline Vec3 load_vec3(const float* p) {
  return {p[0], p[1], p[2]};
}
inline void store_vec3(Vec3 v, float* p) {
  p[0] = float(v.x);
  p[1] = float(v.y);
  p[2] = float(v.z);
}

// Spec "Sign continuity": q_t := -q_t when q_t . q_{t-1} < 0, joint by joint along time.
void make_hemisphere_continuous(RotationSpan rotations);

}  // namespace mocap
