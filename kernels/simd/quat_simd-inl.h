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

// Lanes [i, i + N) of a quaternion curve stored as 4 planes of `stride` lanes (w, x, y, z), and
// of points as 3 planes (x, y, z): float planes for the filters, double for the pop stage's and
// the skeleton's kernels.
template <class D>
HWY_INLINE QuatV<hn::Vec<D>> LoadQuat(D d, const hn::TFromD<D>* planes, std::size_t stride,
                                      std::size_t i) {
  return {hn::LoadU(d, planes + i), hn::LoadU(d, planes + stride + i),
          hn::LoadU(d, planes + 2 * stride + i), hn::LoadU(d, planes + 3 * stride + i)};
}

template <class D>
HWY_INLINE void StoreQuat(D d, QuatV<hn::Vec<D>> q, hn::TFromD<D>* planes, std::size_t stride,
                          std::size_t i) {
  hn::StoreU(q.w, d, planes + i);
  hn::StoreU(q.x, d, planes + stride + i);
  hn::StoreU(q.y, d, planes + 2 * stride + i);
  hn::StoreU(q.z, d, planes + 3 * stride + i);
}

template <class D>
HWY_INLINE Vec3V<hn::Vec<D>> LoadVec3(D d, const hn::TFromD<D>* planes, std::size_t stride,
                                      std::size_t i) {
  return {hn::LoadU(d, planes + i), hn::LoadU(d, planes + stride + i),
          hn::LoadU(d, planes + 2 * stride + i)};
}

