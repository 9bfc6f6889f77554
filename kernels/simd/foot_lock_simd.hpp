#pragma once
// The data-parallel parts of FootLockJob's fast path (kernels/foot_lock.hpp), with Highway
// dynamic dispatch, in double: lanes are the frames the lock touches, stored as planes (one array
// of `stride` doubles per coordinate; stride >= n rounded up to kFootLockPad, the padding lanes
// computed and ignored). Same formulas as the scalar reference in kernels/foot_lock.cpp; their
// rounding differs (fused multiply-adds, Highway's acos, the IK's normalization by a series), far
// below the float the rotations are stored in.
#include <cstddef>

#include "core/quaternion.hpp"

namespace mocap::simd {

inline constexpr std::size_t kFootLockPad = 16;

// The local rotations of `count` joints at n frames, from rows of frame_floats floats (a
// rotation tensor [F][J][4]) into planes: joint s's component k at out + (4 s + k) stride.
void gather_rotations(const float* data, std::size_t frame_floats, const int* frames, std::size_t n,
                      const int* joints, std::size_t count, double* out, std::size_t stride);

// One joint's forward kinematics step over n frames: rot = parent_rot * q, pos = parent_pos +
// parent_rot (local) parent_rot^-1, local the planes `local` or, when null, the constant offset.
// rot and q: 4 planes (w, x, y, z); positions: 3 planes (x, y, z).
void chain_step(const double* parent_rot, const double* parent_pos, const double* q,
                const double* local, Vec3 offset, double* rot, double* pos, std::size_t n,
                std::size_t stride);

// Per frame, once, for one leg (header "Target", "IK", "Reach"): from the filtered hip, knee and
// ankle positions and the offset's horizontal part (ox, oz): u = knee - hip, v = ankle - knee,
// len = (l1, l2, reach L), cos_f and theta_f the knee's interior angle, normal = (u x (ankle -
// hip)) / |.| and bent = 1 where that normal is defined (else 0, normal 0), to_target = ankle +
// (ox, v, oz) - hip and its squared length (distance), v the target's lift (header "Lift"; 0
// when lift is 0).
struct LegGeometry {
  const double *hip, *knee, *ankle, *ox, *oz;  // inputs (3, 3, 3, 1, 1 planes)
  double *u, *v, *len, *cos_f, *theta_f, *normal, *bent, *to_target, *distance;
};
void leg_geometry(const LegGeometry& g, double max_reach, double lift, std::size_t n,
                  std::size_t stride);

// The IK's wanted knee cosine (header "IK") once the hip is lowered by drop: to_target's y is
// raised by drop (in place), d = |to_target| clamped to [|l1 - l2| (1 + tiny), reach], cos1 =
// (l1^2 + l2^2 - d^2) / (2 l1 l2) clamped to [-1, 1], theta1 = acos(cos1); only in the vectors
// with a lane where solve[i] (the others are left unwritten, and leg_ik skips the same ones).
void leg_knee_cosine(double* to_target, const double* drop, const double* len, double* cos1,
                     double* theta1, const unsigned char* solve, std::size_t n, std::size_t stride);

// acos of each of n values clamped to [-1, 1] (in and out padded to a multiple of kFootLockPad).
void acos_planes(const double* in, double* out, std::size_t n);

// The IK of one leg at n frames (header "IK"): inputs u = knee - hip, v = ankle - knee, the
// bend-plane normal, cos0 / cos1 the cosines of the knee's interior angle before / after,
// to_target = target - hip, the global rotations of the hip's parent, hip, knee and ankle (4
// planes each). Output, where solve[i]: the local rotations of hip, knee and ankle, normalized,
// each on the hemisphere of `original` (the local rotation it replaces, as gathered), written as
// floats into the rotation tensor (row frames[i], joint joints[k]): the IK's lanes go straight
// to the tensor instead of through 12 planes and a scalar pass.
struct LegIkPlanes {
  const double *u, *v, *normal, *cos0, *cos1, *to_target;
  const double *parent, *hip, *knee, *ankle;
  const double* original[3];
  const unsigned char* solve;
  float* rotations;
  std::size_t frame_floats;
  const int* frames;
  int joints[3];
};
void leg_ik(const LegIkPlanes& k, std::size_t n, std::size_t stride);

}  // namespace mocap::simd
