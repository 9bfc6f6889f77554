#pragma once
// One joint's rotation curve as float planes (planes.hpp) and the scalar steps around the vector
// kernels of the per-joint filters: loading a joint from a [F][J][4] tensor, storing a slice back,
// and the boundary extension of ../shared/spec/filters.md, "Boundary extension".
#include <algorithm>
#include <cstddef>
#include <vector>

#include "core/tensor.hpp"
#include "kernels/boundary.hpp"
#include "kernels/motion_io.hpp"

namespace mocap::simd {

// The working memory of one per-joint curve filter, reused across joints and passes: every
// buffer holds `planes` planes of `stride` floats.
struct CurvePlanes {
  std::size_t stride = 0;
  std::vector<float> input;     // 4 planes: the pass input, samples [0, F)
  std::vector<float> output;    // 4 planes: the pass output
  std::vector<float> extended;  // 4 planes: sample t at t + reach, identities past the end
  std::vector<float> steps;     // 3 planes: w_m = Log(ext_m^-1 ext_{m+1})
  std::vector<float> weights;   // per-filter rows (bof: the range factors of r = 1..k)

  // Sizes every buffer for a curve of `frames` samples and a filter of reach k with
  // `weight_rows` rows of weights.
  void reserve(int frames, int reach, int weight_rows);
};

// Joints [first, first + curves.size()) of the tensor into curves[g] (4 planes of `stride` each),
// reading each frame's row once: a joint at a time would stride through the whole clip per joint.
void load_joints(RotationView rotations, int first, std::size_t stride,
                 std::vector<std::vector<float>>& curves);
// Samples [begin, end) of curves[g] into joint first + g of the tensor, row by row.
void store_joints(const std::vector<std::vector<float>>& curves, std::size_t stride, int begin,
                  int end, RotationSpan out, int first);

// Runs filter(planes) (which reads planes.input, writes planes.output[frame_begin, frame_end))
// for every joint of io's slice, loading and storing the joints a block at a time.
template <class Filter>
void for_each_joint_curve(const MotionIO& io, CurvePlanes& planes, Filter filter) {
  constexpr int kBlock = 8;
  std::vector<std::vector<float>> curves;
  for (int first = io.joint_begin; first < io.joint_stop(); first += kBlock) {
    const int count = std::min(kBlock, io.joint_stop() - first);
    curves.resize(std::size_t(count));
    for (auto& curve : curves) curve.resize(planes.input.size());
    load_joints(io.rotations, first, planes.stride, curves);
    for (auto& curve : curves) {
      planes.input.swap(curve);
      filter(planes);
      planes.output.swap(curve);
    }
    store_joints(curves, planes.stride, io.frame_begin, io.frame_stop(), io.filtered_rotations,
                 first);
  }
}

// extended := input over [-reach, F + reach) by the boundary mode, then identities up to the
// stride (so that whole-vector reads past the end stay finite). Extrapolation is computed in
// double from the float samples, as the reference does.
void extend_planes(CurvePlanes& planes, int frames, int reach, Boundary boundary);

}  // namespace mocap::simd
