// bof's fast path (bilateral_simd.hpp), compiled once per Highway target. Lanes = consecutive
// frames of one joint.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/bilateral_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <cmath>
#include <utility>
#include <vector>

#include "hwy/highway.h"
#include "kernels/simd/bilateral_simd.hpp"
#include "kernels/simd/curve_simd-inl.h"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {

// The pass-independent constants of the mask
//   m_r = temporal_r exp(-range_scale x_r),  x_r = d_r^2 (gaussian) or d_r / 2 (paper).
struct MaskConstants {
  int k = 0;
  bool paper = false;
  float range_scale = 0;
  std::vector<float> temporal;  // [2k + 1], temporal[r + k]
};

MaskConstants Constants(const BilateralParams& params) {
  MaskConstants c;
  c.k = params.reach();
  c.paper = params.kernel == BilateralKernel::paper;
  const double sigma = c.paper ? params.sigma_g / 2 : params.sigma_g;
  c.range_scale = float(1.0 / (2 * sigma * sigma));
  for (int r = -c.k; r <= c.k; ++r) {
    const double x = c.paper ? std::abs(double(r)) : double(r) * r;
    c.temporal.push_back(float(std::exp(-x / (2 * params.sigma_t * params.sigma_t))));
  }
  return c;
}

// One bof pass: output[t] for t in [begin, end) from planes.input (frames samples).
void Pass(const MaskConstants& mc, Boundary boundary, CurvePlanes& p, int frames, int begin,
          int end) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t lanes = hn::Lanes(d), stride = p.stride, k = std::size_t(mc.k);
  extend_planes(p, frames, mc.k, boundary);
  // Extended index c = t + k is sample t. The centres c run over whole vectors from begin + k;
  // they read steps w_{c+r}, r in [-k, k), and range rows at c and c - r.
  const std::size_t first = std::size_t(begin), stop = VectorEnd(d, first, std::size_t(end));
  TangentSteps(d, p, first, stop + 2 * k);

  // The range factor exp(-range_scale x(d(ext_i, ext_{i+r}))) of r = 1..k at i; by symmetry also
  // the factor of -r at i + r.
  const float* ext = p.extended.data();
  const V neg_scale = hn::Set(d, -mc.range_scale * (mc.paper ? 0.5f : 1.0f));
  for (std::size_t r = 1; r <= k; ++r) {
    float* row = p.weights.data() + (r - 1) * stride;
    for (std::size_t i = first; i < stop + k; i += lanes) {
      const auto a = LoadQuat(d, ext, stride, i), b = LoadQuat(d, ext, stride, i + r);
      const V x = mc.paper ? Geodesic(d, a, b) : GeodesicSquared(d, a, b);
      hn::StoreU(hn::Exp(d, hn::Mul(neg_scale, x)), d, row + i);
    }
  }

  // Lee-Shin with the normalised mask: v = (sum_{r<0} -L_r w_{c+r} + sum_{r>=0} R_r w_{c+r}) / S,
  // L_r = m_{-k} + .. + m_r, R_r = m_{r+1} + .. + m_k, S = L_{-1} + m_0 + R_0 with m_0 = 1.
  const float* w = p.steps.data();
  const float* g = p.weights.data();
  for (std::size_t c = first + k; c < stop + k; c += lanes) {
    V left = hn::Zero(d), right = hn::Zero(d);
    Vec3V<V> acc{hn::Zero(d), hn::Zero(d), hn::Zero(d)};
    for (std::size_t back = k; back >= 1; --back) {  // r = -back
      const V m = hn::Mul(hn::Set(d, mc.temporal[k - back]),
                          hn::LoadU(d, g + (back - 1) * stride + c - back));
      left = hn::Add(left, m);
      const Vec3V<V> step = LoadVec3(d, w, stride, c - back);
      acc = {hn::NegMulAdd(left, step.x, acc.x), hn::NegMulAdd(left, step.y, acc.y),
             hn::NegMulAdd(left, step.z, acc.z)};
    }
    for (std::size_t r = k; r-- > 0;) {  // r = k-1 .. 0, adding m_{r+1}
      const V m = hn::Mul(hn::Set(d, mc.temporal[k + r + 1]), hn::LoadU(d, g + r * stride + c));
      right = hn::Add(right, m);
      const Vec3V<V> step = LoadVec3(d, w, stride, c + r);
      acc = {hn::MulAdd(right, step.x, acc.x), hn::MulAdd(right, step.y, acc.y),
             hn::MulAdd(right, step.z, acc.z)};
    }
    const V inv = hn::Div(hn::Set(d, 1.0f), hn::Add(hn::Set(d, 1.0f), hn::Add(left, right)));
    StoreDisplaced(d, p, c, k,
                   Vec3V<V>{hn::Mul(acc.x, inv), hn::Mul(acc.y, inv), hn::Mul(acc.z, inv)});
  }
}

// All passes, as run_passes (lee_shin.hpp) orders them: every pass but the last over all frames.
void BilateralCurve(const BilateralParams& params, CurvePlanes& p, int frames, int begin, int end) {
  if (frames == 1 || params.iterations < 1) {
    for (std::size_t c = 0; c < 4; ++c)
      for (int t = begin; t < end; ++t)
        p.output[c * p.stride + std::size_t(t)] = p.input[c * p.stride + std::size_t(t)];
    return;
  }
  const MaskConstants mc = Constants(params);
  for (int pass = 0; pass < params.iterations; ++pass) {
    const bool last = pass + 1 == params.iterations;
    Pass(mc, params.boundary, p, frames, last ? begin : 0, last ? end : frames);
    if (!last) std::swap(p.input, p.output);
  }
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(BilateralCurve);

void bilateral_curve(const BilateralParams& params, CurvePlanes& planes, int frames, int begin,
                     int end) {
  HWY_DYNAMIC_DISPATCH(BilateralCurve)(params, planes, frames, begin, end);
}

void bilateral_rotations(const BilateralParams& params, const MotionIO& io) {
  const int frames = io.rotations.frames;
  CurvePlanes planes;
  planes.reserve(frames, params.reach(), params.reach());
  for_each_joint_curve(io, planes, [&](CurvePlanes& p) {
    bilateral_curve(params, p, frames, io.frame_begin, io.frame_stop());
  });
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
