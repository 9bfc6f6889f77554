#pragma once
// One motion clip as the engine holds it: skeleton, frame time and the two tensors.
#include <memory>
#include <string>
#include <vector>

#include "io/skeleton.hpp"
#include "kernels/tensor.hpp"

namespace mocap::io {

struct Clip {
  std::shared_ptr<const Skeleton> skeleton;
  double frame_time = 0;  // seconds
  int frames = 0;
  std::vector<float> rotations;     // [F][J][4], wxyz local rotations, hemisphere-continuous
  std::vector<float> translations;  // [F][J][3]; joints without position channels hold offsets
  std::string source;               // relative path of the source file, e.g. "cmu/01/01_01.bvh"

  int joints() const { return skeleton ? skeleton->joint_count() : 0; }
  RotationView rotation_view() const { return {rotations.data(), frames, joints()}; }
  RotationSpan rotation_span() { return {rotations.data(), frames, joints()}; }
  TranslationView translation_view() const { return {translations.data(), frames, joints()}; }
  TranslationSpan translation_span() { return {translations.data(), frames, joints()}; }
};

}  // namespace mocap::io
