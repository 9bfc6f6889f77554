#include "core/skeleton.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <unordered_map>

namespace mocap {

std::optional<Channel> parse_channel(std::string_view name) {
  constexpr std::string_view names[6] = {"Xposition", "Yposition", "Zposition",
                                         "Xrotation", "Yrotation", "Zrotation"};
  for (int i = 0; i < 6; ++i)
    if (name == names[i]) return Channel(i);
  return std::nullopt;
}

std::string_view to_string(Channel channel) {
  constexpr std::string_view names[6] = {"Xposition", "Yposition", "Zposition",
                                         "Xrotation", "Yrotation", "Zrotation"};
  return names[int(channel)];
}

int Skeleton::channel_count() const {
  int n = 0;
  for (const auto& list : channels) n += int(list.size());
  return n;
}

std::vector<std::uint8_t> Skeleton::translated_mask() const {
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(joint_count()));
  for (int j = 0; j < joint_count(); ++j) mask[std::size_t(j)] = has_translation(j) ? 1 : 0;
  return mask;
}

bool Skeleton::has_translation(int joint) const {
  const auto& list = channels[joint];
  return std::any_of(list.begin(), list.end(), [](Channel c) { return !is_rotation(c); });
}

bool Skeleton::has_rotation(int joint) const {
  const auto& list = channels[joint];
  return std::any_of(list.begin(), list.end(), [](Channel c) { return is_rotation(c); });
}

RotationOrder Skeleton::rotation_order(int joint) const {
  int axes[3] = {0, 1, 2};
  int n = 0;
  for (Channel c : channels[joint])
    if (is_rotation(c) && n < 3) axes[n++] = channel_axis(c);
  return order_from_axes(axes[0], axes[1], axes[2]);
}

std::string Skeleton::channel_list(int joint) const {
  std::string out;
  for (Channel c : channels[joint]) {
    if (!out.empty()) out += ' ';
    out += to_string(c);
  }
  return out;
}

bool Skeleton::operator==(const Skeleton& o) const {
  auto same_vec = [](const Vec3& a, const Vec3& b) {
    return a.x == b.x && a.y == b.y && a.z == b.z;
  };
  if (joint_names != o.joint_names || parents != o.parents || channels != o.channels) return false;
  if (offsets.size() != o.offsets.size() || end_sites.size() != o.end_sites.size()) return false;
  for (std::size_t i = 0; i < offsets.size(); ++i)
    if (!same_vec(offsets[i], o.offsets[i])) return false;
  for (std::size_t i = 0; i < end_sites.size(); ++i) {
    if (end_sites[i].has_value() != o.end_sites[i].has_value()) return false;
    if (end_sites[i] && !same_vec(*end_sites[i], *o.end_sites[i])) return false;
  }
  return true;
}

std::string check_joint_name(std::string_view name) {
  if (name.empty()) return "the name is empty";
  for (char c : name)
    if (c == '\n' || c == '\r' || c == '{' || c == '}' || c == '\0')
      return "the name holds a line break, brace or NUL";
  if (name.front() == ' ' || name.front() == '\t' || name.back() == ' ' || name.back() == '\t')
    return "the name begins or ends with a blank";
  return {};
}

std::string check_structure(const Skeleton& s) {
  const std::size_t n = s.joint_names.size();
  if (n == 0) return "the skeleton has no joints";
  if (s.parents.size() != n || s.offsets.size() != n || s.channels.size() != n ||
      s.end_sites.size() != n)
    return "the skeleton's joint arrays differ in length";
  // Offsets become float translations and BVH text: both must hold them.
  auto storable = [](const Vec3& v) {
    return std::abs(v.x) <= FLT_MAX && std::abs(v.y) <= FLT_MAX && std::abs(v.z) <= FLT_MAX;
  };
  std::unordered_map<std::string_view, std::size_t> seen_names;
  for (std::size_t j = 0; j < n; ++j) {
    const std::string& name = s.joint_names[j];
    if (std::string why = check_joint_name(name); !why.empty())
      return "joint " + std::to_string(j) + " ('" + name + "'): " + why;
    if (const auto [it, fresh] = seen_names.emplace(name, j); !fresh)
      return "joint name '" + name + "' is used by joints " + std::to_string(it->second) + " and " +
             std::to_string(j) + "; joint names must be unique";
    if (j == 0 && s.parents[0] != -1) return "joint '" + name + "', the first, must be the root";
    if (j > 0 && s.parents[j] == -1)
      return "joint '" + name + "' is a second root; a skeleton has exactly one";
    if (s.parents[j] >= int(j) || s.parents[j] < -1)
      return "joint '" + s.joint_names[j] + "' has a parent that does not precede it";
    if (!storable(s.offsets[j]))
      return "joint '" + name + "' has a non-finite or out-of-range offset";
    if (s.end_sites[j] && !storable(*s.end_sites[j]))
      return "joint '" + name + "' has a non-finite or out-of-range End Site";
    int rotations = 0, positions = 0;
    bool seen[6] = {};
    for (Channel c : s.channels[j]) {
      if (seen[int(c)])
        return "joint '" + s.joint_names[j] + "' repeats channel " + std::string(to_string(c));
      seen[int(c)] = true;
      (is_rotation(c) ? rotations : positions)++;
    }
    if (rotations != 0 && rotations != 3)
      return "joint '" + s.joint_names[j] + "' has " + std::to_string(rotations) +
             " rotation channels; expected 0 or 3";
    if (positions != 0 && positions != 3)
      return "joint '" + s.joint_names[j] + "' has " + std::to_string(positions) +
             " position channels; expected 0 or 3";
  }
  return {};
}

}  // namespace mocap
