#pragma once
// Reads BVH motion files into a Clip: Euler channels become unit quaternions, hemisphere-
// continuous along time (spec "Conventions", "Sign continuity"); position channels become
// translations, and joints without them hold their OFFSET (architecture.md, the HDF5 contract).
//
// Liberal where real files vary: LF, CRLF or CR, tabs or spaces, blank lines, trailing
// whitespace, a missing final newline, "End site", any of the six rotation orders per joint,
// position channels on any joint, numbers like "+1E+02", ".5", "-.5". Strict where data would be
// wrong: every malformed file gives one BvhError naming the file and the 1-based line.
//
// Bounds: memory grows with the bytes actually present, never with a count written in the file;
// the hierarchy is parsed with an explicit stack (any nesting depth up to kMaxBvhJoints).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "core/clip.hpp"
#include "io/clip_validation.hpp"

namespace mocap::io {

// More joints than this is refused (CMU skeletons have 31; the largest rigs a few hundred).
inline constexpr int kMaxBvhJoints = 100000;
// A clip larger than this many joint-frames is refused (about 2.8 GB of tensors).
inline constexpr std::int64_t kMaxBvhJointFrames = kMaxClipJointFrames;

struct BvhError {
  std::string file;
  int line = 0;  // 1-based; 0 when the error is not about a line (the file cannot be read)
  std::string message;
  // "path:line: message", or "path: message" when line is 0.
  std::string what() const;
};

// Exactly one of the two is set.
struct BvhReadResult {
  std::optional<Clip> clip;
  std::optional<BvhError> error;
};

// Parses BVH text. `name` names the text in error messages and becomes Clip::source. With
// `keep_source_angles`, Clip::source_angles holds the Euler channel values as read.
BvhReadResult parse_bvh(std::string_view text, const std::string& name,
                        bool keep_source_angles = false);

// Reads the file, then parse_bvh with the path as name. I/O errors are BvhErrors with line 0.
BvhReadResult read_bvh(const std::filesystem::path& path, bool keep_source_angles = false);

// read_bvh's first half, the file access alone (the engine reads files in its serial stage and
// parses them in parallel): the file's bytes in `text`, or an error with line 0.
std::optional<BvhError> read_bvh_text(const std::filesystem::path& path, std::string& text);

}  // namespace mocap::io
