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

}  // namespace mocap
