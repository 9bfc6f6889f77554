#pragma once
// The fast path of the linear orientation filters (../shared/spec/filters.md, "Lee-Shin
// construction": gaussian, butterworth, moving-mean): the passes of lee_shin_pass in float32
// vectors of consecutive frames of one joint, with Highway dynamic dispatch. Each output sample
// is bit-identical whatever slice computed it.
#include <span>

#include "kernels/boundary.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/simd/curve_planes.hpp"

namespace mocap::simd {

// `passes` Lee-Shin passes with `mask` (size 2k+1, sum 1) over one joint's curve in planes.input;
// writes planes.output[begin, end). planes must be reserved for (frames, k, 0).
void lee_shin_curve(std::span<const double> mask, int passes, Boundary boundary,
                    CurvePlanes& planes, int frames, int begin, int end);

// The rotations of io's output slice (translations are the caller's).
void lee_shin_rotations(std::span<const double> mask, int passes, Boundary boundary,
                        const MotionIO& io);

}  // namespace mocap::simd
