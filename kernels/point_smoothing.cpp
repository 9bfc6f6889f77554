#include "kernels/point_smoothing.hpp"

#include <cmath>

#include "kernels/boundary.hpp"

namespace mocap {

std::vector<double> smoothing_taps(double sigma) {
  const int reach = int(std::ceil(3 * sigma));
  std::vector<double> taps(std::size_t(2 * reach + 1));
  for (int r = -reach; r <= reach; ++r)
    taps[std::size_t(r + reach)] = std::exp(-0.5 * r * r / (sigma * sigma));
  return taps;
}

std::vector<Vec3> smooth_mirrored(std::span<const Vec3> points, double sigma) {
  const int n = int(points.size());
  if (n < 2) return {points.begin(), points.end()};
  const std::vector<double> mask = smoothing_taps(sigma);
  const int reach = int(mask.size() / 2);
  double sum = 0;
  for (double w : mask) sum += w;  // in the order r = -R..R, as before
  std::vector<Vec3> out(points.size());
  // Away from the ends the loops run tap by tap over all frames at once, on planes: each frame's
  // sum still takes its taps in the order r = -R..R (the same additions, the same bits), and the
  // frames of one tap are independent, so the compiler can put them in vector lanes.
  const int first = reach, stop = n - reach;  // the frames [first, stop) need no mirror
  if (first < stop) {
    const std::size_t m = std::size_t(stop - first);
    std::vector<double> planes(3 * points.size() + 3 * m, 0.0);
    double* const p[3] = {planes.data(), planes.data() + n, planes.data() + 2 * n};
    double* const acc[3] = {p[2] + n, p[2] + n + m, p[2] + n + 2 * m};
    for (int t = 0; t < n; ++t) {
      p[0][t] = points[std::size_t(t)].x;
      p[1][t] = points[std::size_t(t)].y;
      p[2][t] = points[std::size_t(t)].z;
    }
    for (int r = -reach; r <= reach; ++r) {
      const double g = mask[std::size_t(r + reach)];
      for (int c = 0; c < 3; ++c) {
        const double* const in = p[c] + first + r;
        double* const a = acc[c];
        for (std::size_t i = 0; i < m; ++i) a[i] += g * in[i];
      }
    }
    for (std::size_t i = 0; i < m; ++i)
      out[std::size_t(first) + i] = (1.0 / sum) * Vec3{acc[0][i], acc[1][i], acc[2][i]};
  }
  for (int t = 0; t < n; ++t) {
    if (t >= first && t < stop) continue;
    Vec3 acc;
    for (int r = -reach; r <= reach; ++r)
      acc += mask[std::size_t(r + reach)] *
             points[std::size_t(reflect_index(long(t) + r, n, Boundary::mirror))];
    out[std::size_t(t)] = (1.0 / sum) * acc;
  }
  return out;
}

}  // namespace mocap
