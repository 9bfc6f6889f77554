// The pop screen's cheap chart of one neighbour, in lanes of double (pop_screen.hpp, step 2),
// shared by the bounds' and the intervals' kernels. Included once per target after
// foreach_target.h, hence the toggled guard instead of #pragma once.
#if defined(MOCAP_KERNELS_SIMD_CHEAP_CHART_SIMD_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MOCAP_KERNELS_SIMD_CHEAP_CHART_SIMD_INL_H_
#undef MOCAP_KERNELS_SIMD_CHEAP_CHART_SIMD_INL_H_
#else
#define MOCAP_KERNELS_SIMD_CHEAP_CHART_SIMD_INL_H_
#endif

#include "hwy/highway.h"
#include "kernels/pop_screen.hpp"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <class V>
struct CheapPointV {
  V x, y, z;  // the point c = 2 (x, y, z) of u
  V delta;    // the bound on |Log(u) - c|
  V sine;     // |(x, y, z)| / |u|, compared with kPopScreenMaxSine by the caller
};

// u = conj(a) b taken on w >= 0, given conj(a) (`a_conjugate`), its point and its bound
// delta = sine^3 / (3 (1 - sine^2)) + 2 s |1 / n - 1| (s = |x, y, z|, n = |u|). With one
// division, r = 1 / (n w^2): 1 / n = w^2 r, and since 1 - sine^2 = w^2 / n^2, the series term is
// s^3 r / 3. Where w = 0 (sine = 1, beyond reach) r is infinite and sine NaN, so a comparison
// with the limit is false and the caller leaves the sample unbounded.
template <class D>
HWY_INLINE CheapPointV<hn::Vec<D>> CheapChartPoint(D d, QuatV<hn::Vec<D>> a_conjugate,
                                                   QuatV<hn::Vec<D>> b) {
  using V = hn::Vec<D>;
  const V aw = a_conjugate.w, ax = a_conjugate.x, ay = a_conjugate.y, az = a_conjugate.z;
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0), two = hn::Set(d, 2.0),
          third = hn::Set(d, 1.0 / 3.0);
  const V w = hn::Sub(hn::Sub(hn::Sub(hn::Mul(aw, b.w), hn::Mul(ax, b.x)), hn::Mul(ay, b.y)),
                      hn::Mul(az, b.z));
  V x = hn::Sub(hn::Add(hn::Add(hn::Mul(aw, b.x), hn::Mul(ax, b.w)), hn::Mul(ay, b.z)),
                hn::Mul(az, b.y));
  V y = hn::Add(hn::Add(hn::Sub(hn::Mul(aw, b.y), hn::Mul(ax, b.z)), hn::Mul(ay, b.w)),
                hn::Mul(az, b.x));
  V z = hn::Add(hn::Sub(hn::Add(hn::Mul(aw, b.z), hn::Mul(ax, b.y)), hn::Mul(ay, b.x)),
                hn::Mul(az, b.w));
  const auto flip = hn::Lt(w, zero);
  x = hn::IfThenElse(flip, hn::Neg(x), x);
  y = hn::IfThenElse(flip, hn::Neg(y), y);
  z = hn::IfThenElse(flip, hn::Neg(z), z);
  const V s2 = hn::Add(hn::Add(hn::Mul(x, x), hn::Mul(y, y)), hn::Mul(z, z));
  const V w2 = hn::Mul(w, w), s = hn::Sqrt(s2), length = hn::Sqrt(hn::Add(w2, s2));
  const V r = hn::Div(one, hn::Mul(length, w2));
  const V inverse_length = hn::Mul(w2, r);
  const V series = hn::Mul(hn::Mul(hn::Mul(s2, s), third), r);
  const V scale = hn::Abs(hn::Sub(inverse_length, one));
  return {hn::Mul(two, x), hn::Mul(two, y), hn::Mul(two, z),
          hn::Add(series, hn::Mul(hn::Mul(two, s), scale)), hn::Mul(s, inverse_length)};
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // MOCAP_KERNELS_SIMD_CHEAP_CHART_SIMD_INL_H_
