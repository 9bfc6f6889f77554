// pop_residuals' fast path (pop_residuals_simd.hpp), compiled once per Highway target. Lanes =
// whole-window samples of one joint, in double.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/pop_residuals_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "hwy/highway.h"
#include "kernels/simd/pop_residuals_simd.hpp"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The normal-equation sums a whole window's fit needs (FitSums of pop_repair.cpp without the
// moments, which the candidate blocks carry): r[k][c] = sum o^k v_c, vv = sum |v|^2.
template <class V>
struct FitSumsV {
  V r[3][3];
  V vv;
};

template <class D, class V = hn::Vec<D>>
HWY_INLINE V Dot3(V ax, V ay, V az, V bx, V by, V bz) {
  return hn::Add(hn::Add(hn::Mul(ax, bx), hn::Mul(ay, by)), hn::Mul(az, bz));
}

// The fits of hn::Lanes(d) whole-window samples. chart[((o + window) * 3 + c) * lanes + lane] is
// component c of v_o of the lane's sample; writes its residual, spread and fit error per lane.
template <class D>
void FitLanes(D d, std::span<const pop_detail::BlockFit> blocks, int window, const double* chart,
              double* residual_out, double* spread_out, double* fit_error_out) {
  using V = hn::Vec<D>;
  const std::size_t lanes = hn::Lanes(d);
  const auto load = [&](int o, int c) {
    return hn::LoadU(d, chart + (std::size_t(o + window) * 3 + std::size_t(c)) * lanes);
  };
  // `all` in the reference's order: outwards from t, left side first, with FitSums::add's
  // products (sign 1: o v and o^2 v).
  FitSumsV<V> all;
  for (auto& row : all.r)
    for (V& x : row) x = hn::Zero(d);
  all.vv = hn::Zero(d);
  for (int side : {-1, 1})
    for (int o = side; o >= -window && o <= window; o += side) {
      const V vx = load(o, 0), vy = load(o, 1), vz = load(o, 2);
      const V v[3] = {vx, vy, vz};
      const V o1 = hn::Set(d, double(o)), o2 = hn::Set(d, double(o) * double(o));
      for (int c = 0; c < 3; ++c) {
        all.r[0][c] = hn::Add(all.r[0][c], v[c]);
        all.r[1][c] = hn::Add(all.r[1][c], hn::Mul(o1, v[c]));
        all.r[2][c] = hn::Add(all.r[2][c], hn::Mul(o2, v[c]));
      }
      all.vv = hn::Add(all.vv, Dot3<D>(vx, vy, vz, vx, vy, vz));
    }
  const V infinity = hn::Set(d, std::numeric_limits<double>::infinity()), zero = hn::Zero(d);
  V best_score[2] = {infinity, infinity};
  V best_norm2[2] = {zero, zero};  // |intercept|^2: its square root is the residual
  V best_spread[2] = {hn::Set(d, 1.0), hn::Set(d, 1.0)};
  // The candidate loop of pop_detail::sample_residual with uniform control flow: the block order,
  // the extension of one fit to the next and the strict `<` are the reference's.
  FitSumsV<V> fit = all;
  int fit_x = 0, fit_y = 0;
  bool started = false;
  for (const pop_detail::BlockFit& block : blocks) {
    if (!started || block.x != fit_x || block.y < fit_y) {
      fit = all;
      fit_x = block.x;
      fit_y = block.x - 1;
      started = true;
    }
    for (; fit_y < block.y; ++fit_y) {
      const int o = fit_y + 1;
      if (o == 0) continue;
      const V vx = load(o, 0), vy = load(o, 1), vz = load(o, 2);
      const V v[3] = {vx, vy, vz};
      const V o1 = hn::Set(d, double(o)), o2 = hn::Set(d, double(o) * double(o));
      // FitSums::add with sign -1: adding (-s) v is subtracting s v, to the bit.
      for (int c = 0; c < 3; ++c) {
        fit.r[0][c] = hn::Sub(fit.r[0][c], v[c]);
        fit.r[1][c] = hn::Sub(fit.r[1][c], hn::Mul(o1, v[c]));
        fit.r[2][c] = hn::Sub(fit.r[2][c], hn::Mul(o2, v[c]));
      }
      fit.vv = hn::Sub(fit.vv, Dot3<D>(vx, vy, vz, vx, vy, vz));
    }
    if (block.points < 4 || !block.inverse.valid) continue;
    const pop_detail::MomentInverse& m = block.inverse;
    const V m_row[3][3] = {{hn::Set(d, m.m00), hn::Set(d, m.m01), hn::Set(d, m.m02)},
                           {hn::Set(d, m.m01), hn::Set(d, m.m11), hn::Set(d, m.m12)},
                           {hn::Set(d, m.m02), hn::Set(d, m.m12), hn::Set(d, m.m22)}};
    // solve_quadratic: beta_k = sum_i m_ki r_i; sse = max(0, vv - sum_k beta_k . r_k).
    V beta[3][3];
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c)
        beta[k][c] =
            hn::Add(hn::Add(hn::Mul(m_row[k][0], fit.r[0][c]), hn::Mul(m_row[k][1], fit.r[1][c])),
                    hn::Mul(m_row[k][2], fit.r[2][c]));
    V sse = fit.vv;
    for (int k = 0; k < 3; ++k)
      sse = hn::Sub(
          sse, Dot3<D>(beta[k][0], beta[k][1], beta[k][2], fit.r[k][0], fit.r[k][1], fit.r[k][2]));
    sse = hn::IfThenElse(hn::Lt(zero, sse), sse, zero);  // std::max(0.0, sse), NaN included
    const double leverage = m.m00;
    const V score = hn::Mul(hn::Div(sse, hn::Set(d, block.points - 3)), hn::Set(d, 1 + leverage));
    const int tier = leverage <= pop_detail::kMaxLeverage ? 0 : 1;
    const auto better = hn::Lt(score, best_score[tier]);
    best_score[tier] = hn::IfThenElse(better, score, best_score[tier]);
    best_norm2[tier] = hn::IfThenElse(
        better, Dot3<D>(beta[0][0], beta[0][1], beta[0][2], beta[0][0], beta[0][1], beta[0][2]),
        best_norm2[tier]);
    best_spread[tier] =
        hn::IfThenElse(better, hn::Set(d, std::sqrt(1 + leverage)), best_spread[tier]);
  }
  // Tier 0 where it found a fit (a finite score), else tier 1; no fit at all: fit error 0.
  const auto first = hn::Lt(best_score[0], infinity);
  const V score = hn::IfThenElse(first, best_score[0], best_score[1]);
  hn::StoreU(hn::Sqrt(hn::IfThenElse(first, best_norm2[0], best_norm2[1])), d, residual_out);
  hn::StoreU(hn::IfThenElse(first, best_spread[0], best_spread[1]), d, spread_out);
  hn::StoreU(hn::IfThenElse(hn::Lt(score, infinity), hn::Sqrt(score), zero), d, fit_error_out);
}

