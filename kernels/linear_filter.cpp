#include "kernels/linear_filter.hpp"

#include <cmath>
#include <string>

#include "core/format.hpp"
#include "kernels/per_joint.hpp"
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
      if (window < 0) return Status::error(format("window must be >= 0, got %d", window));
      if (window == 0 && 3 * sigma_t > kMaxWindow)
        return Status::error(
            format("sigma_t %g gives a window of more than %g frames", sigma_t, kMaxWindow));
      if (window > kMaxWindow)
        return Status::error(format("window must be <= %g frames, got %d", kMaxWindow, window));
      break;
    case LinearKind::butterworth:
      if (order < 1 || order > 8)
        return Status::error(format("butterworth order must be in [1, 8], got %d", order));
      if (!(cutoff > 0) || !std::isfinite(cutoff))
        return Status::error(format("cutoff must be > 0 Hz, got %g", cutoff));
      for (std::size_t j = 0; j < joint_cutoffs.size(); ++j)
        if (!(joint_cutoffs[j] > 0) || !std::isfinite(joint_cutoffs[j]))
          return Status::error(
              format("joint_cutoffs[%zu] must be > 0 Hz, got %g", j, joint_cutoffs[j]));
      break;
    case LinearKind::moving_mean:
      if (passes < 1) return Status::error(format("passes must be >= 1, got %d", passes));
      break;
  }
  if (kind != LinearKind::butterworth && !joint_cutoffs.empty())
    return Status::error("joint_cutoffs are a butterworth parameter");
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
    // Each cut-off against the clip's frame rate, without designing the masks.
    const double rate = 1.0 / io.frame_time;
    if (const std::string e = butterworth_mask_error(params.order, params.cutoff, rate); !e.empty())
      return Status::error(e);
    if (!params.joint_cutoffs.empty() &&
        params.joint_cutoffs.size() != std::size_t(io.rotations.joints))
      return Status::error(format("joint_cutoffs has %zu entries for %d joints",
                                  params.joint_cutoffs.size(), io.rotations.joints));
    for (double cutoff : params.joint_cutoffs)
      if (const std::string e = butterworth_mask_error(params.order, cutoff, rate); !e.empty())
        return Status::error(e);
  }
  return {};
}

Status LinearFilterJob::run() const {
  if (Status s = validate(); !s) return s;
  const MaskResult mask = linear_mask(params, io.frame_time);
  if (!mask.error.empty()) return Status::error(mask.error);
  const int passes = linear_passes(params);

  const auto rotations = [&](const MotionIO& slice, std::span<const double> m) {
    if (implementation == Implementation::fast)
      simd::lee_shin_rotations(m, passes, params.boundary, slice);
    else
      filter_each_rotation_curve(
          slice, [&](const auto& curve, auto& out, int begin, int end, CurveScratch& scratch) {
            linear_filter_rotations(curve, m, passes, params.boundary, out, begin, end, scratch);
          });
  };
  if (params.joint_cutoffs.empty()) {
    rotations(io, mask.mask);
  } else {
    // Joint by joint, each with its own mask (validated above).
    MotionIO slice = io;
    for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
      slice.joint_begin = j;
      slice.joint_end = j + 1;
      rotations(slice, butterworth_mask(params.order, params.joint_cutoffs[std::size_t(j)],
                                        1.0 / io.frame_time)
                           .mask);
    }
  }
  filter_each_translation_path(io, [&](const auto& path, auto& out, int begin, int end,
                                       CurveScratch& scratch) {
    linear_filter_translations(path, mask.mask, passes, params.boundary, out, begin, end, scratch);
  });
  return {};
}

}  // namespace mocap
