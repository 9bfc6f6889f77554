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
#include "kernels/simd/cheap_chart_simd-inl.h"
#include "kernels/simd/pop_bounds_simd.hpp"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The neighbour terms of one pair of samples (u, u + o), o > 0, for lanes of consecutive u: the
// cheap point 2x of conj(q_u) q_{u+o} on w >= 0 (pop_screen.hpp, step 2), its Log bound delta and
// whether it is within the chart's reach (1) or not (0). The pair seen from u + o is the
// conjugate: the same w, delta and reach, the point negated; so each pair is computed once for
// the two samples it serves.
struct PairPlanes {
  double *x, *y, *z, *delta, *near;
};

template <class D>
HWY_INLINE void PairTerms(D d, const double* pw, const double* px, const double* py,
                          const double* pz, std::size_t u, std::size_t o, const PairPlanes& out,
                          std::size_t k) {
  using V = hn::Vec<D>;
  const QuatV<V> a_conjugate{hn::LoadU(d, pw + u), hn::Neg(hn::LoadU(d, px + u)),
                             hn::Neg(hn::LoadU(d, py + u)), hn::Neg(hn::LoadU(d, pz + u))};
  const std::size_t v = u + o;
  const QuatV<V> b{hn::LoadU(d, pw + v), hn::LoadU(d, px + v), hn::LoadU(d, py + v),
                   hn::LoadU(d, pz + v)};
  const CheapPointV<V> c = CheapChartPoint(d, a_conjugate, b);
  hn::StoreU(c.x, d, out.x + k);
  hn::StoreU(c.y, d, out.y + k);
  hn::StoreU(c.z, d, out.z + k);
  hn::StoreU(c.delta, d, out.delta + k);
  hn::StoreU(hn::IfThenElseZero(hn::Le(c.sine, hn::Set(d, kPopScreenMaxSine)), hn::Set(d, 1.0)), d,
             out.near + k);
}

// The weighted sums of N blocks at once over the rows r_i, and their maximum with `worst`:
// N independent chains of fused multiply-adds instead of one (the chain's latency was most of
// this kernel's time).
template <std::size_t N, class D>
HWY_INLINE hn::Vec<D> WorstOf(D d, const std::vector<std::vector<double>>& blocks, std::size_t b,
                              const double* rows, std::size_t n, std::size_t lanes,
                              hn::Vec<D> worst) {
  using V = hn::Vec<D>;
  V sum[N];
  const double* w[N];
  for (std::size_t k = 0; k < N; ++k) {
    sum[k] = hn::Zero(d);
    w[k] = blocks[b + k].data();
  }
  for (std::size_t i = 0; i < n; ++i) {
    const V r = hn::LoadU(d, rows + i * lanes);
    for (std::size_t k = 0; k < N; ++k) sum[k] = hn::MulAdd(hn::Set(d, w[k][i]), r, sum[k]);
  }
  for (std::size_t k = 0; k < N; ++k) worst = hn::Max(worst, sum[k]);
  return worst;
}

