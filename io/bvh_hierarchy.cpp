#include "io/bvh_hierarchy.hpp"

#include <string>
#include <unordered_map>
#include <vector>

#include "io/bvh_reader.hpp"

namespace mocap::io::bvh {
namespace {

bool is_keyword(const Token& token, std::string_view keyword) {
  return equals_ignore_case(token.text, keyword);
}

// A block between braces that is still open: a joint or an End Site.
struct OpenBlock {
  int joint = 0;  // the joint, or for an End Site the joint that owns it
  int line = 0;   // where the block's keyword stands
  bool end_site = false;
  bool has_offset = false;
  bool has_channels = false;
  Vec3 end_site_offset;
};

class HierarchyParser {
 public:
  explicit HierarchyParser(Cursor& cursor) : cursor_(cursor) {}

  Skeleton run() {
    expect_header();
    while (!stack_.empty()) step();
    return std::move(skeleton_);
  }

 private:
  [[noreturn]] void fail(int line, std::string message) const {
    throw ParseError{line, std::move(message)};
  }
  int line_of(const Token& token) const { return token.end() ? cursor_.final_line() : token.line; }

  std::string describe(const OpenBlock& block) const {
    const std::string& name = skeleton_.joint_names[std::size_t(block.joint)];
    if (block.end_site)
      return "the End Site of joint '" + name + "' (line " + std::to_string(block.line) + ")";
    return "joint '" + name + "' (line " + std::to_string(block.line) + ")";
  }

  void expect_header() {
    const Token first = cursor_.next_token();
    if (first.end()) fail(line_of(first), "the file is empty");
    if (!is_keyword(first, "HIERARCHY"))
      fail(first.line, "expected HIERARCHY at the start of a BVH file, found " + found(first));
    const Token root = cursor_.next_token();
    if (!is_keyword(root, "ROOT"))
      fail(line_of(root), "expected ROOT after HIERARCHY, found " + found(root));
    open_joint(root, -1);
  }

  void step() {
    const Token token = cursor_.next_token();
    if (token.end())
      fail(line_of(token),
           "the file ends inside the hierarchy: " + describe(stack_.back()) + " is not closed");
    if (is_keyword(token, "OFFSET")) return read_offset(token);
    if (is_keyword(token, "CHANNELS")) return read_channels(token);
    if (is_keyword(token, "JOINT")) return open_child_joint(token);
    if (is_keyword(token, "End")) return open_end_site(token);
    if (token.text == "}") return close_block(token);
    if (is_keyword(token, "ROOT"))
      fail(token.line, "a second ROOT inside " + describe(stack_.back()) +
                           ": only one ROOT is supported, and children are JOINTs");
    if (is_keyword(token, "MOTION"))
      fail(token.line,
           "MOTION inside the hierarchy: " + describe(stack_.back()) + " has no closing '}'");
    fail(token.line, "unexpected " + found(token) + " in " + describe(stack_.back()) +
                         "; expected OFFSET, CHANNELS, JOINT, End Site or '}'");
  }

  void open_joint(const Token& keyword, int parent) {
    const std::string_view name = cursor_.rest_of_line_name();
    if (name.empty())
      fail(keyword.line, std::string(keyword.text) + " needs a name on the same line");
    if (skeleton_.joint_count() >= kMaxBvhJoints)
      fail(keyword.line, "more than " + std::to_string(kMaxBvhJoints) + " joints");
    if (std::string why = check_joint_name(name); !why.empty())
      fail(keyword.line, std::string(keyword.text) + " " + printable(name) + ": " + why);
    const int joint = skeleton_.joint_count();
    if (const auto [it, fresh] = name_lines_.emplace(std::string(name), keyword.line); !fresh)
      fail(keyword.line, "joint name " + printable(name) + " is used already on line " +
                             std::to_string(it->second) + "; joint names must be unique");
    skeleton_.joint_names.emplace_back(name);
    skeleton_.parents.push_back(parent);
    skeleton_.offsets.emplace_back();
    skeleton_.channels.emplace_back();
    skeleton_.end_sites.emplace_back();
    expect_open_brace(std::string(keyword.text) + " " + printable(name));
    stack_.push_back({joint, keyword.line, false, false, false, {}});
  }

  void expect_open_brace(const std::string& after) {
    const Token brace = cursor_.next_token();
    if (brace.text != "{")
      fail(line_of(brace), "expected '{' after " + after + ", found " + found(brace));
  }

  void open_child_joint(const Token& keyword) {
    const OpenBlock& top = stack_.back();
    if (top.end_site) fail(keyword.line, describe(top) + " cannot have children");
    open_joint(keyword, top.joint);
  }

