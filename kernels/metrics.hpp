#pragma once
// The metrics of ../shared/spec/filters.md, "Metrics": geodesic RMSE and PSNR of a result against
// ground truth, and the angular speed profile of one joint.
#include <span>

#include "core/tensor.hpp"

namespace mocap {

// sqrt(mean_{t,j} d(result[t][j], truth[t][j])^2), radians. NaN when the shapes differ or are
// empty (there is no error to report).
double rmse(RotationView result, RotationView truth);

// 10 log10(pi^2 / MSE) dB, MSE as in rmse(); +inf when MSE == 0, NaN when rmse() is NaN.
double psnr(RotationView result, RotationView truth);
double psnr_from_rmse(double rmse);

// out[t] = |Log(q_t^-1 q_{t+1})| / frame_time (rad/s) for t in [0, F-1) of `joint`;
// out.size() must be F - 1 (a clip of F <= 1 frames has no steps).
void angular_speed(RotationView rotations, double frame_time, int joint, std::span<double> out);

}  // namespace mocap
