#pragma once
// The cheap screen of the pop test (kernels/pop_repair.hpp, issue 15): an upper bound on each
// sample's residual that costs one quaternion product per neighbour instead of a Log each and one
// quadratic fit instead of all the candidate fits, so that find_pops runs the full robust fit only
// on samples near a large step and still returns the flags of the unscreened test to the bit.
//
// The bound, for a "whole" sample t (window() neighbours on each side, every one within the
// chart's reach: the fast path's lanes), in the chart at q_t (spec "Conventions": Log):
//   1. The residual is |a_k| for one candidate fit k: a_k is the value at o = 0 of the
//      least-squares quadratic of the chart points v_i = Log(q_t^-1 q_{t+o_i}) of the window,
//      leaving out t and a block. The fit is linear and reproduces quadratics: a_k =
//      sum_i w_ki v_i with w_ki = m00 + m01 o_i + m02 o_i^2 (row 0 of the fit's inverse moments,
//      0 for a left-out point), and for any quadratic p, sum_i w_ki p(o_i) = p(0). So
//        |a_k| = |p(0) + sum_i w_ki (v_i - p(o_i))| <= |p(0)| + sum_i |w_ki| |v_i - p(o_i)|.
//      Every whole sample's chosen fit is of tier 0 (leverage <= kMaxLeverage: the fit of the
//      whole window, leverage 0.26, always has a finite score), so
//        residual <= |p(0)| + max over the tier-0 candidates k of sum_i |w_ki| |v_i - p(o_i)|
//      (for the defaults, 35 candidates whose sum_i |w_ki| is at most 1.97).
//   2. Log without its arc tangent: for the quaternion u = q_t^-1 q_{t+o} (unit up to the float
//      rounding of the samples) with w >= 0 and
//      vector part x, s = |x|, Log(u) = 2 atan2(s, w) x / s, and with n = |u|, sigma = s / n,
//        |Log(u) - 2x| = 2 |asin(sigma) - s| <= 2 (asin(sigma) - sigma) + 2 s |1/n - 1|,
//      asin(sigma) - sigma = sum_{m>=1} c_m sigma^(2m+1) with c_m <= 1/6, so
//        |Log(u) - 2x| <= delta = sigma^3 / (3 (1 - sigma^2)) + 2 s |1/n - 1|.
//      With the cheap chart points c_i = 2x_i: |v_i - p(o_i)| <= |c_i - p(o_i)| + delta_i.
//      Neighbours with sigma > 0.9 (about 2.2 rad away) are not bounded: the sample is then not
//      screened (nor when the reference might find a neighbour beyond kChartReach = 2.5 rad).
//   3. p is the least-squares quadratic of the cheap points c_i (any quadratic gives a bound; the
//      closest one the tightest).
//   4. Rounding: the bound is computed in double from the same quaternion products the fits use;
//      the fits' own rounding (sums of at most 2 window() terms of |o|^k |v| <= 25 x 2.5, times
//      inverse moments below 10) is below 1e-11 rad, and kPopScreenMargin = 1e-9 rad is added.
//   5. Where a looser bound is already at or below the floor (PopRepairParams::floor: no residual
//      at or below it is a pop), it is returned instead and the maximum over the candidates is
//      not taken: with W_i = max_k |w_ki|, sum_i W_i |v_i - p(o_i)| >= every candidate's sum
//      (for the defaults sum_i W_i = 3.83; the loose bound is about 1.5x the tight one, and on a
//      noisy 120 fps capture 97 % of the samples are screened by it against 99.6 % by the tight
//      one).
// The scale: find_pops compares residuals with the joint's median residual (pop_scale), which
// needs every sample's residual. A screened sample's standardized residual lies in [0, bound];
// the median is monotone in each value, so the median with 0 and with the bound in place of the
// screened ones enclose the true scale; a flag decided the same way at both ends is the
// reference's decision. When one is not, the screened samples whose bounds exceed half the
// scale at which that sample would stop being a pop get their fits (the upper median falls),
// and if that does not decide it either, every sample of the joint does (find_pops).
#include <cstdint>
#include <span>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/implementation.hpp"
#include "kernels/pop_repair.hpp"

