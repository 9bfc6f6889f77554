// FootLockJob's fast path kernels (foot_lock_simd.hpp), compiled once per Highway target. Lanes =
// touched frames of one leg, in double; every lane takes the same formula whatever its
// neighbours do, so a frame's result does not depend on which frames share its vector.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/foot_lock_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <cstddef>
#include <cstring>

#include "hwy/contrib/math/math-inl.h"
#include "hwy/highway.h"
#include "kernels/simd/foot_lock_simd.hpp"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

template <class V>
HWY_INLINE Vec3V<V> Cross(Vec3V<V> a, Vec3V<V> b) {
  return {hn::MulSub(a.y, b.z, hn::Mul(a.z, b.y)), hn::MulSub(a.z, b.x, hn::Mul(a.x, b.z)),
          hn::MulSub(a.x, b.y, hn::Mul(a.y, b.x))};
}
template <class V>
HWY_INLINE V Dot(Vec3V<V> a, Vec3V<V> b) {
  return hn::MulAdd(a.z, b.z, hn::MulAdd(a.y, b.y, hn::Mul(a.x, b.x)));
}
template <class V>
HWY_INLINE Vec3V<V> Add(Vec3V<V> a, Vec3V<V> b) {
  return {hn::Add(a.x, b.x), hn::Add(a.y, b.y), hn::Add(a.z, b.z)};
}
template <class V>
HWY_INLINE QuatV<V> Conj(QuatV<V> q) {
  return {q.w, hn::Neg(q.x), hn::Neg(q.y), hn::Neg(q.z)};
}
template <class V>
HWY_INLINE QuatV<V> Scale(QuatV<V> q, V s) {
  return {hn::Mul(q.w, s), hn::Mul(q.x, s), hn::Mul(q.y, s), hn::Mul(q.z, s)};
}

// q v q^-1 for a unit q: v + 2 w (r x v) + 2 r x (r x v) (foot_lock.cpp's rotate_unit).
template <class D, class V = hn::Vec<D>>
HWY_INLINE Vec3V<V> RotateUnit(D d, QuatV<V> q, Vec3V<V> v) {
  const Vec3V<V> r{q.x, q.y, q.z};
  const V two = hn::Set(d, 2.0);
  Vec3V<V> t = Cross(r, v);
  t = {hn::Mul(two, t.x), hn::Mul(two, t.y), hn::Mul(two, t.z)};
  const Vec3V<V> rt = Cross(r, t);
  return {hn::Add(hn::MulAdd(q.w, t.x, v.x), rt.x), hn::Add(hn::MulAdd(q.w, t.y, v.y), rt.y),
          hn::Add(hn::MulAdd(q.w, t.z, v.z), rt.z)};
}

void GatherRotations(const float* data, std::size_t frame_floats, const int* frames, std::size_t n,
                     const int* joints, std::size_t count, double* out, std::size_t stride) {
  std::size_t i = 0;
#if HWY_TARGET != HWY_SCALAR
  // Four frames of one joint at a time: a 4 x 4 transpose, then each component's four values
  // widened to double, two stores per component instead of four.
  const hn::FixedTag<float, 4> df;
  const hn::FixedTag<float, 2> dh;
  const hn::FixedTag<double, 2> dd;
  for (; i + 4 <= n; i += 4) {
    const float* rows[4] = {data + std::size_t(frames[i]) * frame_floats,
                            data + std::size_t(frames[i + 1]) * frame_floats,
                            data + std::size_t(frames[i + 2]) * frame_floats,
                            data + std::size_t(frames[i + 3]) * frame_floats};
    for (std::size_t s = 0; s < count; ++s) {
      const std::size_t at = 4 * std::size_t(joints[s]);
      const auto a = hn::LoadU(df, rows[0] + at), b = hn::LoadU(df, rows[1] + at),
                 c = hn::LoadU(df, rows[2] + at), e = hn::LoadU(df, rows[3] + at);
      const auto ab_lo = hn::InterleaveLower(df, a, b), ab_hi = hn::InterleaveUpper(df, a, b),
                 ce_lo = hn::InterleaveLower(df, c, e), ce_hi = hn::InterleaveUpper(df, c, e);
      const hn::Vec<decltype(df)> parts[4] = {
          hn::ConcatLowerLower(df, ce_lo, ab_lo), hn::ConcatUpperUpper(df, ce_lo, ab_lo),
          hn::ConcatLowerLower(df, ce_hi, ab_hi), hn::ConcatUpperUpper(df, ce_hi, ab_hi)};
      for (std::size_t k = 0; k < 4; ++k) {
        double* plane = out + (4 * s + k) * stride + i;
        hn::StoreU(hn::PromoteTo(dd, hn::LowerHalf(dh, parts[k])), dd, plane);
        hn::StoreU(hn::PromoteTo(dd, hn::UpperHalf(dh, parts[k])), dd, plane + 2);
      }
    }
  }
#endif
  for (; i < n; ++i)
    for (std::size_t s = 0; s < count; ++s) {
      const float* r = data + std::size_t(frames[i]) * frame_floats + 4 * std::size_t(joints[s]);
      for (std::size_t k = 0; k < 4; ++k) out[(4 * s + k) * stride + i] = r[k];
    }
}

