#pragma once
// The fast path of pop_residual_bounds (kernels/pop_screen.hpp), with Highway dynamic dispatch:
// lanes are consecutive samples t, whose neighbours t + o are consecutive too. The same bound in
// double; its own rounding, like the scalar one's, is far below kPopScreenMargin.
#include <span>

#include "core/quaternion.hpp"
#include "kernels/pop_screen.hpp"

namespace mocap::simd {

// The contract of mocap::pop_residual_bounds.
void pop_residual_bounds(std::span<const Quat> curve, const PopScreen& screen,
                         std::span<double> bounds);

}  // namespace mocap::simd
