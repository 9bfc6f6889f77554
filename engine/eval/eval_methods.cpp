#include "engine/eval/eval_methods.hpp"

#include <cstring>
#include <optional>

#include "engine/clip/filter_settings.hpp"
#include "engine/clip/flip_pieces.hpp"
#include "engine/clip/methods.hpp"
#include "kernels/joint_motion.hpp"
#include "kernels/noise_estimate.hpp"

namespace mocap::engine::eval {
namespace {

void copy(const SegmentJob& job) {
  std::memcpy(job.output.data, job.noisy.data, job.noisy.size() * sizeof(float));
  if (!job.translations.empty())
    std::memcpy(job.output_translations.data, job.translations.data,
                job.translations.size() * sizeof(float));
}

}  // namespace

std::string automatic_rule(EvalMethod method) {
  return method.variant().rule();
}

namespace {

// `flip_settings` (when the method filtered) receives the filter of the flipping joints' pieces
// (flip_piece_settings), or stays empty where they are kept as they came.
Status run_variant(EvalMethod method, const ParamPoint* point, const SegmentJob& job,
                   nlohmann::json* resolved, std::optional<FilterSettings>& flip_settings) {
  nlohmann::json used = nlohmann::json::object();
  auto done = [&](Status s) {
    if (resolved) *resolved = used;
    return s;
  };
  const EvalVariant& variant = method.variant();
  const std::optional<FilterSettings> asked =
      job.noisy.frames < 2 ? std::nullopt : variant.settings(point, job.sigma_hat, job.frame_time);
  // One frame, or an automatic parameter without a noise level (nothing moves): nothing to filter.
  if (!asked || (method_entry(asked->method).needs_noise(*asked) && !(job.sigma_hat > 0))) {
    copy(job);
    used["unchanged"] = true;
    return done({});
  }
  // The segment's own position noise, as resolve_for_clip measures the clip's.
  std::optional<TranslationNoise> translation_estimate;
  NoiseContext context;
  context.sigma_hat = job.sigma_hat;
  context.frame_time = job.frame_time;
  context.body_height = job.body_height;
  context.translation_noise = [&] {
    if (!translation_estimate)
      translation_estimate =
          estimate_translation_noise(job.translations, job.translated_joints, job.frame_time);
    return *translation_estimate;
  };
  context.joint_motion = [&](int lag) { return lagged_acceleration_power(job.noisy, lag); };
  context.skeleton = job.skeleton;
  const bool noisy_positions = asked->method == Method::automatic &&
                               has_noisy_positions(context.translation_noise(), job.body_height);
  const FilterSettings settings = resolve_parameters(*asked, context, noisy_positions);

  MotionIO io;
  io.frame_time = job.frame_time;
  io.rotations = job.noisy;
  io.filtered_rotations = job.output;
  if (!job.translations.empty()) {
    io.translations = job.translations;
    io.filtered_translations = job.output_translations;
    io.translated_joints = job.translated_joints;
  }
  const Status s = run_method(settings, io, job.distance_joints);
  flip_settings = flip_piece_settings(*asked, settings, job.sigma_hat, job.frame_time);
  if (asked->method != Method::automatic) {
    used = variant.used(settings);
    return done(s);
  }
  // auto: reported as the variant of what it chose.
  for (const EvalVariant& chosen : eval_variants()) {
    if (!chosen.reports(settings)) continue;
    used = chosen.used(settings);
    used["method"] = std::string(chosen.name);
    break;
  }
  used["noisy_positions"] = noisy_positions;
  return done(s);
}

}  // namespace

Status filter_segment(EvalMethod method, const ParamPoint* point, const SegmentJob& job,
                      nlohmann::json* resolved) {
  std::optional<FilterSettings> flip_settings;
  Status s = run_variant(method, point, job, resolved, flip_settings);
  // Garbage joints as they came, flipping ones then between their flips, as the engine does
  // (run_shard).
  for (std::size_t j = 0; s && j < job.kept_joints.size(); ++j) {
    if (!job.kept_joints[j]) continue;
    for (int t = 0; t < job.noisy.frames; ++t) {
      std::memcpy(job.output.data + (std::size_t(t) * std::size_t(job.noisy.joints) + j) * 4,
                  job.noisy.at(t, int(j)), 4 * sizeof(float));
      if (!job.translations.empty())
        std::memcpy(job.output_translations.at(t, int(j)), job.translations.at(t, int(j)),
                    3 * sizeof(float));
    }
  }
  for (std::size_t j = 0; s && flip_settings && j < job.flip_joints.size(); ++j) {
    if (!job.flip_joints[j]) continue;
    MotionIO io;
    io.frame_time = job.frame_time;
    io.rotations = job.noisy;
    io.filtered_rotations = job.output;
    s = filter_between_flips(*flip_settings, io, int(j), job.distance_joints);
  }
  return s;
}

}  // namespace mocap::engine::eval
