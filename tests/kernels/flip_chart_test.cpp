// A flipping joint's flips as one rotation (kernels/flip_chart.hpp): flips that are all the same
// turn, on the left or on the right, are found with their side and their rotation, taken out to
// leave the motion under them, and put back exactly; flips about axes that vary are no chart.
#include "kernels/flip_chart.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/joint_quality.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

constexpr int kFrames = 300;

// Smooth motion (steps of a few hundredths of a radian), the curve under the flips.
std::vector<Quat> motion(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const std::vector<float> m = test::random_motion(rng, kFrames, 1, 1.2);
  std::vector<Quat> q(kFrames);
  for (int t = 0; t < kFrames; ++t) q[std::size_t(t)] = load_quat(&m[std::size_t(t) * 4]);
  return q;
}

// `under` flipped by `flip` (on the left or the right) on the frames after an odd number of the
// steps in `at`; `flipped` receives which.
std::vector<Quat> flipped_curve(const std::vector<Quat>& under, Quat flip, bool left,
                                const std::vector<int>& at, std::vector<std::uint8_t>& flipped) {
  std::vector<Quat> q = under;
  flipped.assign(under.size(), 0);
  for (std::size_t t = 0; t < q.size(); ++t) {
    const auto n = std::count_if(at.begin(), at.end(), [&](int f) { return int(t) > f; });
    flipped[t] = n % 2;
    if (flipped[t]) q[t] = left ? flip * q[t] : q[t] * flip;
  }
  return q;
}

// Flips every few frames, some of them pieces of one or two frames.
const std::vector<int> kFlipSteps{20, 21, 40, 42, 77, 130, 131, 132, 190, 240, 243, 260};

TEST(FlipChart, FlipsOfOneRotationAreFoundTakenOutAndPutBack) {
  for (const bool left : {true, false})
    for (const double angle : {3.14159265358979, 3.04}) {
      const Quat flip = exp(angle * Vec3{0.36, 0.48, 0.8});
      const std::vector<Quat> under = motion(left ? 3 : 4);
      std::vector<std::uint8_t> truth;
      const std::vector<Quat> curve = flipped_curve(under, flip, left, kFlipSteps, truth);
      const FlipChart chart = find_flip_chart(curve);
      ASSERT_TRUE(chart.found) << left << " " << angle;
      EXPECT_EQ(chart.left, left);
      EXPECT_LT(geodesic(chart.flip, flip), 0.01) << left << " " << angle;

      std::vector<Quat> out = curve;
      std::vector<std::uint8_t> flipped(curve.size());
      take_out_flips(chart, out, flipped);
      double worst = 0;
      for (std::size_t t = 0; t < out.size(); ++t) {
        EXPECT_EQ(flipped[t], truth[t]) << t;
        worst = std::max(worst, geodesic(out[t], under[t]));
        if (t > 0) {
          EXPECT_GE(dot(out[t], out[t - 1]), 0.0) << "not hemisphere-continuous at " << t;
        }
        // Put back: the sample as it came.
        const Quat back = flipped[t] ? chart.reflip(out[t]) : out[t];
        EXPECT_LT(geodesic(back, curve[t]), 1e-6) << t;
      }
      EXPECT_LT(worst, 0.01) << "the motion under the flips, " << left << " " << angle;
    }
}

// Each flip about an axis of its own (and back by its inverse): no rotation that half of them
// agree on.
TEST(FlipChart, FlipsAboutAxesThatVaryAreNoChart) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Quat> curve = motion(5);
  Quat current{1, 0, 0, 0};
  std::size_t next = 0;
  for (std::size_t t = 0; t < curve.size(); ++t) {
    if (next < kFlipSteps.size() && int(t) == kFlipSteps[next] + 1) {
      ++next;
      const Vec3 axis{u(rng), u(rng), u(rng)};
      current = next % 2 ? exp((3.1 / norm(axis)) * axis) : Quat{1, 0, 0, 0};
    }
    curve[t] = curve[t] * current;
  }
  int flips = 0;
  for (std::size_t t = 0; t + 1 < curve.size(); ++t)
    flips += geodesic(curve[t], curve[t + 1]) >= kFlipStep;
  ASSERT_EQ(flips, int(kFlipSteps.size()));
  EXPECT_FALSE(find_flip_chart(curve).found);
}

TEST(FlipChart, ACurveWithoutFlipsHasNoChart) {
  const std::vector<Quat> curve = motion(6);
  const FlipChart chart = find_flip_chart(curve);
  EXPECT_FALSE(chart.found);
  std::vector<Quat> out = curve;
  std::vector<std::uint8_t> flipped(curve.size(), 7);
  take_out_flips(chart, out, flipped);
  for (std::size_t t = 0; t < out.size(); ++t) {
    EXPECT_EQ(flipped[t], 0) << t;
    EXPECT_LT(geodesic(out[t], curve[t]), 1e-12) << t;
  }
}

}  // namespace
}  // namespace mocap
