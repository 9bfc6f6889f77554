#pragma once
// The layout of the HDF5 library file (../shared/spec/architecture.md, "The HDF5 library file"),
// the names in it, and the small records the writer and reader share.
//
//   /                       attrs format = "mocap-clean-library", format_version = 2 (int32)
//   /skeletons/<name>/      joint_names (string[J]), parents (int32[J], -1 = root),
//                           offsets (float64[J,3]), channels (string[J], e.g. "Zrotation
//                           Xrotation Yrotation", "" for none), and two additions so that BVH
//                           export is lossless: end_sites (float64[J,3], zeros where none) and
//                           has_end_site (uint8[J])
//   /clips/<path...>/<clip>/ attrs skeleton (name), frame_time (float64, s), source (string)
//       rotations           float32 [F,J,4] wxyz;  translations  float32 [F,J,3]
//   /provenance             attrs method, parameters (JSON), engine_version, input_file,
//                           created (UTC ISO 8601)
// Strings are fixed-length UTF-8, NUL-padded (h5py reads them as bytes: `.decode()`, `.asstr()`);
// version 1 had variable-length ones, which libhdf5 1.10 cannot read safely from a damaged file
// (scripts/upgrade_library.py converts). A clip group is a group holding
// a "rotations" dataset; its path below /clips keeps the source's folder layout.
#include <string>
#include <string_view>

#include "core/clip.hpp"
#include "core/skeleton.hpp"

namespace mocap::io {

inline constexpr std::string_view kLibraryFormat = "mocap-clean-library";
inline constexpr int kLibraryFormatVersion = 2;

struct Provenance {
  std::string method;           // e.g. "bof"
  std::string parameters_json;  // the filter parameters as a JSON object
  std::string engine_version;
  std::string input_file;
  std::string created;  // UTC ISO 8601, e.g. "2024-05-01T12:00:00Z"; the writer fills it if empty
};

struct ClipHeader {
  std::string path;      // below /clips, e.g. "cmu/01/01_01"
  std::string skeleton;  // name of its group below /skeletons
  double frame_time = 0;
  int frames = 0, joints = 0;
  std::string source;
  std::string error;  // non-empty: the clip cannot be read (read_clip() fails with this message)
};

// The name of a skeleton's group: "<root joint name>-<J>j-<8 hex digits>", the digits being the
// upper half of the FNV-1a 64 hash of skeleton_canonical_bytes(). Equal skeletons get equal
// names in every process, so files written separately agree. Characters of the root name other
// than [A-Za-z0-9_.-] become '_'.
std::string skeleton_name(const Skeleton& skeleton);
// The bytes hashed: joint count (int32 LE); then per joint its name and '\0', parent (int32 LE),
// offset (3 x IEEE binary64 LE), channel list and '\0', has End Site (1 byte) and, if so, the
// End Site (3 x binary64 LE).
std::string skeleton_canonical_bytes(const Skeleton& skeleton);

// "cmu/01/01_01.bvh" -> "cmu/01/01_01": backslashes become '/', "." components and repeated
// slashes vanish, the last extension is dropped. "" when the path is absolute, climbs with "..",
// or leaves no name.
std::string clip_path_from_source(std::string_view relative_source_path);
// Why `clip_path` cannot name a clip (empty, absolute, an empty, "." or ".." component), or "".
std::string check_clip_path(std::string_view clip_path);

// The frame times every reader and writer accepts, in seconds: BVH text and the library hold the
// same range, so a clip read from one can always be written to the other (a fuzz finding: a
// library frame_time of 1e300 was exported as BVH text that import refused).
inline constexpr double kMinFrameTime = 1e-6;
inline constexpr double kMaxFrameTime = 3600;
inline bool valid_frame_time(double seconds) {
  return seconds >= kMinFrameTime && seconds <= kMaxFrameTime;  // false for NaN too
}
// "between 1e-06 and 3600 s", for messages.
std::string frame_time_range();

// Why `clip` cannot be stored, or "": no skeleton, a skeleton that fails check_structure(),
// frame_time not finite and > 0, negative frames, or tensor sizes other than F*J*4 and F*J*3.
std::string check_clip(const Clip& clip);

// Turns off HDF5's printing of its error stack; the store reports errors in its own words (it
// also silences HDF5 while inside its own calls, so this is for the rest of the program).
void silence_hdf5_errors();

// Call first in main(), before any other HDF5 call: keeps HDF5 from closing, at exit, files whose
// close already failed. HDF5 1.10 crashes there (H5F__close_cb from H5_term_library) after a
// write failed on a full disk; every file the store opens is closed, and its errors checked,
// before the program ends, so nothing is left for that clean-up to do.
void skip_hdf5_cleanup_at_exit();

// The current time as UTC ISO 8601 with seconds, e.g. "2024-05-01T12:00:00Z".
std::string utc_now_iso8601();

}  // namespace mocap::io
