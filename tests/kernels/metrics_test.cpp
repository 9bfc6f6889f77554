// Tests of the metrics (spec "Metrics"): geodesic RMSE and PSNR on cases with a known answer,
// and the angular speed of a constant-velocity spin.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/metrics.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

TEST(Metrics, RmseAndPsnrOfKnownRotations) {
  // result[t][j] = truth[t][j] Exp(theta_j u) with random unit axes u: d = theta_j exactly, so
  // RMSE = sqrt(mean_j theta_j^2), up to float storage (~1e-7 rad per sample).
  const int frames = 50, joints = 4;
  const double theta[joints] = {0.01, 0.2, 1.5, 3.0};
  std::mt19937_64 rng(1);
  const std::vector<float> truth = test::random_motion(rng, frames, joints);
  std::vector<float> result = truth;
  std::uniform_real_distribution<double> u(-1, 1);
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < joints; ++j) {
      Vec3 axis{u(rng), u(rng), u(rng)};
      axis = (1.0 / norm(axis)) * axis;
      float* q = &result[(std::size_t(t) * joints + j) * 4];
      store_quat(load_quat(q) * exp(theta[j] * axis), q);
    }
  double mse = 0;
  for (double a : theta) mse += a * a / joints;
  const RotationView r{result.data(), frames, joints}, g{truth.data(), frames, joints};
  EXPECT_NEAR(rmse(r, g), std::sqrt(mse), 1e-6);
  EXPECT_NEAR(psnr(r, g), 10 * std::log10(kPi * kPi / mse), 1e-5);
  EXPECT_NEAR(psnr_from_rmse(rmse(r, g)), psnr(r, g), 1e-9);
  EXPECT_DOUBLE_EQ(rmse(r, g), rmse(g, r));  // symmetric
}

TEST(Metrics, IdenticalMotionsHaveZeroErrorAndInfinitePsnr) {
  std::mt19937_64 rng(2);
  const std::vector<float> truth = test::random_motion(rng, 20, 3);
  std::vector<float> flipped = truth;  // -q is the same rotation
  for (float& v : flipped) v = -v;
  const RotationView g{truth.data(), 20, 3}, f{flipped.data(), 20, 3};
  EXPECT_EQ(rmse(g, g), 0.0);
  EXPECT_EQ(rmse(f, g), 0.0);
  EXPECT_EQ(psnr(g, g), std::numeric_limits<double>::infinity());
  EXPECT_EQ(psnr_from_rmse(0.0), std::numeric_limits<double>::infinity());
  // The error of a rotation by pi everywhere is the largest possible: PSNR 0 dB.
  EXPECT_NEAR(psnr_from_rmse(kPi), 0.0, 1e-12);
}

TEST(Metrics, MismatchedShapesHaveNoError) {
  std::vector<float> a(2 * 3 * 4, 0.5f), b(3 * 2 * 4, 0.5f);
  EXPECT_TRUE(std::isnan(rmse({a.data(), 2, 3}, {b.data(), 3, 2})));
  EXPECT_TRUE(std::isnan(psnr({a.data(), 2, 3}, {b.data(), 3, 2})));
  EXPECT_TRUE(std::isnan(rmse({}, {})));
}

TEST(Metrics, AngularSpeedOfAConstantSpinIsItsRate) {
  // q_t = base Exp(omega t dt axis): each step turns by omega dt, so the speed is omega. The
  // float storage rounds each sample by ~1e-7 rad, i.e. ~1e-7 / dt in speed.
  const int frames = 200, joints = 2;
  const double dt = 1.0 / 120.0;
  const Vec3 axis{0.6, 0.0, -0.8};
  std::mt19937_64 rng(3);
  const Quat base = test::random_rotation(rng);
  for (double omega : {0.5, 3.0, 300.0}) {  // 300 rad/s: 2.5 rad per frame, still below pi
    std::vector<float> rotations(std::size_t(frames) * joints * 4);
    for (int t = 0; t < frames; ++t) {
      store_quat(base * exp(omega * t * dt * axis), &rotations[std::size_t(t) * joints * 4]);
      store_quat(base, &rotations[(std::size_t(t) * joints + 1) * 4]);
    }
    make_hemisphere_continuous({rotations.data(), frames, joints});
    std::vector<double> speed(frames - 1, -1.0), still(frames - 1, -1.0);
    angular_speed({rotations.data(), frames, joints}, dt, 0, speed);
    angular_speed({rotations.data(), frames, joints}, dt, 1, still);
    for (int t = 0; t + 1 < frames; ++t) {
      EXPECT_NEAR(speed[std::size_t(t)], omega, 1e-6 / dt) << "omega " << omega << " t " << t;
      EXPECT_EQ(still[std::size_t(t)], 0.0);
    }
  }
}

TEST(Metrics, AngularSpeedOfOneFrameIsEmpty) {
  const std::vector<float> one{1, 0, 0, 0};
  std::vector<double> none;
  angular_speed({one.data(), 1, 1}, 0.01, 0, none);  // nothing to write, nothing read past
  EXPECT_TRUE(none.empty());
}

}  // namespace
}  // namespace mocap
