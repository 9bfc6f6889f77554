#include "kernels/point_smoothing.hpp"

#include <cmath>

#include "kernels/boundary.hpp"

namespace mocap {

std::vector<Vec3> smooth_mirrored(std::span<const Vec3> points, double sigma) {
  const int n = int(points.size());
  if (n < 2) return {points.begin(), points.end()};
  const int reach = int(std::ceil(3 * sigma));
  std::vector<double> mask(std::size_t(2 * reach + 1));
  double sum = 0;
  for (int r = -reach; r <= reach; ++r)
    sum += mask[std::size_t(r + reach)] = std::exp(-0.5 * r * r / (sigma * sigma));
  std::vector<Vec3> out(points.size());
  for (int t = 0; t < n; ++t) {
    Vec3 acc;
    if (t >= reach && t + reach < n) {  // no mirror needed: no index arithmetic per tap
      for (int r = -reach; r <= reach; ++r)
        acc += mask[std::size_t(r + reach)] * points[std::size_t(t + r)];
    } else {
      for (int r = -reach; r <= reach; ++r)
        acc += mask[std::size_t(r + reach)] *
               points[std::size_t(reflect_index(long(t) + r, n, Boundary::mirror))];
    }
    out[std::size_t(t)] = (1.0 / sum) * acc;
  }
  return out;
}

}  // namespace mocap
