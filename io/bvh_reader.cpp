#include "io/bvh_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <vector>

#include "core/euler.hpp"
#include "io/bvh_hierarchy.hpp"
#include "io/bvh_lexer.hpp"
#include "io/library_format.hpp"

namespace mocap::io {
namespace {

using bvh::Cursor;
using bvh::found;
using bvh::ParseError;
using bvh::quoted;
using bvh::Token;

[[noreturn]] void fail(int line, std::string message) {
  throw ParseError{line, std::move(message)};
}

// Where each joint's values sit in a frame line: the column of each rotation channel in file
// order, and of the x, y, z position channels (-1 when the joint has none).
struct JointColumns {
  int rotation[3] = {-1, -1, -1};
  int position[3] = {-1, -1, -1};
  RotationOrder order = RotationOrder::XYZ;
  Vec3 offset;
};

std::vector<JointColumns> columns_of(const Skeleton& skeleton) {
  std::vector<JointColumns> out(std::size_t(skeleton.joint_count()));
  int column = 0;
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    JointColumns& joint = out[std::size_t(j)];
    int rotations = 0;
    for (Channel c : skeleton.channels[std::size_t(j)]) {
      if (is_rotation(c))
        joint.rotation[rotations++] = column;
      else
        joint.position[channel_axis(c)] = column;
      ++column;
    }
    if (rotations == 3) joint.order = skeleton.rotation_order(j);
    joint.offset = skeleton.offsets[std::size_t(j)];
  }
  return out;
}

struct MotionHeader {
  std::int64_t frames = 0;
  int frames_line = 0;
  double frame_time = 0;
};

// "MOTION", "Frames: N", "Frame Time: T"; the cursor is left at the first frame line.
MotionHeader parse_motion_header(Cursor& cursor, int hierarchy_end_line) {
  auto line_of = [&](const Token& t) { return t.end() ? cursor.final_line() : t.line; };
  const Token motion = cursor.next_token();
  if (motion.end())
    fail(line_of(motion), "missing MOTION section after the hierarchy (which ends on line " +
                              std::to_string(hierarchy_end_line) + ")");
  if (bvh::equals_ignore_case(motion.text, "ROOT"))
    fail(motion.line, "a second ROOT: only one ROOT is supported");
  if (motion.text == "}")
    fail(motion.line, "unbalanced '}': the hierarchy was already closed on line " +
                          std::to_string(hierarchy_end_line));
  if (!bvh::equals_ignore_case(motion.text, "MOTION"))
    fail(motion.line, "expected MOTION after the hierarchy, found " + quoted(motion.text));

  MotionHeader header;
  // "Frames:" is usually followed by the count, but "Frames:2752" also occurs.
  Token frames = cursor.next_token();
  std::string_view count_text;
  if (frames.text.size() >= 7 && bvh::equals_ignore_case(frames.text.substr(0, 7), "Frames:")) {
    count_text = frames.text.substr(7);
    if (count_text.empty()) count_text = cursor.token_on_line().text;
  } else {
    fail(line_of(frames), "expected 'Frames:' after MOTION, found " + found(frames));
  }
  header.frames_line = frames.line;
  const auto count = bvh::parse_count(count_text);
  if (!count)
    fail(frames.line,
         "the frame count " + quoted(count_text) + " is not a non-negative whole number");
  header.frames = *count;

  const Token frame = cursor.next_token();
  const Token time = cursor.token_on_line();
  if (!bvh::equals_ignore_case(frame.text, "Frame") || time.text.size() < 5 ||
      !bvh::equals_ignore_case(time.text.substr(0, 5), "Time:"))
    fail(line_of(frame), "expected 'Frame Time:' after 'Frames:', found " + found(frame));
  std::string_view time_text = time.text.substr(5);
  if (time_text.empty()) time_text = cursor.token_on_line().text;
  const bvh::NumberResult seconds = bvh::parse_number(time_text);
  if (seconds.error || !valid_frame_time(seconds.value))
    fail(frame.line, "the frame time " + quoted(time_text) +
                         " is not a positive number of seconds " + frame_time_range());
  header.frame_time = seconds.value;
  if (!cursor.at_line_end())
    fail(cursor.line(), "unexpected " + quoted(cursor.token_on_line().text) + " after Frame Time");
  cursor.next_line();
  return header;
}

// Reads the frame lines one pass over the text: each line holds exactly one value per channel.
// Blank lines are skipped. Tensors grow as lines arrive, never by the count in the header.
class FrameReader {
 public:
  FrameReader(Cursor& cursor, const Skeleton& skeleton, const MotionHeader& header, Clip& clip,
              bool keep_angles)
      : cursor_(cursor),
        header_(header),
        clip_(clip),
        columns_(columns_of(skeleton)),
        channels_(skeleton.channel_count()),
        joints_(skeleton.joint_count()),
        values_(std::size_t(channels_)),
        keep_angles_(keep_angles) {}

