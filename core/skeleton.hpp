#pragma once
// A BVH hierarchy: joints in file order (parents before children), their offsets, channel lists
// and End Sites. The skeleton description that travels with a clip through the engine.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/euler.hpp"
#include "core/quaternion.hpp"

namespace mocap {

enum class Channel { Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation };

std::optional<Channel> parse_channel(std::string_view name);
std::string_view to_string(Channel channel);
inline bool is_rotation(Channel c) {
  return c >= Channel::Xrotation;
}
inline int channel_axis(Channel c) {
  return int(c) % 3;
}

struct Skeleton {
  std::vector<std::string> joint_names;
  std::vector<int> parents;  // -1 for a root
  std::vector<Vec3> offsets;
  std::vector<std::vector<Channel>> channels;  // per joint, in file order
  std::vector<std::optional<Vec3>> end_sites;  // per joint: the offset of its End Site, if any

  int joint_count() const { return int(joint_names.size()); }
  int channel_count() const;
  bool has_translation(int joint) const;  // the joint carries position channels
  // One entry per joint: 1 where it carries position channels (the mask MotionIO and the
  // translation estimates take).
  std::vector<std::uint8_t> translated_mask() const;
  bool has_rotation(int joint) const;  // the joint carries rotation channels
  // Rotation order of the joint's rotation channels (meaningful when has_rotation()).
  RotationOrder rotation_order(int joint) const;
  // Space-separated channel list of a joint, e.g. "Zrotation Xrotation Yrotation".
  std::string channel_list(int joint) const;

  bool operator==(const Skeleton&) const;
};

// Why `name` cannot name a joint (empty; a line break, brace or NUL; outer blanks: what BVH
// text cannot carry), or "".
std::string check_joint_name(std::string_view name);

// Checks the structure (sizes agree, joint names valid and unique, exactly one root and it comes
// first, parents precede children, offsets and End Sites finite and within float range, 0 or 3
// rotation and position channels, no repeated channel); returns an explanation or "". Every
// reader and writer of skeletons (BVH and library) applies it, so none accepts what another
// refuses.
std::string check_structure(const Skeleton& skeleton);

}  // namespace mocap
