#include "engine/clip/filter_settings.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "engine/clip/flip_pieces.hpp"
#include "engine/clip/methods.hpp"
#include "kernels/foot_contacts.hpp"
#include "kernels/joint_motion.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/noise_estimate.hpp"

namespace mocap::engine {

std::optional<Method> parse_method(std::string_view name) {
  const MethodEntry* entry = find_method(name);
  return entry ? std::optional(entry->method) : std::nullopt;
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
  return method_entry(method).name;
}

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

namespace {

// [kAutoCutoffMinHz, kAutoCutoffMaxNyquist x Nyquist]; below 2.5 fps the ceiling wins.
double within_cutoff_bounds(double cutoff, double frame_time) {
  const double highest = kAutoCutoffMaxNyquist * (1.0 / frame_time) / 2;
  return std::clamp(cutoff, std::min(kAutoCutoffMinHz, highest), highest);
}

}  // namespace

double automatic_cutoff(double sigma_hat, double frame_time) {
  const double rate = 1.0 / frame_time;
  double cutoff = kAutoCutoffHz * std::pow(rate / 30.0, 1.0 / 6.0);
  if (sigma_hat > 0) cutoff *= std::pow(kAutoCutoffSigma / sigma_hat, 1.0 / 6.0);
  return within_cutoff_bounds(cutoff, frame_time);
}

int joint_cutoff_lag(double frame_time) {
  return std::max(1, int(std::lround(1.0 / (30.0 * frame_time))));
}

std::vector<std::uint8_t> leg_joints_of(std::span<const FootChain> feet, int joints) {
  std::vector<std::uint8_t> legs(std::size_t(std::max(joints, 0)), 0);
  for (const FootChain& f : feet)
    for (int j : {f.hip, f.knee})
      if (j >= 0 && j < joints) legs[std::size_t(j)] = 1;
  return legs;
}

std::vector<double> automatic_joint_cutoffs(double cutoff, double sigma_hat,
                                            std::span<const double> power,
                                            std::span<const std::uint8_t> legs, double frame_time) {
  if (!(sigma_hat > 0)) return {};
  const double noise = 6 * sigma_hat * sigma_hat;
  std::vector<double> out;
  out.reserve(power.size());
  for (std::size_t j = 0; j < power.size(); ++j) {
    if (j < legs.size() && legs[j]) {
      out.push_back(cutoff);
      continue;
    }
    const double snr = std::max((power[j] - noise) / noise, 0.0);
    const double factor =
        std::clamp(std::cbrt(snr / kAutoJointCutoffSnr), 1.0, kAutoJointCutoffMaxFactor);
    out.push_back(within_cutoff_bounds(cutoff * factor, frame_time));
  }
  return out;
}

bool has_noisy_positions(const TranslationNoise& noise, double body_height) {
  return body_height > 0 && noise.sigma > kNoisyPositions * body_height;
}

FilterSettings choose_automatic(const FilterSettings& settings, double sigma_hat,
                                bool noisy_positions, double frame_time) {
  FilterSettings s = settings;
  if (noisy_positions) {
    s.method = Method::butterworth;
    LinearParams& l = s.edit<LinearParams>();
    l = LinearParams{};
    l.kind = LinearKind::butterworth;
    l.boundary = settings.param<BilateralParams>().boundary;
    l.order = kAutoButterworthOrder;
    l.cutoff = automatic_cutoff(sigma_hat, frame_time);
  } else if (sigma_hat < kAutoCleanBelow &&
             !(frame_time > 0 && 1.0 / frame_time < kAutoNlpmMinFps)) {
    s.method = Method::nlpm;
    const NlpmParams asked = settings.param<NlpmParams>();
    NlpmParams& n = s.edit<NlpmParams>();
    n = NlpmParams{};
    n.boundary = asked.boundary;
    n.translation_sigma_t = asked.translation_sigma_t;
    n.range_sigma = -1;  // automatic: kNlpmAutoRangeFactor sigma_hat
  } else {
    s.method = Method::bof;
    BilateralParams& b = s.edit<BilateralParams>();
    b = automatic_smoothing(sigma_hat, frame_time);
    b.boundary = settings.param<BilateralParams>().boundary;
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
  return method_entry(method).validate(*this);
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
  method_entry(method).to_json(*this, j);
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
                                  std::span<const std::uint8_t> garbage, const ClipFacts& known) {
  ResolvedSettings r;
  r.settings = settings;
  const MethodEntry& asked = method_entry(settings.method);
  if (asked.normalize) asked.normalize(r.settings);
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
  NoiseContext context;
  context.frame_time = clip.frame_time;
  context.body_height = body_height(*clip.skeleton);
  context.translation_noise = [&] {
    if (!translation_estimate) {
      translation_estimate = estimate_translation_noise(
          clip.translation_view(), clip.skeleton->translated_mask(), clip.frame_time);
    }
    r.translation_noise = *translation_estimate;
    return *translation_estimate;
  };
  // The joints' classes: the noise estimate's moving test and the split's flipping joints.
  std::vector<JointQuality> measured;
  const auto qualities = [&]() -> std::span<const JointQuality> {
    if (!known.joints.empty()) return known.joints;
    if (measured.empty()) measured = classify_joints(clip.rotation_view());
    return measured;
  };
  if (settings.split_impossible) {
    // Flipping joints (uncaptured) jump by ~pi without moving: they do not cut the clip.
    if (known.segments) {
      r.segments = *known.segments;
    } else {
      r.segments =
          motion_segments(clip.rotation_view(), clip.frame_time, flipping_joints(qualities()));
    }
    if (r.segments.size() <= 1) r.segments.clear();
  }
  context.joint_motion = [&](int lag) {
    return lagged_acceleration_power(clip.rotation_view(), lag, r.segments);
  };
  context.skeleton = clip.skeleton.get();
  if (asked.needs_noise(settings)) {
    const NoiseEstimate noise = estimate_noise(
        clip.rotation_view(), any_garbage ? garbage : std::span<const std::uint8_t>{},
        median_steps(qualities()));
    r.noise_sigma = noise.sigma;
    if (noise.moving_joints == 0 || noise.sigma <= 0) {
      r.unchanged = true;  // spec: a clip where no joint moves has nothing to filter
      r.segments.clear();
      return r;
    }
    context.sigma_hat = noise.sigma;
    if (settings.method == Method::automatic)
      r.noisy_positions = has_noisy_positions(context.translation_noise(), context.body_height);
  }
  r.settings = resolve_parameters(r.settings, context, r.noisy_positions);
  if (!r.kept_joints.empty()) {
    std::span<const JointQuality> q = qualities();
    r.flip_joints.assign(r.kept_joints.size(), 0);
    bool any = false;
    for (std::size_t j = 0; j < q.size() && j < r.kept_joints.size(); ++j) {
      r.flip_joints[j] = r.kept_joints[j] && q[j].joint_class == JointClass::flipping;
      any = any || r.flip_joints[j];
    }
    std::optional<FilterSettings> pieces;
    if (any) pieces = flip_piece_settings(settings, r.settings, r.noise_sigma, clip.frame_time);
    if (pieces)
      r.flip_settings = *pieces;
    else
      r.flip_joints.clear();
  }
  return r;
}

}  // namespace mocap::engine
