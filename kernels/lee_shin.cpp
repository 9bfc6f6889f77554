#include "kernels/lee_shin.hpp"

#include <cassert>

namespace mocap {

void lee_shin_coefficients(std::span<const double> mask, std::span<double> b) {
  assert(mask.size() % 2 == 1 && b.size() + 1 == mask.size());
  const int k = int(mask.size() / 2);
  // r < 0: minus the running sum from the left end, m_{-k} .. m_r.
  double left = 0;
  for (int r = -k; r < 0; ++r) {
    left += mask[r + k];
    b[r + k] = -left;
  }
  // r >= 0: the running sum from the right end, m_{r+1} .. m_k.
  double right = 0;
  for (int r = k - 1; r >= 0; --r) {
    right += mask[r + 1 + k];
    b[r + k] = right;
  }
}

std::vector<double> lee_shin_coefficients(std::span<const double> mask) {
  std::vector<double> b(mask.empty() ? 0 : mask.size() - 1);
  lee_shin_coefficients(mask, b);
  return b;
}

void tangent_steps(std::span<const Quat> curve, std::vector<Vec3>& steps) {
  steps.resize(curve.empty() ? 0 : curve.size() - 1);
  for (std::size_t m = 0; m + 1 < curve.size(); ++m)
    steps[m] = log(inverse(curve[m]) * curve[m + 1]);
}

Quat lee_shin_sample(Quat q, std::span<const Vec3> steps, std::span<const double> b) {
  Vec3 v;
  for (std::size_t r = 0; r < b.size(); ++r) v += b[r] * steps[r];
  return q * exp(v);
}

void lee_shin_pass(std::span<const Quat> curve, std::span<const double> mask, Boundary boundary,
                   std::span<Quat> out, int begin, int end, CurveScratch& scratch) {
  if (curve.size() == 1) {
    if (begin < end) out[0] = curve[0];
    return;
  }
  const int k = int(mask.size() / 2);
  scratch.coefficients.resize(2 * std::size_t(k));
  lee_shin_coefficients(mask, scratch.coefficients);
  // Extended sample t + k is q_t, so w_{t+r} (r in [-k, k)) is step t + k + r.
  extend_rotation_curve(curve, k, boundary, scratch.extended);
  tangent_steps(scratch.extended, scratch.steps);
  const std::span<const Vec3> steps = scratch.steps;
  for (int t = begin; t < end; ++t)
    out[t] = lee_shin_sample(curve[t], steps.subspan(t, 2 * std::size_t(k)), scratch.coefficients);
}

}  // namespace mocap
