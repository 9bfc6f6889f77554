// Vector quaternion math for every Highway target: the float32 lane versions of quaternion.hpp
// (../shared/spec/filters.md, "Conventions"). Included once per target by each kernel's .cpp
// after foreach_target.h, hence the toggled guard instead of #pragma once.
//
// Every function works lane by lane: a lane's result depends on that lane's inputs only, never on
// its position in the vector, which is what makes a kernel's output independent of the slice
// that computed it.
#if defined(MOCAP_KERNELS_SIMD_QUAT_SIMD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MOCAP_KERNELS_SIMD_QUAT_SIMD_INL_H_
#undef MOCAP_KERNELS_SIMD_QUAT_SIMD_INL_H_
#else
#define MOCAP_KERNELS_SIMD_QUAT_SIMD_INL_H_
#endif

#include <cstddef>

#include "hwy/contrib/math/math-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <class V>
struct QuatV {
  V w, x, y, z;
};

template <class V>
struct Vec3V {
  V x, y, z;
};

// Lanes [i, i + N) of a quaternion curve stored as 4 planes of `stride` floats (w, x, y, z).
template <class D>
HWY_INLINE QuatV<hn::Vec<D>> LoadQuat(D d, const float* planes, std::size_t stride, std::size_t i) {
  return {hn::LoadU(d, planes + i), hn::LoadU(d, planes + stride + i),
          hn::LoadU(d, planes + 2 * stride + i), hn::LoadU(d, planes + 3 * stride + i)};
}

template <class D>
HWY_INLINE void StoreQuat(D d, QuatV<hn::Vec<D>> q, float* planes, std::size_t stride,
                          std::size_t i) {
  hn::StoreU(q.w, d, planes + i);
  hn::StoreU(q.x, d, planes + stride + i);
  hn::StoreU(q.y, d, planes + 2 * stride + i);
  hn::StoreU(q.z, d, planes + 3 * stride + i);
}

template <class D>
HWY_INLINE Vec3V<hn::Vec<D>> LoadVec3(D d, const float* planes, std::size_t stride, std::size_t i) {
  return {hn::LoadU(d, planes + i), hn::LoadU(d, planes + stride + i),
          hn::LoadU(d, planes + 2 * stride + i)};
}

template <class D>
HWY_INLINE void StoreVec3(D d, Vec3V<hn::Vec<D>> v, float* planes, std::size_t stride,
                          std::size_t i) {
  hn::StoreU(v.x, d, planes + i);
  hn::StoreU(v.y, d, planes + stride + i);
  hn::StoreU(v.z, d, planes + 2 * stride + i);
}

// Hamilton product a * b.
template <class V>
HWY_INLINE QuatV<V> Multiply(QuatV<V> a, QuatV<V> b) {
  return {
      hn::NegMulAdd(a.z, b.z, hn::NegMulAdd(a.y, b.y, hn::NegMulAdd(a.x, b.x, hn::Mul(a.w, b.w)))),
      hn::NegMulAdd(a.z, b.y, hn::MulAdd(a.y, b.z, hn::MulAdd(a.x, b.w, hn::Mul(a.w, b.x)))),
      hn::MulAdd(a.z, b.x, hn::MulAdd(a.y, b.w, hn::NegMulAdd(a.x, b.z, hn::Mul(a.w, b.y)))),
      hn::MulAdd(a.z, b.w, hn::NegMulAdd(a.y, b.x, hn::MulAdd(a.x, b.y, hn::Mul(a.w, b.z))))};
}

// a^-1 b for unit a: the conjugate of a times b. The vector part pairs products whose difference
// is exactly 0 for a = b (no fused multiply-add there), so Log(q^-1 q) = 0 to the bit and a
// constant curve stays constant to the bit.
template <class V>
HWY_INLINE QuatV<V> InverseTimes(QuatV<V> a, QuatV<V> b) {
  const auto pair = [](V p, V q, V r, V s) { return hn::Sub(hn::Mul(p, q), hn::Mul(r, s)); };
  return {hn::MulAdd(a.z, b.z, hn::MulAdd(a.y, b.y, hn::MulAdd(a.x, b.x, hn::Mul(a.w, b.w)))),
          hn::Add(pair(a.w, b.x, a.x, b.w), pair(a.z, b.y, a.y, b.z)),
          hn::Add(pair(a.w, b.y, a.y, b.w), pair(a.x, b.z, a.z, b.x)),
          hn::Add(pair(a.w, b.z, a.z, b.w), pair(a.y, b.x, a.x, b.y))};
}

