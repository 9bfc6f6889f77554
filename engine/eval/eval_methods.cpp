#include "engine/eval/eval_methods.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "engine/filter_settings.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/kalman.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/nlpm.hpp"

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
  }
  return "";
}

Status filter_segment(EvalMethod method, const ParamPoint* point, const SegmentJob& job,
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

  switch (method) {
    case EvalMethod::bof: {
      BilateralParams p;
      if (!point) {
        p.sigma_g = p.sigma_t = 0;  // both automatic: engine/filter_settings.hpp
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
    case EvalMethod::nlpm: {
      NlpmParams p;
      p.search_radius = int(value(point, "K", p.search_radius));
      p.patch_radius = int(value(point, "P", p.patch_radius));
      if (has(point, "h")) {
        p.h = value(point, "h", 0);
      } else {
        if (!(sigma_hat > 0)) break;
        p.h = value(point, "h_factor", kNlpmAutoFactor) * sigma_hat;
      }
      used = {{"h", p.h}, {"K", p.search_radius}, {"P", p.patch_radius}};
      return done(NlpmJob{p, io, {}}.run());
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

}  // namespace mocap::engine::eval
