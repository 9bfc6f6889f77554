#include "engine/clip/shard_work.hpp"

#include <algorithm>
#include <cstring>

#include "engine/clip/flip_pieces.hpp"
#include "engine/clip/methods.hpp"

namespace mocap::engine {

std::vector<Shard> plan_shards(const FilterSettings& settings, int frames, int joints) {
  std::vector<Shard> shards;
  if (method_entry(settings.method).shard_by_frames) {
    for (int f = 0; f < frames; f += settings.shard_frames)
      shards.push_back({0, joints, f, std::min(frames, f + settings.shard_frames)});
  } else {
    for (int j = 0; j < joints; j += settings.shard_joints)
      shards.push_back({j, std::min(joints, j + settings.shard_joints), 0, frames});
  }
  if (shards.empty()) shards.push_back({0, joints, 0, frames});
  return shards;
}

namespace {

// Joints [joint_begin, joint_end) of the shard's frames, rotations and translations, as they came.
void copy_samples(const Clip& input, Clip& output, int joint_begin, int joint_end,
                  const Shard& shard) {
  const std::size_t J = std::size_t(input.joints()), n = std::size_t(joint_end - joint_begin);
  for (int t = shard.frame_begin; t < shard.frame_end; ++t) {
    const std::size_t at = std::size_t(t) * J + std::size_t(joint_begin);
    std::memcpy(output.rotations.data() + at * 4, input.rotations.data() + at * 4,
                sizeof(float) * 4 * n);
    std::memcpy(output.translations.data() + at * 3, input.translations.data() + at * 3,
                sizeof(float) * 3 * n);
  }
}

}  // namespace

Status run_shard(const ResolvedSettings& resolved, const Clip& input, Clip& output,
                 const Shard& shard) {
  const FilterSettings& s = resolved.settings;
  const int J = input.joints();
  if (resolved.unchanged) {
    copy_samples(input, output, shard.joint_begin, shard.joint_end, shard);
    return {};
  }
  const std::vector<std::uint8_t> translated = input.skeleton->translated_mask();

  // Each segment between impossible steps is filtered as a clip of its own: views into its rows
  // (the whole clip when it was not split).
  const std::vector<Segment> whole{{0, input.frames}};
  const std::vector<Segment>& segments = resolved.segments.empty() ? whole : resolved.segments;
  const auto segment_io = [&](const Segment& seg, int begin, int end) {
    const std::size_t row = std::size_t(seg.begin) * std::size_t(J);
    MotionIO io;
    io.frame_time = input.frame_time;
    io.rotations = {input.rotations.data() + row * 4, seg.frames(), J};
    io.filtered_rotations = {output.rotations.data() + row * 4, seg.frames(), J};
    io.translations = {input.translations.data() + row * 3, seg.frames(), J};
    io.filtered_translations = {output.translations.data() + row * 3, seg.frames(), J};
    io.translated_joints = translated;
    io.joint_begin = shard.joint_begin;
    io.joint_end = shard.joint_end;
    io.frame_begin = begin - seg.begin;
    io.frame_end = end - seg.begin;
    return io;
  };
  Status status;
  for (const Segment& seg : segments) {
    const int begin = std::max(seg.begin, shard.frame_begin);
    const int end = std::min(seg.end, shard.frame_end);
    if (begin >= end || !status.ok()) continue;
    status = run_method(s, segment_io(seg, begin, end), resolved.distance_joints);
  }
  // Garbage joints as they came (after the filter: nlpm writes whole poses); flipping joints then
  // filtered between their flips (clip/flip_pieces.hpp).
  for (int j = shard.joint_begin; j < shard.joint_end && !resolved.kept_joints.empty(); ++j)
    if (resolved.kept_joints[std::size_t(j)]) copy_samples(input, output, j, j + 1, shard);
  for (int j = shard.joint_begin; j < shard.joint_end && !resolved.flip_joints.empty(); ++j) {
    if (!resolved.flip_joints[std::size_t(j)]) continue;
    for (const Segment& seg : segments) {
      const int begin = std::max(seg.begin, shard.frame_begin);
      const int end = std::min(seg.end, shard.frame_end);
      if (begin >= end || !status.ok()) continue;
      status = filter_between_flips(resolved.flip_settings, segment_io(seg, begin, end), j,
                                    resolved.distance_joints);
    }
  }
  return status;
}

}  // namespace mocap::engine
