#include "kernels/motion_io.hpp"

#include <string>

namespace mocap {

Status MotionIO::validate() const {
  if (!(frame_time > 0))
    return Status::error("frame_time must be > 0, got " + std::to_string(frame_time));
  if (rotations.data == nullptr || rotations.frames < 1 || rotations.joints < 1)
    return Status::error("the clip has no frames or no joints");
  if (!filtered_rotations.same_shape(rotations))
    return Status::error("filtered_rotations must have the input's shape");
  if (filtered_rotations.data == rotations.data)
    return Status::error("filtered_rotations must not alias rotations");
  if (has_translations()) {
    if (!translations.same_shape(rotations) || !filtered_translations.same_shape(rotations))
      return Status::error("translations must have the rotations' frames and joints");
    if (translated_joints.size() != std::size_t(rotations.joints))
      return Status::error("translated_joints must have one entry per joint");
    if (filtered_translations.data == translations.data)
      return Status::error("filtered_translations must not alias translations");
  }
  if (joint_begin < 0 || joint_stop() > rotations.joints || joint_begin > joint_stop())
    return Status::error("joint slice [" + std::to_string(joint_begin) + ", " +
                         std::to_string(joint_stop()) + ") is outside the clip's " +
                         std::to_string(rotations.joints) + " joints");
  if (frame_begin < 0 || frame_stop() > rotations.frames || frame_begin > frame_stop())
    return Status::error("frame slice [" + std::to_string(frame_begin) + ", " +
                         std::to_string(frame_stop()) + ") is outside the clip's " +
                         std::to_string(rotations.frames) + " frames");
  return {};
}

Status validate_sample_flags(std::string_view job, RotationView rotations,
                             std::span<const std::uint8_t> skip,
                             std::span<const std::uint8_t> flags) {
  const std::size_t J = std::size_t(rotations.joints), F = std::size_t(rotations.frames);
  const std::string name(job);
  if (rotations.frames < 0 || rotations.joints < 0 || (F * J > 0 && !rotations.data))
    return Status::error(name + ": no rotations");
  if (!skip.empty() && skip.size() != J)
    return Status::error(name + ": skip must have one entry per joint (" + std::to_string(J) +
                         "), got " + std::to_string(skip.size()));
  if (flags.size() != F * J)
    return Status::error(name + ": flags must have one entry per sample (" + std::to_string(F * J) +
                         "), got " + std::to_string(flags.size()));
  return {};
}

Status validate_joint_slice(std::string_view job, int joint_begin, int joint_end, int joints) {
  const int end = joint_end < 0 ? joints : joint_end;
  if (joint_begin < 0 || joint_begin > end || end > joints)
    return Status::error(std::string(job) + ": joints [" + std::to_string(joint_begin) + ", " +
                         std::to_string(end) + ") outside the clip's " + std::to_string(joints));
  return {};
}

}  // namespace mocap