void ChainStep(const double* parent_rot, const double* parent_pos, const double* q,
               const double* local, Vec3 offset, double* rot, double* pos, std::size_t n,
               std::size_t stride) {
  const hn::ScalableTag<double> d;
  const std::size_t N = hn::Lanes(d);
  for (std::size_t i = 0; i < n; i += N) {
    const auto rp = LoadQuat(d, parent_rot, stride, i);
    const auto l = local != nullptr
                       ? LoadVec3(d, local, stride, i)
                       : Vec3V<hn::Vec<decltype(d)>>{hn::Set(d, offset.x), hn::Set(d, offset.y),
                                                     hn::Set(d, offset.z)};
    StoreQuat(d, Multiply(rp, LoadQuat(d, q, stride, i)), rot, stride, i);
    StoreVec3(d, Add(LoadVec3(d, parent_pos, stride, i), RotateUnit(d, rp, l)), pos, stride, i);
  }
}

void AcosPlanes(const double* in, double* out, std::size_t n) {
  const hn::ScalableTag<double> d;
  const std::size_t N = hn::Lanes(d);
  const auto one = hn::Set(d, 1.0), minus_one = hn::Set(d, -1.0);
  for (std::size_t i = 0; i < n; i += N)
    hn::StoreU(hn::Acos(d, hn::Min(hn::Max(hn::LoadU(d, in + i), minus_one), one)), d, out + i);
}

void LegGeometryPlanes(const LegGeometry& g, double max_reach, double lift, std::size_t n,
                       std::size_t stride) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t N = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0), minus_one = hn::Set(d, -1.0),
          reach_fraction = hn::Set(d, max_reach), tiny = hn::Set(d, 1e-9),
          lowest = hn::Set(d, -lift), highest = hn::Set(d, lift);
  for (std::size_t i = 0; i < n; i += N) {
    const Vec3V<V> hip = LoadVec3(d, g.hip, stride, i), knee = LoadVec3(d, g.knee, stride, i),
                   ankle = LoadVec3(d, g.ankle, stride, i);
    const Vec3V<V> u{hn::Sub(knee.x, hip.x), hn::Sub(knee.y, hip.y), hn::Sub(knee.z, hip.z)};
    const Vec3V<V> v{hn::Sub(ankle.x, knee.x), hn::Sub(ankle.y, knee.y), hn::Sub(ankle.z, knee.z)};
    const Vec3V<V> w{hn::Sub(ankle.x, hip.x), hn::Sub(ankle.y, hip.y), hn::Sub(ankle.z, hip.z)};
    const V uu = Dot(u, u), vv = Dot(v, v), ww = Dot(w, w);
    const V l1 = hn::Sqrt(uu), l2 = hn::Sqrt(vv), sum = hn::Add(l1, l2);
    const V reach = hn::Min(sum, hn::Max(hn::Mul(reach_fraction, sum), hn::Sqrt(ww)));
    const auto lengths = hn::And(hn::Gt(l1, zero), hn::Gt(l2, zero));
    const V c = hn::Min(hn::Max(hn::Div(hn::Neg(Dot(u, v)), hn::Mul(l1, l2)), minus_one), one);
    const V cos_f = hn::IfThenElse(lengths, c, one);
    hn::StoreU(cos_f, d, g.cos_f + i);
    hn::StoreU(hn::IfThenElseZero(lengths, hn::Acos(d, cos_f)), d, g.theta_f + i);
    const Vec3V<V> n3 = Cross(u, w);
    const V cn = hn::Sqrt(Dot(n3, n3));
    const auto bent = hn::Gt(cn, hn::Mul(tiny, hn::Add(uu, vv)));
    const V inv = hn::IfThenElseZero(bent, hn::Div(one, cn));
    StoreVec3(d, u, g.u, stride, i);
    StoreVec3(d, v, g.v, stride, i);
    hn::StoreU(l1, d, g.len + i);
    hn::StoreU(l2, d, g.len + stride + i);
    hn::StoreU(reach, d, g.len + 2 * stride + i);
    StoreVec3(d, Vec3V<V>{hn::Mul(n3.x, inv), hn::Mul(n3.y, inv), hn::Mul(n3.z, inv)}, g.normal,
              stride, i);
    hn::StoreU(hn::IfThenElseZero(bent, one), d, g.bent + i);
    Vec3V<V> to{hn::Add(w.x, hn::LoadU(d, g.ox + i)), w.y, hn::Add(w.z, hn::LoadU(d, g.oz + i))};
    if (lift > 0) {  // target_lift in kernels/foot_lock.cpp
      const V horizontal2 = hn::MulAdd(to.x, to.x, hn::Mul(to.z, to.z));
      const V height = hn::Sqrt(hn::Max(hn::Sub(ww, horizontal2), zero));
      const V level = hn::IfThenElse(hn::Ge(w.y, zero), height, hn::Neg(height));
      const V rise = hn::IfThenElseZero(hn::Gt(ww, horizontal2), hn::Sub(level, w.y));
      to.y = hn::Add(w.y, hn::Min(hn::Max(rise, lowest), highest));
    }
    StoreVec3(d, to, g.to_target, stride, i);
    hn::StoreU(Dot(to, to), d, g.distance + i);
  }
}

