// The kalman baseline (kernels/kalman.hpp): its steady-state mask against the textbook
// time-varying RTS smoother, and the orientation filter built from it through Lee-Shin.
#include "kernels/kalman.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "core/quaternion.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

constexpr double kLambdas[] = {1e-6, 1e-4, 1e-2, 1.0, 100.0};

TEST(KalmanMask, IsSymmetricSumsToOneAndPeaksAtTheCentre) {
  for (double lambda : kLambdas) {
    const std::vector<double> mask = kalman_mask(lambda);
    ASSERT_EQ(mask.size() % 2, 1u) << lambda;
    const std::size_t k = mask.size() / 2;
    EXPECT_NEAR(std::accumulate(mask.begin(), mask.end(), 0.0), 1.0, 1e-12) << lambda;
    for (std::size_t r = 1; r <= k; ++r) {
      EXPECT_NEAR(mask[k - r], mask[k + r], 1e-9 * mask[k]) << lambda << " lag " << r;
      EXPECT_LT(std::abs(mask[k + r]), mask[k]) << lambda << " lag " << r;
    }
  }
}

TEST(KalmanMask, SmoothsMoreAsLambdaFalls) {
  std::size_t previous = 0;
  double previous_peak = 0;
  for (double lambda : {100.0, 1.0, 1e-2, 1e-4, 1e-6}) {
    const std::vector<double> mask = kalman_mask(lambda);
    EXPECT_GT(mask.size(), previous) << lambda;
    if (previous_peak > 0) {
      EXPECT_LT(mask[mask.size() / 2], previous_peak) << lambda;
    }
    previous = mask.size();
    previous_peak = mask[mask.size() / 2];
  }
}

// Far from both ends the time-varying RTS smoother has converged to its steady state, so the
// direct smoother and the correlation with the mask agree (up to the mask's 1e-6 truncation).
TEST(KalmanMask, MatchesTheDirectRtsSmootherAwayFromTheEnds) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (double lambda : {1e-4, 1e-2, 1.0}) {
    const std::vector<double> mask = kalman_mask(lambda);
    const int k = int(mask.size() / 2);
    const int n = 6 * k + 400;
    std::vector<double> signal(static_cast<std::size_t>(n)), direct(static_cast<std::size_t>(n));
    for (int t = 0; t < n; ++t)
      signal[std::size_t(t)] = std::sin(0.02 * t) + 0.3 * std::cos(0.07 * t) + noise(rng);
    rts_smooth(signal, lambda, direct);
    double worst = 0;
    for (int t = 2 * k; t < n - 2 * k; ++t) {
      double correlated = 0;
      for (int r = -k; r <= k; ++r)
        correlated += mask[std::size_t(r + k)] * signal[std::size_t(t + r)];
      worst = std::max(worst, std::abs(correlated - direct[std::size_t(t)]));
    }
    EXPECT_LT(worst, 2e-6) << "lambda " << lambda << ", k " << k;
  }
}

TEST(KalmanMask, DirectSmootherFollowsAConstantVelocitySignalExactly) {
  // A noise-free ramp is the model's own trajectory: the smoother reproduces it.
  std::vector<double> ramp(200), out(200);
  for (int t = 0; t < 200; ++t) ramp[std::size_t(t)] = 0.01 * t - 0.5;
  rts_smooth(ramp, 1e-3, out);
  for (int t = 0; t < 200; ++t) EXPECT_NEAR(out[std::size_t(t)], ramp[std::size_t(t)], 1e-6) << t;
}

TEST(KalmanParams, ValidateExplains) {
  EXPECT_TRUE(KalmanParams{}.validate().ok());  // lambda 0: for the engine to derive
  KalmanParams p;
  p.lambda = -1;
  const Status s = p.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("lambda"), std::string::npos) << s.message();
  p.lambda = std::nan("");
  EXPECT_FALSE(p.validate().ok());
  p.lambda = 1e7;
  EXPECT_FALSE(p.validate().ok());
}

TEST(KalmanAutoLambda, FallsWithTheNoiseAndCopiesWhenNothingMoves) {
  const double dt = 1.0 / 120;
  EXPECT_GT(kalman_auto_lambda(0.008, dt), kalman_auto_lambda(0.03, dt));
  EXPECT_GT(kalman_auto_lambda(0.03, dt), kalman_auto_lambda(0.12, dt));
  EXPECT_NEAR(kalman_auto_lambda(0.03, dt) / kalman_auto_lambda(0.06, dt), 8.0, 1e-9);
  EXPECT_EQ(kalman_auto_lambda(0.0, dt), kKalmanMaxLambda);
  EXPECT_TRUE(KalmanParams{kalman_auto_lambda(1e-9, dt)}.validate().ok());
}

// Rotations about one fixed axis: the Lee-Shin filter with the mask is the correlation of the
// angle with the mask (spec "Lee-Shin construction"), i.e. the steady-state smoother of the angle.
TEST(KalmanJob, OnASingleAxisIsTheSmootherOfTheAngle) {
  const int frames = 600, joints = 2;
  const double lambda = 1e-2;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.03);
  std::vector<double> angle(frames);
  std::vector<float> rotations(std::size_t(frames) * joints * 4), out(rotations.size());
  const Vec3 axis{0.6, 0.0, 0.8};
  for (int t = 0; t < frames; ++t) {
    angle[std::size_t(t)] = 1.2 * std::sin(0.015 * t) + noise(rng);
    for (int j = 0; j < joints; ++j)
      store_quat(exp((j + 1) * angle[std::size_t(t)] * axis),
                 &rotations[(std::size_t(t) * joints + j) * 4]);
  }
  for (Implementation implementation : {Implementation::reference, Implementation::fast}) {
    MotionIO io;
    io.rotations = {rotations.data(), frames, joints};
    io.filtered_rotations = {out.data(), frames, joints};
    KalmanJob job{{lambda, Boundary::mirror}, io, implementation};
    ASSERT_TRUE(job.run().ok());
    const std::vector<double> mask = kalman_mask(lambda);
    const int k = int(mask.size() / 2);
    for (int t = k; t < frames - k; ++t) {
      double expected = 0;
      for (int r = -k; r <= k; ++r)
        expected += mask[std::size_t(r + k)] * angle[std::size_t(t + r)];
      for (int j = 0; j < joints; ++j) {
        const Quat got = load_quat(&out[(std::size_t(t) * joints + j) * 4]);
        EXPECT_LT(geodesic(got, exp((j + 1) * expected * axis)), 2e-5)
            << to_string(implementation) << " frame " << t << " joint " << j;
      }
    }
  }
}

TEST(KalmanJob, RejectsAnInvalidLambdaBeforeWriting) {
  std::vector<float> rotations(4 * 10, 0.0f), out(rotations.size(), 7.0f);
  for (int t = 0; t < 10; ++t) rotations[std::size_t(t) * 4] = 1.0f;
  MotionIO io;
  io.rotations = {rotations.data(), 10, 1};
  io.filtered_rotations = {out.data(), 10, 1};
  KalmanJob job{{-1.0, Boundary::mirror}, io};
  EXPECT_FALSE(job.run().ok());
  EXPECT_EQ(out[0], 7.0f);
  job.params.lambda = 0;  // automatic is the engine's to resolve, not the kernel's
  const Status s = job.run();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("> 0"), std::string::npos) << s.message();
  EXPECT_EQ(out[0], 7.0f);
}

}  // namespace
}  // namespace mocap
