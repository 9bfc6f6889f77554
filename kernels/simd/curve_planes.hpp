#pragma once
// One joint's rotation curve as float planes (planes.hpp) and the scalar steps around the vector
// kernels of the per-joint filters: loading a joint from a [F][J][4] tensor, storing a slice back,
// and the boundary extension of ../shared/spec/filters.md, "Boundary extension".
#include <cstddef>
#include <vector>

#include "kernels/boundary.hpp"
#include "kernels/tensor.hpp"

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

// input := joint j's curve.
void load_joint(RotationView rotations, int joint, CurvePlanes& planes);
// Samples [begin, end) of `output` into joint j of the tensor.
void store_joint(const CurvePlanes& planes, int begin, int end, RotationSpan out, int joint);

// extended := input over [-reach, F + reach) by the boundary mode, then identities up to the
// stride (so that whole-vector reads past the end stay finite). Extrapolation is computed in
// double from the float samples, as the reference does.
void extend_planes(CurvePlanes& planes, int frames, int reach, Boundary boundary);

}  // namespace mocap::simd
