#pragma once
// Hinges under noise (issue 13). A joint the capture drives about one axis (kernels/pop_hinge.hpp:
// CMU's knees, elbows, wrists and toes) has its samples on the curve {m Exp(theta a)}, a great
// circle of unit quaternions; the spec's noise (q := q Exp(n), n ~ N(0, sigma^2 I_3)) moves them
// off it in two of its three directions. After the filter, what is left of the noise off the
// curve is taken out by putting each filtered sample on the curve's nearest point
// (project_onto_hinge).
// The curve comes from the filter's input, one segment at a time: m is the normalized mean of the
// segment's samples (on the curve when they are: the mean of points of a great circle lies in its
// plane), a the principal axis of their chart points v_t = Log(m^-1 q_t) (a line through 0 along
// a for a hinge). The chordal chart 2 vec(m^-1 q_t) would spare the arc tangents, but it reads
// the spread off the axis cos(angle / 2) smaller far from m, and at 0.12 rad and 120 fps it let
// hips in (docs/automatic-parameters.md, "Hinges under noise"); the statistics read every F /
// kHingeFitSamples-th sample instead. A joint is taken for a hinge when the spread of the chart
// points off that axis (the square roots of the two smaller eigenvalues of their second moments) is
// at most `spread_over_noise` x the clip's estimated noise sigma, what noise alone gives a hinge,
// and the spread along it at least `motion_over_noise` x sigma (it moves): a joint that turns about
// several axes spreads off any one of them by its motion, far more than the noise. Measured on the
// shared clips with eval's gaussian noise (0.008-0.12 rad, 120 and 30 fps, the clip's noise
// estimate sigma): the eight hinges spread 0.85-1.26 sigma off their axes; a joint that really
// turns about several axes spreads by sqrt(its own secondary motion^2 + sigma^2), and that motion
// can be as small as 0.012 rad RMS (02_01's Spine): a limit of 1.3 sigma keeps such a joint out at
// 0.008 rad, where 1.5 let some in (and at 0.12 rad, hips whose abduction is about the noise's
// size: joint position error up 7 %, docs/automatic-parameters.md, "Hinges under noise").
#include <cstdint>
#include <span>

#include "core/quaternion.hpp"
#include "core/status.hpp"
#include "core/tensor.hpp"

namespace mocap {

inline constexpr double kHingeSpreadOverNoise = 1.3;
inline constexpr double kHingeMotionOverNoise = 4.0;
inline constexpr int kHingeFitMinFrames = 10;
inline constexpr int kHingeFitSamples = 256;  // the statistics read every F / 256-th sample

struct HingeProjectionJob {
  RotationView input;   // [F][J]: the samples the curve is fitted to (the filter's input)
  RotationSpan output;  // [F][J]: the filtered samples; a hinge joint's are projected in place
  std::span<const std::uint8_t> skip;  // optional, one per joint: nonzero is left alone
  double noise_sigma = 0;              // rad per axis, the clip's estimate; <= 0: nothing done
  double spread_over_noise = kHingeSpreadOverNoise;
  double motion_over_noise = kHingeMotionOverNoise;
  int min_frames = kHingeFitMinFrames;  // fewer: nothing done
  std::span<std::uint8_t> projected;    // optional, one per joint: 1 where projected, else 0

  Status validate() const;
  Status run() const;
};

}  // namespace mocap
