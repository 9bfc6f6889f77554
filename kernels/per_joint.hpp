#pragma once
// The driver shared by the filters that treat each joint's curve on its own (bof, the linear
// filters, kalman): joint by joint over the job's joints, the whole segment's curve is loaded
// (the filter reads beyond its own frames), the filter writes frames [frame_begin, frame_end),
// and those are stored. Translations likewise, for the joints with position channels; the others
// are copied as they came.
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/lee_shin.hpp"
#include "kernels/motion_io.hpp"

namespace mocap {

// filter(curve, out, begin, end, scratch) writes out[begin, end) from the whole curve.
template <class Filter>
void filter_each_rotation_curve(const MotionIO& io, Filter&& filter) {
  const int frames = io.rotations.frames;
  const int begin = io.frame_begin, end = io.frame_stop();
  CurveScratch scratch;
  std::vector<Quat> curve(frames), out(frames);
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    for (int t = 0; t < frames; ++t) curve[t] = load_quat(io.rotations.at(t, j));
    filter(curve, out, begin, end, scratch);
    for (int t = begin; t < end; ++t) store_quat(out[t], io.filtered_rotations.at(t, j));
  }
}

// filter(path, out, begin, end, scratch) writes out[begin, end) from the whole path; called for
// the joints io.translated_joints marks. Nothing happens when the job carries no translations.
template <class Filter>
void filter_each_translation_path(const MotionIO& io, Filter&& filter) {
  if (!io.has_translations()) return;
  const int frames = io.rotations.frames;
  const int begin = io.frame_begin, end = io.frame_stop();
  CurveScratch scratch;
  std::vector<Vec3> path(frames), out(frames);
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    for (int t = 0; t < frames; ++t) path[t] = load_vec3(io.translations.at(t, j));
    if (io.translated_joints[j] != 0)
      filter(path, out, begin, end, scratch);
    else
      out = path;
    for (int t = begin; t < end; ++t) store_vec3(out[t], io.filtered_translations.at(t, j));
  }
}

}  // namespace mocap
