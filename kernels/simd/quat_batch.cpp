// Batch Log / Exp / geodesic (quat_batch.hpp), compiled once per Highway target.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/quat_batch.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <array>
#include <cstdint>

#include "hwy/highway.h"
#include "kernels/simd/planes.hpp"
#include "kernels/simd/quat_batch.hpp"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {

int64_t TargetId() {
  return HWY_TARGET;
}

// Applies kernel(d, in, out, i) to whole vectors of samples; the last partial vector goes
// through the same kernel on a copy padded with `pad` (a valid sample), so that a sample's result
// does not depend on where the array ends.
template <std::size_t kIn, std::size_t kOut, class Kernel>
void MapPlanes(std::array<const float*, kIn> in, std::array<float*, kOut> out, std::size_t n,
               std::array<float, kIn> pad, Kernel kernel) {
  const hn::ScalableTag<float> d;
  const std::size_t lanes = hn::Lanes(d);
  static_assert(HWY_MAX_BYTES / sizeof(float) <= kMaxLanes);
  std::size_t i = 0;
  for (; i + lanes <= n; i += lanes) kernel(d, in, out, i);
  if (i == n) return;
  float tail_in[kIn][kMaxLanes], tail_out[kOut][kMaxLanes];
  std::array<const float*, kIn> in_tail;
  std::array<float*, kOut> out_tail;
  for (std::size_t c = 0; c < kIn; ++c) {
    for (std::size_t l = 0; l < kMaxLanes; ++l) tail_in[c][l] = i + l < n ? in[c][i + l] : pad[c];
    in_tail[c] = tail_in[c];
  }
  for (std::size_t c = 0; c < kOut; ++c) out_tail[c] = tail_out[c];
  kernel(d, in_tail, out_tail, 0);
  for (std::size_t c = 0; c < kOut; ++c)
    for (std::size_t l = 0; i + l < n; ++l) out[c][i + l] = tail_out[c][l];
}

template <class D, std::size_t kPlanes>
HWY_INLINE QuatV<hn::Vec<D>> QuatAt(D d, const std::array<const float*, kPlanes>& p,
                                    std::size_t first, std::size_t i) {
  return {hn::LoadU(d, p[first] + i), hn::LoadU(d, p[first + 1] + i),
          hn::LoadU(d, p[first + 2] + i), hn::LoadU(d, p[first + 3] + i)};
}

void LogPlanes(const float* q, float* out, std::size_t n) {
  MapPlanes<4, 3>({q, q + n, q + 2 * n, q + 3 * n}, {out, out + n, out + 2 * n}, n, {1, 0, 0, 0},
                  [](auto d, const auto& in, const auto& o, std::size_t i) {
                    const auto v = Log(d, QuatAt(d, in, 0, i));
                    hn::StoreU(v.x, d, o[0] + i);
                    hn::StoreU(v.y, d, o[1] + i);
                    hn::StoreU(v.z, d, o[2] + i);
                  });
}

void ExpPlanes(const float* v, float* out, std::size_t n) {
  MapPlanes<3, 4>({v, v + n, v + 2 * n}, {out, out + n, out + 2 * n, out + 3 * n}, n, {0, 0, 0},
                  [](auto d, const auto& in, const auto& o, std::size_t i) {
                    const auto q = Exp(d, Vec3V<hn::Vec<decltype(d)>>{hn::LoadU(d, in[0] + i),
                                                                      hn::LoadU(d, in[1] + i),
                                                                      hn::LoadU(d, in[2] + i)});
                    hn::StoreU(q.w, d, o[0] + i);
                    hn::StoreU(q.x, d, o[1] + i);
                    hn::StoreU(q.y, d, o[2] + i);
                    hn::StoreU(q.z, d, o[3] + i);
                  });
}

void GeodesicPlanes(const float* a, const float* b, float* out, std::size_t n) {
  MapPlanes<8, 1>({a, a + n, a + 2 * n, a + 3 * n, b, b + n, b + 2 * n, b + 3 * n}, {out}, n,
                  {1, 0, 0, 0, 1, 0, 0, 0},
                  [](auto d, const auto& in, const auto& o, std::size_t i) {
                    hn::StoreU(Geodesic(d, QuatAt(d, in, 0, i), QuatAt(d, in, 4, i)), d, o[0] + i);
                  });
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <cassert>

namespace mocap::simd {

HWY_EXPORT(TargetId);
HWY_EXPORT(LogPlanes);
HWY_EXPORT(ExpPlanes);
HWY_EXPORT(GeodesicPlanes);

std::string_view active_target() {
  return hwy::TargetName(HWY_DYNAMIC_DISPATCH(TargetId)());
}

void log_planes(std::span<const float> q, std::span<float> out, std::size_t n) {
  assert(q.size() >= 4 * n && out.size() >= 3 * n);
  HWY_DYNAMIC_DISPATCH(LogPlanes)(q.data(), out.data(), n);
}

void exp_planes(std::span<const float> v, std::span<float> out, std::size_t n) {
  assert(v.size() >= 3 * n && out.size() >= 4 * n);
  HWY_DYNAMIC_DISPATCH(ExpPlanes)(v.data(), out.data(), n);
}

void geodesic_planes(std::span<const float> a, std::span<const float> b, std::span<float> out,
                     std::size_t n) {
  assert(a.size() >= 4 * n && b.size() >= 4 * n && out.size() >= n);
  HWY_DYNAMIC_DISPATCH(GeodesicPlanes)(a.data(), b.data(), out.data(), n);
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
