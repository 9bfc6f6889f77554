#pragma once
// What a filter run is asked to do: the method, every parameter of the spec, and how a clip is
// cut into shards. Resolves the automatic parameters per clip and runs one shard's job.
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>
#include <vector>

#include "io/clip.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/kalman.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/nlpm.hpp"
#include "kernels/status.hpp"

namespace mocap::engine {

struct Shard;

enum class Method { none, bof, nlpm, gaussian, butterworth, moving_mean, kalman };

std::optional<Method> parse_method(std::string_view name);
std::string_view to_string(Method method);

// nlpm's automatic strength: h = kNlpmAutoFactor * sigma_hat (spec "Noise level estimate"),
// calibrated on ../shared/data/bvh with added noise (README, "Automatic parameters"; `mocap-clean
// eval --grid nlpm.h_factor=...`): 1.2 is within 0.02 dB of the best h at 0.008, 0.03, 0.12 rad.
inline constexpr double kNlpmAutoFactor = 1.2;

// bof's automatic parameters, asked for with sigma_g = 0 and/or sigma_t = 0 (calibrated the same
// way, `--grid bof.sigma_g_factor=... --grid bof.sigma_t_factor=...`):
//   sigma_g = kBofAutoSigmaGFactor sigma_hat
//   sigma_t = max(1, kBofAutoSigmaTFactor sqrt(sigma_hat) (1 / (120 frame_time))^(3/4)) frames
// The temporal width must grow with the noise too: at sigma_t = 1 no sigma_g comes within 3.5 dB
// of the best at 0.12 rad. sqrt(sigma_hat) is the Wiener smoother's width for a motion spectrum
// falling as w^-4; the frame-rate factor follows from the same argument (the shared clips are all
// 120 fps, so it is not measured).
inline constexpr double kBofAutoSigmaGFactor = 3.0;
inline constexpr double kBofAutoSigmaTFactor = 10.0;
// `params` with its zero sigma_g / sigma_t replaced by the rule above.
BilateralParams automatic_bilateral(BilateralParams params, double sigma_hat, double frame_time);

struct FilterSettings {
  Method method = Method::none;
  BilateralParams bilateral;
  LinearParams linear;
  NlpmParams nlpm;                  // h == 0: derived per clip from the estimated noise
  KalmanParams kalman;              // lambda == 0: derived per clip (kalman_auto_lambda)
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
