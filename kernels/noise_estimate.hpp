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

#include "kernels/tensor.hpp"

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
NoiseEstimate estimate_noise(RotationView rotations,
                             std::span<const std::uint8_t> skip_joints = {});

}  // namespace mocap
