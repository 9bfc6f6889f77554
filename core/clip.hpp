#pragma once
// One motion clip as the engine holds it: skeleton, frame time and the two tensors.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/skeleton.hpp"
#include "core/tensor.hpp"

namespace mocap {

// What a run did to one clip, stored with it in a library output (README, "The library file"):
// empty method = nothing recorded (import, noise, method none).
struct ClipProvenance {
  std::string method;              // what ran on this clip: auto's choice, or "unchanged"
  std::string parameters_json;     // its parameters as resolved for this clip (a JSON object)
  double noise_sigma = -1;         // the estimated noise (rad) the parameters came from; -1: none
  bool pop_stage = false;          // the pop stage looked for pops
  bool pops_repaired = false;      // ... and repaired them (else only counted)
  std::vector<std::int32_t> pops;  // [N][2]: frame, joint of each pop found
  bool feet = false;               // foot contacts were looked for (and locked)
  std::vector<std::int32_t> contacts;  // [N][3]: ankle joint, first frame, one past the last
};

struct Clip {
  std::shared_ptr<const Skeleton> skeleton;
  double frame_time = 0;  // seconds
  int frames = 0;
  std::vector<float> rotations;     // [F][J][4], wxyz local rotations, hemisphere-continuous
  std::vector<float> translations;  // [F][J][3]; joints without position channels hold offsets
  std::string source;               // relative path of the source file, e.g. "cmu/01/01_01.bvh"
  // The Euler channel values the BVH file held, [F][J][3] radians in each joint's channel order
  // (zeros for joints without rotation channels); empty unless the reader was asked to keep
  // them. The BVH writer picks, per sample, the Euler solution nearest them, so curves an
  // animator sees stay the source's wherever the rotation did not change.
  std::vector<float> source_angles;
  ClipProvenance provenance;

  int joints() const { return skeleton ? skeleton->joint_count() : 0; }
  RotationView rotation_view() const { return {rotations.data(), frames, joints()}; }
  RotationSpan rotation_span() { return {rotations.data(), frames, joints()}; }
  TranslationView translation_view() const { return {translations.data(), frames, joints()}; }
  TranslationSpan translation_span() { return {translations.data(), frames, joints()}; }
};

// A clip with `like`'s skeleton and timing and the given values, without source, Euler angles or
// provenance: the lean copy the motion measures, the guard and the foot stage work on.
inline Clip with_motion(const Clip& like, std::vector<float> rotations,
                        std::vector<float> translations) {
  Clip c;
  c.skeleton = like.skeleton;
  c.frame_time = like.frame_time;
  c.frames = like.frames;
  c.rotations = std::move(rotations);
  c.translations = std::move(translations);
  return c;
}
inline Clip motion_copy(const Clip& clip) {
  return with_motion(clip, clip.rotations, clip.translations);
}

// Every step-th frame of `clip` (frame time x step): the same motion at a lower frame rate, as
// eval's --frame-step. The source's Euler values follow when the clip holds them; the provenance
// is dropped, since its frame numbers are the full clip's.
inline Clip decimate(Clip clip, int step) {
  if (step <= 1) return clip;
  const std::size_t J = std::size_t(clip.joints());
  const int frames = (clip.frames + step - 1) / step;
  const bool angles = !clip.source_angles.empty();
  for (int t = 0; t < frames; ++t) {
    const std::size_t from = std::size_t(t) * std::size_t(step) * J, to = std::size_t(t) * J;
    std::copy_n(clip.rotations.begin() + std::ptrdiff_t(4 * from), 4 * J,
                clip.rotations.begin() + std::ptrdiff_t(4 * to));
    std::copy_n(clip.translations.begin() + std::ptrdiff_t(3 * from), 3 * J,
                clip.translations.begin() + std::ptrdiff_t(3 * to));
    if (angles)
      std::copy_n(clip.source_angles.begin() + std::ptrdiff_t(3 * from), 3 * J,
                  clip.source_angles.begin() + std::ptrdiff_t(3 * to));
  }
  clip.frames = frames;
  clip.frame_time *= step;
  clip.rotations.resize(std::size_t(frames) * J * 4);
  clip.translations.resize(std::size_t(frames) * J * 3);
  if (angles) clip.source_angles.resize(std::size_t(frames) * J * 3);
  clip.provenance = {};
  return clip;
}

}  // namespace mocap
