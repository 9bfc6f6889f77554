// Tests of the noise models (spec "Noise models") and the noise level estimate (spec "Noise
// level estimate"): determinism, the statistics each model promises, and that the estimator
// recovers a known sigma and ignores joints that do not move.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/noise_estimate.hpp"
#include "kernels/noise_model.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

using test::Motion;

Motion smooth_motion(std::uint64_t seed, int frames, int joints) {
  std::mt19937_64 rng(seed);
  return {frames, joints, test::random_motion(rng, frames, joints)};
}

// Log(a^-1 b) of sample i (a flat index over [F][J]) of two motions.
Vec3 tangent_difference(const Motion& a, const Motion& b, std::size_t i) {
  return log(inverse(load_quat(&a.rotations[4 * i])) * load_quat(&b.rotations[4 * i]));
}

TEST(NoiseModel, SameSeedSameBytesOtherSeedOtherBytes) {
  const Motion clean = smooth_motion(1, 100, 5);
  Motion a = clean, b = clean, c = clean;
  add_noise(GaussianNoise{0.05, 7}, a.span());
  add_noise(GaussianNoise{0.05, 7}, b.span());
  add_noise(GaussianNoise{0.05, 8}, c.span());
  EXPECT_EQ(a.rotations, b.rotations);
  EXPECT_NE(a.rotations, c.rotations);

  Motion d = clean, e = clean, f = clean;
  const int popped_d = add_noise(ImpulseNoise{0.05, 0.3, 1.0, 7}, d.span());
  const int popped_e = add_noise(ImpulseNoise{0.05, 0.3, 1.0, 7}, e.span());
  add_noise(ImpulseNoise{0.05, 0.3, 1.0, 8}, f.span());
  EXPECT_EQ(d.rotations, e.rotations);
  EXPECT_EQ(popped_d, popped_e);
  EXPECT_NE(d.rotations, f.rotations);
}

TEST(NoiseModel, GaussianHasTheRequestedPerComponentDistribution) {
  // n = Log(q_orig^-1 q_noisy) must be N(0, sigma^2 I_3). With N = 60000 samples per component,
  // the standard error of a sample standard deviation is sigma / sqrt(2N) = 0.29%; of a mean,
  // sigma / sqrt(N) = 0.41% of sigma; of a fraction p, sqrt(p (1-p) / N) < 0.21%. The bounds are
  // 5 standard errors (a false alarm about once in 2 million runs; the seed is fixed anyway).
  const double sigma = 0.05;
  const Motion clean = smooth_motion(2, 3000, 20);
  Motion noisy = clean;
  add_noise(GaussianNoise{sigma, 3}, noisy.span());
  const std::size_t n = clean.rotations.size() / 4;
  double sum[3] = {}, sum_sq[3] = {}, cross_xy = 0, cross_yz = 0;
  std::size_t within_one = 0, within_two = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 v = tangent_difference(clean, noisy, i);
    const double c[3] = {v.x, v.y, v.z};
    for (int k = 0; k < 3; ++k) {
      sum[k] += c[k];
      sum_sq[k] += c[k] * c[k];
      within_one += std::abs(c[k]) < sigma;
      within_two += std::abs(c[k]) < 2 * sigma;
    }
    cross_xy += v.x * v.y;
    cross_yz += v.y * v.z;
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(sum[k] / double(n), 0.0, 5 * sigma / std::sqrt(double(n))) << "component " << k;
    EXPECT_NEAR(std::sqrt(sum_sq[k] / double(n)), sigma, 5 * sigma / std::sqrt(2.0 * double(n)))
        << "component " << k;
  }
  const double all = 3.0 * double(n);
  EXPECT_NEAR(double(within_one) / all, 0.682689, 5 * std::sqrt(0.2166 / all));
  EXPECT_NEAR(double(within_two) / all, 0.954500, 5 * std::sqrt(0.0434 / all));
  // Independent components: correlation within 5 / sqrt(N).
  EXPECT_NEAR(cross_xy / double(n) / (sigma * sigma), 0.0, 5 / std::sqrt(double(n)));
  EXPECT_NEAR(cross_yz / double(n) / (sigma * sigma), 0.0, 5 / std::sqrt(double(n)));
}

TEST(NoiseModel, GaussianOfZeroSigmaChangesNothing) {
  const Motion clean = smooth_motion(4, 50, 4);
  Motion noisy = clean;
  add_noise(GaussianNoise{0.0, 5}, noisy.span());
  EXPECT_EQ(noisy.rotations, clean.rotations);
}