  void run() {
    if (channels_ == 0 && header_.frames > 0)
      fail(header_.frames_line, "the hierarchy declares no channels, so frames cannot be read");
    reserve();
    const char* p = cursor_.position();
    const char* const end = cursor_.end();
    int line = cursor_.line();
    std::int64_t read = 0;
    while (read < header_.frames) {
      while (p != end && bvh::is_blank(*p)) ++p;
      if (p == end) break;
      if (!bvh::is_line_break(*p)) {
        p = parse_line(p, end, line, read);
        store_frame();
        ++read;
      }
      if (p != end) p = skip_line_break(p, end, line);
    }
    cursor_.advance_to(p, line - cursor_.line());
    if (read < header_.frames)
      fail(cursor_.final_line(),
           "the file ends after " + std::to_string(read) + " frame lines, but 'Frames:' (line " +
               std::to_string(header_.frames_line) + ") says " + std::to_string(header_.frames));
    const Token extra = cursor_.next_token();
    if (!extra.end())
      fail(extra.line, "more frame lines than the " + std::to_string(header_.frames) +
                           " that 'Frames:' (line " + std::to_string(header_.frames_line) +
                           ") announces");
    clip_.frames = int(read);
  }

 private:
  static const char* skip_line_break(const char* p, const char* end, int& line) {
    if (*p == '\r' && p + 1 != end && p[1] == '\n') ++p;
    ++line;
    return p + 1;
  }

  // Each value takes at least two bytes (a digit and a separator), so the remaining text bounds
  // the number of frames it can hold, whatever the header claims.
  void reserve() {
    const std::int64_t by_bytes =
        channels_ > 0 ? std::int64_t(cursor_.remaining() / (2 * std::size_t(channels_))) + 1 : 0;
    const std::int64_t by_cap = kMaxBvhJointFrames / std::max(joints_, 1);
    const std::int64_t frames = std::min({header_.frames, by_bytes, by_cap});
    clip_.rotations.reserve(std::size_t(frames) * std::size_t(joints_) * 4);
    clip_.translations.reserve(std::size_t(frames) * std::size_t(joints_) * 3);
  }

  // Parses one non-blank line into values_; returns the position of its line break (or end).
  const char* parse_line(const char* p, const char* end, int line, std::int64_t frame) {
    int found = 0;
    for (;;) {
      while (p != end && bvh::is_blank(*p)) ++p;
      if (p == end || bvh::is_line_break(*p)) break;
      const char* start = p;
      while (p != end && !bvh::is_space(*p)) ++p;
      if (found < channels_) {
        const std::string_view token(start, std::size_t(p - start));
        const bvh::NumberResult number = bvh::parse_number(token);
        if (number.error)
          fail(line, "frame " + std::to_string(frame + 1) + ", value " + std::to_string(found + 1) +
                         ": " + quoted(token) + " " + number.error);
        values_[std::size_t(found)] = number.value;
      }
      ++found;
    }
    if (found != channels_)
      fail(line, "frame " + std::to_string(frame + 1) + " has " + std::to_string(found) +
                     " values, expected " + std::to_string(channels_));
    if ((frame + 1) * joints_ > kMaxBvhJointFrames)
      fail(line, "the clip holds more than " + std::to_string(kMaxBvhJointFrames) +
                     " joint-frames, the most one clip may have");
    return p;
  }

