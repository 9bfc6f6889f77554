// The linear filters' fast path (lee_shin_simd.hpp), compiled once per Highway target. Lanes =
// consecutive frames of one joint.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/lee_shin_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <utility>
#include <vector>

#include "hwy/highway.h"
#include "kernels/lee_shin.hpp"
#include "kernels/simd/curve_simd-inl.h"
#include "kernels/simd/lee_shin_simd.hpp"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {

// H(q_i) = q_i Exp(sum_{r=-k}^{k-1} b_r w_{i+r}) for t in [begin, end), b[r + k] = b_r.
void Pass(const std::vector<float>& b, Boundary boundary, CurvePlanes& p, int frames, int begin,
          int end) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t lanes = hn::Lanes(d), stride = p.stride, k = b.size() / 2;
  extend_planes(p, frames, int(k), boundary);
  const std::size_t first = std::size_t(begin), stop = VectorEnd(d, first, std::size_t(end));
  TangentSteps(d, p, first, stop + 2 * k);
  const float* w = p.steps.data();
  for (std::size_t c = first + k; c < stop + k; c += lanes) {
    Vec3V<V> acc{hn::Zero(d), hn::Zero(d), hn::Zero(d)};
    for (std::size_t i = 0; i < 2 * k; ++i) {  // r = i - k
      const V coefficient = hn::Set(d, b[i]);
      const Vec3V<V> step = LoadVec3(d, w, stride, c + i - k);
      acc = {hn::MulAdd(coefficient, step.x, acc.x), hn::MulAdd(coefficient, step.y, acc.y),
             hn::MulAdd(coefficient, step.z, acc.z)};
    }
    StoreDisplaced(d, p, c, k, acc);
  }
}

void LeeShinCurve(const double* mask, std::size_t mask_size, int passes, Boundary boundary,
                  CurvePlanes& p, int frames, int begin, int end) {
  if (frames == 1 || passes < 1) {
    for (std::size_t c = 0; c < 4; ++c)
      for (int t = begin; t < end; ++t)
        p.output[c * p.stride + std::size_t(t)] = p.input[c * p.stride + std::size_t(t)];
    return;
  }
  // The coefficients in double, as the reference, then rounded once.
  const std::vector<double> b = lee_shin_coefficients(std::span<const double>(mask, mask_size));
  const std::vector<float> coefficients(b.begin(), b.end());
  for (int pass = 0; pass < passes; ++pass) {
    const bool last = pass + 1 == passes;
    Pass(coefficients, boundary, p, frames, last ? begin : 0, last ? end : frames);
    if (!last) std::swap(p.input, p.output);
  }
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(LeeShinCurve);

void lee_shin_curve(std::span<const double> mask, int passes, Boundary boundary,
                    CurvePlanes& planes, int frames, int begin, int end) {
  HWY_DYNAMIC_DISPATCH(LeeShinCurve)
  (mask.data(), mask.size(), passes, boundary, planes, frames, begin, end);
}

void lee_shin_rotations(std::span<const double> mask, int passes, Boundary boundary,
                        const MotionIO& io) {
  const int frames = io.rotations.frames;
  CurvePlanes planes;
  planes.reserve(frames, int(mask.size() / 2), 0);
  for_each_joint_curve(io, planes, [&](CurvePlanes& p) {
    lee_shin_curve(mask, passes, boundary, p, frames, io.frame_begin, io.frame_stop());
  });
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