// Whether any of the lanes [i, i + N) ∩ [0, n) is solved: LegKneeCosine and LegIk skip the same
// whole vectors (a leg's frames touched only for the other leg's contacts).
HWY_INLINE bool AnySolved(const unsigned char* solve, std::size_t i, std::size_t N, std::size_t n) {
  for (std::size_t j = i; j < i + N && j < n; ++j)
    if (solve[j]) return true;
  return false;
}

void LegKneeCosine(double* to_target, const double* drop, const double* len, double* cos1,
                   double* theta1, const unsigned char* solve, std::size_t n, std::size_t stride) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t N = hn::Lanes(d);
  const V one = hn::Set(d, 1.0), minus_one = hn::Set(d, -1.0), tiny = hn::Set(d, 1e-9);
  for (std::size_t i = 0; i < n; i += N) {
    if (!AnySolved(solve, i, N, n)) continue;
    const V y = hn::Add(hn::LoadU(d, to_target + stride + i), hn::LoadU(d, drop + i));
    hn::StoreU(y, d, to_target + stride + i);
    const Vec3V<V> to{hn::LoadU(d, to_target + i), y, hn::LoadU(d, to_target + 2 * stride + i)};
    const V l1 = hn::LoadU(d, len + i), l2 = hn::LoadU(d, len + stride + i),
            reach = hn::LoadU(d, len + 2 * stride + i);
    const V shortest = hn::MulAdd(tiny, hn::Add(l1, l2), hn::Abs(hn::Sub(l1, l2)));
    const V dist = hn::Min(hn::Max(hn::Sqrt(Dot(to, to)), shortest), reach);
    const V c = hn::Div(hn::NegMulAdd(dist, dist, hn::MulAdd(l1, l1, hn::Mul(l2, l2))),
                        hn::Mul(hn::Add(l1, l1), l2));
    const V clamped = hn::Min(hn::Max(c, minus_one), one);
    hn::StoreU(clamped, d, cos1 + i);
    hn::StoreU(hn::Acos(d, clamped), d, theta1 + i);
  }
}