  void open_end_site(const Token& keyword) {
    const Token site = cursor_.next_token();
    if (!is_keyword(site, "Site"))
      fail(line_of(site), "expected 'Site' after 'End', found " + found(site));
    const OpenBlock& top = stack_.back();
    if (top.end_site) fail(keyword.line, describe(top) + " cannot have children");
    const std::size_t joint = std::size_t(top.joint);
    // End Sites cannot nest, so an earlier End Site of this joint is already closed and recorded.
    if (skeleton_.end_sites[joint])
      fail(keyword.line, "joint '" + skeleton_.joint_names[joint] +
                             "' has a second End Site; a joint can have at most one");
    // An End Site may carry a name ("End Site Nose") in some exporters; it is not kept.
    cursor_.rest_of_line_name();
    expect_open_brace("End Site");
    stack_.push_back({top.joint, keyword.line, true, false, false, {}});
  }

  void read_offset(const Token& keyword) {
    OpenBlock& top = stack_.back();
    if (top.has_offset) fail(keyword.line, describe(top) + " has a second OFFSET");
    double xyz[3];
    for (double& value : xyz) {
      const Token token = cursor_.next_token();
      const NumberResult number = parse_number(token.text);
      // A non-number on a later line means the values are missing, not misspelt.
      if (token.end() || (number.error && token.line != keyword.line))
        fail(keyword.line, "OFFSET needs 3 numbers, found " + found(token) +
                               (token.end() ? "" : " on line " + std::to_string(token.line)));
      if (number.error) fail(token.line, "OFFSET value " + quoted(token.text) + " " + number.error);
      value = number.value;
    }
    top.has_offset = true;
    const Vec3 offset{xyz[0], xyz[1], xyz[2]};
    if (top.end_site)
      top.end_site_offset = offset;
    else
      skeleton_.offsets[std::size_t(top.joint)] = offset;
  }

  void read_channels(const Token& keyword) {
    OpenBlock& top = stack_.back();
    if (top.end_site) fail(keyword.line, "an End Site has no CHANNELS");
    if (top.has_channels) fail(keyword.line, describe(top) + " has a second CHANNELS");
    top.has_channels = true;
    const Token count_token = cursor_.token_on_line();
    if (count_token.end()) fail(keyword.line, "CHANNELS needs a count and a list of channels");
    const auto count = parse_count(count_token.text);
    if (!count)
      fail(keyword.line, "the CHANNELS count " + quoted(count_token.text) +
                             " is not a non-negative whole number");
    std::vector<Channel>& list = skeleton_.channels[std::size_t(top.joint)];
    bool seen[6] = {};
    int rotations = 0, positions = 0, listed = 0;
    for (Token token = cursor_.token_on_line(); !token.end(); token = cursor_.token_on_line()) {
      ++listed;
      const auto channel = parse_channel_name(token.text);
      if (!channel)
        fail(keyword.line, "unknown channel " + quoted(token.text) +
                               "; expected Xposition, Yposition, Zposition, Xrotation, "
                               "Yrotation or Zrotation");
      if (seen[int(*channel)])
        fail(keyword.line, "channel " + std::string(to_string(*channel)) + " is listed twice");
      seen[int(*channel)] = true;
      (is_rotation(*channel) ? rotations : positions)++;
      list.push_back(*channel);
    }
    if (listed != *count)
      fail(keyword.line, "CHANNELS says " + std::to_string(*count) + " but lists " +
                             std::to_string(listed) + " channels");
    if (rotations != 0 && rotations != 3)
      fail(keyword.line,
           "a joint needs 0 or 3 rotation channels, found " + std::to_string(rotations));
    if (positions != 0 && positions != 3)
      fail(keyword.line,
           "a joint needs 0 or 3 position channels, found " + std::to_string(positions));
  }

  static std::optional<Channel> parse_channel_name(std::string_view name) {
    for (int c = 0; c < 6; ++c)
      if (equals_ignore_case(name, to_string(Channel(c)))) return Channel(c);
    return std::nullopt;
  }

  void close_block(const Token& brace) {
    const OpenBlock top = stack_.back();
    if (!top.has_offset) fail(brace.line, describe(top) + " has no OFFSET");
    if (top.end_site) skeleton_.end_sites[std::size_t(top.joint)] = top.end_site_offset;
    stack_.pop_back();
  }

  Cursor& cursor_;
  Skeleton skeleton_;
  std::vector<OpenBlock> stack_;
  std::unordered_map<std::string, int> name_lines_;  // joint name -> line it was declared on
};

}  // namespace

Skeleton parse_hierarchy(Cursor& cursor) {
  return HierarchyParser(cursor).run();
}

}  // namespace mocap::io::bvh
