#pragma once
// The Euclidean counterparts of the orientation filters for joint translations
// (../shared/spec/filters.md, "Translations"): the same masks applied to positions, with the
// Euclidean analogue of the rotations' boundary mode.
#include <span>

#include "core/quaternion.hpp"
#include "kernels/boundary.hpp"
#include "kernels/lee_shin.hpp"

namespace mocap {

// `passes` times p'_i = sum_r m_r p_{i+r} over one joint's curve; each pass reads the whole
// boundary-extended output of the previous one. Writes out[t] for t in [begin, end) only.
void linear_filter_translations(std::span<const Vec3> curve, std::span<const double> mask,
                                int passes, Boundary boundary, std::span<Vec3> out, int begin,
                                int end, CurveScratch& scratch);

// `iterations` times the Euclidean bilateral filter
//   p'_i = sum_r m_r p_{i+r} / sum_r m_r,
//   m_r = exp(-r^2 / (2 sigma_t^2)) exp(-|p_{i+r} - p_i|^2 / (2 sigma_p^2)),  r in [-k, k];
// sigma_p = infinity gives the Gaussian. Writes out[t] for t in [begin, end) only.
void bilateral_filter_translations(std::span<const Vec3> curve, double sigma_t, double sigma_p,
                                   int k, int iterations, Boundary boundary, std::span<Vec3> out,
                                   int begin, int end, CurveScratch& scratch);

}  // namespace mocap