void LegIk(const LegIkPlanes& io, std::size_t n, std::size_t stride) {
  const hn::ScalableTag<double> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t N = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, 1.0), half = hn::Set(d, 0.5),
          minus_one = hn::Set(d, -1.0);
  const hn::Rebind<float, decltype(d)> df;
  HWY_ALIGN float lanes[4 * HWY_MAX_BYTES / sizeof(double)];
  for (std::size_t i = 0; i < n; i += N) {
    if (!AnySolved(io.solve, i, N, n)) continue;
    // The knee's turn about the normal by theta0 - theta1 from the two cosines (turn_between).
    const V c0 = hn::LoadU(d, io.cos0 + i), c1 = hn::LoadU(d, io.cos1 + i);
    const V s0 = hn::Sqrt(hn::Max(zero, hn::NegMulAdd(c0, c0, one))),
            s1 = hn::Sqrt(hn::Max(zero, hn::NegMulAdd(c1, c1, one)));
    const V cd = hn::Min(hn::Max(hn::MulAdd(c0, c1, hn::Mul(s0, s1)), minus_one), one);
    const V sd = hn::MulSub(s0, c1, hn::Mul(c0, s1));
    const V ch = hn::Sqrt(hn::Mul(half, hn::Add(one, cd)));
    // sin(delta / 2) from sin(delta) where the half angle is below 60 degrees, else from cos
    // delta; the second square root only when a lane needs it (each lane's formula is its own).
    const auto small_turn = hn::Gt(ch, half);
    V sh = hn::Div(sd, hn::Add(ch, ch));
    if (!hn::AllTrue(d, small_turn))
      sh = hn::IfThenElse(small_turn, sh,
                          hn::CopySign(hn::Sqrt(hn::Mul(half, hn::Sub(one, cd))), sd));
    const Vec3V<V> axis = LoadVec3(d, io.normal, stride, i);
    const QuatV<V> knee_turn{ch, hn::Mul(sh, axis.x), hn::Mul(sh, axis.y), hn::Mul(sh, axis.z)};
    // The hip's shortest arc from the bent ankle onto the target (rotation_between).
    const Vec3V<V> a =
        Add(LoadVec3(d, io.u, stride, i), RotateUnit(d, knee_turn, LoadVec3(d, io.v, stride, i)));
    const Vec3V<V> b = LoadVec3(d, io.to_target, stride, i);
    const V nn = hn::Sqrt(hn::Mul(Dot(a, a), Dot(b, b)));
    const V w = hn::Add(nn, Dot(a, b));
    const Vec3V<V> c = Cross(a, b);
    const V inv = hn::Div(one, hn::Sqrt(hn::MulAdd(w, w, Dot(c, c))));
    QuatV<V> swing{hn::Mul(w, inv), hn::Mul(c.x, inv), hn::Mul(c.y, inv), hn::Mul(c.z, inv)};
    const auto opposite = hn::Lt(w, hn::Mul(hn::Set(d, 1e-12), nn));
    if (!hn::AllFalse(d, opposite)) {  // any axis perpendicular to a
      const auto use_x = hn::Lt(hn::Abs(a.x), hn::Mul(hn::Set(d, 0.9), hn::Sqrt(Dot(a, a))));
      const Vec3V<V> e{hn::IfThenElseZero(use_x, one), hn::IfThenZeroElse(use_x, one), zero};
      Vec3V<V> p = Cross(a, e);
      const V pinv = hn::Div(one, hn::Sqrt(Dot(p, p)));
      swing = {hn::IfThenElse(opposite, zero, swing.w),
               hn::IfThenElse(opposite, hn::Mul(p.x, pinv), swing.x),
               hn::IfThenElse(opposite, hn::Mul(p.y, pinv), swing.y),
               hn::IfThenElse(opposite, hn::Mul(p.z, pinv), swing.z)};
    }
    const auto degenerate = hn::Not(hn::Gt(nn, zero));
    swing = {hn::IfThenElse(degenerate, one, swing.w), hn::IfThenZeroElse(degenerate, swing.x),
             hn::IfThenZeroElse(degenerate, swing.y), hn::IfThenZeroElse(degenerate, swing.z)};
    // R_hip' = Q_h R_hip, R_knee' = Q_h Q_k R_knee, R_ankle' kept; as local rotations.
    const QuatV<V> parent = LoadQuat(d, io.parent, stride, i), hip = LoadQuat(d, io.hip, stride, i),
                   knee = LoadQuat(d, io.knee, stride, i), ankle = LoadQuat(d, io.ankle, stride, i);
    const QuatV<V> hip_global = Multiply(swing, hip);
    const QuatV<V> knee_global = Multiply(Multiply(swing, knee_turn), knee);
    const QuatV<V> out[3] = {Multiply(Conj(parent), hip_global),
                             Multiply(Conj(hip_global), knee_global),
                             Multiply(Conj(knee_global), ankle)};
    // Normalized: products of float-stored unit quaternions, so |q|^2 = 1 + e with |e| of the
    // order of float's epsilon, where 1 / sqrt(1 + e) = 1 - e/2 + 3e^2/8 - 5e^3/16 is exact in
    // double (next term ~e^4); a lane farther from unit length takes the division.
    const V limit = hn::Set(d, 1e-4), k1 = hn::Set(d, -0.5), k2 = hn::Set(d, 0.375),
            k3 = hn::Set(d, -0.3125);
    for (int k = 0; k < 3; ++k) {
      const QuatV<V>& q = out[k];
      const V e = hn::Sub(
          hn::MulAdd(q.z, q.z, hn::MulAdd(q.y, q.y, hn::MulAdd(q.x, q.x, hn::Mul(q.w, q.w)))), one);
      V scale = hn::MulAdd(hn::MulAdd(hn::MulAdd(k3, e, k2), e, k1), e, one);
      const auto near = hn::Lt(hn::Abs(e), limit);
      if (!hn::AllTrue(d, near))
        scale = hn::IfThenElse(near, scale, hn::Div(one, hn::Sqrt(hn::Add(e, one))));
      QuatV<V> r = Scale(q, scale);
      const QuatV<V> o = LoadQuat(d, io.original[k], stride, i);
      const auto flip =
          hn::Lt(hn::Add(hn::Add(hn::Add(hn::Mul(r.w, o.w), hn::Mul(r.x, o.x)), hn::Mul(r.y, o.y)),
                         hn::Mul(r.z, o.z)),
                 zero);
      r = {hn::IfThenElse(flip, hn::Neg(r.w), r.w), hn::IfThenElse(flip, hn::Neg(r.x), r.x),
           hn::IfThenElse(flip, hn::Neg(r.y), r.y), hn::IfThenElse(flip, hn::Neg(r.z), r.z)};
      // As floats, interleaved: one 16-byte copy per frame into the tensor.
      hn::StoreInterleaved4(hn::DemoteTo(df, r.w), hn::DemoteTo(df, r.x), hn::DemoteTo(df, r.y),
                            hn::DemoteTo(df, r.z), df, lanes);
      for (std::size_t j = 0; j < N && i + j < n; ++j) {
        if (!io.solve[i + j]) continue;
        std::memcpy(io.rotations + std::size_t(io.frames[i + j]) * io.frame_floats +
                        4 * std::size_t(io.joints[k]),
                    lanes + 4 * j, 4 * sizeof(float));
      }
    }
  }
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(ChainStep);
HWY_EXPORT(GatherRotations);

