#include "kernels/bilateral.hpp"

#include <cmath>
#include <string>

#include "core/format.hpp"
#include "kernels/simd/bilateral_simd.hpp"
#include "kernels/translation_filter.hpp"

namespace mocap {
namespace {

constexpr double kMaxWindow = 1e6;

}  // namespace

std::optional<BilateralKernel> parse_bilateral_kernel(std::string_view name) {
  if (name == "gaussian") return BilateralKernel::gaussian;
  if (name == "paper") return BilateralKernel::paper;
  return std::nullopt;
}

std::string_view to_string(BilateralKernel kernel) {
  switch (kernel) {
    case BilateralKernel::gaussian:
      return "gaussian";
    case BilateralKernel::paper:
      return "paper";
  }
  return "?";
}

Status BilateralParams::validate() const {
  if (!(sigma_t > 0) || !std::isfinite(sigma_t))
    return Status::error(format("sigma_t must be > 0, got %g", sigma_t));
  if (!(sigma_g > 0)) return Status::error(format("sigma_g must be > 0, got %g", sigma_g));
  if (window < 0) return Status::error(format("window must be >= 0, got %g", window));
  if (window == 0 && 3 * sigma_t > kMaxWindow)
    return Status::error(
        format("sigma_t %g gives a window of more than %g frames", sigma_t, kMaxWindow));
  if (window > kMaxWindow)
    return Status::error(format("window must be <= %g frames, got %g", kMaxWindow, window));
  if (iterations < 1) return Status::error(format("iterations must be >= 1, got %g", iterations));
  if (!(sigma_p > 0)) return Status::error(format("sigma_p must be > 0, got %g", sigma_p));
  if (kernel != BilateralKernel::gaussian && kernel != BilateralKernel::paper)
    return Status::error("unknown bilateral kernel");
  if (boundary != Boundary::mirror && boundary != Boundary::hold &&
      boundary != Boundary::extrapolate)
    return Status::error("unknown boundary mode");
  return {};
}

int BilateralParams::reach() const {
  return window > 0 ? window : int(std::ceil(3.0 * sigma_t));
}

void bilateral_pass(std::span<const Quat> curve, const BilateralParams& params, std::span<Quat> out,
                    int begin, int end, CurveScratch& scratch) {
  if (curve.size() == 1) {
    if (begin < end) out[0] = curve[0];
    return;
  }
  const int k = params.reach();
  const std::size_t width = 2 * std::size_t(k) + 1;
  // The temporal factor, and the range factor as exp(-range_scale * x), x = d^2 (gaussian) or
  // the half-angle distance d/2 with sigma_g halved (paper, errata 1, 2 and 6 reproduced).
  std::vector<double> temporal(width);
  const bool paper = params.kernel == BilateralKernel::paper;
  for (int r = -k; r <= k; ++r) {
    const double x = paper ? std::abs(double(r)) : double(r) * r;
    temporal[r + k] = std::exp(-x / (2 * params.sigma_t * params.sigma_t));
  }
  const double sigma = paper ? params.sigma_g / 2 : params.sigma_g;
  const double range_scale = 1.0 / (2 * sigma * sigma);

  extend_rotation_curve(curve, k, params.boundary, scratch.extended);
  tangent_steps(scratch.extended, scratch.steps);
  const std::span<const Vec3> steps = scratch.steps;
  const std::vector<Quat>& q = scratch.extended;
  std::vector<double>& mask = scratch.mask;
  std::vector<double>& b = scratch.coefficients;
  mask.resize(width);
  b.resize(width - 1);
  for (int t = begin; t < end; ++t) {
    const Quat centre = q[t + k];
    double sum = 0;
    for (int r = -k; r <= k; ++r) {
      const double d = geodesic(centre, q[t + k + r]);
      const double x = paper ? d / 2 : d * d;
      mask[r + k] = temporal[r + k] * std::exp(-range_scale * x);
      sum += mask[r + k];
    }
    for (double& m : mask) m /= sum;  // sum >= m_0 = 1
    lee_shin_coefficients(mask, b);
    out[t] = lee_shin_sample(curve[t], steps.subspan(t, 2 * std::size_t(k)), b);
  }
}

void bilateral_filter_rotations(std::span<const Quat> curve, const BilateralParams& params,
                                std::span<Quat> out, int begin, int end, CurveScratch& scratch) {
  run_passes(curve, params.iterations, out, begin, end, scratch.pass_in, scratch.pass_out,
             [&](std::span<const Quat> in, std::span<Quat> result, int b, int e) {
               bilateral_pass(in, params, result, b, e, scratch);
             });
}

Status BilateralJob::validate() const {
  if (Status s = io.validate(); !s) return s;
  if (implementation != Implementation::fast && implementation != Implementation::reference)
    return Status::error("unknown implementation");
  return params.validate();
}

Status BilateralJob::run() const {
  if (Status s = validate(); !s) return s;
  const int frames = io.rotations.frames;
  const int begin = io.frame_begin, end = io.frame_stop();
  CurveScratch scratch;
  if (implementation == Implementation::fast && params.reach() <= simd::kBilateralMaxFastReach) {
    simd::bilateral_rotations(params, io);
  } else {
    std::vector<Quat> curve(frames), out(frames);
    for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
      for (int t = 0; t < frames; ++t) curve[t] = load_quat(io.rotations.at(t, j));
      bilateral_filter_rotations(curve, params, out, begin, end, scratch);
      for (int t = begin; t < end; ++t) store_quat(out[t], io.filtered_rotations.at(t, j));
    }
  }

  if (!io.has_translations()) return {};
  std::vector<Vec3> path(frames), path_out(frames);
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    for (int t = 0; t < frames; ++t) path[t] = load_vec3(io.translations.at(t, j));
    if (io.translated_joints[j] != 0)
      bilateral_filter_translations(path, params.sigma_t, params.sigma_p, params.reach(),
                                    params.iterations, params.boundary, path_out, begin, end,
                                    scratch);
    else
      path_out = path;
    for (int t = begin; t < end; ++t) store_vec3(path_out[t], io.filtered_translations.at(t, j));
  }
  return {};
}

}  // namespace mocap