TEST(NoiseModel, NoisyMotionIsHemisphereContinuous) {
  const Motion clean = smooth_motion(5, 400, 6);
  Motion gaussian = clean, impulse = clean;
  add_noise(GaussianNoise{0.3, 6}, gaussian.span());
  add_noise(ImpulseNoise{0.2, 2.0, 3.0, 6}, impulse.span());
  for (const Motion* m : {&gaussian, &impulse})
    for (int t = 1; t < m->frames; ++t)
      for (int j = 0; j < m->joints; ++j)
        ASSERT_GE(dot(load_quat(m->view().at(t - 1, j)), load_quat(m->view().at(t, j))), 0);
}

TEST(NoiseModel, ImpulsePopsAtTheRateWithinTheAngleRange) {
  const double rate = 0.01, a = 0.3, b = 1.0;
  const Motion clean = smooth_motion(6, 4000, 25);  // N = 100000 joint-samples
  Motion noisy = clean;
  const int popped = add_noise(ImpulseNoise{rate, a, b, 9}, noisy.span());
  const std::size_t n = clean.rotations.size() / 4;
  // Binomial(N, rate): mean 1000, standard deviation 31.5; bound at 5 of them.
  EXPECT_NEAR(popped, rate * double(n), 5 * std::sqrt(double(n) * rate * (1 - rate)));

  int changed = 0;
  double angle_sum = 0;
  Vec3 axis_sum;
  for (std::size_t i = 0; i < n; ++i) {
    // Untouched samples are equal up to sign, at geodesic distance exactly 0.
    const double angle =
        geodesic(load_quat(&clean.rotations[4 * i]), load_quat(&noisy.rotations[4 * i]));
    if (angle == 0) continue;
    const Vec3 v = tangent_difference(clean, noisy, i);
    ++changed;
    // Float storage rounds each component by ~3e-8.
    EXPECT_GE(angle, a - 1e-6) << "sample " << i;
    EXPECT_LE(angle, b + 1e-6) << "sample " << i;
    angle_sum += angle;
    axis_sum += (1.0 / norm(v)) * v;
  }
  EXPECT_EQ(changed, popped);
  // Angle uniform on [a, b]: mean (a + b)/2, standard deviation (b - a)/sqrt(12) per pop.
  EXPECT_NEAR(angle_sum / changed, 0.5 * (a + b), 5 * (b - a) / std::sqrt(12.0 * changed));
  // Axis uniform on the sphere: each component of the mean axis has variance 1/(3 n).
  const double bound = 5 / std::sqrt(3.0 * changed);
  EXPECT_NEAR(axis_sum.x / changed, 0, bound);
  EXPECT_NEAR(axis_sum.y / changed, 0, bound);
  EXPECT_NEAR(axis_sum.z / changed, 0, bound);
}

TEST(NoiseModel, ImpulseRateZeroAndOne) {
  const Motion clean = smooth_motion(7, 60, 3);
  Motion none = clean, all = clean;
  EXPECT_EQ(add_noise(ImpulseNoise{0.0, 0.3, 1.0, 1}, none.span()), 0);
  EXPECT_EQ(none.rotations, clean.rotations);
  EXPECT_EQ(add_noise(ImpulseNoise{1.0, 0.3, 1.0, 1}, all.span()), 60 * 3);
}

TEST(NoiseModel, ValidateSaysWhatIsWrong) {
  auto gaussian = [](double sigma) { return GaussianNoise{sigma, 1}.validate(); };
  auto impulse = [](double rate, double a, double b) {
    return ImpulseNoise{rate, a, b, 1}.validate();
  };
  EXPECT_TRUE(GaussianNoise{}.validate().ok());
  EXPECT_EQ(gaussian(-1).message(), "gaussian noise sigma must be a finite angle >= 0 rad, got -1");
  EXPECT_FALSE(gaussian(INFINITY).ok());
  EXPECT_TRUE(ImpulseNoise{}.validate().ok());
  EXPECT_EQ(impulse(1.5, 0.3, 1.0).message(), "impulse noise rate must be in [0, 1], got 1.5");
  EXPECT_EQ(impulse(0.01, 1.0, 0.3).message(),
            "impulse noise angles must satisfy 0 <= min_angle <= max_angle <= pi, got [1, 0.3]");
  EXPECT_FALSE(impulse(0.01, 0.3, 4.0).ok());
}

// Tolerance of the estimate: each joint's MAD runs over 3 (F - 2) ~ 3000 components; a MAD-based
// standard deviation has 37% efficiency, so about 2% relative standard error per joint (more for
// the correlated neighbouring second differences), and the median over 12 joints cuts that to
// about 1%. The smooth part of the test motions (steps changing by ~1e-3 rad per frame) and the
// second-order terms of composing rotations (sigma^2 / 2 against sigma sqrt(6)) bias it by well
// under 1% for sigma up to 0.12. 5% is five standard errors. Measured: within 0.7%.
constexpr double kEstimateTolerance = 0.05;

