// Band geodesics in both layouts (band_geodesics.hpp), compiled once per Highway target.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/band_geodesics.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <algorithm>
#include <cstring>
#include <vector>

#include "hwy/highway.h"
#include "kernels/simd/band_geodesics.hpp"
#include "kernels/simd/planes.hpp"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {

void BandLanesTime(const float* rotations, int frames, int joints, int k, float* out) {
  const hn::ScalableTag<float> d;
  const std::size_t lanes = hn::Lanes(d), f = std::size_t(frames);
  // Reads reach sample t + r of a vector starting below F: F + k + lanes samples.
  const std::size_t stride = plane_size(f + std::size_t(k));
  std::vector<float> planes(4 * stride, 0.0f);
  std::fill_n(planes.begin(), stride, 1.0f);  // identity padding beyond F
  for (int j = 0; j < joints; ++j) {
    // The transposition into planes: part of this layout's cost.
    for (std::size_t t = 0; t < f; ++t) {
      const float* q = rotations + (t * std::size_t(joints) + std::size_t(j)) * 4;
      for (std::size_t c = 0; c < 4; ++c) planes[c * stride + t] = q[c];
    }
    for (int r = 1; r <= k; ++r) {
      float* row = out + (std::size_t(j) * std::size_t(k) + std::size_t(r - 1)) * f;
      for (std::size_t t = 0; t < f; t += lanes) {
        const auto a = LoadQuat(d, planes.data(), stride, t);
        const auto b = LoadQuat(d, planes.data(), stride, t + std::size_t(r));
        hn::StoreU(Geodesic(d, a, b), d, row + t);  // may spill into the next row: rewritten
      }
      std::fill(row + std::max<std::ptrdiff_t>(0, frames - r), row + f, 0.0f);
    }
  }
}

int BandLanesJoints(const float* rotations, int frames, int joints, int k,
                    std::vector<float>& out) {
  const hn::ScalableTag<float> d;
  const std::size_t lanes = hn::Lanes(d);
  const std::size_t padded = (std::size_t(joints) + lanes - 1) / lanes * lanes;
  const std::size_t f = std::size_t(frames);
  std::vector<float> copy;
  const float* rows = rotations;
  if (padded != std::size_t(joints)) {  // whole vectors per row: pad with identities
    copy.assign(f * padded * 4, 0.0f);
    for (std::size_t t = 0; t < f; ++t) {
      std::memcpy(&copy[t * padded * 4], rotations + t * std::size_t(joints) * 4,
                  std::size_t(joints) * 4 * sizeof(float));
      for (std::size_t j = std::size_t(joints); j < padded; ++j) copy[(t * padded + j) * 4] = 1.0f;
    }
    rows = copy.data();
  }
  out.assign(f * std::size_t(k) * padded, 0.0f);
  using V = hn::Vec<decltype(d)>;
  for (std::size_t t = 0; t < f; ++t) {
    for (std::size_t jb = 0; jb < padded; jb += lanes) {
      QuatV<V> a;
      hn::LoadInterleaved4(d, rows + (t * padded + jb) * 4, a.w, a.x, a.y, a.z);
      for (std::size_t r = 1; r <= std::size_t(k) && t + r < f; ++r) {
        QuatV<V> b;
        hn::LoadInterleaved4(d, rows + ((t + r) * padded + jb) * 4, b.w, b.x, b.y, b.z);
        hn::StoreU(Geodesic(d, a, b), d, &out[(t * std::size_t(k) + r - 1) * padded + jb]);
      }
    }
  }
  return int(padded);
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(BandLanesTime);
HWY_EXPORT(BandLanesJoints);

void band_geodesics_lanes_time(RotationView rotations, int k, std::vector<float>& out) {
  out.assign(
      std::size_t(rotations.joints) * std::size_t(k) * std::size_t(rotations.frames) + kMaxLanes,
      0.0f);
  HWY_DYNAMIC_DISPATCH(BandLanesTime)
  (rotations.data, rotations.frames, rotations.joints, k, out.data());
  out.resize(out.size() - kMaxLanes);
}

int band_geodesics_lanes_joints(RotationView rotations, int k, std::vector<float>& out) {
  return HWY_DYNAMIC_DISPATCH(BandLanesJoints)(rotations.data, rotations.frames, rotations.joints,
                                               k, out);
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
