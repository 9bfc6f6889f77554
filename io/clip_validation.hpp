#pragma once
// The one validation of a clip, whatever file it came from: `info --check`, `filter`, `export`,
// `noise` and `import` all refuse exactly what this refuses, so no command writes a clip another
// one rejects (issue 19).
#include <cstdint>
#include <string>

#include "core/clip.hpp"

namespace mocap::io {

// A clip larger than this many joint-frames is refused by every reader (BVH and library): about
// 2.8 GB of float32 tensors, the bound on the memory one clip can take.
inline constexpr std::int64_t kMaxClipJointFrames = 100'000'000;

// Why the clip cannot be used, or "": check_clip() (a skeleton that fails check_structure(),
// frame time not finite and > 0, tensor sizes), more than kMaxClipJointFrames, a NaN or
// infinite value (naming frame and joint, frames counted from 1 as BVH lines are), a quaternion
// whose norm is off 1 by more than 1e-3, frames without a single channel to hold them in BVH.
std::string validate_clip(const Clip& clip);

}  // namespace mocap::io