void PopResiduals(std::span<const Quat> curve, const PopRepairParams& params,
                  std::span<double> residuals, std::span<double> spreads,
                  std::span<double> fit_errors, std::span<const std::uint8_t> only,
                  std::span<const pop_detail::BlockFit> whole_window,
                  std::span<const std::vector<pop_detail::BlockFit>> end_windows) {
  const hn::ScalableTag<double> d;
  const std::size_t lanes = hn::Lanes(d);
  const int frames = int(curve.size()), window = params.window();
  std::vector<pop_detail::BlockFit> own;
  if (whole_window.empty()) own = pop_detail::whole_window_blocks(params);
  const std::span<const pop_detail::BlockFit> blocks = whole_window.empty() ? own : whole_window;
  pop_detail::ChartScratch scratch(curve.size());
  std::vector<double> chart(std::size_t(2 * window + 1) * 3 * lanes);
  std::vector<double> residual(lanes), spread(lanes), fit_error(lanes);
  std::vector<int> batch;  // the samples of the lanes
  const auto fit_batch = [&]() {
    // A partial batch repeats its first sample in the free lanes (their results are dropped).
    for (std::size_t lane = batch.size(); lane < lanes; ++lane)
      for (std::size_t row = 0; row < chart.size(); row += lanes) chart[row + lane] = chart[row];
    FitLanes(d, blocks, window, chart.data(), residual.data(), spread.data(), fit_error.data());
    for (std::size_t lane = 0; lane < batch.size(); ++lane) {
      const std::size_t t = std::size_t(batch[lane]);
      residuals[t] = residual[lane];
      spreads[t] = spread[lane];
      fit_errors[t] = fit_error[lane];
    }
    batch.clear();
  };
  for (int t = 0; t < frames; ++t) {
    if (!only.empty() && !only[std::size_t(t)]) continue;
    // Whole: the window is not shifted at a clip end and every neighbour is within reach (the
    // reference's test, pop_repair.cpp).
    bool whole = t >= window && t + window < frames;
    if (whole) {
      const Quat to_chart = inverse(curve[std::size_t(t)]);
      const std::size_t lane = batch.size();
      for (int o = -window; o <= window && whole; ++o) {
        if (o == 0) continue;
        const Vec3 v = log(to_chart * curve[std::size_t(t + o)]);
        whole = norm(v) <= pop_detail::kChartReach;
        double* row = chart.data() + std::size_t(o + window) * 3 * lanes + lane;
        row[0] = v.x;
        row[lanes] = v.y;
        row[2 * lanes] = v.z;
      }
    }
    if (!whole) {
      pop_detail::sample_residual(curve, params, blocks, t, scratch, residuals, spreads, fit_errors,
                                  end_windows);
      continue;
    }
    batch.push_back(t);
    if (batch.size() == lanes) fit_batch();
  }
  if (!batch.empty()) fit_batch();
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(PopResiduals);

void pop_residuals(std::span<const Quat> curve, const PopRepairParams& params,
                   std::span<double> residuals, std::span<double> spreads,
                   std::span<double> fit_errors, std::span<const std::uint8_t> only,
                   std::span<const pop_detail::BlockFit> whole_window,
                   std::span<const std::vector<pop_detail::BlockFit>> end_windows) {
  HWY_DYNAMIC_DISPATCH(PopResiduals)
  (curve, params, residuals, spreads, fit_errors, only, whole_window, end_windows);
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
