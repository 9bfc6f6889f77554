#pragma once
// The linear orientation filters of ../shared/spec/filters.md, "Lee-Shin construction"
// (gaussian, butterworth, moving-mean), as a job over a clip; translations of the joints that
// carry them get the same mask (spec "Translations").
#include <span>
#include <vector>

#include "core/status.hpp"
#include "kernels/boundary.hpp"
#include "kernels/implementation.hpp"
#include "kernels/lee_shin.hpp"
#include "kernels/linear_masks.hpp"
#include "kernels/motion_io.hpp"

namespace mocap {

struct LinearParams {
  LinearKind kind = LinearKind::gaussian;
  double sigma_t = 1.0;  // gaussian: width in frames
  int window = 0;        // gaussian: reach k; 0 = ceil(3 sigma_t)
  int order = 2;         // butterworth: order n, in [1, 8]
  double cutoff = 6.0;   // butterworth: single-pass -3 dB cut-off, Hz
  // butterworth: empty, or one cut-off (Hz) per joint of the clip for its rotations; `cutoff`
  // then serves the position channels only. Joints are filtered independently, so a joint's
  // output is the same bits as with that cut-off for every joint.
  std::vector<double> joint_cutoffs;
  int passes = 5;  // moving-mean: number of passes
  Boundary boundary = Boundary::mirror;

  // The parameters of `kind` only (the butterworth cut-offs are checked against the clip's frame
  // rate and joint_cutoffs' size against its joints by the job).
  Status validate() const;
};

// The mask of `params` at a clip's frame time (butterworth depends on the frame rate).
MaskResult linear_mask(const LinearParams& params, double frame_time);

// How many times the mask is applied: `passes` for moving-mean, once otherwise.
int linear_passes(const LinearParams& params);

// `passes` Lee-Shin passes with `mask` over one joint's rotation curve (double), each pass
// reading the previous one's whole output. Writes out[t] for t in [begin, end) only.
void linear_filter_rotations(std::span<const Quat> curve, std::span<const double> mask, int passes,
                             Boundary boundary, std::span<Quat> out, int begin, int end,
                             CurveScratch& scratch);

struct LinearFilterJob {
  LinearParams params;
  MotionIO io;
  // fast: the SIMD rotations of kernels/simd/lee_shin_simd.hpp (float32); reference: the double
  // passes above. Translations take the same (scalar) path either way.
  Implementation implementation = Implementation::fast;

  Status validate() const;
  // Writes joints [io.joint_begin, io.joint_stop()) of frames [io.frame_begin, io.frame_stop()).
  Status run() const;
};

}  // namespace mocap
