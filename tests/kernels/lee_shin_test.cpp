// Property tests of the Lee-Shin construction (spec "Lee-Shin construction"): for rotations about
// one fixed axis the filter is the scalar correlation sum_j m_j theta_{i+j} of the angle, with the
// same boundary extension, for every linear mask and an asymmetric one.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "kernels/lee_shin.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/linear_masks.hpp"

namespace mocap {
namespace {

const Vec3 kAxis{0.48, -0.6, 0.64};  // unit

// The angle signal extended like the rotation curve (spec "Boundary extension"), written out
// here independently of kernels/boundary.
double extended_angle(const std::vector<double>& theta, long t, Boundary boundary) {
  const long frames = long(theta.size()), last = frames - 1;
  if (t >= 0 && t <= last) return theta[t];
  if (frames == 1) return theta[0];
  switch (boundary) {
    case Boundary::mirror: {
      long m = t % (2 * last);
      if (m < 0) m += 2 * last;
      return theta[m <= last ? m : 2 * last - m];
    }
    case Boundary::hold:
      return t < 0 ? theta[0] : theta[last];
    case Boundary::extrapolate:
      return t < 0 ? theta[0] + double(t) * (theta[1] - theta[0])
                   : theta[last] + double(t - last) * (theta[last] - theta[last - 1]);
  }
  return 0;
}

// One pass of sum_j m_j theta_{i+j}.
std::vector<double> correlate(const std::vector<double>& theta, const std::vector<double>& mask,
                              Boundary boundary) {
  const int k = int(mask.size() / 2);
  std::vector<double> out(theta.size());
  for (long i = 0; i < long(theta.size()); ++i) {
    double sum = 0;
    for (int j = -k; j <= k; ++j) sum += mask[j + k] * extended_angle(theta, i + j, boundary);
    out[i] = sum;
  }
  return out;
}

std::vector<Quat> single_axis_curve(const std::vector<double>& theta) {
  std::vector<Quat> curve;
  for (double a : theta) curve.push_back(exp(a * kAxis));
  return curve;
}

// A wandering angle whose steps stay below pi but whose range goes well beyond pi.
std::vector<double> wandering_angle(std::mt19937_64& rng, int frames) {
  std::normal_distribution<double> noise(0.0, 0.15);
  std::vector<double> theta(frames);
  for (int i = 0; i < frames; ++i) theta[i] = 3.5 * std::sin(0.045 * i + 0.3) + 1.0 + noise(rng);
  return theta;
}

double max_angle_error(const std::vector<Quat>& out, const std::vector<double>& expected) {
  double worst = 0;
  for (std::size_t i = 0; i < out.size(); ++i)
    worst = std::max(worst, geodesic(out[i], exp(expected[i] * kAxis)));
  return worst;
}

struct NamedMask {
  const char* name;
  std::vector<double> mask;
  int passes;
};

std::vector<NamedMask> masks_to_check() {
  return {
      {"gaussian sigma 1", gaussian_mask(1.0, 3), 1},
      {"gaussian sigma 2.5", gaussian_mask(2.5, 8), 1},
      {"butterworth n2 6Hz@120", butterworth_mask(2, 6.0, 120.0).mask, 1},
      {"butterworth n5 10Hz@60", butterworth_mask(5, 10.0, 60.0).mask, 1},
      {"moving-mean x1", moving_mean_mask(), 1},
      {"moving-mean x5", moving_mean_mask(), 5},
      {"asymmetric", {0.05, 0.1, 0.45, 0.25, 0.1, 0.05, 0.0}, 1},
      {"one-sided", {0.0, 0.0, 0.0, 0.2, 0.3, 0.4, 0.1}, 2},
  };
}

TEST(LeeShin, CoefficientsFollowTheDefinition) {
  // k = 1, m = (1/3, 1/3, 1/3): b = (-1/3, +1/3) (erratum 5: the minus sign for r < 0).
  const std::vector<double> b = lee_shin_coefficients(std::vector<double>{1. / 3, 1. / 3, 1. / 3});
  ASSERT_EQ(b.size(), 2u);
  EXPECT_DOUBLE_EQ(b[0], -1. / 3);
  EXPECT_DOUBLE_EQ(b[1], 1. / 3);
  // The scalar identity behind the construction: sum_r b_r (x_{r+1} - x_r) = sum_j m_j x_j - x_0.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  for (int k : {0, 1, 2, 5}) {
    std::vector<double> mask(2 * k + 1);
    double sum = 0;
    for (double& m : mask) sum += (m = u(rng));
    for (double& m : mask) m /= sum;
    std::vector<double> x(2 * k + 1);
    for (double& v : x) v = 4 * u(rng) - 2;
    const std::vector<double> coeff = lee_shin_coefficients(mask);
    ASSERT_EQ(coeff.size(), std::size_t(2 * k));
    double lhs = 0, rhs = -x[k];
    for (int r = -k; r < k; ++r) lhs += coeff[r + k] * (x[r + k + 1] - x[r + k]);
    for (int j = -k; j <= k; ++j) rhs += mask[j + k] * x[j + k];
    EXPECT_NEAR(lhs, rhs, 1e-14) << "k " << k;
  }
}

TEST(LeeShin, SingleAxisIsTheScalarCorrelationOfTheAngle) {
  std::mt19937_64 rng(11);
  const std::vector<double> theta = wandering_angle(rng, 240);
  const std::vector<Quat> curve = single_axis_curve(theta);
  CurveScratch scratch;
  for (const NamedMask& m : masks_to_check()) {
    ASSERT_FALSE(m.mask.empty()) << m.name;
    for (Boundary boundary : {Boundary::mirror, Boundary::hold, Boundary::extrapolate}) {
      std::vector<double> expected = theta;
      for (int p = 0; p < m.passes; ++p) expected = correlate(expected, m.mask, boundary);
      std::vector<Quat> out(curve.size());
      linear_filter_rotations(curve, m.mask, m.passes, boundary, out, 0, int(curve.size()),
                              scratch);
      EXPECT_LT(max_angle_error(out, expected), 1e-9)
          << m.name << ", boundary " << to_string(boundary);
    }
  }
}

TEST(LeeShin, ReachLongerThanTheClip) {
  // F = 3 with k = 10: mirror repeats its reflection, hold and extrapolate reach far out.
  const std::vector<double> theta{0.4, 1.3, 2.9};
  const std::vector<Quat> curve = single_axis_curve(theta);
  const std::vector<double> mask = gaussian_mask(4.0, 10);
  CurveScratch scratch;
  for (Boundary boundary : {Boundary::mirror, Boundary::hold, Boundary::extrapolate}) {
    std::vector<Quat> out(curve.size());
    lee_shin_pass(curve, mask, boundary, out, 0, 3, scratch);
    EXPECT_LT(max_angle_error(out, correlate(theta, mask, boundary)), 1e-9) << to_string(boundary);
  }
}

TEST(LeeShin, SliceWritesOnlyItsFramesWithTheSameValues) {
  std::mt19937_64 rng(13);
  const std::vector<Quat> curve = single_axis_curve(wandering_angle(rng, 50));
  const std::vector<double> mask = moving_mean_mask();
  CurveScratch scratch;
  std::vector<Quat> full(curve.size()), part(curve.size(), Quat{7, 7, 7, 7});
  linear_filter_rotations(curve, mask, 3, Boundary::mirror, full, 0, 50, scratch);
  linear_filter_rotations(curve, mask, 3, Boundary::mirror, part, 20, 31, scratch);
  for (int t = 0; t < 50; ++t) {
    if (t >= 20 && t < 31) {
      EXPECT_EQ(part[t].w, full[t].w);
      EXPECT_EQ(part[t].x, full[t].x);
      EXPECT_EQ(part[t].y, full[t].y);
      EXPECT_EQ(part[t].z, full[t].z);
    } else {
      EXPECT_EQ(part[t].w, 7.0) << "frame " << t << " outside the slice was written";
    }
  }
}

}  // namespace
}  // namespace mocap
