#pragma once
// What the engine checks of a clip's values before filtering it, whatever file it came from.
#include <string>

#include "core/clip.hpp"

namespace mocap::engine {

// Why the clip's tensors cannot be filtered ("NaN in rotations at frame 12, joint 'LeftArm'",
// a quaternion whose norm is off by more than 1e-3), or "" when they can.
std::string check_clip_values(const Clip& clip);

}  // namespace mocap::engine
