#pragma once
// The fast path of pop_residuals (kernels/pop_repair.hpp), with Highway dynamic dispatch. Lanes
// are samples t whose window is "whole" (window() neighbours on each side, all within the chart's
// reach): they share the candidate blocks and their exact moment inverses, so every lane runs the
// same fits. The other samples (the clip's first and last window(), or a neighbour out of reach)
// take the scalar code. The chart Logs stay scalar double (the float Log of quat_simd-inl.h is far
// from double accuracy). The fits use the reference's operations in its order, without fused
// multiply-adds (-ffp-contract=off), so where the scalar build does not fuse either (the x86-64
// baseline) the results are the reference's to the bit (tests/kernels/pop_repair_test.cpp).
#include <cstdint>
#include <span>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/pop_repair.hpp"

namespace mocap::simd {

// The contract of mocap::pop_residuals. With `only` (one entry per sample), just the samples
// where it is nonzero are computed (each lane's arithmetic is its own, so a sample's bits do not
// depend on which others share its batch); the others are left as they were. `whole_window`:
// pop_detail::whole_window_blocks(params) when the caller has it (empty: made here);
// `end_windows`, pop_detail::end_window_blocks(params) or empty (pop_detail::sample_residual).
void pop_residuals(std::span<const Quat> curve, const PopRepairParams& params,
                   std::span<double> residuals, std::span<double> spreads,
                   std::span<double> fit_errors, std::span<const std::uint8_t> only = {},
                   std::span<const pop_detail::BlockFit> whole_window = {},
                   std::span<const std::vector<pop_detail::BlockFit>> end_windows = {});

}  // namespace mocap::simd
