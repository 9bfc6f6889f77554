#pragma once
// Pop repair: finds isolated outlier samples ("pops": a sample that jumps away and comes back, the
// spec's `impulse` noise model, ../shared/spec/filters.md "Noise models") and replaces them by
// geodesic interpolation, before a smoothing filter runs. No filter of the spec removes pops: they
// are sparse, large (0.3-1 rad) and the robust noise estimate ignores them by design.
//
// Detection, per joint, in the tangent space (spec "Conventions": Log, Exp, d):
//   For each sample t, the 2 window() neighbours around it (shifted inwards at the clip ends) are
//   mapped to the chart at q_t, v_o = Log(q_t^-1 q_{t+o}), up to the first one farther than
//   2.5 rad on each side (Log wraps at pi), and a quadratic a + b o + c o^2 is fitted to them by
//   least squares, leaving out t and one block of up to max_run other samples (next to t: t's
//   own run; or anywhere in the window: a run of pops near a clean t). Of all blocks, the fit
//   with the smallest estimated prediction variance, mean squared residual per degree of freedom
//   times (1 + leverage of t), is kept (a pop inside a fit spoils it), preferring fits of
//   leverage <= 10 (far extrapolations at the clip ends are a last resort). The residual of t is
//   |a| = d(q_t, q_t Exp(a)): how far t lies from the motion its clean neighbours predict. A
//   quadratic follows real fast motion (constant angular acceleration); a pop, a jump away and
//   back, no quadratic follows.
//   Per joint the robust scale is the median over t of residual / sqrt(1 + leverage), and t is
//   flagged when its residual exceeds max(threshold * scale * sqrt(1 + leverage), floor) and
//   local_threshold times the fit's own prediction error (sqrt of the score above, a Hampel-type
//   local scale): a pop stands out from neighbours that a quadratic fits well, whereas real
//   motion that starts or stops abruptly leaves its neighbours badly fitted too. floor = 0.2 rad
//   sits below the spec's smallest pop (0.3 rad). Measured on the CMU clips (300 frames each,
//   tests/kernels/pop_repair_test.cpp), residual / fit error of the spec's pops: 0.5% below 6.4, 1%
//   below 9.9; of the clean samples that pass the first test: half below 6.1 at 120 fps, three
//   quarters below 6.1 at 30 fps.
// Repair: each maximal run of flagged samples is replaced by slerp between the nearest unflagged
// samples on either side, q_s Exp(u Log(q_s^-1 q_e)); at a clip end the nearest unflagged sample
// is held. Sign continuity (spec "Sign continuity") with the sample before is kept.
//
// Limits: runs longer than max_run are not guaranteed to be found; at 30 fps real motion that
// starts or stops within a frame or two (knees, feet, hands) is still flagged in about 0.17% of
// the samples; real one-frame glitches of the data (0.2-0.7 rad on toes and fingers) are
// flagged like pops; clips shorter than
// kPopRepairMinFrames frames are returned unchanged (no neighbours to predict from); an isolated
// jump at a clip end (the synthetic T-pose frame 0 of CMU conversions) looks like a pop and is
// flagged. Joints that are not motion (kernels/joint_quality.hpp: flipping by pi, constant,
// rounding) should be skipped: a joint flipping by pi is all pops to this test.
#include <cstdint>
#include <span>
#include <vector>

#include "core/quaternion.hpp"
#include "core/status.hpp"
#include "kernels/implementation.hpp"
#include "kernels/motion_io.hpp"

namespace mocap {

inline constexpr int kPopRepairMinFrames = 5;
inline constexpr int kPopRepairMaxRun = 8;  // the fits per sample grow as window() * max_run

struct PopRepairParams {
  int max_run = 3;         // longest run of consecutive pops found for sure (rate 0.01 makes 3s)
  int reach = 2;           // clean samples beyond a run, each side, that the fit needs
  double threshold = 8.0;  // in robust scales (median residuals of the joint)
  double floor = 0.2;      // rad: residuals below this are never pops
  double local_threshold = 6;  // in the fit's own prediction error (0: no local test)

