#include "kernels/forward_kinematics.hpp"

#include <string>
#include <vector>

namespace mocap {

Status ForwardKinematicsJob::validate() const {
  const int joints = int(parents.size());
  if (offsets.size() != parents.size())
    return Status::error("offsets has " + std::to_string(offsets.size()) + " entries, parents " +
                         std::to_string(joints));
  if (rotations.joints != joints)
    return Status::error("rotations have " + std::to_string(rotations.joints) +
                         " joints, parents " + std::to_string(joints));
  if (rotations.frames > 0 && rotations.data == nullptr)
    return Status::error("rotations have no data");
  for (int j = 0; j < joints; ++j)
    if (parents[j] >= j || parents[j] < -1)
      return Status::error("joint " + std::to_string(j) + " has parent " +
                           std::to_string(parents[j]) + ": parents must precede their children");
  if (!translated_joints.empty()) {
    if (int(translated_joints.size()) != joints)
      return Status::error("translated_joints must have one entry per joint");
    if (!translations.same_shape(rotations) || translations.data == nullptr)
      return Status::error("translations must have the shape of the rotations");
  }
  const int outputs = output_joints.empty() ? joints : int(output_joints.size());
  if (positions.frames != rotations.frames || positions.joints != outputs ||
      (rotations.frames > 0 && positions.data == nullptr))
    return Status::error(output_joints.empty() ? "positions must have the shape of the rotations"
                                               : "positions must be [frames][output joints][3]");
  for (const JointSite& s : sites)
    if (s.joint < 0 || s.joint >= joints)
      return Status::error("site on joint " + std::to_string(s.joint) + " of " +
                           std::to_string(joints));
  for (int j : output_joints)
    if (j < 0 || j >= joints)
      return Status::error("output joint " + std::to_string(j) + " of " + std::to_string(joints));
  if (!output_joints.empty() && !sites.empty())
    return Status::error("sites need every joint: output_joints must be empty");
  if (!sites.empty() &&
      (site_positions.frames != rotations.frames || site_positions.joints != int(sites.size()) ||
       site_positions.data == nullptr))
    return Status::error("site_positions must be [frames][sites][3]");
  return {};
}

Status ForwardKinematicsJob::run() const {
  if (Status s = validate(); !s) return s;
  const int joints = int(parents.size());
  std::vector<Quat> global_rotation(parents.size());
  std::vector<Vec3> global_position(parents.size());
  // The joints to compute: all, or the chains of the output joints.
  std::vector<std::uint8_t> computed(parents.size(), output_joints.empty() ? 1 : 0);
  for (int o : output_joints)
    for (int j = o; j >= 0 && !computed[std::size_t(j)]; j = parents[std::size_t(j)])
      computed[std::size_t(j)] = 1;
  for (int t = 0; t < rotations.frames; ++t) {
    for (int j = 0; j < joints; ++j) {
      if (!computed[std::size_t(j)]) continue;
      const Quat local = load_quat(rotations.at(t, j));
      const Vec3 translation = !translated_joints.empty() && translated_joints[j] != 0
                                   ? load_vec3(translations.at(t, j))
                                   : offsets[j];
      const int p = parents[j];
      if (p < 0) {
        global_rotation[j] = local;
        global_position[j] = translation;
      } else {
        global_rotation[j] = global_rotation[p] * local;
        global_position[j] = global_position[p] + rotate(global_rotation[p], translation);
      }
      if (output_joints.empty()) store_vec3(global_position[j], positions.at(t, j));
    }
    for (std::size_t k = 0; k < output_joints.size(); ++k)
      store_vec3(global_position[std::size_t(output_joints[k])], positions.at(t, int(k)));
    for (std::size_t s = 0; s < sites.size(); ++s) {
      const int j = sites[s].joint;
      store_vec3(global_position[j] + rotate(global_rotation[j], sites[s].offset),
                 site_positions.at(t, int(s)));
    }
  }
  return {};
}

}  // namespace mocap
