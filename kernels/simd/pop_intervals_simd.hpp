#pragma once
// The fast path of pop_residual_intervals (kernels/pop_screen.hpp), with Highway dynamic
// dispatch: lanes are samples (any, in order), whose candidate fits run on their cheap chart
// points side by side. The same intervals in double, with their own rounding (far inside the
// allowances the intervals carry).
#include <cstdint>
#include <span>

#include "core/quaternion.hpp"
#include "kernels/pop_screen.hpp"

namespace mocap::simd {

// The contract of mocap::pop_residual_intervals.
void pop_residual_intervals(std::span<const Quat> curve, const PopScreen& screen,
                            std::span<const std::uint8_t> only, std::span<double> lows,
                            std::span<double> highs);

}  // namespace mocap::simd
