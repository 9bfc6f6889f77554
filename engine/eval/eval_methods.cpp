#include "engine/eval/eval_methods.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "engine/clip/filter_settings.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/kalman.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/nlpm.hpp"
#include "kernels/noise_estimate.hpp"

namespace mocap::engine::eval {
namespace {

double value(const ParamPoint* point, const std::string& name, double fallback) {
  if (point)
    for (const auto& [n, v] : *point)
      if (n == name) return v;
  return fallback;
}
bool has(const ParamPoint* point, const std::string& name) {
  return point &&
         std::any_of(point->begin(), point->end(), [&](const auto& p) { return p.first == name; });
}

void copy(const SegmentJob& job) {
  std::memcpy(job.output.data, job.noisy.data, job.noisy.size() * sizeof(float));
  if (!job.translations.empty())
    std::memcpy(job.output_translations.data, job.translations.data,
                job.translations.size() * sizeof(float));
}

}  // namespace

std::string automatic_rule(EvalMethod method) {
  switch (method) {
    case EvalMethod::bof:
      return fmt::format(
          "sigma_g={:g}*sigma_hat sigma_t=max(1, {:g}*sqrt(sigma_hat)) iterations=5 "
          "(--sigma-g 0 --sigma-t 0)",
          kBofAutoSigmaGFactor, kBofAutoSigmaTFactor);
    case EvalMethod::nlpm:
      return fmt::format("h={:g}*sigma_hat K=10 P=5", kNlpmAutoFactor);
    case EvalMethod::gaussian:
      return "sigma_t=1 (spec default)";
    case EvalMethod::butterworth:
      return "order=2 cutoff=6 Hz (spec defaults)";
    case EvalMethod::moving_mean:
      return "passes=5 (spec default)";
    case EvalMethod::kalman:
      return fmt::format("lambda={:g}*(120*frame_time)^2.5/sigma_hat^3", kKalmanAutoScale);
    case EvalMethod::nlpm_robust:
      return fmt::format("h={:g}*sigma_hat range_sigma={:g}*sigma_hat K=10 P=5", kNlpmAutoFactor,
                         kNlpmAutoRangeFactor);
    case EvalMethod::automatic:
      return "--method auto: the method and parameters chosen per clip (choose_automatic), after "
             "pop repair";
  }
  return "";
}

namespace {

Status run_method(EvalMethod method, const ParamPoint* point, const SegmentJob& job,
                  nlohmann::json* resolved) {
  nlohmann::json used = nlohmann::json::object();
  auto done = [&](Status s) {
    if (resolved) *resolved = used;
    return s;
  };
  if (job.noisy.frames < 2) {
    copy(job);
    used["unchanged"] = true;
    return done({});
  }
  const double sigma_hat = job.sigma_hat;
  MotionIO io;
  io.frame_time = job.frame_time;
  io.rotations = job.noisy;
  io.filtered_rotations = job.output;
  if (!job.translations.empty()) {
    io.translations = job.translations;
    io.filtered_translations = job.output_translations;
    io.translated_joints = job.translated_joints;
  }

  switch (method) {
    case EvalMethod::bof: {
      BilateralParams p;
      if (!point) {
        p.sigma_g = p.sigma_t = 0;  // both automatic: engine/clip/filter_settings.hpp
      } else {
        p.sigma_t = value(point, "sigma_t", p.sigma_t);
        p.sigma_g = value(point, "sigma_g", p.sigma_g);
        p.iterations = int(value(point, "iterations", p.iterations));
        if (has(point, "sigma_t_factor")) {
          if (!(sigma_hat > 0)) break;
          p.sigma_t = std::max(1.0, value(point, "sigma_t_factor", 0.0) * std::sqrt(sigma_hat) *
                                        std::pow(1.0 / (120.0 * job.frame_time), 0.75));
        }
        if (has(point, "sigma_g_factor")) {
          if (!(sigma_hat > 0)) break;
          p.sigma_g = std::max(value(point, "sigma_g_floor", 0.0),
                               value(point, "sigma_g_factor", 1.0) * sigma_hat);
        }
      }
      if (p.sigma_g == 0 || p.sigma_t == 0) {
        if (!(sigma_hat > 0)) break;
        p = automatic_bilateral(p, sigma_hat, job.frame_time);
      }
      used = {{"sigma_g", p.sigma_g}, {"sigma_t", p.sigma_t}, {"iterations", p.iterations}};
      return done(BilateralJob{p, io}.run());
    }
    case EvalMethod::nlpm:
    case EvalMethod::nlpm_robust: {
      // nlpm-robust: nlpm with its range term, whose width is relative to the noise.
      const bool robust = method == EvalMethod::nlpm_robust;
      NlpmParams p;
      p.search_radius = int(value(point, "K", p.search_radius));
      p.patch_radius = int(value(point, "P", p.patch_radius));
      if ((robust || !has(point, "h")) && !(sigma_hat > 0)) break;
      p.h = has(point, "h") ? value(point, "h", 0)
                            : value(point, "h_factor", kNlpmAutoFactor) * sigma_hat;
      if (robust) p.range_sigma = value(point, "range_factor", kNlpmAutoRangeFactor) * sigma_hat;
      if (job.automatic_floors) {  // what --method auto does (engine/clip/filter_settings.hpp)
        p.h = std::max(p.h, kAutoNlpmMinH);
        if (robust) p.range_sigma = std::max(p.range_sigma, kAutoNlpmMinRange);
      }
      p.translation_sigma_t =
          has(point, "translation_sigma_t")
              ? value(point, "translation_sigma_t", 0)
              : automatic_translation_sigma_t(
                    estimate_translation_noise(job.translations, job.translated_joints,
                                               job.frame_time),
                    job.frame_time, job.body_height);
      used = {{"h", p.h},
              {"K", p.search_radius},
              {"P", p.patch_radius},
              {"translation_sigma_t", p.translation_sigma_t}};
      if (robust) used["range_sigma"] = p.range_sigma;
      return done(NlpmJob{p, io, job.distance_joints}.run());
    }
    case EvalMethod::automatic: {
      if (!(sigma_hat > 0)) break;
      const bool noisy_positions = has_noisy_positions(
          estimate_translation_noise(job.translations, job.translated_joints, job.frame_time),
          job.body_height);
      const FilterSettings chosen =
          choose_automatic(FilterSettings{}, sigma_hat, noisy_positions, job.frame_time);
      const EvalMethod as =
          chosen.method == Method::nlpm
              ? (chosen.nlpm_range != 0 ? EvalMethod::nlpm_robust : EvalMethod::nlpm)
          : chosen.method == Method::kalman ? EvalMethod::kalman
                                            : EvalMethod::bof;
      SegmentJob floored = job;
      floored.automatic_floors = true;
      // The smooth bof of noisy positions: its sigma_g as chosen, sigma_t automatic.
      const ParamPoint smooth{{"sigma_g", chosen.bilateral.sigma_g},
                              {"sigma_t", 0.0},
                              {"iterations", double(chosen.bilateral.iterations)}};
      const bool smooth_bof = as == EvalMethod::bof && chosen.bilateral.sigma_g > 0;
      const Status s = run_method(as, smooth_bof ? &smooth : nullptr, floored, &used);
      used["noisy_positions"] = noisy_positions;
      used["method"] = std::string(to_string(as));
      return done(s);
    }
    case EvalMethod::gaussian:
    case EvalMethod::butterworth:
    case EvalMethod::moving_mean: {
      LinearParams p;
      p.kind = method == EvalMethod::gaussian      ? LinearKind::gaussian
               : method == EvalMethod::butterworth ? LinearKind::butterworth
                                                   : LinearKind::moving_mean;
      p.sigma_t = value(point, "sigma_t", p.sigma_t);
      p.cutoff = value(point, "cutoff", p.cutoff);
      p.order = int(value(point, "order", p.order));
      p.passes = int(value(point, "passes", p.passes));
      if (method == EvalMethod::gaussian) used = {{"sigma_t", p.sigma_t}};
      if (method == EvalMethod::butterworth) used = {{"cutoff", p.cutoff}, {"order", p.order}};
      if (method == EvalMethod::moving_mean) used = {{"passes", p.passes}};
      return done(LinearFilterJob{p, io}.run());
    }
    case EvalMethod::kalman: {
      KalmanParams p;
      if (has(point, "lambda")) {
        p.lambda = value(point, "lambda", p.lambda);
      } else {
        if (!(sigma_hat > 0)) break;
        p.lambda = kalman_auto_lambda(sigma_hat, job.frame_time,
                                      value(point, "lambda_scale", kKalmanAutoScale));
      }
      used = {{"lambda", p.lambda}};
      return done(KalmanJob{p, io}.run());
    }
  }
  // An automatic parameter without a noise level: nothing moves, nothing to filter.
  copy(job);
  used["unchanged"] = true;
  return done({});
}

}  // namespace

Status filter_segment(EvalMethod method, const ParamPoint* point, const SegmentJob& job,
                      nlohmann::json* resolved) {
  const Status s = run_method(method, point, job, resolved);
  // Garbage joints as they came, as the engine keeps them (run_shard).
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
  return s;
}

}  // namespace mocap::engine::eval
