#include "engine/clip/filter_settings.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "kernels/foot_contacts.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/noise_estimate.hpp"

namespace mocap::engine {

std::optional<Method> parse_method(std::string_view name) {
  if (name == "none") return Method::none;
  if (name == "bof") return Method::bof;
  if (name == "nlpm") return Method::nlpm;
  if (name == "gaussian") return Method::gaussian;
  if (name == "butterworth") return Method::butterworth;
  if (name == "moving-mean") return Method::moving_mean;
  if (name == "kalman") return Method::kalman;
  if (name == "auto") return Method::automatic;
  return std::nullopt;
}

std::optional<PopsMode> parse_pops_mode(std::string_view name) {
  if (name == "off") return PopsMode::off;
  if (name == "detect") return PopsMode::detect;
  if (name == "repair") return PopsMode::repair;
  if (name == "auto") return PopsMode::automatic;
  return std::nullopt;
}

std::string_view to_string(PopsMode mode) {
  switch (mode) {
    case PopsMode::off:
      return "off";
    case PopsMode::detect:
      return "detect";
    case PopsMode::repair:
      return "repair";
    case PopsMode::automatic:
      return "auto";
  }
  return "?";
}

std::string_view to_string(Method method) {
  switch (method) {
    case Method::none:
      return "none";
    case Method::bof:
      return "bof";
    case Method::nlpm:
      return "nlpm";
    case Method::gaussian:
      return "gaussian";
    case Method::butterworth:
      return "butterworth";
    case Method::moving_mean:
      return "moving-mean";
    case Method::kalman:
      return "kalman";
    case Method::automatic:
      return "auto";
  }
  return "?";
}

namespace {

LinearKind linear_kind(Method method) {
  if (method == Method::butterworth) return LinearKind::butterworth;
  if (method == Method::moving_mean) return LinearKind::moving_mean;
  return LinearKind::gaussian;
}

}  // namespace

double body_height(const Skeleton& skeleton) {
  std::vector<std::pair<int, Vec3>> sites;
  for (int j = 0; j < skeleton.joint_count(); ++j)
    if (skeleton.end_sites[std::size_t(j)])
      sites.push_back({j, *skeleton.end_sites[std::size_t(j)]});
  return rest_height(skeleton.parents, skeleton.offsets, sites);
}

double automatic_translation_sigma_t(TranslationNoise noise, double frame_time,
                                     double body_height) {
  if (!has_noisy_positions(noise, body_height) || noise.accel < 0) return 0;
  const double cap = kTranslationSigmaMaxSeconds / frame_time;
  if (noise.accel == 0) return cap;
  const double s =
      kTranslationSigmaFactor *
      std::pow(noise.sigma * noise.sigma / (2 * std::sqrt(kPi) * noise.accel * noise.accel), 0.2);
  return std::min(s, cap);
}

BilateralParams automatic_bilateral(BilateralParams params, double sigma_hat, double frame_time) {
  if (params.sigma_g == 0) params.sigma_g = kBofAutoSigmaGFactor * sigma_hat;
  if (params.sigma_t == 0)
    params.sigma_t = std::max(1.0, kBofAutoSigmaTFactor * std::sqrt(sigma_hat) *
                                       std::pow(1.0 / (120.0 * frame_time), 0.75));
  return params;
}

int automatic_iterations(double sigma_hat) {
  if (!(sigma_hat > 0)) return 1;
  return int(std::clamp(std::lround(sigma_hat / kAutoNoisePerIteration), 1L, 5L));
}

BilateralParams automatic_smoothing(double sigma_hat, double frame_time) {
  BilateralParams p;
  p.iterations = automatic_iterations(sigma_hat);
  const double passes = std::sqrt(double(p.iterations));
  p.sigma_g = kAutoSigmaGFactor * sigma_hat / passes;
  p.sigma_t = std::max(1.0, kAutoSigmaTFactor * std::sqrt(sigma_hat) *
                                std::sqrt(1.0 / (120.0 * frame_time)) / passes);
  return p;
}

bool has_noisy_positions(const TranslationNoise& noise, double body_height) {
  return body_height > 0 && noise.sigma > kNoisyPositions * body_height;
}

FilterSettings choose_automatic(const FilterSettings& settings, double sigma_hat,
                                bool noisy_positions, double frame_time) {
  FilterSettings s = settings;
  if (noisy_positions) {
    s.method = Method::bof;
    s.bilateral = BilateralParams{};
    s.bilateral.boundary = settings.bilateral.boundary;
    s.bilateral.sigma_g = kAutoSmoothSigmaGFactor * sigma_hat;
    s.bilateral.sigma_t = 0;  // automatic_bilateral
    s.bilateral.iterations = std::clamp(int(std::ceil(5.0 / (120.0 * frame_time) - 1e-9)), 2, 5);
  } else if (sigma_hat < kAutoCleanBelow) {
    s.method = Method::nlpm;
    s.nlpm = NlpmParams{};
    s.nlpm.boundary = settings.nlpm.boundary;
    s.nlpm.translation_sigma_t = settings.nlpm.translation_sigma_t;
    s.nlpm_range = -1;  // automatic: kNlpmAutoRangeFactor sigma_hat
  } else {
    s.method = Method::bof;
    s.bilateral = automatic_smoothing(sigma_hat, frame_time);
    s.bilateral.boundary = settings.bilateral.boundary;
    // Position channels without measurable noise are kept as they came, as nlpm's automatic
    // translation width keeps them (automatic_translation_sigma_t): bof's Gaussian of 1.3 frames
    // on a clean root at 30 fps raised one clip's joint position error to 1.62x its noisy
    // input's (02_03, 0.008 rad).
    s.filter_translations = false;
  }
  return s;
}

Status FilterSettings::validate() const {
  if (shard_joints < 1) return Status::error("shard joints must be >= 1");
  if (shard_frames < 1) return Status::error("shard frames must be >= 1");
  if (!std::isfinite(nlpm_range))
    return Status::error("nlpm's range sigma must be finite (0 = off, < 0 = automatic)");
  switch (method) {
    case Method::none:
    case Method::automatic:
      return {};
    case Method::bof: {
      BilateralParams p = bilateral;
      if (p.sigma_g == 0) p.sigma_g = 1;  // automatic: resolved per clip
      if (p.sigma_t == 0) p.sigma_t = 1;
      return p.validate();
    }
    case Method::kalman:
      return kalman.validate();  // lambda 0: automatic, resolved per clip
    case Method::nlpm: {
      NlpmParams p = nlpm;
      if (p.h == 0) p.h = 1;  // automatic: checked per clip
      if (p.translation_sigma_t < 0) p.translation_sigma_t = 0;
      return p.validate();
    }
    default: {
      LinearParams p = linear;
      p.kind = linear_kind(method);
      return p.validate();
    }
  }
}

nlohmann::json FilterSettings::to_json() const {
  nlohmann::json j;
  j["method"] = std::string(to_string(method));
  j["translations"] = filter_translations ? "filter" : "keep";
  if (split_impossible) j["split_impossible"] = true;
  if (method != Method::none) {
    j["pops"] = std::string(to_string(pops));
    if (pops != PopsMode::off) j["garbage_joints"] = keep_garbage_joints ? "keep" : "filter";
    if (lock_feet) j["feet"] = "lock";
    if (guard_motion) j["guard"] = "on";
  }
  switch (method) {
    case Method::none:
    case Method::automatic:
      break;
    case Method::bof:
      j["sigma_t"] =
          bilateral.sigma_t == 0 ? nlohmann::json("auto") : nlohmann::json(bilateral.sigma_t);
      j["sigma_g"] =
          bilateral.sigma_g == 0 ? nlohmann::json("auto") : nlohmann::json(bilateral.sigma_g);
      j["window"] = bilateral.window;
      j["iterations"] = bilateral.iterations;
      j["kernel"] = bilateral.kernel == BilateralKernel::paper ? "paper" : "gaussian";
      j["boundary"] = std::string(to_string(bilateral.boundary));
      if (std::isfinite(bilateral.sigma_p)) j["sigma_p"] = bilateral.sigma_p;
      break;
    case Method::nlpm:
      j["search_radius"] = nlpm.search_radius;
      j["patch_radius"] = nlpm.patch_radius;
      j["h"] = nlpm.h == 0 ? nlohmann::json("auto") : nlohmann::json(nlpm.h);
      j["space"] = nlpm.space == NlpmSpace::log ? "log" : "tangent";
      j["range_sigma"] = nlpm_range < 0 ? nlohmann::json("auto") : nlohmann::json(nlpm_range);
      j["translation_sigma_t"] = nlpm.translation_sigma_t < 0
                                     ? nlohmann::json("auto")
                                     : nlohmann::json(nlpm.translation_sigma_t);
      j["boundary"] = std::string(to_string(nlpm.boundary));
      break;
    case Method::gaussian:
      j["sigma_t"] = linear.sigma_t;
      j["window"] = linear.window;
      j["boundary"] = std::string(to_string(linear.boundary));
      break;
    case Method::butterworth:
      j["order"] = linear.order;
      j["cutoff"] = linear.cutoff;
      j["boundary"] = std::string(to_string(linear.boundary));
      break;
    case Method::moving_mean:
      j["passes"] = linear.passes;
      j["boundary"] = std::string(to_string(linear.boundary));
      break;
    case Method::kalman:
      j["lambda"] = kalman.lambda == 0 ? nlohmann::json("auto") : nlohmann::json(kalman.lambda);
      j["boundary"] = std::string(to_string(kalman.boundary));
      break;
  }
  return j;
}

std::vector<std::uint8_t> distance_joints_without(std::span<const std::uint8_t> garbage) {
  std::vector<std::uint8_t> distance;
  for (std::uint8_t g : garbage) distance.push_back(g ? 0 : 1);
  const auto count = std::count(distance.begin(), distance.end(), std::uint8_t{1});
  if (count == 0 || std::size_t(count) == distance.size()) distance.clear();
  return distance;
}

ResolvedSettings resolve_for_clip(const FilterSettings& settings, const Clip& clip,
                                  std::span<const std::uint8_t> garbage) {
  ResolvedSettings r;
  r.settings = settings;
  r.settings.linear.kind = linear_kind(settings.method);
  if (settings.method == Method::none || clip.frames < 2) {
    r.unchanged = true;
    return r;
  }
  // Garbage joints count only with the robust stages on: pops off is the spec's filter exactly.
  const bool robust = settings.pops != PopsMode::off;
  const bool any_garbage =
      robust && std::any_of(garbage.begin(), garbage.end(), [](std::uint8_t g) { return g; });
  if (any_garbage) {
    if (settings.keep_garbage_joints) r.kept_joints.assign(garbage.begin(), garbage.end());
    r.distance_joints = distance_joints_without(garbage);
  }

  // The position channels' noise, estimated once: auto's choice and nlpm's translation width
  // both read it.
  std::optional<TranslationNoise> translation_estimate;
  auto translation_noise = [&] {
    if (!translation_estimate) {
      translation_estimate = estimate_translation_noise(
          clip.translation_view(), clip.skeleton->translated_mask(), clip.frame_time);
    }
    return *translation_estimate;
  };
  const Method asked = settings.method;
  const bool automatic_nlpm =
      asked == Method::nlpm && (settings.nlpm.h == 0 || settings.nlpm_range < 0);
  const bool automatic_bof =
      asked == Method::bof && (settings.bilateral.sigma_g == 0 || settings.bilateral.sigma_t == 0);
  const bool automatic_kalman = asked == Method::kalman && settings.kalman.lambda == 0;
  if (asked == Method::automatic || automatic_nlpm || automatic_bof || automatic_kalman) {
    const NoiseEstimate noise = estimate_noise(
        clip.rotation_view(), any_garbage ? garbage : std::span<const std::uint8_t>{});
    r.noise_sigma = noise.sigma;
    if (noise.moving_joints == 0 || noise.sigma <= 0) {
      r.unchanged = true;  // spec: a clip where no joint moves has nothing to filter
      return r;
    }
    if (asked == Method::automatic) {
      r.translation_noise = translation_noise();
      r.noisy_positions = has_noisy_positions(r.translation_noise, body_height(*clip.skeleton));
      r.settings = choose_automatic(settings, noise.sigma, r.noisy_positions, clip.frame_time);
    }
    FilterSettings& s = r.settings;
    s.linear.kind = linear_kind(s.method);
    if (s.method == Method::nlpm) {
      if (s.nlpm.h == 0) s.nlpm.h = kNlpmAutoFactor * noise.sigma;
      if (s.nlpm_range < 0) s.nlpm_range = kNlpmAutoRangeFactor * noise.sigma;
      if (asked == Method::automatic) {
        s.nlpm.h = std::max(s.nlpm.h, kAutoNlpmMinH);
        s.nlpm_range = std::max(s.nlpm_range, kAutoNlpmMinRange);
      }
    }
    if (s.method == Method::bof)
      s.bilateral = automatic_bilateral(s.bilateral, noise.sigma, clip.frame_time);
    if (s.method == Method::kalman && s.kalman.lambda == 0)
      s.kalman.lambda = kalman_auto_lambda(noise.sigma, clip.frame_time);
  }
  r.settings.nlpm.range_sigma = std::max(0.0, r.settings.nlpm_range);
  if (r.settings.method == Method::nlpm && r.settings.nlpm.translation_sigma_t < 0) {
    r.translation_noise = translation_noise();
    r.settings.nlpm.translation_sigma_t = automatic_translation_sigma_t(
        r.translation_noise, clip.frame_time, body_height(*clip.skeleton));
  }
  if (settings.split_impossible) {
    // Flipping joints (uncaptured) jump by ~pi without moving: they do not cut the clip.
    std::vector<std::uint8_t> flipping;
    for (const JointQuality& q : classify_joints(clip.rotation_view()))
      flipping.push_back(q.joint_class == JointClass::flipping);
    r.segments = motion_segments(clip.rotation_view(), clip.frame_time, flipping);
    if (r.segments.size() <= 1) r.segments.clear();
  }
  return r;
}

}  // namespace mocap::engine