void gather_rotations(const float* data, std::size_t frame_floats, const int* frames, std::size_t n,
                      const int* joints, std::size_t count, double* out, std::size_t stride) {
  HWY_DYNAMIC_DISPATCH(GatherRotations)(data, frame_floats, frames, n, joints, count, out, stride);
}
HWY_EXPORT(AcosPlanes);
HWY_EXPORT(LegIk);
HWY_EXPORT(LegGeometryPlanes);
HWY_EXPORT(LegKneeCosine);

void leg_geometry(const LegGeometry& g, double max_reach, double lift, std::size_t n,
                  std::size_t stride) {
  HWY_DYNAMIC_DISPATCH(LegGeometryPlanes)(g, max_reach, lift, n, stride);
}

void leg_knee_cosine(double* to_target, const double* drop, const double* len, double* cos1,
                     double* theta1, const unsigned char* solve, std::size_t n,
                     std::size_t stride) {
  HWY_DYNAMIC_DISPATCH(LegKneeCosine)(to_target, drop, len, cos1, theta1, solve, n, stride);
}

void chain_step(const double* parent_rot, const double* parent_pos, const double* q,
                const double* local, Vec3 offset, double* rot, double* pos, std::size_t n,
                std::size_t stride) {
  HWY_DYNAMIC_DISPATCH(ChainStep)(parent_rot, parent_pos, q, local, offset, rot, pos, n, stride);
}

void acos_planes(const double* in, double* out, std::size_t n) {
  HWY_DYNAMIC_DISPATCH(AcosPlanes)(in, out, n);
}

void leg_ik(const LegIkPlanes& k, std::size_t n, std::size_t stride) {
  HWY_DYNAMIC_DISPATCH(LegIk)(k, n, stride);
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
