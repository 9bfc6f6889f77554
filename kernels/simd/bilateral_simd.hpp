#pragma once
// The fast path of bof (../shared/spec/filters.md, "Bilateral orientation filter"): the same
// passes as kernels/bilateral.cpp in float32 vectors of consecutive frames of one joint, with
// Highway dynamic dispatch. Agrees with the reference within float rounding (tests/
// simd_kernels_test.cpp); each output sample is bit-identical whatever slice computed it.
#include "kernels/bilateral.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/simd/curve_planes.hpp"

namespace mocap::simd {

// The widest reach the fast path takes: it keeps k rows of range weights per joint (k x F floats),
// so BilateralJob runs wider windows (sigma_t above 21 frames) on the reference.
inline constexpr int kBilateralMaxFastReach = 64;

// All params.iterations passes of bof over one joint's curve in planes.input (frames samples);
// writes planes.output[begin, end). planes must be reserved for (frames, params.reach(),
// params.reach()).
void bilateral_curve(const BilateralParams& params, CurvePlanes& planes, int frames, int begin,
                     int end);

// The rotations of io's output slice (translations are the caller's). Expects valid params / io.
void bilateral_rotations(const BilateralParams& params, const MotionIO& io);

}  // namespace mocap::simd
