#pragma once
// Gaussian smoothing of a curve of points (positions along time), mirrored at its ends: what the
// contact detector (foot_contacts.hpp) and the position-noise estimate (noise_estimate.hpp) read
// instead of the raw points, so that per-frame noise does not read as speed or acceleration.
//
//     out[t] = sum_{r=-R..R} g(r) p[m(t + r)] / sum_r g(r),   g(r) = exp(-r^2 / (2 sigma^2)),
//     R = ceil(3 sigma), m: boundary.hpp's mirror index (periodic for reaches beyond the curve)
//
// The taps are summed in the order r = -R..R at every frame, so a frame's value does not depend
// on whether it needed the mirror.
#include <span>
#include <vector>

#include "core/quaternion.hpp"

namespace mocap {

// The taps g(r), r = -R..R, unnormalized, of the smoothing at sigma frames (> 0).
std::vector<double> smoothing_taps(double sigma);

// sigma in frames (> 0); a curve of one point is returned as it is.
std::vector<Vec3> smooth_mirrored(std::span<const Vec3> points, double sigma);

}  // namespace mocap
