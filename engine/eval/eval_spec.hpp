#pragma once
// What an evaluation runs: the noise conditions, the methods and the parameter grid of each
// (parsed from eval's --noise, --methods and --grid), with a modest default grid per method.
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "engine/clip/methods.hpp"
#include "kernels/noise_model.hpp"

namespace mocap::engine::eval {

// One of eval's methods: an index into the method table's eval_variants()
// (engine/clip/methods.hpp): "bof", "nlpm", "gaussian", "butterworth", "moving-mean", "kalman",
// "nlpm-robust" (nlpm with the per-joint range term), "auto" (what `--method auto` chooses per
// clip, choose_automatic).
struct EvalMethod {
  int index = 0;
  bool operator==(const EvalMethod&) const = default;
  const EvalVariant& variant() const { return eval_variants()[std::size_t(index)]; }
  bool automatic() const { return variant().method == Method::automatic; }
};

std::optional<EvalMethod> parse_eval_method(std::string_view name);
std::string_view to_string(EvalMethod method);

struct NoiseCondition {
  enum class Model { gaussian, impulse } model = Model::gaussian;
  double sigma = 0.03;   // gaussian, rad
  ImpulseNoise impulse;  // impulse: rate and pop angles (seed set per clip)
  // Position noise on every position channel, as a fraction of the body's height (spec "Noise
  // models": 0.004 of a 1.7 m body is 7 mm); 0 = none.
  double position_sigma = 0;
  std::string label() const;  // "gaussian 0.03", "impulse 0.01", "gaussian 0.02+pos 0.004"
  bool is_gaussian() const { return model == Model::gaussian; }
};

// "gaussian:0.008,0.03,0.12" (one condition per sigma; 0 = the capture as it is), "impulse" (the
// spec's defaults) or "impulse:RATE[,MIN,MAX]", each optionally followed by "+pos:F" (position
// noise of F body heights on every condition of the spec). Empty result and *error set on a
// malformed spec.
std::vector<NoiseCondition> parse_noise(std::string_view spec, std::string* error);
std::vector<NoiseCondition> default_noise_conditions();

// ParamPoint, one grid point, and GridAxis: engine/clip/methods.hpp.
std::string describe(const ParamPoint& point);  // "sigma_g=0.2 sigma_t=1"

// The parameters a method takes in a grid (docs/eval.md):
//   bof: sigma_g | sigma_g_factor [+ sigma_g_floor], sigma_t | sigma_t_factor, iterations
//   nlpm: h | h_factor, K, P          gaussian: sigma_t
//   butterworth: cutoff, order        moving-mean: passes
//   kalman: lambda | lambda_scale
// The relative ones follow each segment's estimated noise sigma_hat, as the automatic rules do
// (their calibration): sigma_g = max(floor, factor sigma_hat), sigma_t = max(1, factor
// sqrt(sigma_hat)) frames, h = factor sigma_hat, lambda = kalman_auto_lambda with that scale.
std::vector<std::string> method_parameters(EvalMethod method);

std::vector<GridAxis> default_axes(EvalMethod method);

// "--grid METHOD.PARAM=v1,v2,..." replaces that axis of the method's grid (and the axis of its
// alternative: h and h_factor, sigma_g and sigma_g_factor, sigma_t and sigma_t_factor, lambda
// and lambda_scale).
struct GridOverride {
  EvalMethod method;
  GridAxis axis;
};
std::optional<GridOverride> parse_grid_override(std::string_view spec, std::string* error);

struct MethodGrid {
  EvalMethod method;
  std::vector<ParamPoint> points;  // the cartesian product of the axes
  // Run after the engine's default pop stage (--pops auto), with garbage joints kept as they
  // came and out of nlpm's
  // distance (what `clean` does by default); false: the spec's filter on the noisy clip.
  bool repaired = false;
  // Foot locking after the filter (engine/clip/foot_stage.hpp, as `clean --feet lock`), with the
  // contacts found on the noisy clip the filter saw (docs/feet.md).
  bool lock_feet = false;
};
// One grid per method and pops mode: with_plain, the spec's filter; with_repaired, the same after
// pop repair. `auto` runs repaired only (that is its definition).
std::vector<MethodGrid> build_grids(const std::vector<EvalMethod>& methods,
                                    const std::vector<GridOverride>& overrides,
                                    bool with_plain = true, bool with_repaired = false);
// "bof", or "bof+pops" for a grid after the pop stage, "+feet" when it locks the feet.
std::string label(const MethodGrid& grid);

// eval's --feet: off, no locking; lock, every run locks the feet; both, the grids as with off
// plus one grid per method that locks the feet after its automatic parameters only (locking
// does not change which grid point is best; this bounds the cost). Unknown modes are rejected by
// the command line.
void apply_feet_mode(std::vector<MethodGrid>& grids, std::string_view mode);
// True for a grid that --feet both added beside grids[m - 1].
bool locked_twin(const std::vector<MethodGrid>& grids, std::size_t m);

}  // namespace mocap::engine::eval
