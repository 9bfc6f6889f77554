// Tests of the hinge projection (kernels/hinge_projection.hpp): a noisy hinge is found against the
// noise and its samples put on its curve, which takes out most of the noise off the axis; a joint
// that also turns about a second axis by more than the noise, a still joint, a skipped joint, a
// segment too short and a clip without a noise estimate are left bit for bit; a noise-free hinge
// stays where it is; validate() says what is wrong.
#include "kernels/hinge_projection.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "kernels/noise_model.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

using test::Motion;

Vec3 unit(Vec3 v) {
  return (1 / norm(v)) * v;
}

// Joint 0: a hinge (base Exp(theta a)), 1.0 rad of swing. Joint 1: the same swing about its own
// axis plus 0.08 rad about a second one (a joint with two degrees of freedom). Joint 2: still.
Motion three_joints(std::uint64_t seed, int frames = 240) {
  std::mt19937_64 rng(seed);
  Motion m{frames, 3, std::vector<float>(std::size_t(frames) * 3 * 4)};
  for (int j = 0; j < 3; ++j) {
    const Quat base = test::random_rotation(rng);
    const Vec3 a = unit(log(test::random_rotation(rng)));
    const Vec3 other = log(test::random_rotation(rng));
    const Vec3 b = unit(other - dot(other, a) * a);
    for (int t = 0; t < frames; ++t) {
      const double theta = j == 2 ? 0.0 : 1.0 * std::sin(0.05 * t + j);
      const double second = j == 1 ? 0.08 * std::sin(0.11 * t) : 0.0;
      store_quat(base * exp(theta * a) * exp(second * b), m.span().at(t, j));
    }
  }
  make_hemisphere_continuous(m.span());
  return m;
}

double rms_error(const Motion& a, const Motion& b, int j) {
  double sum = 0;
  for (int t = 0; t < a.frames; ++t) sum += std::pow(geodesic(a.at(t, j), b.at(t, j)), 2);
  return std::sqrt(sum / a.frames);
}

TEST(HingeProjection, PutsANoisyHingeOnItsCurveAndLeavesTheOthers) {
  for (const double sigma : {0.008, 0.03}) {
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
      const Motion clean = three_joints(seed);
      Motion noisy = clean;
      GaussianNoise noise;
      noise.sigma = sigma;
      noise.seed = seed;
      add_noise(noise, noisy.span());
      Motion out = noisy;
      std::vector<std::uint8_t> projected(3, 7);
      HingeProjectionJob job;
      job.input = noisy.view();
      job.output = out.span();
      job.noise_sigma = sigma;
      job.projected = projected;
      ASSERT_TRUE(job.run().ok());
      EXPECT_EQ(projected, (std::vector<std::uint8_t>{1, 0, 0})) << sigma << " " << seed;
      // Two of the noise's three directions taken out: about sqrt(1/3) of its RMS is left.
      EXPECT_LT(rms_error(out, clean, 0), 0.7 * rms_error(noisy, clean, 0)) << sigma << " " << seed;
      for (int t = 0; t < out.frames; ++t)
        for (int j = 1; j < 3; ++j)
          for (int k = 0; k < 4; ++k)
            ASSERT_EQ(out.span().at(t, j)[k], noisy.span().at(t, j)[k]) << t << " " << j;
    }
  }
}

TEST(HingeProjection, NothingIsDoneWithoutNoiseOnTooFewFramesOrOnSkippedJoints) {
  const Motion clean = three_joints(9);
  Motion noisy = clean;
  GaussianNoise noise;
  noise.sigma = 0.01;
  add_noise(noise, noisy.span());
  HingeProjectionJob job;
  job.input = noisy.view();
  Motion out = noisy;
  job.output = out.span();
  ASSERT_TRUE(job.run().ok());  // noise_sigma 0: no estimate
  EXPECT_EQ(out.rotations, noisy.rotations);
  job.noise_sigma = 0.01;
  const std::vector<std::uint8_t> skip{1, 0, 0};
  job.skip = skip;
  ASSERT_TRUE(job.run().ok());
  EXPECT_EQ(out.rotations, noisy.rotations);
  job.skip = {};
  Motion short_clip{
      8, 3, std::vector<float>(noisy.rotations.begin(), noisy.rotations.begin() + 8 * 3 * 4)};
  const Motion short_before = short_clip;
  job.input = short_before.view();
  job.output = short_clip.span();
  ASSERT_TRUE(job.run().ok());
  EXPECT_EQ(short_clip.rotations, short_before.rotations);
}

TEST(HingeProjection, ANoiseFreeHingeStaysWhereItIs) {
  const Motion clean = three_joints(2);
  Motion out = clean;
  HingeProjectionJob job;
  job.input = clean.view();
  job.output = out.span();
  job.noise_sigma = 0.002;
  ASSERT_TRUE(job.run().ok());
  EXPECT_LT(rms_error(out, clean, 0), 1e-6);
}

TEST(HingeProjection, ValidateSaysWhatIsWrong) {
  const Motion m = three_joints(1, 20);
  Motion out = m;
  Motion other{10, 3, std::vector<float>(10 * 3 * 4)};
  HingeProjectionJob job;
  job.input = m.view();
  job.output = other.span();
  EXPECT_NE(job.validate().message().find("shape"), std::string::npos);
  job.output = out.span();
  EXPECT_TRUE(job.validate().ok());
  const std::vector<std::uint8_t> two(2, 0);
  job.skip = two;
  EXPECT_NE(job.validate().message().find("skip"), std::string::npos);
  job.skip = {};
  job.noise_sigma = NAN;
  EXPECT_NE(job.validate().message().find("noise_sigma"), std::string::npos);
  job.noise_sigma = 0.01;
  job.spread_over_noise = 0;
  EXPECT_NE(job.validate().message().find("spread_over_noise"), std::string::npos);
  job.spread_over_noise = kHingeSpreadOverNoise;
  job.min_frames = 2;
  EXPECT_NE(job.validate().message().find("min_frames"), std::string::npos);
}

}  // namespace
}  // namespace mocap
