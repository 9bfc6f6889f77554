#pragma once
// ForwardKinematicsJob's fast path (kernels/forward_kinematics.hpp), with Highway dynamic
// dispatch, in double: lanes are frames, stored as planes (one array of `stride` doubles per
// coordinate; n is a multiple of kForwardKinematicsPad, the padding lanes computed and ignored).
// Each lane does the scalar reference's IEEE operations in the reference's order: the Hamilton
// product of core/quaternion.hpp term by term, a rotation as (q p) q^-1 with p = (0, v) (the zero
// products included: they decide a signed zero), no fused multiply-add (-ffp-contract=off for
// these sources; the scalar build targets baseline x86-64). So the two agree to the bit
// (tests/kernels/forward_kinematics_test.cpp), and the engine's positions, contacts and locks do
// not depend on which path computed them.
#include <cstddef>

#include "core/quaternion.hpp"

namespace mocap::simd {

// The lanes of the widest double vector of any x86 target (AVX-512).
inline constexpr std::size_t kForwardKinematicsPad = 8;

// One joint over n frames. A joint's frame is 7 planes: its global rotation (w, x, y, z) and
// global position (x, y, z). rotation: the local rotation's 4 planes; translation: 3 planes of
// the per-frame local translation, or null for the constant offset. parent: the parent's 7
// planes, or null for a root (its frame is then its local rotation and translation).
void forward_kinematics_joint(const double* parent, const double* rotation,
                              const double* translation, Vec3 offset, double* joint, std::size_t n,
                              std::size_t stride);

// A point fixed to a joint (an End Site): position + rotation (offset) over n frames, into 3
// planes.
void forward_kinematics_site(const double* joint, Vec3 offset, double* point, std::size_t n,
                             std::size_t stride);

}  // namespace mocap::simd
