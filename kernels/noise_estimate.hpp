#pragma once
// The noise level estimate of ../shared/spec/filters.md, "Noise level estimate (for defaults)":
//
//     sigma_hat = median over moving joints of 1.4826 MAD(c) / sqrt(6)
//
// with c the three components of the second differences Log(q_t^-1 q_{t+1}) - Log(q_{t-1}^-1 q_t)
// of a joint, over all t. For i.i.d. tangent noise n_t ~ N(0, sigma^2 I_3) the second difference
// carries n_{t+1} - 2 n_t + n_{t-1}, variance 6 sigma^2 per component, and 1.4826 MAD is a robust
// standard deviation: sigma_hat estimates the `sigma` of the gaussian noise model. Sparse pops
// (the impulse model) leave the medians untouched, by design of a robust estimator.
#include <cstdint>
#include <span>

#include "core/tensor.hpp"

namespace mocap {

// A joint moves when its median frame-to-frame step exceeds this (rad): uncaptured joints are
// constant or carry only float-rounding jitter and would pull the median to zero.
inline constexpr double kMovingJointStep = 1e-5;

struct NoiseEstimate {
  double sigma = 0;       // rad, per tangent component; 0 when no joint moves
  int moving_joints = 0;  // joints the median runs over
};

// Needs 3 frames for a second difference; shorter clips (and clips where nothing moves) give
// {0, 0}: nothing to filter. Medians of an even count are the mean of the two middle values.
// `skip_joints` (empty, or one entry per joint): nonzero = left out, for joints known to be
// garbage (kernels/joint_quality.hpp): a joint flipping by pi is "moving" to the step test, and
// would count its flips as noise.
// `median_steps` (empty, or one per joint): each joint's median frame-to-frame geodesic step
// when the caller has it already (JointQuality::median_step of the same rotations), which is
// exactly what the moving test would compute. Either span of another size is ignored (no joint
// left out; the steps measured here).
NoiseEstimate estimate_noise(RotationView rotations, std::span<const std::uint8_t> skip_joints = {},
                             std::span<const double> median_steps = {});

// The noise of the translated joints' trajectories (position channels), for nlpm's translation
// filter (engine's automatic rules):
//   sigma  = max over the translated joints of 1.4826 MAD(c) / sqrt(20), c the components of the
//            third differences p[t+2] - 3 p[t+1] + 3 p[t] - p[t-1] (i.i.d. noise of deviation
//            sigma gives them variance 20 sigma^2; a trajectory's own jerk per frame^3 is small
//            even at 30 fps, where its second differences are not);
//   accel  = the RMS per component of the second differences of the same joint after a Gaussian
//            of 0.1 s, which removes that noise and keeps the motion: the trajectory's own
//            acceleration per frame^2 (the largest joint's sigma decides which joint).
// File units. Needs 4 frames; {0, 0} without translated joints or frames.
struct TranslationNoise {
  double sigma = 0;  // file units
  double accel = 0;  // file units per frame^2; -1 = not measurable (a clip shorter than 0.2 s)
};
TranslationNoise estimate_translation_noise(TranslationView translations,
                                            std::span<const std::uint8_t> translated_joints,
                                            double frame_time);

}  // namespace mocap
