#pragma once
// Log, Exp and the geodesic distance of quaternion.hpp over arrays of float samples, with the
// vector code every SIMD kernel uses (kernels/simd/quat_simd-inl.h), dispatched to the best
// Highway target of the machine. The building blocks of the fast kernels, exposed for their
// accuracy tests and micro-benchmarks.
#include <cstddef>
#include <span>
#include <string_view>

namespace mocap::simd {

// The Highway target the dispatcher runs on this machine now ("AVX2", "AVX3", ...).
std::string_view active_target();

// Samples as planes: q holds 4 planes of n floats (w[n], x[n], y[n], z[n]), a rotation vector 3
// (x[n], y[n], z[n]). Every sample goes through the same vector path, the last partial vector
// included, so out[i] does not depend on n or on i's position.
void log_planes(std::span<const float> q, std::span<float> out, std::size_t n);
void exp_planes(std::span<const float> v, std::span<float> out, std::size_t n);
void geodesic_planes(std::span<const float> a, std::span<const float> b, std::span<float> out,
                     std::size_t n);

}  // namespace mocap::simd
