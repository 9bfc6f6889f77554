// Per-target pieces shared by the per-joint curve filters (bof, Lee-Shin linear filters) of
// ../shared/spec/filters.md, "Lee-Shin construction": the local displacements w_m and the final
// q_i Exp(v_i). Toggled guard: included once per Highway target.
#if defined(MOCAP_KERNELS_SIMD_CURVE_SIMD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MOCAP_KERNELS_SIMD_CURVE_SIMD_INL_H_
#undef MOCAP_KERNELS_SIMD_CURVE_SIMD_INL_H_
#else
#define MOCAP_KERNELS_SIMD_CURVE_SIMD_INL_H_
#endif

#include <cstddef>

#include "hwy/highway.h"
#include "kernels/simd/curve_planes.hpp"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {

// Whole vectors covering [first, last) from `first`.
template <class D>
HWY_INLINE std::size_t VectorEnd(D d, std::size_t first, std::size_t last) {
  const std::size_t lanes = hn::Lanes(d);
  return first + (last - first + lanes - 1) / lanes * lanes;
}

// steps[m] = w_m = Log(ext_m^-1 ext_{m+1}) for m in [first, last), in whole vectors from first
// (reads ext up to a vector past last + 1: the planes' padding).
template <class D>
HWY_INLINE void TangentSteps(D d, CurvePlanes& p, std::size_t first, std::size_t last) {
  const std::size_t lanes = hn::Lanes(d), stride = p.stride;
  const float* ext = p.extended.data();
  for (std::size_t m = first; m < last; m += lanes) {
    const auto a = LoadQuat(d, ext, stride, m);
    const auto b = LoadQuat(d, ext, stride, m + 1);
    StoreVec3(d, Log(d, InverseTimes(a, b)), p.steps.data(), stride, m);
  }
}

// output[c - reach] = ext_c Exp(v) for the vector of centres starting at c.
template <class D, class V = hn::Vec<D>>
HWY_INLINE void StoreDisplaced(D d, CurvePlanes& p, std::size_t c, std::size_t reach, Vec3V<V> v) {
  const auto q = Multiply(LoadQuat(d, p.extended.data(), p.stride, c), Exp(d, v));
  StoreQuat(d, q, p.output.data(), p.stride, c - reach);
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // MOCAP_KERNELS_SIMD_CURVE_SIMD_INL_H_