namespace mocap {

inline constexpr double kPopScreenMargin = 1e-9;  // rad, over the fits' rounding (< 1e-11)
inline constexpr double kPopScreenMaxSine = 0.9;  // sigma of a neighbour beyond which no bound
inline constexpr double kPopIntervalSse = 1e-9;   // rad^2: the intervals' allowance on an sse

// The intervals (pop_residual_intervals). Where the bounds leave a joint's scale open (the
// noisiest joints: there the bounds are 3-5x the residuals, and the lower median with 0 for every
// screened sample says nothing), each screened sample gets [lo, hi] around its standardized
// residual residual / spread instead of [0, bound], from the candidate fits themselves run on the
// cheap chart points c_i (no arc tangent):
//   1. The fit of candidate k is linear in the points: a_k(v) = sum_i w_ki v_i, so with
//      |v_i - c_i| <= delta_i, |a_k(v) - a_k(c)| <= e_k = sum_i |w_ki| delta_i.
//   2. sqrt(sse_k) is the norm of the points' part outside the fit's span (a projection), so it
//      moves by at most Delta = sqrt(sum_i delta_i^2) between v and c; the score's square root
//      sqrt(sse_k (1 + leverage_k) / (points_k - 3)) lies in [S_lo(k), S_hi(k)].
//   3. The fit the full test keeps has the least score, so it is among K = {k : S_lo(k) <=
//      min_j S_hi(j)}, and residual / spread lies in [min over K of (|a_k(c)| - e_k) / s_k,
//      max over K of (|a_k(c)| + e_k) / s_k], s_k = sqrt(1 + leverage_k).
//   4. Rounding: sqrt(kPopIntervalSse) added to Delta, which covers an error of up to
//      kPopIntervalSse / 4 in each computed sse (of the full test's fits and of these: sums of
//      2 window() terms of at most a few hundred, so errors below 1e-12), a relative 1e-12 on
//      the scores, kPopScreenMargin on the ends.
// The medians with lo and with hi in place of the screened samples' values bracket the scale as
// 0 and the bounds do (find_pops), but closely, so far fewer residuals need their exact fits
// (measured in docs/performance.md).
// The weights of the bound for one PopRepairParams (its whole window's candidate fits).
struct PopScreen {
  int window = 0, max_run = 0;  // of the PopRepairParams it was made for
  std::vector<double> offsets;  // the 2 window() neighbours' offsets o_i, -window..window but 0
  // |w_ki| of each tier-0 candidate k, each distinct row once (28 of 35 for the defaults).
  std::vector<std::vector<double>> block_weights;
  std::vector<double> fit[3];  // p's coefficient k = sum_i fit[k][i] c_i (least squares)
  // W_i = max_k |w_ki| (step 5), and the bound below which the loose sum is returned.
  std::vector<double> loose_weights;
  double loose_cutoff = 0;
  // The tier-0 candidates whose weights are in block_weights, in the same order (the intervals).
  std::vector<pop_detail::BlockFit> candidates;
  // pop_detail::whole_window_blocks(params): the exact fits' candidates, made once per screen.
  std::vector<pop_detail::BlockFit> whole_window;
  // pop_detail::end_window_blocks(params): the shifted windows' near a clip's ends.
  std::vector<std::vector<pop_detail::BlockFit>> end_windows;
  bool usable = false;  // false: a tier-0 candidate with a negative leverage (never on doubles)

  explicit PopScreen(const PopRepairParams& params);
};

// bounds[t] >= the residual pop_residuals gives sample t, or +infinity where the screen gives no
// bound (the first and last window() samples, a neighbour too far away). `fast`:
// simd::pop_residual_bounds (kernels/simd/pop_bounds_simd.hpp), lanes of consecutive samples.
void pop_residual_bounds(std::span<const Quat> curve, const PopScreen& screen,
                         std::span<double> bounds,
                         Implementation implementation = Implementation::fast);

// For each sample t with only[t] != 0: lows[t] <= residual / spread <= highs[t] (pop_residuals'
// values; the intervals above), or 0 and +infinity where the screen gives no bound (as
// pop_residual_bounds). The others are left as they were. `fast`: simd::pop_residual_intervals
// (kernels/simd/pop_intervals_simd.hpp), lanes of samples.
void pop_residual_intervals(std::span<const Quat> curve, const PopScreen& screen,
                            std::span<const std::uint8_t> only, std::span<double> lows,
                            std::span<double> highs,
                            Implementation implementation = Implementation::fast);

}  // namespace mocap
