#include "io/skeleton.hpp"

#include <algorithm>

namespace mocap::io {

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

std::string check_structure(const Skeleton& s) {
  const std::size_t n = s.joint_names.size();
  if (n == 0) return "the skeleton has no joints";
  if (s.parents.size() != n || s.offsets.size() != n || s.channels.size() != n ||
      s.end_sites.size() != n)
    return "the skeleton's joint arrays differ in length";
  for (std::size_t j = 0; j < n; ++j) {
    if (s.parents[j] >= int(j) || s.parents[j] < -1)
      return "joint '" + s.joint_names[j] + "' has a parent that does not precede it";
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

}  // namespace mocap::io
