#include "kernels/simd/curve_planes.hpp"

#include <algorithm>

#include "core/quaternion.hpp"
#include "kernels/simd/planes.hpp"

namespace mocap::simd {
namespace {

Quat sample(const std::vector<float>& planes, std::size_t stride, long t) {
  const std::size_t i = std::size_t(t);
  return {planes[i], planes[stride + i], planes[2 * stride + i], planes[3 * stride + i]};
}

void put(std::vector<float>& planes, std::size_t stride, long t, Quat q) {
  const std::size_t i = std::size_t(t);
  planes[i] = float(q.w);
  planes[stride + i] = float(q.x);
  planes[2 * stride + i] = float(q.y);
  planes[3 * stride + i] = float(q.z);
}

}  // namespace

void CurvePlanes::reserve(int frames, int reach, int weight_rows) {
  // Vector loops run up to a whole vector past F + 2 reach and read up to `reach` further.
  stride = plane_size(std::size_t(frames) + 2 * std::size_t(reach) + 2 * kMaxLanes);
  input.resize(4 * stride);
  output.resize(4 * stride);
  extended.resize(4 * stride);
  steps.resize(3 * stride);
  weights.resize(std::size_t(weight_rows) * stride);
}

void load_joints(RotationView rotations, int first, std::size_t stride,
                 std::vector<std::vector<float>>& curves) {
  // The planes' base pointers, hoisted: the copy is a transposition of [F][block][4] rows.
  std::vector<float*> planes;
  for (auto& curve : curves)
    for (std::size_t c = 0; c < 4; ++c) planes.push_back(curve.data() + c * stride);
  const std::size_t width = planes.size();
  for (int t = 0; t < rotations.frames; ++t) {
    const float* row = rotations.at(t, first);
    for (std::size_t i = 0; i < width; ++i) planes[i][t] = row[i];
  }
}

void store_joints(const std::vector<std::vector<float>>& curves, std::size_t stride, int begin,
                  int end, RotationSpan out, int first) {
  std::vector<const float*> planes;
  for (const auto& curve : curves)
    for (std::size_t c = 0; c < 4; ++c) planes.push_back(curve.data() + c * stride);
  const std::size_t width = planes.size();
  for (int t = begin; t < end; ++t) {
    float* row = out.at(t, first);
    for (std::size_t i = 0; i < width; ++i) row[i] = planes[i][t];
  }
}

void extend_planes(CurvePlanes& planes, int frames, int reach, Boundary boundary) {
  const std::size_t stride = planes.stride;
  const std::vector<float>& in = planes.input;
  std::vector<float>& ext = planes.extended;
  for (std::size_t c = 0; c < 4; ++c) {
    std::copy_n(in.begin() + long(c * stride), frames, ext.begin() + long(c * stride) + reach);
    std::fill(ext.begin() + long(c * stride) + frames + 2 * reach,
              ext.begin() + long((c + 1) * stride), c == 0 ? 1.0f : 0.0f);
  }
  const long last = frames - 1;
  for (long i = 0; i < long(frames) + 2 * reach; ++i) {
    const long t = i - reach;
    if (t >= 0 && t <= last) {
      i = reach + last;  // the interior is copied above
      continue;
    }
    if (boundary != Boundary::extrapolate || frames < 2) {
      put(ext, stride, i, sample(in, stride, reflect_index(t, frames, boundary)));
    } else if (t < 0) {
      const Quat q0 = sample(in, stride, 0), q1 = sample(in, stride, 1);
      put(ext, stride, i, q0 * exp(double(t) * log(inverse(q0) * q1)));
    } else {
      const Quat qa = sample(in, stride, last - 1), qb = sample(in, stride, last);
      put(ext, stride, i, qb * exp(double(t - last) * log(inverse(qa) * qb)));
    }
  }
}

}  // namespace mocap::simd
