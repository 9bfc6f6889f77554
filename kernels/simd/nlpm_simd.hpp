#pragma once
// The fast path of nlpm in the tangent space (../shared/spec/filters.md, "Non-local pose means"):
// the pose-distance band e(u, u + delta) and the tangent-space averaging in float32 vectors of
// consecutive frames (one joint at a time), with Highway dynamic dispatch. Between them, per
// frame, the box sums of the band, D_min and the weights f(t, s) are computed in double exactly as
// kernels/nlpm.cpp does (anchored every kNlpmAnchorFrames frames), so each output sample is
// bit-identical whatever time or joint slice computed it. The range form (range_sigma > 0) takes
// its per-joint range terms exp(-d^2 / (2 range_sigma^2)) in float32 inside the averaging, from
// the same Log(q_t^-1 q_s) it averages. The log space stays on the reference.
#include <cstddef>

#include "kernels/nlpm.hpp"

namespace mocap::simd {

// band[(delta - 1) * stride + u] += d(q_u, q_{u + delta})^2 for u in [0, count), 1 <= delta <= K,
// from one joint's curve as 4 planes of `stride` floats (stride >= count + K + kMaxLanes, rounded
// up to whole vectors); the band rows share the stride. Called once per distance joint, in joint
// order, it sums the squared distances of e(u, v) (before the division by J_d), each capped at
// cap_squared (+inf: no cap; NlpmParams::distance_cap).
void accumulate_pose_band(const float* planes, std::size_t stride, std::size_t count, int max_delta,
                          float cap_squared, float* band);

// The rotations and translations of job's output slice (job valid, space tangent, F >= 2).
void nlpm_tangent(const NlpmJob& job);

}  // namespace mocap::simd
