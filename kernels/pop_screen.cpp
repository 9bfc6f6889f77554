#include "kernels/pop_screen.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/simd/pop_bounds_simd.hpp"
#include "kernels/simd/pop_intervals_simd.hpp"

namespace mocap {

PopScreen::PopScreen(const PopRepairParams& params)
    : window(params.window()), max_run(params.max_run) {
  for (int o = -window; o <= window; ++o)
    if (o != 0) offsets.push_back(double(o));
  const std::size_t n = offsets.size();
  usable = true;
  whole_window = pop_detail::whole_window_blocks(params);
  end_windows = pop_detail::end_window_blocks(params);
  for (const pop_detail::BlockFit& block : whole_window) {
    const pop_detail::MomentInverse& m = block.inverse;
    // The candidates sample_residual skips, and those of tier 1, which a whole sample never
    // keeps (pop_screen.hpp, step 1).
    if (block.points < 4 || !m.valid || !(m.m00 <= pop_detail::kMaxLeverage)) continue;
    if (!(m.m00 >= 0)) usable = false;  // its spread would be below 1 (the median bound's premise)
    std::vector<double> weights(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const double o = offsets[i];
      if (o >= block.x && o <= block.y) continue;  // left out
      weights[i] = std::abs(m.m00 + m.m01 * o + m.m02 * o * o);
    }
    // A block whose weights another already has adds nothing to the maximum (candidates that
    // differ only in t's own place in the block leave out the same neighbours).
    if (std::find(block_weights.begin(), block_weights.end(), weights) == block_weights.end()) {
      block_weights.push_back(std::move(weights));
      candidates.push_back(block);
    }
  }
  loose_weights.assign(n, 0.0);
  for (const std::vector<double>& weights : block_weights)
    for (std::size_t i = 0; i < n; ++i) loose_weights[i] = std::max(loose_weights[i], weights[i]);
  loose_cutoff = params.floor;
  // The least-squares quadratic of all 2 window() points: (X^T X)^-1 X^T by cofactors.
  double s[5] = {};
  for (double o : offsets)
    for (int k = 0; k < 5; ++k) s[k] += std::pow(o, k);
  const double a = s[0], b = s[1], c = s[2], d = s[3], e = s[4];
  const double c00 = c * e - d * d, c01 = c * d - b * e, c02 = b * d - c * c;
  const double c11 = a * e - c * c, c12 = b * c - a * d, c22 = a * c - b * b;
  const double det = a * c00 + b * c01 + c * c02;
  const double inv[3][3] = {{c00 / det, c01 / det, c02 / det},
                            {c01 / det, c11 / det, c12 / det},
                            {c02 / det, c12 / det, c22 / det}};
  for (int k = 0; k < 3; ++k) {
    fit[k].resize(n);
    for (std::size_t i = 0; i < n; ++i)
      fit[k][i] = inv[k][0] + inv[k][1] * offsets[i] + inv[k][2] * offsets[i] * offsets[i];
  }
}

namespace {

// The cheap chart of sample t (pop_screen.hpp, step 2): points[i] = 2x and deltas[i] for each
// neighbour; false when one is beyond the reach of the bound.
bool cheap_chart(std::span<const Quat> curve, const PopScreen& screen, int t,
                 std::vector<Vec3>& points, std::vector<double>& deltas) {
  const Quat to_chart = inverse(curve[std::size_t(t)]);
  for (std::size_t i = 0; i < screen.offsets.size(); ++i) {
    Quat u = to_chart * curve[std::size_t(t + int(screen.offsets[i]))];
    if (u.w < 0) u = negate(u);
    const Vec3 x{u.x, u.y, u.z};
    const double s = norm(x), length = std::sqrt(u.w * u.w + s * s);
    const double sine = s / length;
    if (!(sine <= kPopScreenMaxSine)) return false;
    points[i] = 2.0 * x;
    deltas[i] =
        sine * sine * sine / (3.0 * (1.0 - sine * sine)) + 2.0 * s * std::abs(1.0 / length - 1.0);
  }
  return true;
}

}  // namespace

void pop_residual_bounds(std::span<const Quat> curve, const PopScreen& screen,
                         std::span<double> bounds, Implementation implementation) {
  if (implementation == Implementation::fast && screen.usable)
    return simd::pop_residual_bounds(curve, screen, bounds);
  constexpr double kNone = std::numeric_limits<double>::infinity();
  const int frames = int(curve.size()), window = screen.window;
  const std::size_t n = screen.offsets.size();
  std::fill(bounds.begin(), bounds.end(), kNone);
  if (!screen.usable) return;
  std::vector<Vec3> points(n);
  std::vector<double> deltas(n);
  for (int t = window; t + window < frames; ++t) {
    if (!cheap_chart(curve, screen, t, points, deltas)) continue;
    Vec3 coefficient[3];
    for (int k = 0; k < 3; ++k)
      for (std::size_t i = 0; i < n; ++i) coefficient[k] += screen.fit[k][i] * points[i];
    for (std::size_t i = 0; i < n; ++i) {
      const double o = screen.offsets[i];
      const Vec3 p = coefficient[0] + o * coefficient[1] + (o * o) * coefficient[2];
      deltas[i] += norm(points[i] - p);  // now a bound on |v_i - p(o_i)|
    }
    double loose = 0;
    for (std::size_t i = 0; i < n; ++i) loose += screen.loose_weights[i] * deltas[i];
    loose += norm(coefficient[0]) + kPopScreenMargin;
    if (loose <= screen.loose_cutoff) {
      bounds[std::size_t(t)] = loose;
      continue;
    }
    double worst = 0;
    for (const std::vector<double>& weights : screen.block_weights) {
      double sum = 0;
      for (std::size_t i = 0; i < n; ++i) sum += weights[i] * deltas[i];
      worst = std::max(worst, sum);
    }
    bounds[std::size_t(t)] = norm(coefficient[0]) + worst + kPopScreenMargin;
  }
}

void pop_residual_intervals(std::span<const Quat> curve, const PopScreen& screen,
                            std::span<const std::uint8_t> only, std::span<double> lows,
                            std::span<double> highs, Implementation implementation) {
  if (implementation == Implementation::fast && screen.usable)
    return simd::pop_residual_intervals(curve, screen, only, lows, highs);
  const int frames = int(curve.size()), window = screen.window;
  const std::size_t n = screen.offsets.size(), k_count = screen.candidates.size();
  std::vector<Vec3> points(n);
  std::vector<double> deltas(n), a(k_count), e(k_count), s_lo(k_count), s_hi(k_count);
  for (int t = 0; t < frames; ++t) {
    if (!only[std::size_t(t)]) continue;
    lows[std::size_t(t)] = 0;
    highs[std::size_t(t)] = std::numeric_limits<double>::infinity();
    if (!screen.usable || t < window || t + window >= frames) continue;
    if (!cheap_chart(curve, screen, t, points, deltas)) continue;
    double delta2 = 0;
    for (double d : deltas) delta2 += d * d;
    const double slack = std::sqrt(delta2) + std::sqrt(kPopIntervalSse);  // Delta, rounding
    double least_high = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < k_count; ++k) {
      const pop_detail::BlockFit& block = screen.candidates[k];
      const pop_detail::MomentInverse& m = block.inverse;
      // The normal equations of the points the candidate keeps: r_j = sum o^j c, vv = sum |c|^2.
      Vec3 r[3];
      double vv = 0;
      e[k] = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const double o = screen.offsets[i];
        if (o >= block.x && o <= block.y) continue;
        r[0] += points[i];
        r[1] += o * points[i];
        r[2] += (o * o) * points[i];
        vv += dot(points[i], points[i]);
        e[k] += screen.block_weights[k][i] * deltas[i];
      }
      const Vec3 beta0 = m.m00 * r[0] + m.m01 * r[1] + m.m02 * r[2];
      const Vec3 beta1 = m.m01 * r[0] + m.m11 * r[1] + m.m12 * r[2];
      const Vec3 beta2 = m.m02 * r[0] + m.m12 * r[1] + m.m22 * r[2];
      const double sse = vv - dot(beta0, r[0]) - dot(beta1, r[1]) - dot(beta2, r[2]);
      const double g = std::sqrt((1 + m.m00) / (block.points - 3));
      a[k] = norm(beta0);
      const double root = std::sqrt(std::max(0.0, sse));
      s_lo[k] = std::max(0.0, root - slack) * g * (1 - 1e-12);
      s_hi[k] = (root + slack) * g * (1 + 1e-12);
      least_high = std::min(least_high, s_hi[k]);
    }
    double lo = std::numeric_limits<double>::infinity(), hi = 0;
    for (std::size_t k = 0; k < k_count; ++k) {
      if (s_lo[k] > least_high) continue;  // never the least score
      const double spread = std::sqrt(1 + screen.candidates[k].inverse.m00);
      lo = std::min(lo, (a[k] - e[k]) / spread);
      hi = std::max(hi, (a[k] + e[k]) / spread);
    }
    lows[std::size_t(t)] = std::max(0.0, lo - kPopScreenMargin);
    highs[std::size_t(t)] = hi + kPopScreenMargin;
  }
}

}  // namespace mocap
