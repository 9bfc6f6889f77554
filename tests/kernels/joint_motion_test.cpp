// Tests of the per-joint motion measure (kernels/joint_motion.hpp): exact values on motions whose
// lag-L second difference is known, the noise's share 6 sigma^2, and segments that keep a jump
// between them out.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/joint_motion.hpp"
#include "kernels/noise_model.hpp"

namespace mocap {
namespace {

// Joint 0 turns about a fixed axis by angle(t); joint 1 stays at a fixed rotation.
std::vector<float> two_joints(int frames, double (*angle)(int)) {
  std::vector<float> r(std::size_t(frames) * 2 * 4);
  const Quat fixed = exp(Vec3{0.3, -0.2, 0.5});
  for (int t = 0; t < frames; ++t) {
    store_quat(exp(Vec3{0, 0, angle(t)}), &r[std::size_t(t) * 8]);
    store_quat(fixed, &r[std::size_t(t) * 8 + 4]);
  }
  return r;
}

TEST(JointMotion, UniformTurnsHaveNoAccelerationAndQuadraticOnesTheirOwn) {
  // theta = c t^2 (steps below pi): v(t) = c ((t + L)^2 - t^2) about the axis, a(t) = 2 c L^2 in
  // one component of three, so P = (2 c L^2)^2 / 3 at every lag; a uniform turn gives 0.
  const int frames = 80;
  const std::vector<float> uniform = two_joints(frames, [](int t) { return 0.05 * t; });
  const std::vector<float> quadratic = two_joints(frames, [](int t) { return 2e-3 * t * t; });
  for (int lag : {1, 2, 4}) {
    const std::vector<double> u = lagged_acceleration_power({uniform.data(), frames, 2}, lag);
    const std::vector<double> q = lagged_acceleration_power({quadratic.data(), frames, 2}, lag);
    ASSERT_EQ(u.size(), 2u);
    EXPECT_NEAR(u[0], 0.0, 1e-12) << "lag " << lag;
    EXPECT_NEAR(u[1], 0.0, 1e-12);
    // The rotations are stored as floats: about 1e-7 rad on each sample.
    const double a = 2 * 2e-3 * lag * lag;
    EXPECT_NEAR(q[0], a * a / 3, 1e-3 * a * a) << "lag " << lag;
    EXPECT_NEAR(q[1], 0.0, 1e-12);
  }
}

TEST(JointMotion, NoiseAloneGivesSixSigmaSquared) {
  const int frames = 20000;
  const double sigma = 0.02;
  std::vector<float> r = two_joints(frames, [](int) { return 0.4; });
  add_noise(GaussianNoise{sigma, 11}, {r.data(), frames, 2});
  for (int lag : {1, 4}) {
    const std::vector<double> p = lagged_acceleration_power({r.data(), frames, 2}, lag);
    for (double x : p) EXPECT_NEAR(x / (6 * sigma * sigma), 1.0, 0.03) << "lag " << lag;
  }
}

TEST(JointMotion, SegmentsKeepTheJumpBetweenThemOut) {
  // A jump of 2 rad at frame 40 dominates the whole-clip measure; split there, the two uniform
  // halves measure 0. Segments shorter than 2L + 1 frames add nothing.
  const int frames = 80;
  const std::vector<float> r =
      two_joints(frames, [](int t) { return 0.01 * t + (t >= 40 ? 2.0 : 0.0); });
  const RotationView view{r.data(), frames, 2};
  EXPECT_GT(lagged_acceleration_power(view, 2)[0], 0.01);
  const std::vector<Segment> halves = {{0, 40}, {40, 80}};
  EXPECT_NEAR(lagged_acceleration_power(view, 2, halves)[0], 0.0, 1e-12);
  const std::vector<Segment> short_ones = {{0, 4}, {4, 8}};
  EXPECT_EQ(lagged_acceleration_power(view, 2, short_ones), std::vector<double>(2, 0.0));
  EXPECT_EQ(lagged_acceleration_power({nullptr, 0, 0}, 1), std::vector<double>{});
}

}  // namespace
}  // namespace mocap
