#pragma once
// The table of filter methods: one entry per method holds everything the engine, eval and the
// command line need to know about it (its name, --method help, provenance, validation, automatic
// parameters, shard shape, the kernel job it runs, and its eval grid). The pipeline
// (resolve_for_clip, plan_shards, run_shard) and eval (filter_segment) both dispatch through it,
// so a parameter is resolved and a kernel run the same way in both. README "Layout" lists what a
// new method touches.
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/status.hpp"
#include "engine/clip/filter_settings.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/noise_estimate.hpp"

namespace mocap::engine {

// What a method's automatic rule reads about a clip (or one of eval's segments).
struct NoiseContext {
  double sigma_hat = -1;  // estimated rotation noise (rad); > 0 whenever needs_noise asked for it
  double frame_time = 1.0 / 120;
  bool automatic = false;  // chosen by --method auto: auto's floors apply (choose_automatic)
  // The position channels' noise (estimated on first call) and the body's height (file units).
  std::function<TranslationNoise()> translation_noise;
  double body_height = 0;
  // Each joint's lag-L acceleration power (kernels/joint_motion.hpp) over the clip's segments, for
  // auto's per-joint cut-offs; unset: one cut-off for every joint.
  std::function<std::vector<double>(int lag)> joint_motion;
  // The clip's skeleton, whose legs' hips and knees keep the clip's cut-off (leg_joints_of);
  // null: no joint is kept.
  const Skeleton* skeleton = nullptr;
};

// One grid point of eval: named parameter values, in a fixed order; and one axis of a grid.
using ParamPoint = std::vector<std::pair<std::string, double>>;
struct GridAxis {
  std::string parameter;
  std::vector<double> values;
};

// One command-line option of a method's parameters, as data: app/filter_options.cpp makes it a
// CLI11 option (the engine never includes CLI11). Several methods may declare the same option
// (--sigma-t: bof and gaussian): it is registered once, with the first declaration's text, default
// and checks, and its value goes to every declaration's `apply`.
struct MethodOption {
  enum class Type { real, integer, word };
  enum class Check { none, non_negative, positive, range };
  std::string_view flags{};  // "--window,-k": the long name first
  std::string_view help{};
  Type type = Type::real;
  double default_number = 0;        // real and integer
  std::string_view default_word{};  // word
  bool angle = false;  // rad, or degrees with "deg" (rewritten in radians before the checks)
  Check check = Check::none;
  int min = 0, max = 0;                     // Check::range
  std::vector<std::string_view> choices{};  // word: one of these
  // A word without choices: "" when `value` is acceptable, else what is wrong.
  std::string (*check_word)(const std::string& value) = nullptr;
  bool after_methods = false;   // an option of every method (--boundary): listed after the others
  std::string_view json_key{};  // its key in provenance (FilterSettings::to_json)
  // Past this (> 0) the value is almost surely degrees given as radians: a warning says so, and
  // why.
  double implausible_above = 0;
  std::string_view implausible_why{};
  // Sets the parameter in `settings` from the number (real, integer) or the word.
  void (*apply)(FilterSettings& settings, double number, const std::string& word) = nullptr;

  std::string_view long_name() const;  // "window" for "--window,-k"
};

struct MethodEntry {
  Method method = Method::none;  // its place in the table (set by the table, not by the entry)
  std::string_view name{};       // --method's name
  std::string_view help{};       // its line in --method's help (empty: shares the line of another)
  std::vector<MethodOption> options{};  // its parameters on the command line
  // Shards: joint blocks (per-joint methods, settings.shard_joints), or time blocks
  // (settings.shard_frames) for a method that reads whole poses.
  bool shard_by_frames = false;
  // Fields implied by the method itself (the linear filters' kind).
  void (*normalize)(FilterSettings& settings) = nullptr;
  // The method's parameters, automatic markers (0, < 0) allowed: they are resolved per clip.
  Status (*validate)(const FilterSettings& settings) = nullptr;
  // Its parameters as recorded in provenance (FilterSettings::to_json).
  void (*to_json)(const FilterSettings& settings, nlohmann::json& j) = nullptr;
  // Whether a parameter is asked for from the estimated rotation noise (sigma_hat).
  bool (*needs_noise)(const FilterSettings& settings) = nullptr;
  // Replaces the automatic markers of its parameters by the clip's values.
  void (*resolve)(FilterSettings& settings, const NoiseContext& context) = nullptr;
  // Runs its kernel job on one slice (io's joint and frame range); `distance_joints`: the joints
  // a pose distance looks at (empty: all).
  Status (*run)(const FilterSettings& settings, const MotionIO& io,
                std::span<const std::uint8_t> distance_joints) = nullptr;
};

// Every method, in the order of the Method enum.
std::span<const MethodEntry> method_entries();
const MethodEntry& method_entry(Method method);
const MethodEntry* find_method(std::string_view name);

// The settings with their automatic parameters resolved (context.sigma_hat > 0 wherever the
// method's needs_noise asks for it): for --method auto the method choose_automatic picks, with
// auto's floors; otherwise the asked method's own rule. Used per clip by resolve_for_clip and per
// segment by eval.
FilterSettings resolve_parameters(const FilterSettings& settings, const NoiseContext& context,
                                  bool noisy_positions);

// Runs the resolved settings' kernel job on `io`, with the position channels left alone where the
// settings keep them (filter_translations false).
Status run_method(const FilterSettings& settings, MotionIO io,
                  std::span<const std::uint8_t> distance_joints);

// eval's methods: each runs an engine method from a grid point (or with the automatic parameters
// the engine uses when none is given). nlpm-robust is nlpm with its range term.
struct EvalVariant {
  std::string_view name{};       // eval's --methods name
  std::string_view note{};       // a word on it in eval's --help (empty: none)
  Method method = Method::none;  // a method without a name in Method: find_method("...")->method
  // The parameters a grid may name (docs/eval.md), and the default grid's axes.
  std::vector<std::string> parameters{};
  std::vector<GridAxis> axes{};
  // The automatic rule, as eval's report states it.
  std::string (*rule)() = nullptr;
  // The settings a grid point asks for (nullptr: the automatic parameters), with the point's
  // noise-relative parameters (factors) applied; nullopt when one needs a noise level and
  // sigma_hat is not > 0. Parameters left automatic are resolved by resolve_parameters.
  std::optional<FilterSettings> (*settings)(const ParamPoint* point, double sigma_hat,
                                            double frame_time) = nullptr;
  // The parameters a run used, as eval's report.json records them.
  nlohmann::json (*used)(const FilterSettings& resolved) = nullptr;
  // Whether eval's auto reports settings it chose under this variant's name.
  bool (*reports)(const FilterSettings& chosen) = nullptr;
};

// In the order eval's plots colour them.
std::span<const EvalVariant> eval_variants();

}  // namespace mocap::engine
