#pragma once
// The borrowed inputs and outputs every filter job shares: a clip's rotations (and optionally its
// translations) in, the same shapes out, and the slice of the output this job writes.
#include <cstdint>
#include <span>
#include <string_view>

#include "core/status.hpp"
#include "core/tensor.hpp"

namespace mocap {

struct MotionIO {
  double frame_time = 1.0 / 120.0;  // seconds; frequencies (butterworth cut-off) depend on it
  RotationView rotations;           // [F][J][4], hemisphere-continuous, read-only
  RotationSpan filtered_rotations;  // [F][J][4], written
  // Optional: empty views leave translations alone. translated_joints[j] != 0 marks the joints
  // whose translations are filtered (those with position channels); the others are copied.
  TranslationView translations;
  TranslationSpan filtered_translations;
  std::span<const std::uint8_t> translated_joints;

  // The slice of the output this job writes: joints [joint_begin, joint_end) of frames
  // [frame_begin, frame_end); -1 means "to the end". A job reads the whole input whatever its
  // slice, and each output sample is bit-identical whatever slice computed it (the engine shards
  // clips by joint block or time block and relies on this).
  int joint_begin = 0, joint_end = -1;
  int frame_begin = 0, frame_end = -1;

  int joint_stop() const { return joint_end < 0 ? rotations.joints : joint_end; }
  int frame_stop() const { return frame_end < 0 ? rotations.frames : frame_end; }
  bool has_translations() const { return !translations.empty(); }

  // Shapes agree, the slice lies inside the clip, frame_time > 0, no aliasing of in and out.
  Status validate() const;
};

// The shapes the pop tests share (kernels/pop_detour.hpp, kernels/pop_skeleton.hpp): rotations
// [F][J] (data unless empty), `skip` empty or one entry per joint, `flags` one per sample [F][J].
// Errors start with `job`.
Status validate_sample_flags(std::string_view job, RotationView rotations,
                             std::span<const std::uint8_t> skip,
                             std::span<const std::uint8_t> flags);
// The joint slice [joint_begin, joint_end) of a job that runs in joint slices (joint_end -1: to
// the last joint) lies within the clip's `joints`. Errors start with `job`.
Status validate_joint_slice(std::string_view job, int joint_begin, int joint_end, int joints);

}  // namespace mocap
