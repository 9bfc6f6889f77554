#pragma once
// Writes a Clip as BVH text: the skeleton's hierarchy, channel lists and orders, End Sites and
// offsets as they were read; quaternions back to Euler angles in each joint's own order, chosen
// continuous from frame to frame (no 360-degree wraps a curve editor would show as spikes).
//
// Numbers: rotations in degrees with 6 decimals (at most 5e-7 degrees, 9e-9 rad, from the exact
// angle; trailing zeros dropped), translations in the shortest form that reads back to the same
// float, offsets and the frame time in the shortest form that reads back to the same double.
// Tabs for indentation, LF line endings.
#include <filesystem>
#include <string>

#include "core/clip.hpp"

namespace mocap::io {

// What keeps the clip from being written as BVH (empty when it can be): a skeleton that fails
// check_structure (one root, names BVH can carry, finite offsets), tensors of the wrong size, a
// frame time that is not positive, non-finite values, frames without any channel to hold them.
std::string check_clip_for_bvh(const Clip& clip);

// The BVH text of a clip that passes check_clip_for_bvh.
std::string format_bvh(const Clip& clip);

// Checks the clip, writes the text to path + ".tmp", then renames it into place, so no
// half-written file is ever left at `path` (a failed write removes the temporary file). On failure
// returns false and, when `error` is given, stores "path: reason" there.
bool write_bvh(const Clip& clip, const std::filesystem::path& path, std::string* error);

}  // namespace mocap::io
