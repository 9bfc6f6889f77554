#include "kernels/linear_filter.hpp"

#include <cmath>
#include <string>

#include "core/format.hpp"
#include "kernels/simd/lee_shin_simd.hpp"
#include "kernels/translation_filter.hpp"

namespace mocap {
namespace {

// A Gaussian reach beyond this many frames is a parameter mistake, not a filter.
constexpr double kMaxWindow = 1e6;

}  // namespace

Status LinearParams::validate() const {
  switch (kind) {
    case LinearKind::gaussian:
      if (!(sigma_t > 0) || !std::isfinite(sigma_t))
        return Status::error(format("sigma_t must be > 0, got %g", sigma_t));
      if (window < 0) return Status::error(format("window must be >= 0, got %g", window));
      if (window == 0 && 3 * sigma_t > kMaxWindow)
        return Status::error(
            format("sigma_t %g gives a window of more than %g frames", sigma_t, kMaxWindow));
      if (window > kMaxWindow)
        return Status::error(format("window must be <= %g frames, got %g", kMaxWindow, window));
      break;
    case LinearKind::butterworth:
      if (order < 1 || order > 8)
        return Status::error(format("butterworth order must be in [1, 8], got %g", order));
      if (!(cutoff > 0) || !std::isfinite(cutoff))
        return Status::error(format("cutoff must be > 0 Hz, got %g", cutoff));
      break;
    case LinearKind::moving_mean:
      if (passes < 1) return Status::error(format("passes must be >= 1, got %g", passes));
      break;
  }
  switch (boundary) {
    case Boundary::mirror:
    case Boundary::hold:
    case Boundary::extrapolate:
      return {};
  }
  return Status::error("unknown boundary mode");
}

MaskResult linear_mask(const LinearParams& params, double frame_time) {
  switch (params.kind) {
    case LinearKind::gaussian: {
      const int k = params.window > 0 ? params.window : default_gaussian_window(params.sigma_t);
      return {gaussian_mask(params.sigma_t, k), {}};
    }
    case LinearKind::butterworth:
      return butterworth_mask(params.order, params.cutoff, 1.0 / frame_time);
    case LinearKind::moving_mean:
      return {moving_mean_mask(), {}};
  }
  return {{}, "unknown linear filter kind"};
}

int linear_passes(const LinearParams& params) {
  return params.kind == LinearKind::moving_mean ? params.passes : 1;
}

void linear_filter_rotations(std::span<const Quat> curve, std::span<const double> mask, int passes,
                             Boundary boundary, std::span<Quat> out, int begin, int end,
                             CurveScratch& scratch) {
  run_passes(curve, passes, out, begin, end, scratch.pass_in, scratch.pass_out,
             [&](std::span<const Quat> in, std::span<Quat> result, int b, int e) {
               lee_shin_pass(in, mask, boundary, result, b, e, scratch);
             });
}

Status LinearFilterJob::validate() const {
  if (Status s = io.validate(); !s) return s;
  if (Status s = params.validate(); !s) return s;
  if (implementation != Implementation::fast && implementation != Implementation::reference)
    return Status::error("unknown implementation");
  if (params.kind == LinearKind::butterworth) {
    const MaskResult mask = linear_mask(params, io.frame_time);
    if (!mask.error.empty()) return Status::error(mask.error);
  }
  return {};
}

Status LinearFilterJob::run() const {
  if (Status s = validate(); !s) return s;
  const MaskResult mask = linear_mask(params, io.frame_time);
  if (!mask.error.empty()) return Status::error(mask.error);
  const int passes = linear_passes(params);

  const int frames = io.rotations.frames;
  const int begin = io.frame_begin, end = io.frame_stop();
  CurveScratch scratch;
  if (implementation == Implementation::fast) {
    simd::lee_shin_rotations(mask.mask, passes, params.boundary, io);
  } else {
    std::vector<Quat> curve(frames), out(frames);
    for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
      for (int t = 0; t < frames; ++t) curve[t] = load_quat(io.rotations.at(t, j));
      linear_filter_rotations(curve, mask.mask, passes, params.boundary, out, begin, end, scratch);
      for (int t = begin; t < end; ++t) store_quat(out[t], io.filtered_rotations.at(t, j));
    }
  }

  if (!io.has_translations()) return {};
  std::vector<Vec3> path(frames), path_out(frames);
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    for (int t = 0; t < frames; ++t) path[t] = load_vec3(io.translations.at(t, j));
    if (io.translated_joints[j] != 0)
      linear_filter_translations(path, mask.mask, passes, params.boundary, path_out, begin, end,
                                 scratch);
    else
      path_out = path;
    for (int t = begin; t < end; ++t) store_vec3(path_out[t], io.filtered_translations.at(t, j));
  }
  return {};
}

}  // namespace mocap
