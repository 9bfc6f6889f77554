#include "kernels/metrics.hpp"

#include <cmath>
#include <limits>

#include "core/quaternion.hpp"

namespace mocap {
namespace {

double mean_squared_error(RotationView result, RotationView truth) {
  if (!result.same_shape(truth) || result.empty() || truth.empty())
    return std::numeric_limits<double>::quiet_NaN();
  double sum = 0;
  for (int t = 0; t < truth.frames; ++t)
    for (int j = 0; j < truth.joints; ++j) {
      const double d = geodesic(load_quat(result.at(t, j)), load_quat(truth.at(t, j)));
      sum += d * d;
    }
  return sum / (double(truth.frames) * double(truth.joints));
}

double psnr_from_mse(double mse) {
  if (mse == 0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(kPi * kPi / mse);
}

}  // namespace

double rmse(RotationView result, RotationView truth) {
  return std::sqrt(mean_squared_error(result, truth));
}

double psnr(RotationView result, RotationView truth) {
  return psnr_from_mse(mean_squared_error(result, truth));
}

double psnr_from_rmse(double rmse) {
  return psnr_from_mse(rmse * rmse);
}

void angular_speed(RotationView rotations, double frame_time, int joint, std::span<double> out) {
  // The geodesic is |Log(q_t^-1 q_{t+1})|, computed so that small steps stay accurate.
  for (int t = 0; t + 1 < rotations.frames && std::size_t(t) < out.size(); ++t)
    out[std::size_t(t)] =
        geodesic(load_quat(rotations.at(t, joint)), load_quat(rotations.at(t + 1, joint))) /
        frame_time;
}

}  // namespace mocap
