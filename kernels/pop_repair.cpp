#include "kernels/pop_repair.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "core/format.hpp"
#include "core/quaternion.hpp"
#include "kernels/median.hpp"
#include "kernels/pop_screen.hpp"
#include "kernels/simd/pop_residuals_simd.hpp"

namespace mocap {
namespace {

using pop_detail::BlockFit;
using pop_detail::kChartReach;
using pop_detail::kMaxLeverage;
using pop_detail::MomentInverse;

// The normal-equation sums of a quadratic least-squares fit in the offset o, per point
// (1, o, o^2, o^3, o^4) and per component (v, o v, o^2 v), plus sum |v|^2.
struct FitSums {
  double s[5] = {};
  Vec3 r[3];
  double vv = 0;

  void add(double o, Vec3 v, double sign) {
    const double o2 = o * o;
    s[0] += sign;
    s[1] += sign * o;
    s[2] += sign * o2;
    s[3] += sign * o2 * o;
    s[4] += sign * o2 * o2;
    r[0] += sign * v;
    r[1] += (sign * o) * v;
    r[2] += (sign * o2) * v;
    vv += sign * dot(v, v);
  }
};

MomentInverse invert_moments(const FitSums& f) {
  const double a = f.s[0], b = f.s[1], c = f.s[2], d = f.s[3], e = f.s[4];
  const double c00 = c * e - d * d, c01 = c * d - b * e, c02 = b * d - c * c;
  const double c11 = a * e - c * c, c12 = b * c - a * d, c22 = a * c - b * b;
  const double det = a * c00 + b * c01 + c * c02;
  if (!(std::abs(det) > 1e-9)) return {};
  const double inv = 1.0 / det;
  return {c00 * inv, c01 * inv, c02 * inv, c11 * inv, c12 * inv, c22 * inv, true};
}

// The least-squares quadratic of `f` with its inverse moments `m`: `intercept` is the fit at
// o = 0 and `sse` the sum of squared residuals.
void solve_quadratic(const MomentInverse& m, const FitSums& f, Vec3& intercept, double& sse) {
  const Vec3 beta0 = m.m00 * f.r[0] + m.m01 * f.r[1] + m.m02 * f.r[2];
  const Vec3 beta1 = m.m01 * f.r[0] + m.m11 * f.r[1] + m.m12 * f.r[2];
  const Vec3 beta2 = m.m02 * f.r[0] + m.m12 * f.r[1] + m.m22 * f.r[2];
  intercept = beta0;
  // Least squares: sse = sum |v|^2 - beta . X^T v.
  sse = std::max(0.0, f.vv - dot(beta0, f.r[0]) - dot(beta1, f.r[1]) - dot(beta2, f.r[2]));
}

// The candidate blocks of a sample whose window is [lo, hi] (t inside), in the order the fits
// are compared (the first of equal scores wins). With `moments`, also their point counts and
// moment inverses for a window where every neighbour is in the chart: offsets are integers, so
// the moments and cofactors are exact and computing them once changes no bit of any fit. Without
// (a window near an end or with neighbours out of the chart, whose fits count their own points
// and invert their own moments), only the blocks' extents.
std::vector<BlockFit> candidate_blocks(int t, int lo, int hi, int max_run, bool moments) {
  std::vector<BlockFit> blocks;
  FitSums all;
  if (moments)
    for (int u = lo; u <= hi; ++u)
      if (u != t) all.add(u - t, {}, 1.0);
  for (int x = lo; x <= hi; ++x)
    for (int y = x - 1; y <= std::min(hi, x + max_run); ++y) {
      const int excluded = y - x + 1 - (x <= t && t <= y ? 1 : 0);
      if (excluded > max_run || (y < x && x != lo)) continue;
      if (!moments) {
        blocks.push_back({x - t, y - t, 0, {}});
        continue;
      }
      FitSums fit = all;
      for (int u = x; u <= y; ++u)
        if (u != t) fit.add(u - t, {}, -1.0);
      blocks.push_back({x - t, y - t, std::round(fit.s[0]), invert_moments(fit)});
    }
  return blocks;
}

}  // namespace

Status PopRepairParams::validate() const {
  if (max_run < 1 || max_run > kPopRepairMaxRun)
    return Status::error("max_run must be in [1, " + std::to_string(kPopRepairMaxRun) + "], got " +
                         std::to_string(max_run));
  if (reach < 2)
    return Status::error("reach must be >= 2 (a quadratic needs clean neighbours), got " +
                         std::to_string(reach));
  if (!(threshold > 0) || !std::isfinite(threshold))
    return Status::error(format("threshold must be finite and > 0, got %g", threshold));
  if (!(floor > 0) || !std::isfinite(floor))
    return Status::error(format("floor must be finite and > 0 rad, got %g", floor));
  if (!(local_threshold >= 0) || !std::isfinite(local_threshold))
    return Status::error(
        format("local_threshold must be finite and >= 0, got %g", local_threshold));
  return {};
}

namespace pop_detail {

std::vector<BlockFit> whole_window_blocks(const PopRepairParams& params) {
  return candidate_blocks(params.window(), 0, 2 * params.window(), params.max_run, true);
}

std::vector<std::vector<BlockFit>> end_window_blocks(const PopRepairParams& params) {
  const int window = params.window();
  std::vector<std::vector<BlockFit>> ends(std::size_t(2 * window + 1));
  for (int p = 0; p <= 2 * window; ++p)
    if (p != window)
      ends[std::size_t(p)] = candidate_blocks(p, 0, 2 * window, params.max_run, true);
  return ends;
}

void sample_residual(std::span<const Quat> curve, const PopRepairParams& params,
                     std::span<const BlockFit> whole_window, int t, ChartScratch& scratch,
                     std::span<double> residuals, std::span<double> spreads,
                     std::span<double> fit_errors,
                     std::span<const std::vector<BlockFit>> end_windows) {
  const int frames = int(curve.size());
  const int window = params.window();
  std::vector<Vec3>& chart = scratch.chart;
  std::vector<std::uint8_t>& in_chart = scratch.in_chart;
  // 2 window neighbours, shifted inwards at the clip ends so that an end sample is predicted
  // from as many samples as an inner one.
  const int lo = std::max(0, std::min(t - window, frames - 1 - 2 * window));
  const int hi = std::min(frames - 1, std::max(t + window, 2 * window));
  const Quat to_chart = inverse(curve[std::size_t(t)]);
  FitSums all;
  // Outwards from t on each side, up to the first neighbour out of the chart's reach: beyond
  // it, Log may have wrapped (a point 4.5 rad away maps to 2pi - 4.5 = 1.8 rad).
  for (int side : {-1, 1}) {
    bool reachable = true;
    for (int u = t + side; u >= lo && u <= hi; u += side) {
      chart[std::size_t(u)] = log(to_chart * curve[std::size_t(u)]);
      reachable = reachable && norm(chart[std::size_t(u)]) <= kChartReach;
      in_chart[std::size_t(u)] = reachable;
      if (reachable) all.add(u - t, chart[std::size_t(u)], 1.0);
    }
  }
  // The best fit among those that predict t well (leverage <= kMaxLeverage), else among all.
  double best_score[2] = {std::numeric_limits<double>::infinity(),
                          std::numeric_limits<double>::infinity()};
  double residual[2] = {0, 0}, spread[2] = {1, 1};
  const auto reachable = [&](int u) { return u == t || in_chart[std::size_t(u)] != 0; };
  bool in_reach = true;
  for (int u = lo; in_reach && u <= hi; ++u) in_reach = reachable(u);
  // A window of 2 window() + 1 samples all in reach has its candidates' moments made once: the
  // whole window's, or a shifted one's near an end (then `whole` too: the same bits).
  const bool centred = lo == t - window && hi == t + window;
  const bool shifted = !centred && hi - lo == 2 * window && !end_windows.empty();
  const bool whole = in_reach && (centred || shifted);
  std::vector<BlockFit> near_an_end;
  if (!whole) near_an_end = candidate_blocks(t, lo, hi, params.max_run, false);
  const std::span<const BlockFit> blocks =
      !whole    ? std::span<const BlockFit>(near_an_end)
      : centred ? whole_window
                : std::span<const BlockFit>(end_windows[std::size_t(t - lo)]);
  // Blocks come x by x with y rising: each fit is the one before with one more point left
  // out, in the same order as leaving the whole block out of `all` (the same bits).
  FitSums fit;
  int fit_x = 0, fit_y = 0;
  bool started = false;
  for (const BlockFit& block : blocks) {
    if (!started || block.x != fit_x || block.y < fit_y) {
      fit = all;
      fit_x = block.x;
      fit_y = block.x - 1;
      started = true;
    }
    for (; fit_y < block.y; ++fit_y) {
      const int u = t + fit_y + 1;
      if (u != t && in_chart[std::size_t(u)]) fit.add(u - t, chart[std::size_t(u)], -1.0);
    }
    const double points = whole ? block.points : std::round(fit.s[0]);  // an exact count
    if (points < 4) continue;
    const MomentInverse inverse = whole ? block.inverse : invert_moments(fit);
    if (!inverse.valid) continue;
    Vec3 intercept;
    double sse = 0;
    solve_quadratic(inverse, fit, intercept, sse);
    const double leverage = inverse.m00;
    // The estimated variance of the prediction at t: noise variance times (1 + leverage).
    const double score = sse / (points - 3) * (1 + leverage);
    const int tier = leverage <= kMaxLeverage ? 0 : 1;
    if (score < best_score[tier]) {
      best_score[tier] = score;
      residual[tier] = norm(intercept);
      spread[tier] = std::sqrt(1 + leverage);
    }
  }
  const int tier = std::isfinite(best_score[0]) ? 0 : 1;
  residuals[std::size_t(t)] = residual[tier];
  spreads[std::size_t(t)] = spread[tier];
  fit_errors[std::size_t(t)] = std::isfinite(best_score[tier]) ? std::sqrt(best_score[tier]) : 0;
}

}  // namespace pop_detail

void pop_residuals(std::span<const Quat> curve, const PopRepairParams& params,
                   std::span<double> residuals, std::span<double> spreads,
                   std::span<double> fit_errors) {
  const std::vector<BlockFit> whole_window = pop_detail::whole_window_blocks(params);
  pop_detail::ChartScratch scratch(curve.size());
  for (int t = 0; t < int(curve.size()); ++t)
    pop_detail::sample_residual(curve, params, whole_window, t, scratch, residuals, spreads,
                                fit_errors);
}

double pop_scale(std::span<const double> residuals, std::span<const double> spreads) {
  if (residuals.empty()) return 0;
  std::vector<double> standardized(residuals.size());
  for (std::size_t t = 0; t < residuals.size(); ++t) standardized[t] = residuals[t] / spreads[t];
  return median(standardized);
}

namespace {

// find_pops' test of one sample against the joint's scale.
bool is_pop(double residual, double spread, double fit_error, double scale,
            const PopRepairParams& params) {
  return residual > std::max(params.threshold * scale * spread, params.floor) &&
         residual > params.local_threshold * fit_error;
}

}  // namespace

namespace {

// find_pops with the screen's weights made once per job (null: no screen).
int find_pops_with(std::span<const Quat> curve, const PopRepairParams& params,
                   std::span<std::uint8_t> flags, Implementation implementation,
                   const PopScreen* screen) {
  std::fill(flags.begin(), flags.end(), std::uint8_t{0});
  if (curve.size() < std::size_t(kPopRepairMinFrames)) return 0;
  const std::size_t n = curve.size();
  std::vector<double> residuals(n), spreads(n), fit_errors(n);
  // The candidate blocks of a whole window, made once per screen, or once here.
  const std::vector<BlockFit> own =
      screen ? std::vector<BlockFit>{} : pop_detail::whole_window_blocks(params);
  const std::span<const BlockFit> whole_window = screen ? screen->whole_window : own;
  // The shifted windows' candidates near the ends, made once per screen (none without).
  const std::span<const std::vector<BlockFit>> end_windows =
      screen ? std::span<const std::vector<BlockFit>>(screen->end_windows)
             : std::span<const std::vector<BlockFit>>{};
  // The residuals of the samples where `only` is nonzero (all when empty).
  const auto compute = [&](std::span<const std::uint8_t> only) {
    if (implementation == Implementation::fast) {
      simd::pop_residuals(curve, params, residuals, spreads, fit_errors, only, whole_window,
                          end_windows);
    } else if (only.empty()) {
      pop_residuals(curve, params, residuals, spreads, fit_errors);
    } else {
      pop_detail::ChartScratch scratch(n);
      for (std::size_t t = 0; t < n; ++t)
        if (only[t])
          pop_detail::sample_residual(curve, params, whole_window, int(t), scratch, residuals,
                                      spreads, fit_errors, end_windows);
    }
  };
  int count = 0;
  if (screen) {
    // kernels/pop_screen.hpp: only samples whose bound exceeds the floor can be pops.
    std::vector<double> bounds(n);
    pop_residual_bounds(curve, *screen, bounds);
    std::vector<std::uint8_t> exact(n);
    std::vector<std::size_t> maybe;  // computed samples that are pops at some scale >= 0
    for (std::size_t t = 0; t < n; ++t) exact[t] = !(bounds[t] <= params.floor);
    compute(exact);
    // is_pop only turns false as the scale grows; at scale 0 it is the floor and local tests.
    for (std::size_t t = 0; t < n; ++t)
      if (exact[t] && is_pop(residuals[t], spreads[t], fit_errors[t], 0.0, params))
        maybe.push_back(t);
    if (maybe.empty()) return 0;  // no sample is a pop whatever the scale
    // The scale lies between the medians with the lower and with the upper ends of what is
    // known of each screened sample's standardized residual in place of it ([0, bound], or the
    // interval pop_residual_intervals gives; the median is monotone in each value); a sample
    // that is a pop at the upper end is one at the true scale, one that is not at the lower end
    // is not.
    std::vector<double> lows(n, 0.0), highs(bounds);
    const auto scale_with = [&](bool upper) {
      std::vector<double> values(n);
      for (std::size_t t = 0; t < n; ++t)
        values[t] = exact[t] ? residuals[t] / spreads[t] : upper ? highs[t] : lows[t];
      return median(values);
    };
    const auto decide = [&]() {
      const double high = scale_with(true);
      std::vector<std::size_t> open;
      for (std::size_t t : maybe)
        if (!is_pop(residuals[t], spreads[t], fit_errors[t], high, params)) open.push_back(t);
      if (open.empty()) return true;
      const double low = scale_with(false);
      for (std::size_t t : open)
        if (is_pop(residuals[t], spreads[t], fit_errors[t], low, params)) return false;
      maybe.erase(std::remove_if(maybe.begin(), maybe.end(),
                                 [&](std::size_t t) {
                                   return std::find(open.begin(), open.end(), t) != open.end();
                                 }),
                  maybe.end());
      return true;
    };
    bool decided = decide();
    if (!decided) {
      // The bounds are too loose here (a noisy joint): the screened samples get the intervals
      // of the candidate fits on the cheap chart (kernels/pop_screen.hpp), a few times tighter,
      // and usually decide without a fit on the Logs.
      std::vector<std::uint8_t> tighten(n);
      for (std::size_t t = 0; t < n; ++t) tighten[t] = !exact[t] && std::isfinite(bounds[t]);
      pop_residual_intervals(curve, *screen, tighten, lows, highs, implementation);
      for (std::size_t t = 0; t < n; ++t)
        if (tighten[t]) highs[t] = std::min(highs[t], bounds[t]);
      decided = decide();
    }
    if (!decided) {
      // The bounds above a sample's own limit (the scale at which it stops being a pop, halved)
      // keep the upper median too high, and the screened samples' zeros the lower one too low:
      // those samples get their residuals, largest bound first, in rounds with a decision after
      // each (the flags depend only on the scale, not on which residuals are known). A sample
      // that is no pop needs more than half of the joint's residuals above its limit to be
      // decided, so the first round brings the known ones to half; the largest bounds are the
      // samples most likely to be those.
      double limit = std::numeric_limits<double>::infinity();
      for (std::size_t t : maybe)
        limit = std::min(limit, 0.5 * residuals[t] / (params.threshold * spreads[t]));
      std::vector<std::size_t> order;
      std::size_t known = 0;
      for (std::size_t t = 0; t < n; ++t) {
        known += exact[t];
        if (!exact[t] && bounds[t] > limit) order.push_back(t);
      }
      std::stable_sort(order.begin(), order.end(),
                       [&](std::size_t a, std::size_t b) { return bounds[a] > bounds[b]; });
      std::vector<std::uint8_t> more(n);
      const std::size_t step = std::max<std::size_t>(1, n / 16);
      std::size_t first = n / 2 + 1 > known ? n / 2 + 1 - known : 0;
      for (std::size_t done = 0; !decided && done < order.size();) {
        const std::size_t batch = std::min(order.size() - done, std::max(step, first));
        first = 0;
        std::fill(more.begin(), more.end(), std::uint8_t{0});
        for (std::size_t i = done; i < done + batch; ++i) more[order[i]] = exact[order[i]] = 1;
        done += batch;
        compute(more);
        decided = decide();
      }
    }
    if (decided) {
      for (std::size_t t : maybe) {
        flags[t] = 1;
        ++count;
      }
      return count;
    }
    // The scale decides some sample: the residuals of all (those computed keep their bits).
    for (std::size_t t = 0; t < n; ++t) exact[t] = !exact[t];
    compute(exact);
  } else {
    compute({});
  }
  const double scale = pop_scale(residuals, spreads);
  for (std::size_t t = 0; t < n; ++t)
    if (is_pop(residuals[t], spreads[t], fit_errors[t], scale, params)) {
      flags[t] = 1;
      ++count;
    }
  return count;
}

}  // namespace

int find_pops(std::span<const Quat> curve, const PopRepairParams& params,
              std::span<std::uint8_t> flags, Implementation implementation, bool screen) {
  if (!screen) return find_pops_with(curve, params, flags, implementation, nullptr);
  const PopScreen weights(params);
  return find_pops_with(curve, params, flags, implementation, &weights);
}

void repair_pops(std::span<const Quat> curve, std::span<const std::uint8_t> flags,
                 std::span<Quat> out) {
  const int frames = int(curve.size());
  std::copy(curve.begin(), curve.end(), out.begin());
  for (int s = 0; s < frames;) {
    if (!flags[std::size_t(s)]) {
      ++s;
      continue;
    }
    int e = s;
    while (e + 1 < frames && flags[std::size_t(e + 1)]) ++e;
    const int before = s - 1, after = e + 1;
    if (before >= 0 && after < frames) {
      const Quat from = curve[std::size_t(before)];
      const Vec3 path = log(inverse(from) * curve[std::size_t(after)]);
      for (int t = s; t <= e; ++t)
        out[std::size_t(t)] = from * exp((double(t - before) / double(after - before)) * path);
    } else if (before >= 0 || after < frames) {
      const Quat held = curve[std::size_t(before >= 0 ? before : after)];
      for (int t = s; t <= e; ++t) out[std::size_t(t)] = held;
    }
    // Sign continuity with the sample before (or after, for a run at the start).
    for (int t = s; t <= e; ++t) {
      const int neighbour = t > 0 ? t - 1 : after;
      if (neighbour < frames && dot(out[std::size_t(t)], out[std::size_t(neighbour)]) < 0)
        out[std::size_t(t)] = negate(out[std::size_t(t)]);
    }
    s = e + 1;
  }
}

Status PopFindJob::validate() const {
  if (Status s = validate_sample_flags("PopFindJob", rotations, skip, flags); !s) return s;
  if (joint_begin < 0 || joint_stop() > rotations.joints || joint_begin > joint_stop())
    return Status::error("PopFindJob: joint slice [" + std::to_string(joint_begin) + ", " +
                         std::to_string(joint_stop()) + ") is outside the clip's " +
                         std::to_string(rotations.joints) + " joints");
  if (implementation != Implementation::fast && implementation != Implementation::reference)
    return Status::error("PopFindJob: unknown implementation");
  if (screen_weights != nullptr &&
      (screen_weights->window != params.window() || screen_weights->max_run != params.max_run))
    return Status::error("PopFindJob: screen_weights were made for a window of " +
                         std::to_string(screen_weights->window) + " and max_run " +
                         std::to_string(screen_weights->max_run) + ", params have " +
                         std::to_string(params.window()) + " and " +
                         std::to_string(params.max_run));
  return params.validate();
}

Status PopFindJob::run() const {
  if (Status s = validate(); !s) return s;
  const std::size_t F = std::size_t(rotations.frames), J = std::size_t(rotations.joints);
  std::vector<Quat> curve(F);
  std::vector<std::uint8_t> found(F);
  const std::optional<PopScreen> own = screen && screen_weights == nullptr
                                           ? std::optional<PopScreen>(params)
                                           : std::optional<PopScreen>();
  const PopScreen* weights = !screen ? nullptr : screen_weights ? screen_weights : &*own;
  for (int j = joint_begin; j < joint_stop(); ++j) {
    std::fill(found.begin(), found.end(), std::uint8_t{0});
    if (skip.empty() || skip[std::size_t(j)] == 0) {
      for (std::size_t t = 0; t < F; ++t) curve[t] = load_quat(rotations.at(int(t), j));
      find_pops_with(curve, params, found, implementation, weights);
    }
    for (std::size_t t = 0; t < F; ++t) flags[t * J + std::size_t(j)] = found[t];
  }
  return {};
}

Status PopRepairJob::validate() const {
  if (Status s = io.validate(); !s) return s;
  const std::size_t joints = std::size_t(io.rotations.joints);
  if (!skip_joints.empty() && skip_joints.size() != joints)
    return Status::error("skip_joints must have one entry per joint (" + std::to_string(joints) +
                         "), got " + std::to_string(skip_joints.size()));
  if (!flagged_per_joint.empty() && flagged_per_joint.size() != joints)
    return Status::error("flagged_per_joint must have one entry per joint (" +
                         std::to_string(joints) + "), got " +
                         std::to_string(flagged_per_joint.size()));
  const std::size_t samples = std::size_t(io.rotations.frames) * joints;
  if (!flagged_samples.empty() && flagged_samples.size() != samples)
    return Status::error("flagged_samples must have one entry per sample (" +
                         std::to_string(samples) + "), got " +
                         std::to_string(flagged_samples.size()));
  if (implementation != Implementation::fast && implementation != Implementation::reference)
    return Status::error("unknown implementation");
  return params.validate();
}

Status PopRepairJob::run() const {
  if (Status s = validate(); !s) return s;
  const int frames = io.rotations.frames, joints = io.rotations.joints;
  const int begin = io.frame_begin, end = io.frame_stop();
  std::vector<Quat> curve(static_cast<std::size_t>(frames)),
      repaired(static_cast<std::size_t>(frames));
  std::vector<std::uint8_t> flags(static_cast<std::size_t>(frames));
  const std::optional<PopScreen> weights =
      screen ? std::optional<PopScreen>(params) : std::optional<PopScreen>();
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    const bool skip = !skip_joints.empty() && skip_joints[std::size_t(j)] != 0;
    std::fill(flags.begin(), flags.end(), std::uint8_t{0});
    if (!skip) {
      for (int t = 0; t < frames; ++t) curve[std::size_t(t)] = load_quat(io.rotations.at(t, j));
      find_pops_with(curve, params, flags, implementation, weights ? &*weights : nullptr);
    }
    const bool changes = std::find(flags.begin() + begin, flags.begin() + end, std::uint8_t{1}) !=
                         flags.begin() + end;
    if (changes) repair_pops(curve, flags, repaired);
    int count = 0;
    for (int t = begin; t < end; ++t) {
      const std::size_t i = std::size_t(t);
      count += flags[i];
      if (!flagged_samples.empty())
        flagged_samples[i * std::size_t(joints) + std::size_t(j)] = flags[i];
      if (changes && flags[i])
        store_quat(repaired[i], io.filtered_rotations.at(t, j));
      else
        std::memcpy(io.filtered_rotations.at(t, j), io.rotations.at(t, j), 4 * sizeof(float));
    }
    if (!flagged_per_joint.empty()) flagged_per_joint[std::size_t(j)] = count;
  }
  if (io.has_translations())
    for (int t = begin; t < end; ++t)
      for (int j = io.joint_begin; j < io.joint_stop(); ++j)
        std::memcpy(io.filtered_translations.at(t, j), io.translations.at(t, j), 3 * sizeof(float));
  return {};
}

}  // namespace mocap
