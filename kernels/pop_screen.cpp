#include "kernels/pop_screen.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/simd/pop_bounds_simd.hpp"

namespace mocap {

PopScreen::PopScreen(const PopRepairParams& params) : window(params.window()) {
  for (int o = -window; o <= window; ++o)
    if (o != 0) offsets.push_back(double(o));
  const std::size_t n = offsets.size();
  usable = true;
  for (const pop_detail::BlockFit& block : pop_detail::whole_window_blocks(params)) {
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
    if (std::find(block_weights.begin(), block_weights.end(), weights) == block_weights.end())
      block_weights.push_back(std::move(weights));
  }
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
    // The cheap chart: 2x of q_t^-1 q_u, the product the reference's Log reads, on w >= 0.
    const Quat to_chart = inverse(curve[std::size_t(t)]);
    bool bounded = true;
    for (std::size_t i = 0; i < n && bounded; ++i) {
      Quat u = to_chart * curve[std::size_t(t + int(screen.offsets[i]))];
      if (u.w < 0) u = negate(u);
      const Vec3 x{u.x, u.y, u.z};
      const double s = norm(x), length = std::sqrt(u.w * u.w + s * s);
      const double sine = s / length;
      bounded = sine <= kPopScreenMaxSine;
      points[i] = 2.0 * x;
      deltas[i] =
          sine * sine * sine / (3.0 * (1.0 - sine * sine)) + 2.0 * s * std::abs(1.0 / length - 1.0);
    }
    if (!bounded) continue;
    Vec3 coefficient[3];
    for (int k = 0; k < 3; ++k)
      for (std::size_t i = 0; i < n; ++i) coefficient[k] += screen.fit[k][i] * points[i];
    for (std::size_t i = 0; i < n; ++i) {
      const double o = screen.offsets[i];
      const Vec3 p = coefficient[0] + o * coefficient[1] + (o * o) * coefficient[2];
      deltas[i] += norm(points[i] - p);  // now a bound on |v_i - p(o_i)|
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

}  // namespace mocap