// Log(q): axis times angle in [0, pi], q taken with w >= 0 (spec "Conventions"). The half angle
// atan2(s, w) (s = |x, y, z| >= 0, w >= 0, s^2 + w^2 = 1) is the arcsine of the smaller of s and
// w: asin is well conditioned below 1/sqrt(2), so this is accurate near 0 (asin(s) / s -> 1, the
// factor angle / s -> 2) and near pi (pi/2 - asin(w)), without a division inside an arctangent.
template <class D, class V = hn::Vec<D>>
HWY_INLINE Vec3V<V> Log(D d, QuatV<V> q) {
  const V sign = hn::And(q.w, hn::SignBit(d));  // -0 as well: q and -q are one rotation
  const V w = hn::Xor(q.w, sign), x = hn::Xor(q.x, sign), y = hn::Xor(q.y, sign),
          z = hn::Xor(q.z, sign);
  const V s = hn::Sqrt(hn::MulAdd(z, z, hn::MulAdd(y, y, hn::Mul(x, x))));
  const V a = hn::Asin(d, hn::Min(s, w));
  const V half = hn::IfThenElse(hn::Gt(s, w), hn::Sub(hn::Set(d, 1.5707963267948966f), a), a);
  // s = 0 only where x = y = z = 0, whose Log is 0 whatever the factor; a floor keeps it finite.
  const V factor = hn::Div(hn::Add(half, half), hn::Max(s, hn::Set(d, 1e-30f)));
  return {hn::Mul(factor, x), hn::Mul(factor, y), hn::Mul(factor, z)};
}

// Exp(v) = (cos(|v|/2), sin(|v|/2) v / |v|). sin(theta/2) / theta -> 1/2 as theta -> 0; the floor
// on theta only matters where v is 0 (or below 1e-30 rad).
template <class D, class V = hn::Vec<D>>
HWY_INLINE QuatV<V> Exp(D d, Vec3V<V> v) {
  const V theta = hn::Sqrt(hn::MulAdd(v.z, v.z, hn::MulAdd(v.y, v.y, hn::Mul(v.x, v.x))));
  const V half = hn::Mul(theta, hn::Set(d, 0.5f));
  const V k = hn::Div(hn::Sin(d, half), hn::Max(theta, hn::Set(d, 1e-30f)));
  return {hn::Cos(d, half), hn::Mul(k, v.x), hn::Mul(k, v.y), hn::Mul(k, v.z)};
}

// |a - s b| with s = sign(a . b): the chord between a and the nearer of b, -b.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V Chord(D d, QuatV<V> a, QuatV<V> b) {
  const V dot = hn::MulAdd(a.z, b.z, hn::MulAdd(a.y, b.y, hn::MulAdd(a.x, b.x, hn::Mul(a.w, b.w))));
  const V flip = hn::IfThenElseZero(hn::Lt(dot, hn::Zero(d)), hn::Set(d, -0.0f));
  const V dw = hn::Sub(a.w, hn::Xor(b.w, flip)), dx = hn::Sub(a.x, hn::Xor(b.x, flip)),
          dy = hn::Sub(a.y, hn::Xor(b.y, flip)), dz = hn::Sub(a.z, hn::Xor(b.z, flip));
  return hn::Sqrt(hn::MulAdd(dz, dz, hn::MulAdd(dy, dy, hn::MulAdd(dx, dx, hn::Mul(dw, dw)))));
}

// Geodesic distance d(a, b) = 4 asin(min(1, |a - s b| / 2)) in [0, pi] (spec "Conventions"): for
// float inputs a few ulps apart the chord's differences are exact, so small angles keep their
// relative precision.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V Geodesic(D d, QuatV<V> a, QuatV<V> b) {
  const V half_chord = hn::Min(hn::Set(d, 1.0f), hn::Mul(hn::Set(d, 0.5f), Chord(d, a, b)));
  return hn::Mul(hn::Set(d, 4.0f), hn::Asin(d, half_chord));
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // MOCAP_KERNELS_SIMD_QUAT_SIMD_INL_H_