  void store_frame() {
    constexpr double kRadiansPerDegree = kPi / 180.0;
    const std::size_t r0 = clip_.rotations.size(), t0 = clip_.translations.size();
    clip_.rotations.resize(r0 + std::size_t(joints_) * 4);
    clip_.translations.resize(t0 + std::size_t(joints_) * 3);
    float* rotation = clip_.rotations.data() + r0;
    float* angles_out = nullptr;
    if (keep_angles_) {
      const std::size_t a0 = clip_.source_angles.size();
      clip_.source_angles.resize(a0 + std::size_t(joints_) * 3, 0.0f);
      angles_out = clip_.source_angles.data() + a0;
    }
    float* translation = clip_.translations.data() + t0;
    for (const JointColumns& joint : columns_) {
      Quat q;
      if (joint.rotation[0] >= 0) {
        // BVH composes R_first * R_second * R_third in file order: euler_to_quat's convention.
        const EulerAngles angles{values_[std::size_t(joint.rotation[0])] * kRadiansPerDegree,
                                 values_[std::size_t(joint.rotation[1])] * kRadiansPerDegree,
                                 values_[std::size_t(joint.rotation[2])] * kRadiansPerDegree};
        q = euler_to_quat(joint.order, angles);
        if (angles_out)
          for (int i = 0; i < 3; ++i) angles_out[i] = float(angles[std::size_t(i)]);
      }
      if (angles_out) angles_out += 3;
      store_quat(q, rotation);
      Vec3 t = joint.offset;
      if (joint.position[0] >= 0)
        t = {values_[std::size_t(joint.position[0])], values_[std::size_t(joint.position[1])],
             values_[std::size_t(joint.position[2])]};
      store_vec3(t, translation);
      rotation += 4;
      translation += 3;
    }
  }

  Cursor& cursor_;
  const MotionHeader& header_;
  Clip& clip_;
  std::vector<JointColumns> columns_;
  int channels_;
  int joints_;
  std::vector<double> values_;
  bool keep_angles_;
};

}  // namespace

std::string BvhError::what() const {
  if (line <= 0) return file + ": " + message;
  return file + ":" + std::to_string(line) + ": " + message;
}

BvhReadResult parse_bvh(std::string_view text, const std::string& name, bool keep_source_angles) {
  // A UTF-8 byte order mark is not part of the text.
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  BvhReadResult result;
  try {
    Cursor cursor(text);
    auto skeleton = std::make_shared<Skeleton>(bvh::parse_hierarchy(cursor));
    const int hierarchy_end_line = cursor.line();
    if (const std::string problem = check_structure(*skeleton); !problem.empty())
      fail(hierarchy_end_line, problem);
    const MotionHeader header = parse_motion_header(cursor, hierarchy_end_line);
    Clip clip;
    clip.skeleton = skeleton;
    clip.frame_time = header.frame_time;
    clip.source = name;
    FrameReader(cursor, *skeleton, header, clip, keep_source_angles).run();
    make_hemisphere_continuous(clip.rotation_span());
    result.clip = std::move(clip);
  } catch (const ParseError& e) {
    result.error = BvhError{name, e.line, e.message};
  } catch (const std::bad_alloc&) {
    result.error = BvhError{name, 0, "out of memory while reading the clip"};
  }
  return result;
}

std::optional<BvhError> read_bvh_text(const std::filesystem::path& path, std::string& text) {
  const std::string name = path.string();
  auto io_error = [&](const char* what) {
    return BvhError{name, 0, std::string(what) + ": " + std::strerror(errno)};
  };
  text.clear();
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(name.c_str(), "rb"),
                                                       &std::fclose);
  if (!file) return io_error("cannot open the file");
  std::error_code size_error;
  const auto size = std::filesystem::file_size(path, size_error);
  if (!size_error) text.reserve(std::size_t(size));
  char buffer[1 << 16];
  for (;;) {
    const std::size_t n = std::fread(buffer, 1, sizeof buffer, file.get());
    text.append(buffer, n);
    if (n < sizeof buffer) break;
  }
  if (std::ferror(file.get())) return io_error("cannot read the file");
  return std::nullopt;
}

BvhReadResult read_bvh(const std::filesystem::path& path, bool keep_source_angles) {
  std::string text;
  if (std::optional<BvhError> error = read_bvh_text(path, text)) {
    BvhReadResult result;
    result.error = std::move(error);
    return result;
  }
  return parse_bvh(text, path.string(), keep_source_angles);
}

}  // namespace mocap::io