TEST(NoiseEstimate, RecoversTheSigmaOfAddedGaussianNoise) {
  for (double sigma : {0.008, 0.03, 0.12}) {
    Motion noisy = smooth_motion(8, 1000, 12);
    add_noise(GaussianNoise{sigma, 9}, noisy.span());
    const NoiseEstimate estimate = estimate_noise(noisy.view());
    EXPECT_NEAR(estimate.sigma, sigma, kEstimateTolerance * sigma);
    EXPECT_EQ(estimate.moving_joints, 12);
  }
}

TEST(NoiseEstimate, IsTheMedianOverJoints) {
  // Joint j carries noise sigma_j = 0.01 (j + 1): the median joint is j = 2.
  Motion noisy = smooth_motion(10, 1000, 5);
  for (int j = 0; j < 5; ++j) {
    Motion one = smooth_motion(11 + j, 1000, 1);
    add_noise(GaussianNoise{0.01 * (j + 1), 20 + std::uint64_t(j)}, one.span());
    for (int t = 0; t < 1000; ++t) std::copy_n(one.view().at(t, 0), 4, noisy.span().at(t, j));
  }
  EXPECT_NEAR(estimate_noise(noisy.view()).sigma, 0.03, kEstimateTolerance * 0.03);
  // Leaving out the two least noisy joints moves the median to j = 3.
  const std::vector<std::uint8_t> skip{1, 1, 0, 0, 0};
  EXPECT_NEAR(estimate_noise(noisy.view(), skip).sigma, 0.04, kEstimateTolerance * 0.04);
  // Spans that are not one per joint are ignored, never read past their end.
  const std::vector<std::uint8_t> short_skip{1, 1};
  const std::vector<double> short_steps{1.0};
  EXPECT_EQ(estimate_noise(noisy.view(), short_skip, short_steps).sigma,
            estimate_noise(noisy.view()).sigma);
}

TEST(NoiseEstimate, IgnoresJointsThatDoNotMove) {
  // 6 moving joints among 10 constant joints and 4 carrying float-rounding jitter only: without
  // the moving-joint rule the median would be (nearly) zero.
  const double sigma = 0.03;
  const int frames = 1000, moving = 6, joints = 20;
  Motion live = smooth_motion(12, frames, moving);
  add_noise(GaussianNoise{sigma, 13}, live.span());
  Motion clip{frames, joints, std::vector<float>(std::size_t(frames) * joints * 4)};
  std::mt19937_64 rng(14);
  std::normal_distribution<double> jitter(0, 1e-7);
  for (int j = 0; j < joints; ++j) {
    const Quat base = test::random_rotation(rng);
    for (int t = 0; t < frames; ++t) {
      float* q = clip.span().at(t, j);
      if (j < moving) {
        std::copy_n(live.view().at(t, j), 4, q);
      } else if (j < 16) {
        store_quat(base, q);
      } else {
        store_quat(base * exp({jitter(rng), jitter(rng), jitter(rng)}), q);
      }
    }
  }
  const NoiseEstimate estimate = estimate_noise(clip.view());
  EXPECT_EQ(estimate.moving_joints, moving);
  EXPECT_NEAR(estimate.sigma, sigma, kEstimateTolerance * sigma);
}

TEST(NoiseEstimate, SparsePopsBarelyMoveIt) {
  // Spec: sparse pops leave the median (nearly) untouched. Each pop spoils 3 second differences:
  // ~3% outliers raise the MAD by about 4%.
  const double sigma = 0.03;
  Motion noisy = smooth_motion(15, 1000, 12);
  add_noise(GaussianNoise{sigma, 16}, noisy.span());
  const double without = estimate_noise(noisy.view()).sigma;
  add_noise(ImpulseNoise{0.01, 0.3, 1.0, 17}, noisy.span());
  const double with = estimate_noise(noisy.view()).sigma;
  EXPECT_NEAR(with, without, 0.06 * without);
}

TEST(NoiseEstimate, NothingMovesNothingToEstimate) {
  Motion still = smooth_motion(18, 100, 4);
  for (int t = 1; t < 100; ++t) std::copy_n(still.view().at(0, 0), 16, still.span().at(t, 0));
  NoiseEstimate estimate = estimate_noise(still.view());
  EXPECT_EQ(estimate.sigma, 0.0);
  EXPECT_EQ(estimate.moving_joints, 0);
  // Two frames have no second difference.
  Motion short_clip = smooth_motion(19, 2, 4);
  add_noise(GaussianNoise{0.1, 1}, short_clip.span());
  estimate = estimate_noise(short_clip.view());
  EXPECT_EQ(estimate.sigma, 0.0);
  EXPECT_EQ(estimate.moving_joints, 0);
}

}  // namespace
}  // namespace mocap
