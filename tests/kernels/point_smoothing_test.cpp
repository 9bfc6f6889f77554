// smooth_mirrored (kernels/point_smoothing.hpp): the header's formula at every frame, near the
// ends and with reaches beyond the curve, and the properties a smoothing must have.
#include "kernels/point_smoothing.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace mocap {
namespace {

std::vector<Vec3> random_points(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Vec3> p(static_cast<std::size_t>(n));
  for (Vec3& v : p) v = {u(rng), u(rng), u(rng)};
  return p;
}

// The header's formula, written out with the mirror of the spec (q[-t], q[2(F-1) - t]) applied
// until the index lands inside.
Vec3 direct(const std::vector<Vec3>& p, int t, double sigma) {
  const int n = int(p.size()), reach = int(std::ceil(3 * sigma));
  Vec3 acc;
  double sum = 0;
  for (int r = -reach; r <= reach; ++r) {
    long s = t + r;
    while (s < 0 || s >= n) s = s < 0 ? -s : 2L * (n - 1) - s;
    const double g = std::exp(-0.5 * r * r / (sigma * sigma));
    acc += g * p[std::size_t(s)];
    sum += g;
  }
  return (1.0 / sum) * acc;
}

TEST(PointSmoothing, IsTheFormulaAtEveryFrameWithTheMirrorAtTheEnds) {
  for (const auto& [n, sigma] : {std::pair{50, 2.0}, {50, 6.3}, {7, 4.0}, {2, 1.5}}) {
    const std::vector<Vec3> p = random_points(n, std::uint64_t(n) * 7 + 1);
    const std::vector<Vec3> s = smooth_mirrored(p, sigma);
    ASSERT_EQ(s.size(), p.size());
    for (int t = 0; t < n; ++t) {
      const Vec3 d = direct(p, t, sigma), e = s[std::size_t(t)] - d;
      EXPECT_LT(norm(e), 1e-12) << "n " << n << ", sigma " << sigma << ", frame " << t;
    }
  }
}

TEST(PointSmoothing, KeepsConstantsAndStraightLinesAwayFromTheEnds) {
  const int n = 60;
  const double sigma = 3;
  std::vector<Vec3> constant(n, Vec3{1.5, -2, 0.25}), line(n);
  for (int t = 0; t < n; ++t) line[std::size_t(t)] = {0.1 * t, -0.3 * t + 2, 5};
  const std::vector<Vec3> c = smooth_mirrored(constant, sigma), l = smooth_mirrored(line, sigma);
  const int reach = int(std::ceil(3 * sigma));
  for (int t = 0; t < n; ++t) {
    EXPECT_LT(norm(c[std::size_t(t)] - constant[std::size_t(t)]), 1e-12) << t;
    if (t < reach || t + reach >= n) continue;  // the mirror bends a line at the ends
    EXPECT_LT(norm(l[std::size_t(t)] - line[std::size_t(t)]), 1e-12) << t;
  }
  // Noise comes out smaller: the mean squared step of white points falls.
  const std::vector<Vec3> p = random_points(n, 3), s = smooth_mirrored(p, sigma);
  double raw = 0, smoothed = 0;
  for (int t = 1; t < n; ++t) {
    raw +=
        dot(p[std::size_t(t)] - p[std::size_t(t - 1)], p[std::size_t(t)] - p[std::size_t(t - 1)]);
    smoothed +=
        dot(s[std::size_t(t)] - s[std::size_t(t - 1)], s[std::size_t(t)] - s[std::size_t(t - 1)]);
  }
  EXPECT_LT(smoothed, 0.05 * raw);
  // One point has nothing to smooth with.
  const std::vector<Vec3> one{{1, 2, 3}};
  EXPECT_EQ(smooth_mirrored(one, 2.0)[0].y, 2.0);
}

}  // namespace
}  // namespace mocap
