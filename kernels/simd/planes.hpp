#pragma once
// The structure-of-arrays layout of the SIMD kernels: a curve of samples along time as planes of
// floats (w[], x[], y[], z[] for rotations), so that a vector holds consecutive frames of one
// joint (lanes = time; see docs/performance.md for why not lanes = joints).
#include <cstddef>

namespace mocap::simd {

// The widest float vector of any x86 target Highway compiles for (AVX-512: 16 lanes). Kernels
// read and write whole vectors, so every plane is padded by at least this many floats.
inline constexpr std::size_t kMaxLanes = 16;

// A plane length for n samples: n rounded up to whole vectors, plus one vector of slack for the
// unaligned reads at i + r.
inline constexpr std::size_t plane_size(std::size_t n) {
  return (n + kMaxLanes - 1) / kMaxLanes * kMaxLanes + kMaxLanes;
}

}  // namespace mocap::simd
