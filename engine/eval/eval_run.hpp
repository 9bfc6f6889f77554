#pragma once
// The evaluation itself: clean clips in; for each clip x noise condition a seeded noisy copy; for
// each method x grid point (and the automatic parameters) the filtered copy, scored against the
// clean clip. All (clip x condition x method x point) tasks run in one tbb::parallel_for; each is
// a pure function of its indices (noise seeded by --seed, clip path and condition), and results
// are stored by index, so the report is identical for any thread count.
#include <cmath>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/clip.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/clip/motion_check.hpp"
#include "engine/eval/eval_metrics.hpp"
#include "engine/eval/eval_spec.hpp"
#include "kernels/motion_split.hpp"

namespace mocap::engine::eval {

struct EvalConfig {
  std::vector<NoiseCondition> conditions;
  std::vector<MethodGrid> grids;
  std::uint64_t seed = 1;
  double unit_cm = 0;  // 0 = guess per clip
  bool split_impossible = true;
  MotionSplitParams split;
  bool repaired = false;  // some grid runs on the conditioned clips: prepare them
  // The conditioning of those clips: clean's default (automatic: repairs at 60 fps and more,
  // below only clips with many flags) or repair at every frame rate (--pop-stage repair).
  PopsMode pop_stage = PopsMode::automatic;
  bool lock_feet = false;  // some grid locks the feet: find the noisy clips' contacts
  // auto's runs end with the engine's guard (engine/clip/motion_guard.hpp), as `clean` does.
  bool guard = true;
};

// One clean clip and what eval derives from it once.
struct EvalClip {
  std::string name;  // clip path ("cmu_mb_01_01", "cmu/01/01_01")
  Clip clean;
  std::vector<ImpossibleStep> steps;  // found in the clean clip (see eval_run.cpp)
  std::vector<Segment> segments;
  ClipGeometry geometry;
  ClipReference reference;
};

// The noise of one clip x condition and the noise level estimated on each of its segments.
struct NoisyClip {
  std::vector<float> rotations;     // [F][J][4]
  std::vector<float> translations;  // [F][J][3]: the clean ones plus the condition's position noise
  std::vector<double> sigma_hats;   // per segment
  // The same after the engine's conditioning (engine/clip/clip_conditioning.hpp: pop repair,
  // garbage joints found on the noisy clip), and its noise estimates (garbage joints left out).
  std::vector<float> repaired;
  std::vector<double> repaired_sigma_hats;
  std::vector<std::uint8_t> garbage;
  std::vector<std::uint8_t> flipping;  // per joint: 1 = flipping (garbage, filtered between flips)
  std::size_t pops = 0;                // samples the repair replaced
  // Against the clean clip: samples the noise moved by more than kPoppedAngle (the spec's pops
  // are 0.3-1 rad), how many of them the pop stage flagged, how many flags fell on other samples
  // (false repairs), and how many popped samples stay that far from the clean after the stage.
  std::size_t popped = 0, pops_caught = 0, false_repairs = 0, pops_left = 0;
  // Of those, the popped and left samples on a frame that is a segment of its own in the clean
  // clip (CMU's synthetic T-pose frame 0): no neighbour in time to tell a pop there from the pose,
  // so the pops removed are reported with and without them.
  std::size_t popped_lone = 0, pops_left_lone = 0;
  std::vector<std::pair<int, int>> left_samples;  // (frame, joint) of the pops left
  // With config.lock_feet: the legs and contacts found on the noisy clip (feet) and on the
  // conditioned one (repaired_feet), as `clean` finds them on the clip its filter sees.
  ClipFeet feet, repaired_feet;
  // With config.guard: the noisy clip's jitter and skating, as the guard measures its input.
  MotionMeasure before;
};
inline constexpr double kPoppedAngle = 0.25;

struct TaskResult {
  Score score;
  nlohmann::json resolved;  // automatic runs: the parameters used per segment
  std::string error;
};

struct EvalResults {
  std::vector<EvalClip> clips;
  std::vector<std::vector<NoisyClip>> noisy;     // [condition][clip]
  std::vector<std::vector<Score>> noisy_scores;  // [condition][clip]
  // [method][point][condition][clip]; point == grid.points.size() is the automatic parameters.
  std::vector<std::vector<std::vector<std::vector<TaskResult>>>> results;
  double prepare_seconds = 0, filter_seconds = 0;
  std::size_t tasks = 0;
};

// The seed of one clip x condition: splitmix64 of --seed and an FNV-1a hash of both names, so a
// clip's noise does not depend on which other clips or conditions run.
std::uint64_t noise_seed(std::uint64_t seed, const std::string& clip, const std::string& condition);

// Adds the condition's rotation noise to a copy of `clean`'s rotations.
std::vector<float> make_noisy(const Clip& clean, const NoiseCondition& condition,
                              std::uint64_t seed);
// Adds the condition's position noise (position_sigma body heights, on the joints with position
// channels) to a copy of `clean`'s translations; seeded apart from the rotation noise.
std::vector<float> make_noisy_translations(const Clip& clean, const NoiseCondition& condition,
                                           double body_height, std::uint64_t seed);

// Prepares a clip from its source: every frame_step-th frame of it (a lower frame rate,
// core/clip.hpp decimate), the impossible steps and segments (when config.split_impossible), the
// geometry and the reference, whose glitches are found on the source at its own rate.
EvalClip prepare_clip(std::string name, Clip source, const EvalConfig& config, int frame_step = 1);

// Runs every task on all threads of the current TBB arena; `progress(done, total)` is called
// under a lock after each task (may be empty).
EvalResults run_evaluation(std::vector<EvalClip> clips, const EvalConfig& config,
                           const std::function<void(std::size_t, std::size_t)>& progress);

// The pooled score of method m, point p, condition c over all clips (p == points: automatic).
Score pooled(const EvalResults& results, std::size_t m, std::size_t p, std::size_t c);
Score pooled_noisy(const EvalResults& results, std::size_t c);
// The grid point with the highest pooled PSNR (NaN scores lose), or -1 when none scored.
int best_point(const EvalResults& results, const EvalConfig& config, std::size_t m, std::size_t c);
// The parameters of grid point p that sit at the lowest or highest value of their axis (axes of
// one value do not count): a best point there may lie beyond the grid, which should be widened.
std::vector<std::string> edge_parameters(const MethodGrid& grid, std::size_t p);
// Min, median and max over clips of method m, point p, condition c (clips that failed left
// out); NaN when none scored.
struct Spread {
  double min = NAN, median = NAN, max = NAN;
};
Spread psnr_spread(const EvalResults& results, std::size_t m, std::size_t p, std::size_t c);

// Filters every segment of noisy clip (clip, condition) with a method into `out` (sized like the
// clip); the one place where the segments are applied. `resolved` may be null.
// With `repaired`, on the conditioned clip: garbage joints are copied as they came and stay out
// of nlpm's pose distance.
// `out_translations` receives the filtered translations (sized like the clip's).
// With `lock_feet`, the planted feet are then pinned (engine/clip/foot_stage.hpp) with the noisy
// clip's contacts. With `guard` (needs noisy.before), the engine's guard then keeps the first of
// filtered (locked), filtered, input (locked), input that raises neither the jitter nor the
// skating of the noisy clip (engine/clip/motion_guard.hpp).
Status filter_clip(const EvalClip& clip, const NoisyClip& noisy, EvalMethod method, bool repaired,
                   const ParamPoint* point, std::vector<float>& out,
                   std::vector<float>& out_translations, nlohmann::json* resolved,
                   bool lock_feet = false, bool guard = false);

}  // namespace mocap::engine::eval
