// ForwardKinematicsJob's fast path kernels (forward_kinematics_simd.hpp), compiled once per
// Highway target. Only Mul, Add, Sub and Neg, each correctly rounded in a lane as in a scalar:
// the reference's operations, in its order.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/forward_kinematics_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <cstddef>

#include "hwy/highway.h"
#include "kernels/simd/forward_kinematics_simd.hpp"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// core/quaternion.hpp's operator*, term by term, left to right.
template <class V>
HWY_INLINE QuatV<V> HamiltonProduct(QuatV<V> a, QuatV<V> b) {
  using hn::Add, hn::Mul, hn::Sub;
  return {Sub(Sub(Sub(Mul(a.w, b.w), Mul(a.x, b.x)), Mul(a.y, b.y)), Mul(a.z, b.z)),
          Sub(Add(Add(Mul(a.w, b.x), Mul(a.x, b.w)), Mul(a.y, b.z)), Mul(a.z, b.y)),
          Add(Add(Sub(Mul(a.w, b.y), Mul(a.x, b.z)), Mul(a.y, b.w)), Mul(a.z, b.x)),
          Add(Sub(Add(Mul(a.w, b.z), Mul(a.x, b.y)), Mul(a.y, b.x)), Mul(a.z, b.w))};
}

// core/quaternion.cpp's rotate: (q (0, v)) q^-1, its vector part.
template <class D, class V = hn::Vec<D>>
HWY_INLINE Vec3V<V> RotateSandwich(D d, QuatV<V> q, Vec3V<V> v) {
  const QuatV<V> p{hn::Zero(d), v.x, v.y, v.z};
  const QuatV<V> inverse{q.w, hn::Neg(q.x), hn::Neg(q.y), hn::Neg(q.z)};
  const QuatV<V> r = HamiltonProduct(HamiltonProduct(q, p), inverse);
  return {r.x, r.y, r.z};
}

void ForwardKinematicsJoint(const double* parent, const double* rotation, const double* translation,
                            Vec3 offset, double* joint, std::size_t n, std::size_t stride) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t N = hn::Lanes(d);
  const Vec3V<V> constant{hn::Set(d, offset.x), hn::Set(d, offset.y), hn::Set(d, offset.z)};
  for (std::size_t i = 0; i < n; i += N) {
    const QuatV<V> q = LoadQuat(d, rotation, stride, i);
    const Vec3V<V> local = translation ? LoadVec3(d, translation, stride, i) : constant;
    if (parent == nullptr) {
      StoreQuat(d, q, joint, stride, i);
      StoreVec3(d, local, joint + 4 * stride, stride, i);
      continue;
    }
    const QuatV<V> r = LoadQuat(d, parent, stride, i);
    const Vec3V<V> p = LoadVec3(d, parent + 4 * stride, stride, i);
    const Vec3V<V> m = RotateSandwich(d, r, local);
    StoreQuat(d, HamiltonProduct(r, q), joint, stride, i);
    StoreVec3(d, Vec3V<V>{hn::Add(p.x, m.x), hn::Add(p.y, m.y), hn::Add(p.z, m.z)},
              joint + 4 * stride, stride, i);
  }
}

void ForwardKinematicsSite(const double* joint, Vec3 offset, double* point, std::size_t n,
                           std::size_t stride) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t N = hn::Lanes(d);
  const Vec3V<V> local{hn::Set(d, offset.x), hn::Set(d, offset.y), hn::Set(d, offset.z)};
  for (std::size_t i = 0; i < n; i += N) {
    const Vec3V<V> p = LoadVec3(d, joint + 4 * stride, stride, i);
    const Vec3V<V> m = RotateSandwich(d, LoadQuat(d, joint, stride, i), local);
    StoreVec3(d, Vec3V<V>{hn::Add(p.x, m.x), hn::Add(p.y, m.y), hn::Add(p.z, m.z)}, point, stride,
              i);
  }
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(ForwardKinematicsJoint);
HWY_EXPORT(ForwardKinematicsSite);

void forward_kinematics_joint(const double* parent, const double* rotation,
                              const double* translation, Vec3 offset, double* joint, std::size_t n,
                              std::size_t stride) {
  HWY_DYNAMIC_DISPATCH(ForwardKinematicsJoint)
  (parent, rotation, translation, offset, joint, n, stride);
}

void forward_kinematics_site(const double* joint, Vec3 offset, double* point, std::size_t n,
                             std::size_t stride) {
  HWY_DYNAMIC_DISPATCH(ForwardKinematicsSite)(joint, offset, point, n, stride);
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
