#pragma once
// The bilateral orientation filter (bof) of ../shared/spec/filters.md, "Bilateral orientation
// filter" (Courty 2008, with the spec's errata): per joint and sample a signal-dependent mask
//   m_r = exp(-r^2 / (2 sigma_t^2)) exp(-d(q_i, q_{i+r})^2 / (2 sigma_g^2)),  normalised,
// then the Lee-Shin construction with that mask at that sample; `iterations` repeats the whole
// filter on its own output. Translations get the Euclidean bilateral filter (spec "Translations").
#include <limits>
#include <optional>
#include <span>
#include <string_view>

#include "core/status.hpp"
#include "kernels/boundary.hpp"
#include "kernels/implementation.hpp"
#include "kernels/lee_shin.hpp"
#include "kernels/motion_io.hpp"

namespace mocap {

enum class BilateralKernel {
  gaussian,  // the spec's kernel above
  paper,  // as printed: exp(-|r| / (2 sigma_t^2)) exp(-(d/2) / (2 (sigma_g/2)^2)), comparison only
};

// "gaussian", "paper".
std::optional<BilateralKernel> parse_bilateral_kernel(std::string_view name);
std::string_view to_string(BilateralKernel kernel);

struct BilateralParams {
  double sigma_t = 1.0;  // frames
  double sigma_g = 0.2;  // rad, full rotation angle
  int window = 0;        // k; 0 = ceil(3 sigma_t)
  int iterations = 5;
  BilateralKernel kernel = BilateralKernel::gaussian;
  Boundary boundary = Boundary::mirror;
  // Translations: range width in the file's length unit; infinity = the plain Gaussian.
  double sigma_p = std::numeric_limits<double>::infinity();

  Status validate() const;
  int reach() const;  // k
};

// One bof pass over one joint's rotation curve (double): writes out[t] for t in [begin, end).
void bilateral_pass(std::span<const Quat> curve, const BilateralParams& params, std::span<Quat> out,
                    int begin, int end, CurveScratch& scratch);

// All `params.iterations` passes over one joint's curve, each reading the previous pass's whole
// output; writes out[t] for t in [begin, end) only.
void bilateral_filter_rotations(std::span<const Quat> curve, const BilateralParams& params,
                                std::span<Quat> out, int begin, int end, CurveScratch& scratch);

struct BilateralJob {
  BilateralParams params;
  MotionIO io;
  // fast: the SIMD rotations of kernels/simd/bilateral_simd.hpp (float32; reaches above
  // simd::kBilateralMaxFastReach = 64 frames run the reference); reference: the double passes
  // above. Translations take the same (scalar) path either way.
  Implementation implementation = Implementation::fast;

  Status validate() const;
  // Writes joints [io.joint_begin, io.joint_stop()) of frames [io.frame_begin, io.frame_stop()).
  Status run() const;
};

}  // namespace mocap
