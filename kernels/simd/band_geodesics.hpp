#pragma once
// The band of geodesic distances bof's range weights read (../shared/spec/filters.md, "Bilateral
// orientation filter"): d(q[t][j], q[t + r][j]) for 1 <= r <= k, per joint. Only r > 0 is
// evaluated: d(q_i, q_{i+r}) = d(q_{i+r}, q_i) gives the r < 0 half (and d = 0 at r = 0).
//
// Two layouts of the same kernel, kept side by side because the choice between them was made by
// measuring them (bench/kernels_bench.cpp, docs/performance.md):
//   lanes = time:   each joint's curve transposed into planes w[], x[], y[], z[]; a vector holds
//                   consecutive frames of one joint. What bof, the linear filters and nlpm use.
//   lanes = joints: LoadInterleaved4 turns a [J][4] row into w, x, y, z vectors of consecutive
//                   joints at one frame; J is padded to whole vectors.
#include <span>
#include <vector>

#include "core/tensor.hpp"

namespace mocap::simd {

// Lanes = time. out[(j * k + r - 1) * F + t] = d(q[t][j], q[t + r][j]) for t + r < F, 0 beyond.
void band_geodesics_lanes_time(RotationView rotations, int k, std::vector<float>& out);

// Lanes = joints. out[(t * k + r - 1) * J' + j] (J' = J rounded up to whole vectors of the active
// target, returned), same values. Padding joints hold the distance between identities (0).
int band_geodesics_lanes_joints(RotationView rotations, int k, std::vector<float>& out);

}  // namespace mocap::simd
