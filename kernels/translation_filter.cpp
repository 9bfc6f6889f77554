#include "kernels/translation_filter.hpp"

#include <cmath>

namespace mocap {
void linear_filter_translations(std::span<const Vec3> curve, std::span<const double> mask,
                                int passes, Boundary boundary, std::span<Vec3> out, int begin,
                                int end, CurveScratch& scratch) {
  const int k = int(mask.size() / 2);
  run_passes(curve, passes, out, begin, end, scratch.pass_in_p, scratch.pass_out_p,
             [&](std::span<const Vec3> in, std::span<Vec3> result, int b, int e) {
               extend_translation_curve(in, k, boundary, scratch.extended_p);
               for (int t = b; t < e; ++t) {
                 Vec3 sum;
                 for (int r = -k; r <= k; ++r) sum += mask[r + k] * scratch.extended_p[t + k + r];
                 result[t] = sum;
               }
             });
}

void bilateral_filter_translations(std::span<const Vec3> curve, double sigma_t, double sigma_p,
                                   int k, int iterations, Boundary boundary, std::span<Vec3> out,
                                   int begin, int end, CurveScratch& scratch) {
  std::vector<double> temporal(2 * std::size_t(k) + 1);
  for (int r = -k; r <= k; ++r)
    temporal[r + k] = std::exp(-double(r) * r / (2 * sigma_t * sigma_t));
  // With sigma_p infinite the range factor is exp(-0) = 1: the Gaussian.
  const double range_scale = 1.0 / (2 * sigma_p * sigma_p);
  run_passes(curve, iterations, out, begin, end, scratch.pass_in_p, scratch.pass_out_p,
             [&](std::span<const Vec3> in, std::span<Vec3> result, int b, int e) {
               extend_translation_curve(in, k, boundary, scratch.extended_p);
               const std::vector<Vec3>& p = scratch.extended_p;
               for (int t = b; t < e; ++t) {
                 const Vec3 centre = p[t + k];
                 Vec3 sum;
                 double weight_sum = 0;
                 for (int r = -k; r <= k; ++r) {
                   const Vec3 d = p[t + k + r] - centre;
                   const double m = temporal[r + k] * std::exp(-dot(d, d) * range_scale);
                   sum += m * p[t + k + r];
                   weight_sum += m;
                 }
                 result[t] = (1.0 / weight_sum) * sum;
               }
             });
}

}  // namespace mocap