template <class D>
HWY_INLINE void StoreVec3(D d, Vec3V<hn::Vec<D>> v, hn::TFromD<D>* planes, std::size_t stride,
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

// asin(x) for x in [0, 1] (Cephes asinf, relative error ~2.5e-7): x + x z P(z), z = x^2, below
// 1/2; pi/2 - 2 asin(sqrt((1 - x) / 2)) above. The square root is skipped when no lane needs it,
// which changes no lane's value (each lane takes the same formula either way). Distances between
// neighbouring samples and Log of small steps are all below 1/2, so it mostly is.
// asin(x) / x = 1 + z P(z), z = x^2 <= 1/4 (Cephes asinf's polynomial).
template <class D, class V = hn::Vec<D>>
HWY_INLINE V AsinOverX(D d, V z) {
  V p = hn::Set(d, 4.2163199048e-2f);
  p = hn::MulAdd(p, z, hn::Set(d, 2.4181311049e-2f));
  p = hn::MulAdd(p, z, hn::Set(d, 4.5470025998e-2f));
  p = hn::MulAdd(p, z, hn::Set(d, 7.4953002686e-2f));
  p = hn::MulAdd(p, z, hn::Set(d, 1.6666752422e-1f));
  return hn::MulAdd(z, p, hn::Set(d, 1.0f));
}

template <class D, class V = hn::Vec<D>>
HWY_INLINE V AsinNonNegative(D d, V x) {
  const auto big = hn::Gt(x, hn::Set(d, 0.5f));
  V z = hn::Mul(x, x), root = x;
  if (!hn::AllFalse(d, big)) {
    z = hn::IfThenElse(big, hn::NegMulAdd(hn::Set(d, 0.5f), x, hn::Set(d, 0.5f)), z);
    root = hn::IfThenElse(big, hn::Sqrt(z), x);
  }
  const V r = hn::Mul(root, AsinOverX(d, z));
  return hn::IfThenElse(big, hn::NegMulAdd(hn::Set(d, 2.0f), r, hn::Set(d, 1.5707963267948966f)),
                        r);
}

// sin(x) / x and cos(x) from z = x^2, |x| <= pi/4 (Cephes sinf / cosf minimax polynomials).
template <class D, class V = hn::Vec<D>>
HWY_INLINE V SinOverX(D d, V z) {
  V p = hn::Set(d, -1.9515295891e-4f);
  p = hn::MulAdd(p, z, hn::Set(d, 8.3321608736e-3f));
  p = hn::MulAdd(p, z, hn::Set(d, -1.6666654611e-1f));
  return hn::MulAdd(p, z, hn::Set(d, 1.0f));
}

template <class D, class V = hn::Vec<D>>
HWY_INLINE V CosOfRoot(D d, V z) {
  V p = hn::Set(d, 2.443315711809948e-5f);
  p = hn::MulAdd(p, z, hn::Set(d, -1.388731625493765e-3f));
  p = hn::MulAdd(p, z, hn::Set(d, 4.166664568298827e-2f));
  return hn::MulAdd(hn::Mul(p, z), z, hn::NegMulAdd(hn::Set(d, 0.5f), z, hn::Set(d, 1.0f)));
}

// sin(x) and cos(x) for x >= 0 with one shared range reduction (Cephes sinf/cosf): n = round(x /
// (pi/2)), r = x - n pi/2 in three parts (exact products), minimax polynomials on [-pi/4, pi/4],
// then the quadrant n mod 4 swaps and negates them. Accurate to a few ulps for x below ~1e4.
template <class D, class V = hn::Vec<D>>
HWY_INLINE void SinCosNonNegative(D d, V x, V& sin_x, V& cos_x) {
  const V n = hn::Round(hn::Mul(x, hn::Set(d, 0.63661977236758134f)));
  V r = hn::NegMulAdd(n, hn::Set(d, 1.5703125f), x);
  r = hn::NegMulAdd(n, hn::Set(d, 4.837512969970703125e-4f), r);
  r = hn::NegMulAdd(n, hn::Set(d, 7.54978995489188216e-8f), r);
  const V z = hn::Mul(r, r);
  const V ps = hn::Mul(r, SinOverX(d, z)), pc = CosOfRoot(d, z);
  // n mod 4, exact in float for the arguments above.
  const V quadrant = hn::NegMulAdd(hn::Set(d, 4.0f), hn::Floor(hn::Mul(n, hn::Set(d, 0.25f))), n);
  const auto odd = hn::Or(hn::Eq(quadrant, hn::Set(d, 1.0f)), hn::Eq(quadrant, hn::Set(d, 3.0f)));
  const auto sin_negative = hn::Ge(quadrant, hn::Set(d, 2.0f));
  const auto cos_negative =
      hn::Or(hn::Eq(quadrant, hn::Set(d, 1.0f)), hn::Eq(quadrant, hn::Set(d, 2.0f)));
  const V s = hn::IfThenElse(odd, pc, ps), c = hn::IfThenElse(odd, ps, pc);
  sin_x = hn::IfThenElse(sin_negative, hn::Neg(s), s);
  cos_x = hn::IfThenElse(cos_negative, hn::Neg(c), c);
}

// Log(q): axis times angle in [0, pi], q taken with w >= 0 (spec "Conventions"). The half angle
// atan2(s, w) (s = |x, y, z| >= 0, w >= 0, s^2 + w^2 = 1) is the arcsine of the smaller of s and
// w: asin is well conditioned below 1/sqrt(2), so this is accurate near 0 (asin(s) / s -> 1, the
// factor angle / s -> 2) and near pi (pi/2 - asin(w)), without a division inside an arctangent.
// Below 60 degrees (s^2 <= 1/4, the steps of any captured motion) the factor 2 asin(s) / s is a
// polynomial in s^2: no square root, no division. A lane takes that formula whenever it
// qualifies, whatever the other lanes do, so the shortcut changes no result.
template <class D, class V = hn::Vec<D>>
HWY_INLINE Vec3V<V> Log(D d, QuatV<V> q) {
  const V sign = hn::And(q.w, hn::SignBit(d));  // -0 as well: q and -q are one rotation
  const V w = hn::Xor(q.w, sign), x = hn::Xor(q.x, sign), y = hn::Xor(q.y, sign),
          z = hn::Xor(q.z, sign);
  const V s2 = hn::MulAdd(z, z, hn::MulAdd(y, y, hn::Mul(x, x)));
  const auto small = hn::And(hn::Le(s2, hn::Set(d, 0.25f)), hn::Le(s2, hn::Mul(w, w)));
  const V two = hn::Set(d, 2.0f);
  V factor = hn::Mul(two, AsinOverX(d, s2));
  if (!hn::AllTrue(d, small)) {
    const V s = hn::Sqrt(s2);
    const V a = AsinNonNegative(d, hn::Min(s, w));
    const V half = hn::IfThenElse(hn::Gt(s, w), hn::Sub(hn::Set(d, 1.5707963267948966f), a), a);
    // s = 0 only where x = y = z = 0, whose Log is 0 whatever the factor: a floor keeps it finite.
    factor =
        hn::IfThenElse(small, factor, hn::Div(hn::Mul(two, half), hn::Max(s, hn::Set(d, 1e-30f))));
  }
  return {hn::Mul(factor, x), hn::Mul(factor, y), hn::Mul(factor, z)};
}

// Exp(v) = (cos(|v|/2), sin(|v|/2) v / |v|). Up to |v| = pi/2 both are polynomials in |v|^2 / 4
// (sin(h) / h, cos h): no square root, no division, no range reduction; beyond, one shared range
// reduction. As in Log, a lane's formula depends on its own value only.
template <class D, class V = hn::Vec<D>>
HWY_INLINE QuatV<V> Exp(D d, Vec3V<V> v) {
  const V theta2 = hn::MulAdd(v.z, v.z, hn::MulAdd(v.y, v.y, hn::Mul(v.x, v.x)));
  const V half2 = hn::Mul(theta2, hn::Set(d, 0.25f));
  const auto small = hn::Le(half2, hn::Set(d, 0.61685027506808491f));  // (pi/4)^2
  V c = CosOfRoot(d, half2);
  V k = hn::Mul(hn::Set(d, 0.5f), SinOverX(d, half2));  // sin(theta/2) / theta
  if (!hn::AllTrue(d, small)) {
    const V theta = hn::Sqrt(theta2);
    V sin_half, cos_half;
    SinCosNonNegative(d, hn::Mul(theta, hn::Set(d, 0.5f)), sin_half, cos_half);
    c = hn::IfThenElse(small, c, cos_half);
    k = hn::IfThenElse(small, k, hn::Div(sin_half, theta));  // theta > pi/2 here
  }
  return {c, hn::Mul(k, v.x), hn::Mul(k, v.y), hn::Mul(k, v.z)};
}

// |a - s b|^2 with s = sign(a . b): the squared chord between a and the nearer of b, -b.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V ChordSquared(D d, QuatV<V> a, QuatV<V> b) {
  const V dot = hn::MulAdd(a.z, b.z, hn::MulAdd(a.y, b.y, hn::MulAdd(a.x, b.x, hn::Mul(a.w, b.w))));
  const V flip = hn::IfThenElseZero(hn::Lt(dot, hn::Zero(d)), hn::Set(d, -0.0f));
  const V dw = hn::Sub(a.w, hn::Xor(b.w, flip)), dx = hn::Sub(a.x, hn::Xor(b.x, flip)),
          dy = hn::Sub(a.y, hn::Xor(b.y, flip)), dz = hn::Sub(a.z, hn::Xor(b.z, flip));
  return hn::MulAdd(dz, dz, hn::MulAdd(dy, dy, hn::MulAdd(dx, dx, hn::Mul(dw, dw))));
}

