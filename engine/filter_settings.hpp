#pragma once
// What a filter run is asked to do: the method, every parameter of the spec, and how a clip is
// cut into shards. Resolves the automatic parameters per clip and runs one shard's job.
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>
#include <vector>

#include "io/clip.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/nlpm.hpp"
#include "kernels/status.hpp"

namespace mocap::engine {

struct Shard;

enum class Method { none, bof, nlpm, gaussian, butterworth, moving_mean };

std::optional<Method> parse_method(std::string_view name);
std::string_view to_string(Method method);

// nlpm's automatic strength: h = kNlpmAutoFactor * sigma_hat (spec "Noise level estimate"),
// calibrated on ../shared/data/bvh with added noise (README, "Automatic parameters").
inline constexpr double kNlpmAutoFactor = 1.0;

struct FilterSettings {
  Method method = Method::none;
  BilateralParams bilateral;
  LinearParams linear;
  NlpmParams nlpm;                  // h == 0: derived per clip from the estimated noise
  bool filter_translations = true;  // --translations filter|keep
  int shard_joints = 8;             // joint block of per-joint methods
  int shard_frames = 256;           // time block of nlpm

  Status validate() const;
  nlohmann::json to_json() const;  // parameters as recorded in provenance
};

// The per-clip resolution of automatic parameters, done once on the whole clip before sharding.
struct ResolvedSettings {
  FilterSettings settings;
  double noise_sigma = -1;  // estimated, when it was needed; -1 otherwise
  bool unchanged = false;   // nothing to filter (1 frame, or no joint moves for automatic h)
};
ResolvedSettings resolve_for_clip(const FilterSettings& settings, const io::Clip& clip);

// The output slices of a clip: joint blocks for per-joint methods, time blocks for nlpm.
std::vector<Shard> plan_shards(const FilterSettings& settings, int frames, int joints);

// Writes `shard` of `output` (already sized like input) from `input`.
Status run_shard(const ResolvedSettings& resolved, const io::Clip& input, io::Clip& output,
                 const Shard& shard);

}  // namespace mocap::engine
