#include "io/library_format.hpp"

#include <hdf5.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <vector>

#include "core/format.hpp"

namespace mocap::io {

namespace {

void append_le(std::string& out, std::uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out += char((value >> (8 * i)) & 0xff);
}

void append_vec3(std::string& out, const Vec3& v) {
  for (double d : {v.x, v.y, v.z}) append_le(out, std::bit_cast<std::uint64_t>(d), 8);
}

std::uint64_t fnv1a64(std::string_view bytes) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  return h;
}

std::vector<std::string_view> split_path(std::string_view path) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (start <= path.size()) {
    const std::size_t slash = path.find('/', start);
    const std::size_t end = slash == std::string_view::npos ? path.size() : slash;
    parts.push_back(path.substr(start, end - start));
    start = end + 1;
  }
  return parts;
}

}  // namespace

std::string skeleton_canonical_bytes(const Skeleton& s) {
  std::string out;
  const int n = s.joint_count();
  append_le(out, std::uint32_t(n), 4);
  for (int j = 0; j < n; ++j) {
    out += s.joint_names[j];
    out += '\0';
    append_le(out, std::uint32_t(j < int(s.parents.size()) ? s.parents[j] : -1), 4);
    append_vec3(out, j < int(s.offsets.size()) ? s.offsets[j] : Vec3{});
    if (j < int(s.channels.size())) out += s.channel_list(j);
    out += '\0';
    const bool end_site = j < int(s.end_sites.size()) && s.end_sites[j].has_value();
    out += char(end_site ? 1 : 0);
    if (end_site) append_vec3(out, *s.end_sites[j]);
  }
  return out;
}

std::string skeleton_name(const Skeleton& s) {
  std::string root = s.joint_names.empty() ? std::string("skeleton") : s.joint_names[0];
  for (char& c : root) {
    const bool keep = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                      c == '_' || c == '-' || c == '.';
    if (!keep) c = '_';
  }
  if (root.empty() || root == "." || root == "..") root = "skeleton";
  const unsigned hash = unsigned(fnv1a64(skeleton_canonical_bytes(s)) >> 32);
  return root + "-" + std::to_string(s.joint_count()) + "j-" + format("%08x", hash);
}

std::string clip_path_from_source(std::string_view source) {
  std::string path(source);
  for (char& c : path)
    if (c == '\\') c = '/';
  if (path.empty() || path.front() == '/') return {};
  std::string out;
  for (std::string_view part : split_path(path)) {
    if (part.empty() || part == ".") continue;
    if (part == "..") return {};
    if (!out.empty()) out += '/';
    out += part;
  }
  const std::size_t slash = out.rfind('/');
  const std::size_t name_start = slash == std::string::npos ? 0 : slash + 1;
  const std::size_t dot = out.rfind('.');
  if (dot != std::string::npos && dot > name_start) out.erase(dot);
  if (out.size() == name_start) return {};
  return out;
}

std::string check_clip_path(std::string_view clip_path) {
  if (clip_path.empty()) return "the clip path is empty";
  if (clip_path.front() == '/')
    return "clip path '" + std::string(clip_path) + "' must be relative (no leading '/')";
  for (std::string_view part : split_path(clip_path))
    if (part.empty() || part == "." || part == "..")
      return "clip path '" + std::string(clip_path) + "' has an empty, '.' or '..' component";
  return {};
}

std::string frame_time_range() {
  return format("between %g and %g s", kMinFrameTime, kMaxFrameTime);
}

std::string check_clip(const Clip& clip) {
  if (!clip.skeleton) return "the clip has no skeleton";
  if (std::string problem = check_structure(*clip.skeleton); !problem.empty())
    return "the clip's skeleton is malformed: " + problem;
  if (!valid_frame_time(clip.frame_time)) {
    return "frame_time must be " + frame_time_range() + ", got " + format("%g", clip.frame_time);
  }
  if (clip.frames < 0) return "frames must be >= 0, got " + std::to_string(clip.frames);
  const std::size_t samples = std::size_t(clip.frames) * std::size_t(clip.joints());
  if (clip.rotations.size() != samples * 4)
    return "rotations hold " + std::to_string(clip.rotations.size()) + " floats, expected " +
           std::to_string(samples * 4) + " (" + std::to_string(clip.frames) + " frames x " +
           std::to_string(clip.joints()) + " joints x 4)";
  if (clip.translations.size() != samples * 3)
    return "translations hold " + std::to_string(clip.translations.size()) + " floats, expected " +
           std::to_string(samples * 3) + " (" + std::to_string(clip.frames) + " frames x " +
           std::to_string(clip.joints()) + " joints x 3)";
  return {};
}

void skip_hdf5_cleanup_at_exit() {
  H5dont_atexit();
}

void silence_hdf5_errors() {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

std::string utc_now_iso8601() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

}  // namespace mocap::io
