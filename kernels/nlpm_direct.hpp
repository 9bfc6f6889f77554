#pragma once
// Non-local pose means as the literal double sum of ../shared/spec/filters.md, "Non-local pose
// means (nlpm)": every D(t, s) summed over its 2P+1 patch offsets, every e(u, v) from freshly
// boundary-extended samples. O(F (2K+1) (2P+1) J): a test oracle for NlpmJob (the fast form),
// not for production.
#include <cstdint>
#include <span>

#include "core/status.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/nlpm.hpp"

namespace mocap {

// Same contract as NlpmJob{params, io, distance_joints}.run(), including the output slice.
Status nlpm_direct(const NlpmParams& params, const MotionIO& io,
                   std::span<const std::uint8_t> distance_joints);

}  // namespace mocap
