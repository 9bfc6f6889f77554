#include "kernels/forward_kinematics.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include "kernels/simd/forward_kinematics_simd.hpp"

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
  if (implementation != Implementation::fast && implementation != Implementation::reference)
    return Status::error("unknown implementation");
  if (!sites.empty() &&
      (site_positions.frames != rotations.frames || site_positions.joints != int(sites.size()) ||
       site_positions.data == nullptr))
    return Status::error("site_positions must be [frames][sites][3]");
  return {};
}

namespace {

// The joints to compute: all, or the chains of the output joints.
std::vector<std::uint8_t> computed_joints(const ForwardKinematicsJob& job) {
  std::vector<std::uint8_t> computed(job.parents.size(), job.output_joints.empty() ? 1 : 0);
  for (int o : job.output_joints)
    for (int j = o; j >= 0 && !computed[std::size_t(j)]; j = job.parents[std::size_t(j)])
      computed[std::size_t(j)] = 1;
  return computed;
}

void run_reference(const ForwardKinematicsJob& job) {
  const int joints = int(job.parents.size());
  const auto& parents = job.parents;
  std::vector<Quat> global_rotation(parents.size());
  std::vector<Vec3> global_position(parents.size());
  const std::vector<std::uint8_t> computed = computed_joints(job);
  for (int t = 0; t < job.rotations.frames; ++t) {
    for (int j = 0; j < joints; ++j) {
      if (!computed[std::size_t(j)]) continue;
      const Quat local = load_quat(job.rotations.at(t, j));
      const Vec3 translation = !job.translated_joints.empty() && job.translated_joints[j] != 0
                                   ? load_vec3(job.translations.at(t, j))
                                   : job.offsets[j];
      const int p = parents[j];
      if (p < 0) {
        global_rotation[j] = local;
        global_position[j] = translation;
      } else {
        global_rotation[j] = global_rotation[p] * local;
        global_position[j] = global_position[p] + rotate(global_rotation[p], translation);
      }
      if (job.output_joints.empty()) store_vec3(global_position[j], job.positions.at(t, j));
    }
    for (std::size_t k = 0; k < job.output_joints.size(); ++k)
      store_vec3(global_position[std::size_t(job.output_joints[k])], job.positions.at(t, int(k)));
    for (std::size_t s = 0; s < job.sites.size(); ++s) {
      const int j = job.sites[s].joint;
      store_vec3(global_position[j] + rotate(global_rotation[j], job.sites[s].offset),
                 job.site_positions.at(t, int(s)));
    }
  }
}

// The reference's steps with a chunk of frames as the lanes of every operation: each computed
// joint's global rotation and position as 7 planes (simd/forward_kinematics_simd.hpp), the chunk
// small enough that the planes of a whole skeleton stay in the first two cache levels (31 joints:
// 125 KB) and a run takes the same memory for any clip length.
void run_fast(const ForwardKinematicsJob& job) {
  constexpr std::size_t kChunk = 64, P = simd::kForwardKinematicsPad;
  static_assert(kChunk % P == 0);
  // One pad more than a chunk between planes: planes a power of two apart share cache sets.
  constexpr std::size_t stride = kChunk + P;
  const int joints = int(job.parents.size());
  const std::vector<std::uint8_t> computed = computed_joints(job);
  std::vector<int> slot(std::size_t(joints), -1);
  int count = 0;
  for (int j = 0; j < joints; ++j)
    if (computed[std::size_t(j)]) slot[std::size_t(j)] = count++;
  // Zeroed once: a padding lane holds finite values (a chunk's or an earlier chunk's), ignored.
  std::vector<double> planes((7 * std::size_t(count) + 7 + 3) * stride);
  double* const rotation = planes.data() + 7 * std::size_t(count) * stride;  // the local planes
  double* const translation = rotation + 4 * stride;
  double* const site = translation + 3 * stride;
  const auto frame_of = [&](int j) { return planes.data() + 7 * std::size_t(slot[j]) * stride; };
  const auto store = [&](const double* point, std::size_t m, int t0, TranslationSpan out,
                         int column) {
    for (std::size_t k = 0; k < m; ++k) {
      float* o = out.at(t0 + int(k), column);
      o[0] = float(point[k]);
      o[1] = float(point[stride + k]);
      o[2] = float(point[2 * stride + k]);
    }
  };
  for (int t0 = 0; t0 < job.rotations.frames; t0 += int(kChunk)) {
    const std::size_t m = std::min(kChunk, std::size_t(job.rotations.frames - t0));
    const std::size_t n = (m + P - 1) / P * P;
    for (int j = 0; j < joints; ++j) {
      if (!computed[std::size_t(j)]) continue;
      for (std::size_t k = 0; k < m; ++k) {
        const float* q = job.rotations.at(t0 + int(k), j);
        for (std::size_t c = 0; c < 4; ++c) rotation[c * stride + k] = q[c];
      }
      const bool moved = !job.translated_joints.empty() && job.translated_joints[j] != 0;
      if (moved)
        for (std::size_t k = 0; k < m; ++k) {
          const float* v = job.translations.at(t0 + int(k), j);
          for (std::size_t c = 0; c < 3; ++c) translation[c * stride + k] = v[c];
        }
      const int p = job.parents[j];
      simd::forward_kinematics_joint(p < 0 ? nullptr : frame_of(p), rotation,
                                     moved ? translation : nullptr, job.offsets[j], frame_of(j), n,
                                     stride);
      if (job.output_joints.empty()) store(frame_of(j) + 4 * stride, m, t0, job.positions, j);
    }
    for (std::size_t k = 0; k < job.output_joints.size(); ++k)
      store(frame_of(job.output_joints[k]) + 4 * stride, m, t0, job.positions, int(k));
    for (std::size_t s = 0; s < job.sites.size(); ++s) {
      simd::forward_kinematics_site(frame_of(job.sites[s].joint), job.sites[s].offset, site, n,
                                    stride);
      store(site, m, t0, job.site_positions, int(s));
    }
  }
}

}  // namespace

Status ForwardKinematicsJob::run() const {
  if (Status s = validate(); !s) return s;
  if (implementation == Implementation::fast)
    run_fast(*this);
  else
    run_reference(*this);
  return {};
}

}  // namespace mocap
