// pop_residual_bounds' fast path (pop_bounds_simd.hpp), compiled once per Highway target. Lanes =
// consecutive samples of one joint, in double.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/pop_bounds_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

#include "hwy/highway.h"
#include "kernels/simd/pop_bounds_simd.hpp"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void PopResidualBounds(std::span<const Quat> curve, const PopScreen& screen,
                       std::span<double> bounds) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t lanes = hn::Lanes(d);
  const int frames = int(curve.size()), window = screen.window;
  const std::size_t n = screen.offsets.size();
  // The curve as planes, so that the neighbours at offset o of `lanes` samples are one load.
  std::vector<double> planes(4 * curve.size());
  double* const pw = planes.data();
  double* const px = pw + curve.size();
  double* const py = px + curve.size();
  double* const pz = py + curve.size();
  for (std::size_t t = 0; t < curve.size(); ++t) {
    pw[t] = curve[t].w;
    px[t] = curve[t].x;
    py[t] = curve[t].y;
    pz[t] = curve[t].z;
  }
  std::fill(bounds.begin(), bounds.end(), std::numeric_limits<double>::infinity());
  // The cheap points and their deltas per neighbour, as unaligned rows of `lanes` (a std::vector
  // of vectors would not be aligned for them).
  std::vector<double> rows(4 * n * lanes);
  const auto row = [&](int plane, std::size_t i) { return rows.data() + (plane * n + i) * lanes; };
  const V zero = hn::Zero(d), two = hn::Set(d, 2.0), one = hn::Set(d, 1.0),
          third = hn::Set(d, 1.0 / 3.0), max_sine = hn::Set(d, kPopScreenMaxSine),
          none = hn::Set(d, std::numeric_limits<double>::infinity()),
          margin = hn::Set(d, kPopScreenMargin);
  int t = window;
  for (; t + int(lanes) - 1 + window < frames; t += int(lanes)) {
    // The chart's cheap points: 2x of conj(q_t) q_u taken with w >= 0 (pop_screen.hpp, step 2).
    const V aw = hn::LoadU(d, pw + t), ax = hn::Neg(hn::LoadU(d, px + t)),
            ay = hn::Neg(hn::LoadU(d, py + t)), az = hn::Neg(hn::LoadU(d, pz + t));
    auto bounded = hn::Eq(zero, zero);
    for (std::size_t i = 0; i < n; ++i) {
      const int u = t + int(screen.offsets[i]);
      const V bw = hn::LoadU(d, pw + u), bx = hn::LoadU(d, px + u), by = hn::LoadU(d, py + u),
              bz = hn::LoadU(d, pz + u);
      const V w = hn::Sub(hn::Sub(hn::Sub(hn::Mul(aw, bw), hn::Mul(ax, bx)), hn::Mul(ay, by)),
                          hn::Mul(az, bz));
      V x = hn::Sub(hn::Add(hn::Add(hn::Mul(aw, bx), hn::Mul(ax, bw)), hn::Mul(ay, bz)),
                    hn::Mul(az, by));
      V y = hn::Add(hn::Add(hn::Sub(hn::Mul(aw, by), hn::Mul(ax, bz)), hn::Mul(ay, bw)),
                    hn::Mul(az, bx));
      V z = hn::Add(hn::Sub(hn::Add(hn::Mul(aw, bz), hn::Mul(ax, by)), hn::Mul(ay, bx)),
                    hn::Mul(az, bw));
      const auto flip = hn::Lt(w, zero);
      x = hn::IfThenElse(flip, hn::Neg(x), x);
      y = hn::IfThenElse(flip, hn::Neg(y), y);
      z = hn::IfThenElse(flip, hn::Neg(z), z);
      const V s2 = hn::Add(hn::Add(hn::Mul(x, x), hn::Mul(y, y)), hn::Mul(z, z));
      const V s = hn::Sqrt(s2), length = hn::Sqrt(hn::Add(hn::Mul(w, w), s2));
      const V sine = hn::Div(s, length);
      bounded = hn::And(bounded, hn::Le(sine, max_sine));
      hn::StoreU(hn::Mul(two, x), d, row(0, i));
      hn::StoreU(hn::Mul(two, y), d, row(1, i));
      hn::StoreU(hn::Mul(two, z), d, row(2, i));
      const V sine2 = hn::Mul(sine, sine);
      const V series = hn::Div(hn::Mul(hn::Mul(sine2, sine), third), hn::Sub(one, sine2));
      const V scale = hn::Abs(hn::Sub(hn::Div(one, length), one));
      hn::StoreU(hn::Add(series, hn::Mul(hn::Mul(two, s), scale)), d, row(3, i));
    }
    // p: the least-squares quadratic of the cheap points (step 3).
    V coefficient[3][3];
    for (int k = 0; k < 3; ++k) {
      V sx = zero, sy = zero, sz = zero;
      for (std::size_t i = 0; i < n; ++i) {
        const V f = hn::Set(d, screen.fit[k][i]);
        sx = hn::Add(sx, hn::Mul(f, hn::LoadU(d, row(0, i))));
        sy = hn::Add(sy, hn::Mul(f, hn::LoadU(d, row(1, i))));
        sz = hn::Add(sz, hn::Mul(f, hn::LoadU(d, row(2, i))));
      }
      coefficient[k][0] = sx;
      coefficient[k][1] = sy;
      coefficient[k][2] = sz;
    }
    const V intercept = hn::Sqrt(hn::Add(hn::Add(hn::Mul(coefficient[0][0], coefficient[0][0]),
                                                 hn::Mul(coefficient[0][1], coefficient[0][1])),
                                         hn::Mul(coefficient[0][2], coefficient[0][2])));
    for (std::size_t i = 0; i < n; ++i) {
      const double o = screen.offsets[i];
      const V o1 = hn::Set(d, o), o2 = hn::Set(d, o * o);
      V e[3];
      const V c[3] = {hn::LoadU(d, row(0, i)), hn::LoadU(d, row(1, i)), hn::LoadU(d, row(2, i))};
      for (int k = 0; k < 3; ++k) {
        const V p = hn::Add(hn::Add(coefficient[0][k], hn::Mul(o1, coefficient[1][k])),
                            hn::Mul(o2, coefficient[2][k]));
        e[k] = hn::Sub(c[k], p);
      }
      const V error =
          hn::Sqrt(hn::Add(hn::Add(hn::Mul(e[0], e[0]), hn::Mul(e[1], e[1])), hn::Mul(e[2], e[2])));
      // Row 3 becomes the bound on |v_i - p(o_i)|.
      hn::StoreU(hn::Add(error, hn::LoadU(d, row(3, i))), d, row(3, i));
    }
    // The worst block's weighted sum. Eight blocks at a time: eight independent chains of adds
    // instead of one (the chain's latency was most of this kernel's time), each block's sum
    // still taken over i in order and the maxima in block order (the same bits).
    V worst = zero;
    const std::vector<std::vector<double>>& blocks = screen.block_weights;
    std::size_t b = 0;
    for (; b + 8 <= blocks.size(); b += 8) {
      const double* w[8];
      for (int k = 0; k < 8; ++k) w[k] = blocks[b + std::size_t(k)].data();
      V s0 = zero, s1 = zero, s2 = zero, s3 = zero, s4 = zero, s5 = zero, s6 = zero, s7 = zero;
      for (std::size_t i = 0; i < n; ++i) {
        const V r = hn::LoadU(d, row(3, i));
        s0 = hn::Add(s0, hn::Mul(hn::Set(d, w[0][i]), r));
        s1 = hn::Add(s1, hn::Mul(hn::Set(d, w[1][i]), r));
        s2 = hn::Add(s2, hn::Mul(hn::Set(d, w[2][i]), r));
        s3 = hn::Add(s3, hn::Mul(hn::Set(d, w[3][i]), r));
        s4 = hn::Add(s4, hn::Mul(hn::Set(d, w[4][i]), r));
        s5 = hn::Add(s5, hn::Mul(hn::Set(d, w[5][i]), r));
        s6 = hn::Add(s6, hn::Mul(hn::Set(d, w[6][i]), r));
        s7 = hn::Add(s7, hn::Mul(hn::Set(d, w[7][i]), r));
      }
      worst = hn::Max(hn::Max(hn::Max(hn::Max(worst, s0), s1), s2), s3);
      worst = hn::Max(hn::Max(hn::Max(hn::Max(worst, s4), s5), s6), s7);
    }
    for (; b < blocks.size(); ++b) {
      V sum = zero;
      for (std::size_t i = 0; i < n; ++i)
        sum = hn::Add(sum, hn::Mul(hn::Set(d, blocks[b][i]), hn::LoadU(d, row(3, i))));
      worst = hn::Max(worst, sum);
    }
    const V bound = hn::Add(intercept, worst);
    hn::StoreU(hn::IfThenElse(bounded, hn::Add(bound, margin), none), d, bounds.data() + t);
  }
  // The samples left: the scalar bound, on the tail of the curve alone (the screen's window
  // reaches window() samples on each side, so a suffix starting window() earlier holds them).
  if (t + window < frames) {
    const std::size_t from = std::size_t(t - window);
    std::vector<double> tail(curve.size() - from);
    mocap::pop_residual_bounds(curve.subspan(from), screen, tail, Implementation::reference);
    for (std::size_t k = std::size_t(window); k < tail.size(); ++k) bounds[from + k] = tail[k];
  }
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(PopResidualBounds);

void pop_residual_bounds(std::span<const Quat> curve, const PopScreen& screen,
                         std::span<double> bounds) {
  HWY_DYNAMIC_DISPATCH(PopResidualBounds)(curve, screen, bounds);
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