  Status validate() const;
  int window() const { return max_run + reach; }  // neighbours each side of a sample
};

// The steps of the job on one joint's curve (double), exposed for tests and measurements.
// residuals[t]: the geodesic residual of t against its best clean quadratic fit (rad);
// spreads[t]: sqrt(1 + leverage) of that fit, the factor by which its prediction error exceeds
// the noise of one sample (about 1.1 inside the clip, more where the fit extrapolates);
// fit_errors[t]: the chosen fit's estimated prediction error at t (rad).
// This is the scalar reference; simd::pop_residuals (kernels/simd/pop_residuals_simd.hpp) is its
// fast path.
void pop_residuals(std::span<const Quat> curve, const PopRepairParams& params,
                   std::span<double> residuals, std::span<double> spreads,
                   std::span<double> fit_errors);
// The joint's robust scale: median over t of residuals[t] / spreads[t].
double pop_scale(std::span<const double> residuals, std::span<const double> spreads);
// flags[t] = 1 where residuals[t] > max(threshold * scale * spreads[t], floor) and
// residuals[t] > local_threshold * fit_errors[t]; all 0 below
// kPopRepairMinFrames frames. Returns the number of flagged samples. `implementation` picks the
// residuals' path (both give the same bits on this build, see pop_residuals_simd.hpp). With
// `screen`, only the samples kernels/pop_screen.hpp cannot rule out get the full fits (the same
// flags: tests/kernels/pop_screen_test.cpp compares every bit with the unscreened test).
int find_pops(std::span<const Quat> curve, const PopRepairParams& params,
              std::span<std::uint8_t> flags, Implementation implementation = Implementation::fast,
              bool screen = true);
// out = curve with each run of flagged samples replaced by slerp between its unflagged
// neighbours (held at a clip end; left as it is when no sample is unflagged).
void repair_pops(std::span<const Quat> curve, std::span<const std::uint8_t> flags,
                 std::span<Quat> out);

// Detection alone: find_pops on each joint's whole curve, no output but the flags (the pipeline
// decides whether to repair once it has seen every flag of a clip, engine/clip).
struct PopScreen;  // kernels/pop_screen.hpp

struct PopFindJob {
  PopRepairParams params;
  RotationView rotations;              // [F][J]
  std::span<const std::uint8_t> skip;  // optional, one per joint: nonzero is never flagged
  // [F][J]: 1 where a sample is flagged, 0 elsewhere, written for the joints tested.
  std::span<std::uint8_t> flags;
  // The joints tested, [joint_begin, joint_end) (-1: to the last); slices can run as parallel
  // tasks, and each flag is the same whatever slice wrote it.
  int joint_begin = 0, joint_end = -1;
  Implementation implementation = Implementation::fast;  // of the residuals, see find_pops
  bool screen = true;                                    // find_pops' screen (the same flags)
  // Optional: the screen's weights for `params`, made once by the caller for many jobs (slices
  // of one joint each would otherwise make their own); null: run() makes them.
  const PopScreen* screen_weights = nullptr;

  int joint_stop() const { return joint_end < 0 ? rotations.joints : joint_end; }
  Status validate() const;
  Status run() const;
};

struct PopRepairJob {
  PopRepairParams params;
  // Rotations in and out (io.frame_time is not used). Translations, when given, are copied
  // unchanged. A job reads whole joint curves, so each output sample is bit-identical whatever
  // slice computed it.
  MotionIO io;
  // Optional, one entry per joint: nonzero leaves that joint as it came (and counts nothing).
  std::span<const std::uint8_t> skip_joints;
  // Optional, one entry per joint: the number of flagged samples of the job's frame slice,
  // written for the joints of the job's joint slice.
  std::span<int> flagged_per_joint;
  // Optional, [F][J] row-major: 1 where a sample is flagged, 0 elsewhere; written in the slice.
  std::span<std::uint8_t> flagged_samples;
  Implementation implementation = Implementation::fast;  // of the residuals, see find_pops
  bool screen = true;                                    // find_pops' screen (the same flags)

  Status validate() const;
  Status run() const;
};

// The pieces of pop_residuals that its fast path shares.
namespace pop_detail {

// Neighbours farther than this from the sample (rad), and all beyond them, are left out of its
// fit: Log wraps at pi, so a fast motion (0.45 rad per frame over 10 frames) would fold back.
inline constexpr double kChartReach = 2.5;

// Fits that extrapolate far (the block leaves only distant samples on one side of t) predict t
// with (1 + leverage) times the noise variance; above this leverage they are a last resort. The
// symmetric fit has 0.26, one side of 10 samples 1.4.
inline constexpr double kMaxLeverage = 10.0;

// (X^T X)^-1 of a quadratic fit: the cofactors of the symmetric moment matrix
// M = [[s0 s1 s2] [s1 s2 s3] [s2 s3 s4]] over its determinant. `leverage` is m00 =
// x0^T (X^T X)^-1 x0 at x0 = (1, 0, 0): the prediction at o = 0 has variance (1 + leverage)
// sigma^2 for i.i.d. noise of variance sigma^2 per point. `valid` is false when the points do
// not determine a quadratic.
struct MomentInverse {
  double m00 = 0, m01 = 0, m02 = 0, m11 = 0, m12 = 0, m22 = 0;
  bool valid = false;
};

// One candidate fit of a sample t: t and the block [x, y] (x > y: none) of its window left out,
// as offsets from t.
struct BlockFit {
  int x = 0, y = -1;
  double points = 0;
  MomentInverse inverse;  // for the whole window in the chart (the usual case), else unused
};

// The candidates of a "whole" sample: window() neighbours on each side, all within kChartReach.
std::vector<BlockFit> whole_window_blocks(const PopRepairParams& params);

// The candidates, with their moments, of a sample near a clip's end whose window is shifted
// inwards ([lo, lo + 2 window()], all within kChartReach): entry p for t = lo + p (entry
// window(), the whole window's place, is empty). Offsets are integers, so the moments are exact
// and these give the bits of the fits that count their own points.
std::vector<std::vector<BlockFit>> end_window_blocks(const PopRepairParams& params);

// Per-curve scratch of sample_residual: the chart and which samples are in it.
struct ChartScratch {
  std::vector<Vec3> chart;
  std::vector<std::uint8_t> in_chart;
  explicit ChartScratch(std::size_t frames) : chart(frames), in_chart(frames) {}
};

// residuals[t], spreads[t], fit_errors[t] of pop_residuals for one sample t; whole_window is
// whole_window_blocks(params); end_windows, end_window_blocks(params) or empty (the shifted
// windows' fits then count their points and invert their moments themselves: the same bits).
void sample_residual(std::span<const Quat> curve, const PopRepairParams& params,
                     std::span<const BlockFit> whole_window, int t, ChartScratch& scratch,
                     std::span<double> residuals, std::span<double> spreads,
                     std::span<double> fit_errors,
                     std::span<const std::vector<BlockFit>> end_windows = {});

}  // namespace pop_detail
}  // namespace mocap
