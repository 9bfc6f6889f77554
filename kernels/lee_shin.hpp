#pragma once
// The Lee-Shin construction of ../shared/spec/filters.md, "Lee-Shin construction": a linear
// filter of orientation data built from a normalised scalar mask m_{-k..k},
//   H(q_i) = q_i Exp( sum_{r=-k}^{k-1} b_r w_{i+r} ),  w_i = Log(q_i^-1 q_{i+1}),
// which is the correlation sum_j m_j theta_{i+j} for rotations about one fixed axis.
#include <span>
#include <utility>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/boundary.hpp"

namespace mocap {

// b_{-k..k-1} from a mask m_{-k..k} (odd size 2k+1, summing to 1):
//   b_r = -sum_{j=-k}^{r} m_j for r < 0,  b_r = +sum_{j=r+1}^{k} m_j for r >= 0.
// Returns 2k coefficients; b[r + k] is b_r.
std::vector<double> lee_shin_coefficients(std::span<const double> mask);
// The same into caller memory: b.size() == mask.size() - 1.
void lee_shin_coefficients(std::span<const double> mask, std::span<double> b);

// Local displacements w_m = Log(curve[m]^-1 curve[m+1]), curve.size() - 1 of them.
void tangent_steps(std::span<const Quat> curve, std::vector<Vec3>& steps);

// H(q) = q Exp(sum_r b_r w_r), with steps = w_{i-k} .. w_{i+k-1} around q = q_i (2k of them).
Quat lee_shin_sample(Quat q, std::span<const Vec3> steps, std::span<const double> b);

// Working memory of the per-joint curve filters, reused across joints and passes so that a job
// allocates once per run rather than once per joint.
struct CurveScratch {
  std::vector<Quat> extended, pass_in, pass_out;
  std::vector<Vec3> steps, extended_p, pass_in_p, pass_out_p;
  std::vector<double> mask, coefficients;
};

// Repeats a filter pass `passes` times over one joint's curve, each pass reading the whole output
// of the previous one (which the next pass extends anew at the boundaries): every pass but the
// last runs over all samples, the last one only over [begin, end) of `out`, so a sample's value
// does not depend on the slice that computed it. `pass(in, out, begin, end)` writes out[begin,
// end) from the whole curve `in`. A 1-sample curve is copied.
template <class T, class Pass>
void run_passes(std::span<const T> curve, int passes, std::span<T> out, int begin, int end,
                std::vector<T>& in, std::vector<T>& next, Pass pass) {
  const int frames = int(curve.size());
  if (frames == 1 || passes < 1) {
    for (int t = begin; t < end; ++t) out[t] = curve[t];
    return;
  }
  if (passes == 1) {
    pass(curve, out, begin, end);
    return;
  }
  in.assign(curve.begin(), curve.end());
  next.resize(curve.size());
  for (int p = 0; p + 1 < passes; ++p) {
    pass(std::span<const T>(in), std::span<T>(next), 0, frames);
    std::swap(in, next);
  }
  pass(std::span<const T>(in), out, begin, end);
}

// One pass of the Lee-Shin filter with a fixed mask over one joint's curve of F samples, the
// samples outside [0, F) taken from the boundary extension of the curve. Writes out[t] for t in
// [begin, end) only; out.size() == curve.size(). A 1-sample curve is copied.
void lee_shin_pass(std::span<const Quat> curve, std::span<const double> mask, Boundary boundary,
                   std::span<Quat> out, int begin, int end, CurveScratch& scratch);

}  // namespace mocap
