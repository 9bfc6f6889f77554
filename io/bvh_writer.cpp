#include "io/bvh_writer.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <system_error>
#include <vector>

#include "core/euler.hpp"
#include "io/library_format.hpp"

namespace mocap::io {
namespace {

// The characters one value can take in a frame line: a double in fixed notation with 6 decimals
// (write_degrees' fallback), which also bounds the shortest form of any float or double.
constexpr std::size_t kMaxValueChars = 352;

// Shortest text that reads back to the same double (or float: std::to_chars picks by type),
// written at p; returns the end.
template <class Real>
char* write_shortest(char* p, Real value) {
  return std::to_chars(p, p + kMaxValueChars, value).ptr;
}

template <class Real>
void append_shortest(std::string& out, Real value) {
  char buffer[kMaxValueChars];
  out.append(buffer, write_shortest(buffer, value));
}

// Degrees with 6 decimals, trailing zeros dropped: "-21", "12.5", "0.000123". 6 decimals keep a
// re-read within 5e-7 degrees (9e-9 rad) of the exact angle, far inside the float storage of
// the quaternions, at about half the bytes of the shortest round-trip form of a double.
// Formatted as an integer count of micro-degrees: several times faster than fixed-precision
// std::to_chars, which dominated the writer's time. Written at p; returns the end.
char* write_degrees(char* p, double degrees) {
  constexpr double kLimit = 9e12;  // micro-degrees still fit an int64 exactly
  if (!(std::abs(degrees) < kLimit))
    return std::to_chars(p, p + kMaxValueChars, degrees, std::chars_format::fixed, 6).ptr;
  const long long micro = std::llround(degrees * 1e6);
  if (micro == 0) {
    *p++ = '0';  // no "-0": a sign on zero is noise
    return p;
  }
  const unsigned long long magnitude = micro < 0 ? 0ull - (unsigned long long)micro : micro;
  if (micro < 0) *p++ = '-';
  p = std::to_chars(p, p + 24, magnitude / 1000000).ptr;
  unsigned long long fraction = magnitude % 1000000;
  if (fraction == 0) return p;
  int digits = 6;
  while (fraction % 10 == 0) {
    fraction /= 10;
    --digits;
  }
  *p++ = '.';
  char buffer[8];
  const char* end = std::to_chars(buffer, buffer + sizeof buffer, fraction).ptr;
  const std::size_t length = std::size_t(end - buffer), zeros = std::size_t(digits) - length;
  std::memset(p, '0', zeros);
  std::memcpy(p + zeros, buffer, length);
  return p + zeros + length;
}

void append_vec3(std::string& out, Vec3 v) {
  append_shortest(out, v.x);
  out += ' ';
  append_shortest(out, v.y);
  out += ' ';
  append_shortest(out, v.z);
}

void indent(std::string& out, std::size_t depth) {
  out.append(depth, '\t');
}

void append_hierarchy(std::string& out, const Skeleton& skeleton) {
  out += "HIERARCHY\n";
  std::vector<int> open;  // joints whose block is not closed yet, outermost first
  auto close_top = [&] {
    const int joint = open.back();
    if (const auto& end_site = skeleton.end_sites[std::size_t(joint)]) {
      indent(out, open.size());
      out += "End Site\n";
      indent(out, open.size());
      out += "{\n";
      indent(out, open.size() + 1);
      out += "OFFSET ";
      append_vec3(out, *end_site);
      out += '\n';
      indent(out, open.size());
      out += "}\n";
    }
    open.pop_back();
    indent(out, open.size());
    out += "}\n";
  };
  // Joints are in file order (each parent before its children, subtrees contiguous), so the
  // blocks to close before joint j are those above its parent on the stack.
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    const int parent = skeleton.parents[std::size_t(j)];
    while (!open.empty() && open.back() != parent) close_top();
    indent(out, open.size());
    out += parent < 0 ? "ROOT " : "JOINT ";
    out += skeleton.joint_names[std::size_t(j)];
    out += '\n';
    indent(out, open.size());
    out += "{\n";
    indent(out, open.size() + 1);
    out += "OFFSET ";
    append_vec3(out, skeleton.offsets[std::size_t(j)]);
    out += '\n';
    indent(out, open.size() + 1);
    const auto& channels = skeleton.channels[std::size_t(j)];
    out += "CHANNELS ";
    out += std::to_string(channels.size());
    if (!channels.empty()) {
      out += ' ';
      out += skeleton.channel_list(j);
    }
    out += '\n';
    open.push_back(j);
  }
  while (!open.empty()) close_top();
}

void append_frames(std::string& out, const Clip& clip) {
  constexpr double kDegreesPerRadian = 180.0 / kPi;
  const Skeleton& skeleton = *clip.skeleton;
  const int joints = skeleton.joint_count();
  std::vector<RotationOrder> orders(static_cast<std::size_t>(joints));
  for (int j = 0; j < joints; ++j)
    if (skeleton.has_rotation(j)) orders[std::size_t(j)] = skeleton.rotation_order(j);
  // The angles written for the previous frame, so each curve continues where it was; or, when
  // the clip came from BVH, the source's own values for this sample: of the rotation's Euler
  // solutions (two, each up to multiples of 2 pi) the one nearest what the source wrote, so a
  // curve keeps the source's branch (e.g. a forearm written near 180 degrees) wherever the
  // rotation did not change, and follows it closely where it did.
  std::vector<std::optional<EulerAngles>> previous(static_cast<std::size_t>(joints));
  const std::size_t samples = std::size_t(clip.frames) * std::size_t(joints);
  const bool follow_source = clip.source_angles.size() == samples * 3;
  const RotationView rotations = clip.rotation_view();
  const TranslationView translations = clip.translation_view();
  // A frame's line is written into a buffer with room for its widest values, then appended
  // whole: appending value by value and space by space to the string was most of the writer's
  // own time.
  std::size_t values = 0;
  for (const auto& channels : skeleton.channels) values += channels.size();
  std::vector<char> line(values * (kMaxValueChars + 1) + 1);
  for (int t = 0; t < clip.frames; ++t) {
    char* p = line.data();
    bool first_value = true;
    for (int j = 0; j < joints; ++j) {
      std::optional<EulerAngles>& angles = previous[std::size_t(j)];
      if (skeleton.has_rotation(j)) {
        if (follow_source) {
          const float* s = clip.source_angles.data() + (std::size_t(t) * joints + j) * 3;
          angles = EulerAngles{s[0], s[1], s[2]};
        }
        angles = quat_to_euler(orders[std::size_t(j)], load_quat(rotations.at(t, j)), angles);
      }
      const float* translation = translations.at(t, j);
      int rotation_index = 0;
      for (Channel c : skeleton.channels[std::size_t(j)]) {
        if (!first_value) *p++ = ' ';
        first_value = false;
        if (is_rotation(c))
          p = write_degrees(p, (*angles)[std::size_t(rotation_index++)] * kDegreesPerRadian);
        else
          p = write_shortest(p, translation[channel_axis(c)]);
      }
    }
    *p++ = '\n';
    out.append(line.data(), p);
  }
}

bool all_finite(const std::vector<float>& values) {
  for (float v : values)
    if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace

std::string check_clip_for_bvh(const Clip& clip) {
  if (!clip.skeleton) return "the clip has no skeleton";
  const Skeleton& skeleton = *clip.skeleton;
  if (std::string problem = check_structure(skeleton); !problem.empty()) return problem;
  if (!valid_frame_time(clip.frame_time))
    return "the frame time must be a positive number of seconds " + frame_time_range() + ", got " +
           std::to_string(clip.frame_time);
  if (clip.frames < 0) return "the frame count is negative";
  const std::size_t samples = std::size_t(clip.frames) * std::size_t(skeleton.joint_count());
  if (clip.rotations.size() != samples * 4 || clip.translations.size() != samples * 3)
    return "the tensors do not match " + std::to_string(clip.frames) + " frames x " +
           std::to_string(skeleton.joint_count()) + " joints";
  if (!all_finite(clip.rotations) || !all_finite(clip.translations))
    return "the clip holds non-finite values";
  // A BVH file stores motion only through channels: frame lines of no values are unreadable.
  if (clip.frames > 0 && skeleton.channel_count() == 0)
    return "the skeleton has no channels, so its " + std::to_string(clip.frames) +
           " frames cannot be written";
  return {};
}

std::string format_bvh(const Clip& clip) {
  std::string out;
  // About 10 bytes a value; one allocation for typical clips.
  out.reserve(4096 + std::size_t(clip.frames) * std::size_t(clip.skeleton->channel_count()) * 10);
  append_hierarchy(out, *clip.skeleton);
  out += "MOTION\nFrames: ";
  out += std::to_string(clip.frames);
  out += "\nFrame Time: ";
  append_shortest(out, clip.frame_time);
  out += '\n';
  append_frames(out, clip);
  return out;
}

bool write_bvh(const Clip& clip, const std::filesystem::path& path, std::string* error) {
  auto failed = [&](const std::string& reason) {
    if (error) *error = path.string() + ": " + reason;
    return false;
  };
  if (std::string problem = check_clip_for_bvh(clip); !problem.empty()) return failed(problem);
  const std::string text = format_bvh(clip);

  std::filesystem::path temporary = path;
  temporary += ".tmp";
  std::FILE* file = std::fopen(temporary.c_str(), "wb");
  if (!file) return failed("cannot create " + temporary.string() + ": " + std::strerror(errno));
  // No fsync: the rename already keeps a killed or crashing process from leaving a partial file
  // at `path`, and a sync per clip would cost milliseconds each over a library of thousands.
  const bool written =
      std::fwrite(text.data(), 1, text.size(), file) == text.size() && std::fflush(file) == 0;
  const int write_errno = errno;
  const bool closed = std::fclose(file) == 0;
  std::error_code ignored;
  if (!written || !closed) {
    std::filesystem::remove(temporary, ignored);
    return failed("cannot write " + temporary.string() + ": " +
                  std::strerror(written ? errno : write_errno));
  }
  std::error_code renamed;
  std::filesystem::rename(temporary, path, renamed);
  if (renamed) {
    std::filesystem::remove(temporary, ignored);
    return failed("cannot rename " + temporary.string() + " into place: " + renamed.message());
  }
  return true;
}

}  // namespace mocap::io
