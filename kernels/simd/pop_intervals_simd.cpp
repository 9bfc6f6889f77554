// pop_residual_intervals' fast path (pop_intervals_simd.hpp), compiled once per Highway target.
// Lanes = samples of one joint, in double.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/pop_intervals_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "hwy/highway.h"
#include "kernels/simd/cheap_chart_simd-inl.h"
#include "kernels/simd/pop_intervals_simd.hpp"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void PopResidualIntervals(std::span<const Quat> curve, const PopScreen& screen,
                          std::span<const std::uint8_t> only, std::span<double> lows,
                          std::span<double> highs) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t lanes = hn::Lanes(d);
  const int frames = int(curve.size()), window = screen.window;
  const std::size_t n = screen.offsets.size(), K = screen.candidates.size();
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  // Per batch: the lanes' quaternions (q_t, then each neighbour's), the cheap points (3 rows per
  // neighbour) and deltas, and per candidate |a_k|, e_k and the score's ends.
  std::vector<double> q(8 * lanes), rows(4 * n * lanes), per(4 * K * lanes);
  const auto row = [&](std::size_t plane, std::size_t i) {
    return rows.data() + (plane * n + i) * lanes;
  };
  const auto cand = [&](std::size_t plane, std::size_t k) {
    return per.data() + (plane * K + k) * lanes;
  };
  std::vector<int> batch;
  const V zero = hn::Zero(d), max_sine = hn::Set(d, kPopScreenMaxSine),
          infinity = hn::Set(d, kInfinity), margin = hn::Set(d, kPopScreenMargin),
          rounding = hn::Set(d, std::sqrt(kPopIntervalSse)), below = hn::Set(d, 1 - 1e-12),
          above = hn::Set(d, 1 + 1e-12);
  const auto run_batch = [&]() {
    // A partial batch repeats its first sample in the free lanes (results dropped).
    const auto sample = [&](std::size_t lane) {
      return std::size_t(batch[lane < batch.size() ? lane : 0]);
    };
    for (std::size_t lane = 0; lane < lanes; ++lane) {
      const Quat& a = curve[sample(lane)];
      q[lane] = a.w;
      q[lanes + lane] = -a.x;
      q[2 * lanes + lane] = -a.y;
      q[3 * lanes + lane] = -a.z;
    }
    const QuatV<V> a_conjugate{hn::LoadU(d, q.data()), hn::LoadU(d, q.data() + lanes),
                               hn::LoadU(d, q.data() + 2 * lanes),
                               hn::LoadU(d, q.data() + 3 * lanes)};
    auto near = hn::Eq(zero, zero);
    V delta2 = zero;
    // The cheap chart (pop_screen.hpp, step 2): 2x of conj(q_t) q_u on w >= 0, and delta.
    for (std::size_t i = 0; i < n; ++i) {
      const int o = int(screen.offsets[i]);
      for (std::size_t lane = 0; lane < lanes; ++lane) {
        const Quat& b = curve[std::size_t(int(sample(lane)) + o)];
        q[4 * lanes + lane] = b.w;
        q[5 * lanes + lane] = b.x;
        q[6 * lanes + lane] = b.y;
        q[7 * lanes + lane] = b.z;
      }
      const V bw = hn::LoadU(d, q.data() + 4 * lanes), bx = hn::LoadU(d, q.data() + 5 * lanes),
              by = hn::LoadU(d, q.data() + 6 * lanes), bz = hn::LoadU(d, q.data() + 7 * lanes);
      const CheapPointV<V> c = CheapChartPoint(d, a_conjugate, {bw, bx, by, bz});
      near = hn::And(near, hn::Le(c.sine, max_sine));
      hn::StoreU(c.x, d, row(0, i));
      hn::StoreU(c.y, d, row(1, i));
      hn::StoreU(c.z, d, row(2, i));
      hn::StoreU(c.delta, d, row(3, i));
      delta2 = hn::MulAdd(c.delta, c.delta, delta2);
    }
    const V slack = hn::Add(hn::Sqrt(delta2), rounding);  // Delta and the rounding
    // The normal equations of all the points: r[j][c] = sum o^j c, vv = sum |c|^2.
    V all[3][3], all_vv = zero;
    for (auto& r : all)
      for (V& v : r) v = zero;
    for (std::size_t i = 0; i < n; ++i) {
      const double o = screen.offsets[i];
      const V o1 = hn::Set(d, o), o2 = hn::Set(d, o * o);
      for (std::size_t c = 0; c < 3; ++c) {
        const V p = hn::LoadU(d, row(c, i));
        all[0][c] = hn::Add(all[0][c], p);
        all[1][c] = hn::MulAdd(o1, p, all[1][c]);
        all[2][c] = hn::MulAdd(o2, p, all[2][c]);
        all_vv = hn::MulAdd(p, p, all_vv);
      }
    }
    // Each candidate: its points' sums (all but its block), its fit, the score's ends.
    V least_high = infinity;
    for (std::size_t k = 0; k < K; ++k) {
      const pop_detail::BlockFit& block = screen.candidates[k];
      const pop_detail::MomentInverse& m = block.inverse;
      V r[3][3], vv = all_vv;
      for (std::size_t j = 0; j < 3; ++j)
        for (std::size_t c = 0; c < 3; ++c) r[j][c] = all[j][c];
      V e = zero;
      for (std::size_t i = 0; i < n; ++i) {
        const double o = screen.offsets[i];
        if (o >= block.x && o <= block.y) {
          const V o1 = hn::Set(d, o), o2 = hn::Set(d, o * o);
          for (std::size_t c = 0; c < 3; ++c) {
            const V p = hn::LoadU(d, row(c, i));
            r[0][c] = hn::Sub(r[0][c], p);
            r[1][c] = hn::NegMulAdd(o1, p, r[1][c]);
            r[2][c] = hn::NegMulAdd(o2, p, r[2][c]);
            vv = hn::NegMulAdd(p, p, vv);
          }
        } else {
          e = hn::MulAdd(hn::Set(d, screen.block_weights[k][i]), hn::LoadU(d, row(3, i)), e);
        }
      }
      const V m0[3] = {hn::Set(d, m.m00), hn::Set(d, m.m01), hn::Set(d, m.m02)};
      const V m1[3] = {hn::Set(d, m.m01), hn::Set(d, m.m11), hn::Set(d, m.m12)};
      const V m2[3] = {hn::Set(d, m.m02), hn::Set(d, m.m12), hn::Set(d, m.m22)};
      V sse = vv, a2 = zero;
      for (std::size_t c = 0; c < 3; ++c) {
        const V b0 =
            hn::MulAdd(m0[2], r[2][c], hn::MulAdd(m0[1], r[1][c], hn::Mul(m0[0], r[0][c])));
        const V b1 =
            hn::MulAdd(m1[2], r[2][c], hn::MulAdd(m1[1], r[1][c], hn::Mul(m1[0], r[0][c])));
        const V b2 =
            hn::MulAdd(m2[2], r[2][c], hn::MulAdd(m2[1], r[1][c], hn::Mul(m2[0], r[0][c])));
        sse = hn::NegMulAdd(b0, r[0][c], sse);
        sse = hn::NegMulAdd(b1, r[1][c], sse);
        sse = hn::NegMulAdd(b2, r[2][c], sse);
        a2 = hn::MulAdd(b0, b0, a2);
      }
      const V g = hn::Set(d, std::sqrt((1 + m.m00) / (block.points - 3)));
      const V root = hn::Sqrt(hn::Max(sse, zero));
      const V s_lo = hn::Mul(hn::Mul(hn::Max(hn::Sub(root, slack), zero), g), below);
      const V s_hi = hn::Mul(hn::Mul(hn::Add(root, slack), g), above);
      hn::StoreU(hn::Sqrt(a2), d, cand(0, k));
      hn::StoreU(e, d, cand(1, k));
      hn::StoreU(s_lo, d, cand(2, k));
      least_high = hn::Min(least_high, s_hi);
    }
    // The candidates that can have the least score bound the standardized residual.
    V lo = infinity, hi = zero;
    for (std::size_t k = 0; k < K; ++k) {
      const auto possible = hn::Le(hn::LoadU(d, cand(2, k)), least_high);
      const V a = hn::LoadU(d, cand(0, k)), e = hn::LoadU(d, cand(1, k));
      // 1 / s_k in place of a division: its rounding is far inside the margin.
      const V inverse_spread = hn::Set(d, 1.0 / std::sqrt(1 + screen.candidates[k].inverse.m00));
      lo = hn::IfThenElse(possible, hn::Min(lo, hn::Mul(hn::Sub(a, e), inverse_spread)), lo);
      hi = hn::IfThenElse(possible, hn::Max(hi, hn::Mul(hn::Add(a, e), inverse_spread)), hi);
    }
    lo = hn::IfThenElse(near, hn::Max(hn::Sub(lo, margin), zero), zero);
    hi = hn::IfThenElse(near, hn::Add(hi, margin), infinity);
    hn::StoreU(lo, d, q.data());
    hn::StoreU(hi, d, q.data() + lanes);
    for (std::size_t lane = 0; lane < batch.size(); ++lane) {
      lows[std::size_t(batch[lane])] = q[lane];
      highs[std::size_t(batch[lane])] = q[lanes + lane];
    }
    batch.clear();
  };
  for (int t = 0; t < frames; ++t) {
    if (!only[std::size_t(t)]) continue;
    if (t < window || t + window >= frames) {
      lows[std::size_t(t)] = 0;
      highs[std::size_t(t)] = kInfinity;
      continue;
    }
    batch.push_back(t);
    if (batch.size() == lanes) run_batch();
  }
  if (!batch.empty()) run_batch();
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(PopResidualIntervals);

void pop_residual_intervals(std::span<const Quat> curve, const PopScreen& screen,
                            std::span<const std::uint8_t> only, std::span<double> lows,
                            std::span<double> highs) {
  HWY_DYNAMIC_DISPATCH(PopResidualIntervals)(curve, screen, only, lows, highs);
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