// Geodesic distance d(a, b) = 4 asin(min(1, |a - s b| / 2)) in [0, pi] (spec "Conventions"): for
// float inputs a few ulps apart the chord's differences are exact, so small angles keep their
// relative precision.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V Geodesic(D d, QuatV<V> a, QuatV<V> b) {
  const V half_chord =
      hn::Min(hn::Set(d, 1.0f), hn::Mul(hn::Set(d, 0.5f), hn::Sqrt(ChordSquared(d, a, b))));
  return hn::Mul(hn::Set(d, 4.0f), AsinNonNegative(d, half_chord));
}

// d(a, b)^2, what bof's gaussian range weights and nlpm's pose distance need: up to 120 degrees
// (half chord x <= 1/2) it is 16 x^2 (asin(x) / x)^2, a polynomial in x^2 = |a - s b|^2 / 4 with
// no square root; beyond, the square of Geodesic. Per lane as in Log.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V GeodesicSquared(D d, QuatV<V> a, QuatV<V> b) {
  const V x2 = hn::Min(hn::Set(d, 1.0f), hn::Mul(hn::Set(d, 0.25f), ChordSquared(d, a, b)));
  const auto small = hn::Le(x2, hn::Set(d, 0.25f));
  const V ratio = AsinOverX(d, x2);
  V d2 = hn::Mul(hn::Mul(hn::Set(d, 16.0f), x2), hn::Mul(ratio, ratio));
  if (!hn::AllTrue(d, small)) {
    const V dist = hn::Mul(hn::Set(d, 4.0f), AsinNonNegative(d, hn::Sqrt(x2)));
    d2 = hn::IfThenElse(small, d2, hn::Mul(dist, dist));
  }
  return d2;
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // MOCAP_KERNELS_SIMD_QUAT_SIMD_INL_H_