void PopResidualBounds(std::span<const Quat> curve, const PopScreen& screen,
                       std::span<double> bounds) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t lanes = hn::Lanes(d);
  const int frames = int(curve.size()), window = screen.window;
  const std::size_t n = screen.offsets.size(), W = std::size_t(window);
  std::fill(bounds.begin(), bounds.end(), std::numeric_limits<double>::infinity());
  // The samples the lanes take: [window, end), whole groups of `lanes`.
  const std::size_t whole = frames > 2 * window ? std::size_t(frames - 2 * window) : 0;
  const std::size_t end = W + whole / lanes * lanes;
  // The curve as planes, so that the neighbours at offset o of `lanes` samples are one load;
  // `lanes` more samples (copies of the last) for the pair groups that pass the last sample.
  const std::size_t length = curve.size() + lanes;
  std::vector<double> planes(4 * length);
  double* const pw = planes.data();
  double* const px = pw + length;
  double* const py = px + length;
  double* const pz = py + length;
  for (std::size_t t = 0; t < length && !curve.empty(); ++t) {
    const Quat& q = curve[std::min(t, curve.size() - 1)];
    pw[t] = q.w;
    px[t] = q.x;
    py[t] = q.y;
    pz[t] = q.z;
  }
  // Chunks of samples [c0, c1); their pairs (u, u + o) for u in [c0 - window, c1), o = 1..window,
  // as five planes per o of `span` entries (a chunk keeps them in the L1 and L2 caches).
  constexpr std::size_t kChunk = 256;
  const std::size_t span = kChunk + W + lanes;
  std::vector<double> pairs(5 * W * span);
  const auto pair_planes = [&](std::size_t o) {  // o = 1..window
    double* const base = pairs.data() + 5 * (o - 1) * span;
    return PairPlanes{base, base + span, base + 2 * span, base + 3 * span, base + 4 * span};
  };
  // The rows of one group of samples: the cheap points c_i (3), then the bounds on |v_i - p(o_i)|.
  std::vector<double> rows(4 * n * lanes);
  const auto row = [&](int plane, std::size_t i) { return rows.data() + (plane * n + i) * lanes; };
  const V zero = hn::Zero(d), none = hn::Set(d, std::numeric_limits<double>::infinity()),
          margin = hn::Set(d, kPopScreenMargin), count = hn::Set(d, double(n)),
          cutoff = hn::Set(d, screen.loose_cutoff);
  const std::vector<std::vector<double>>& blocks = screen.block_weights;
  for (std::size_t c0 = W; c0 < end; c0 += kChunk) {
    const std::size_t c1 = std::min(end, c0 + kChunk), first = c0 - W;
    for (std::size_t o = 1; o <= W; ++o)
      for (std::size_t k = 0; first + k < c1; k += lanes)
        PairTerms(d, pw, px, py, pz, first + k, o, pair_planes(o), k);
    for (std::size_t t = c0; t < c1; t += lanes) {
      V near = zero;
      for (std::size_t i = 0; i < n; ++i) {
        const double offset = screen.offsets[i];
        const std::size_t o = std::size_t(std::abs(offset));
        const PairPlanes p = pair_planes(o);
        // Sample t's pair with t + o is the one from t; with t - o, the one from t - o, seen back.
        const std::size_t k = offset > 0 ? t - first : t - o - first;
        V x = hn::LoadU(d, p.x + k), y = hn::LoadU(d, p.y + k), z = hn::LoadU(d, p.z + k);
        if (offset < 0) {
          x = hn::Neg(x);
          y = hn::Neg(y);
          z = hn::Neg(z);
        }
        hn::StoreU(x, d, row(0, i));
        hn::StoreU(y, d, row(1, i));
        hn::StoreU(z, d, row(2, i));
        hn::StoreU(hn::LoadU(d, p.delta + k), d, row(3, i));
        near = hn::Add(near, hn::LoadU(d, p.near + k));
      }
      // p: the least-squares quadratic of the cheap points (step 3), nine independent sums.
      V coefficient[3][3];
      for (auto& c : coefficient)
        for (V& v : c) v = zero;
      for (std::size_t i = 0; i < n; ++i) {
        const V c[3] = {hn::LoadU(d, row(0, i)), hn::LoadU(d, row(1, i)), hn::LoadU(d, row(2, i))};
        for (int k = 0; k < 3; ++k) {
          const V f = hn::Set(d, screen.fit[k][i]);
          for (int a = 0; a < 3; ++a) coefficient[k][a] = hn::MulAdd(f, c[a], coefficient[k][a]);
        }
      }
      const V intercept =
          hn::Sqrt(hn::MulAdd(coefficient[0][2], coefficient[0][2],
                              hn::MulAdd(coefficient[0][1], coefficient[0][1],
                                         hn::Mul(coefficient[0][0], coefficient[0][0]))));
      for (std::size_t i = 0; i < n; ++i) {
        const double o = screen.offsets[i];
        const V o1 = hn::Set(d, o), o2 = hn::Set(d, o * o);
        V e[3];
        for (int k = 0; k < 3; ++k) {
          const V p = hn::MulAdd(o2, coefficient[2][k],
                                 hn::MulAdd(o1, coefficient[1][k], coefficient[0][k]));
          e[k] = hn::Sub(hn::LoadU(d, row(k, i)), p);
        }
        const V error =
            hn::Sqrt(hn::MulAdd(e[2], e[2], hn::MulAdd(e[1], e[1], hn::Mul(e[0], e[0]))));
        // Row 3 becomes the bound on |v_i - p(o_i)|.
        hn::StoreU(hn::Add(error, hn::LoadU(d, row(3, i))), d, row(3, i));
      }
      // The loose bound (step 5); where every lane's is at or below the cutoff, it is the bound.
      V loose = zero;
      for (std::size_t i = 0; i < n; ++i)
        loose = hn::MulAdd(hn::Set(d, screen.loose_weights[i]), hn::LoadU(d, row(3, i)), loose);
      loose = hn::Add(hn::Add(intercept, loose), margin);
      const auto loose_enough = hn::Le(loose, cutoff);
      if (hn::AllTrue(d, loose_enough)) {
        hn::StoreU(hn::IfThenElse(hn::Eq(near, count), loose, none), d, bounds.data() + t);
        continue;
      }
      // The worst block's weighted sum, eight blocks at a time, then four, then one.
      V worst = zero;
      std::size_t b = 0;
      for (; b + 8 <= blocks.size(); b += 8)
        worst = WorstOf<8>(d, blocks, b, row(3, 0), n, lanes, worst);
      for (; b + 4 <= blocks.size(); b += 4)
        worst = WorstOf<4>(d, blocks, b, row(3, 0), n, lanes, worst);
      for (; b < blocks.size(); ++b) worst = WorstOf<1>(d, blocks, b, row(3, 0), n, lanes, worst);
      const V bound =
          hn::IfThenElse(loose_enough, loose, hn::Add(hn::Add(intercept, worst), margin));
      hn::StoreU(hn::IfThenElse(hn::Eq(near, count), bound, none), d, bounds.data() + t);
    }
  }
  // The samples left: the scalar bound, on the tail of the curve alone (the screen's window
  // reaches window() samples on each side, so a suffix starting window() earlier holds them).
  if (end + W < curve.size()) {
    const std::size_t from = end - W;
    std::vector<double> tail(curve.size() - from);
    mocap::pop_residual_bounds(curve.subspan(from), screen, tail, Implementation::reference);
    for (std::size_t k = W; k < tail.size(); ++k) bounds[from + k] = tail[k];
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
