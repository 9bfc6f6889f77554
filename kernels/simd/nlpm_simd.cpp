// nlpm's fast path (nlpm_simd.hpp): the vector kernels are compiled once per Highway target; the
// per-frame bookkeeping between them (box sums, weights) is plain double code, once.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/nlpm_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "hwy/highway.h"
#include "kernels/simd/nlpm_simd.hpp"
#include "kernels/simd/planes.hpp"
#include "kernels/simd/quat_simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {

void AccumulatePoseBand(const float* planes, std::size_t stride, std::size_t count, int max_delta,
                        float cap_squared, float* band) {
  const hn::ScalableTag<float> d;
  const std::size_t lanes = hn::Lanes(d);
  const auto cap = hn::Set(d, cap_squared);
  for (std::size_t u = 0; u < count; u += lanes) {
    const auto a = LoadQuat(d, planes, stride, u);
    for (std::size_t delta = 1; delta <= std::size_t(max_delta); ++delta) {
      const auto d2 = hn::Min(GeodesicSquared(d, a, LoadQuat(d, planes, stride, u + delta)), cap);
      float* row = band + (delta - 1) * stride + u;
      hn::StoreU(hn::Add(hn::LoadU(d, row), d2), d, row);
    }
  }
}

// Output frames i in [0, count) of one joint, whose curve `planes` starts `search` frames before
// the first output frame:
//   q'_i = q_i Exp( inv_sum_i sum_{delta != 0} weights[delta + K][i] Log(q_i^-1 q_{i+delta}) ).
// Rows of `weights` and inv_sum have stride `wstride`; out: 4 planes of `stride`.
void AverageTangent(const float* planes, std::size_t stride, std::size_t count, int search,
                    const float* weights, const float* inv_sum, std::size_t wstride, float* out) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t lanes = hn::Lanes(d), k = std::size_t(search);
  for (std::size_t i = 0; i < count; i += lanes) {
    const QuatV<V> qt = LoadQuat(d, planes, stride, i + k);
    Vec3V<V> acc{hn::Zero(d), hn::Zero(d), hn::Zero(d)};
    for (std::size_t s = 0; s <= 2 * k; ++s) {  // s = delta + K, delta = 0 adds Log(1) = 0
      if (s == k) continue;
      const V f = hn::LoadU(d, weights + s * wstride + i);
      const Vec3V<V> v = Log(d, InverseTimes(qt, LoadQuat(d, planes, stride, i + s)));
      acc = {hn::MulAdd(f, v.x, acc.x), hn::MulAdd(f, v.y, acc.y), hn::MulAdd(f, v.z, acc.z)};
    }
    const V scale = hn::LoadU(d, inv_sum + i);
    const Vec3V<V> mean{hn::Mul(acc.x, scale), hn::Mul(acc.y, scale), hn::Mul(acc.z, scale)};
    StoreQuat(d, Multiply(qt, Exp(d, mean)), out, stride, i);
  }
}

// The range form (nlpm.hpp) of AverageTangent: each sample's weight times its range term,
//   w = weights[delta + K][i] exp(neg_scale d^2),  d^2 = |Log(q_i^-1 q_{i+delta})|^2,
// normalised by their sum in the lane, which starts at the self weight weights[K][i].
// neg_scale = -1 / (2 range_sigma^2), which may be -inf (range_sigma^2 underflowed): d^2 = 0
// then still weighs f, as in the reference, and the exponent is clamped into Exp's valid range.
void AverageTangentRange(const float* planes, std::size_t stride, std::size_t count, int search,
                         const float* weights, float neg_scale, std::size_t wstride, float* out) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const std::size_t lanes = hn::Lanes(d), k = std::size_t(search);
  const V scale = hn::Set(d, neg_scale), lowest = hn::Set(d, std::numeric_limits<float>::lowest()),
          one = hn::Set(d, 1.0f);
  for (std::size_t i = 0; i < count; i += lanes) {
    const QuatV<V> qt = LoadQuat(d, planes, stride, i + k);
    Vec3V<V> acc{hn::Zero(d), hn::Zero(d), hn::Zero(d)};
    V sum = hn::LoadU(d, weights + k * wstride + i);
    for (std::size_t s = 0; s <= 2 * k; ++s) {
      if (s == k) continue;
      const Vec3V<V> v = Log(d, InverseTimes(qt, LoadQuat(d, planes, stride, i + s)));
      const V d2 = hn::MulAdd(v.z, v.z, hn::MulAdd(v.y, v.y, hn::Mul(v.x, v.x)));
      const V range = hn::IfThenElse(hn::Eq(d2, hn::Zero(d)), one,
                                     hn::Exp(d, hn::Max(hn::Mul(d2, scale), lowest)));
      const V f = hn::Mul(hn::LoadU(d, weights + s * wstride + i), range);
      acc = {hn::MulAdd(f, v.x, acc.x), hn::MulAdd(f, v.y, acc.y), hn::MulAdd(f, v.z, acc.z)};
      sum = hn::Add(sum, f);
    }
    // A frame's sum is at least its self weight f(t, t) = 1 (exactly, in float too); only the
    // padding lanes past `count`, whose weights are all 0, are raised to 1 here.
    const V inv = hn::Div(one, hn::Max(sum, one));
    const Vec3V<V> mean{hn::Mul(acc.x, inv), hn::Mul(acc.y, inv), hn::Mul(acc.z, inv)};
    StoreQuat(d, Multiply(qt, Exp(d, mean)), out, stride, i);
  }
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(AccumulatePoseBand);
HWY_EXPORT(AverageTangent);
HWY_EXPORT(AverageTangentRange);

void accumulate_pose_band(const float* planes, std::size_t stride, std::size_t count, int max_delta,
                          float cap_squared, float* band) {
  HWY_DYNAMIC_DISPATCH(AccumulatePoseBand)(planes, stride, count, max_delta, cap_squared, band);
}

namespace {

// Frames per pass over the band, as kernels/nlpm.cpp: whole anchor blocks.
constexpr long kChunkFrames = 16 * kNlpmAnchorFrames;

// Every joint's curve over the frames one chunk reads, [first, first + count), boundary-extended
// outside [0, F): 4 planes of `stride` per joint. Filled row by row, so that the transposition of
// the [F][J][4] tensor reads it sequentially, once per chunk, for the band and the averaging.
struct ChunkCurves {
  long first = 0;
  std::size_t count = 0, stride = 0;
  std::vector<std::vector<float>> joints;  // [J][4 * stride]

  void load(RotationView rotations, Boundary boundary, long from, std::size_t frames) {
    first = from;
    count = frames;
    stride = plane_size(count + kMaxLanes);
    joints.resize(std::size_t(rotations.joints));
    std::vector<float*> planes;
    for (auto& curve : joints) {
      curve.assign(4 * stride, 0.0f);
      std::fill_n(curve.begin(), stride, 1.0f);  // identities past the end
      for (std::size_t c = 0; c < 4; ++c) planes.push_back(curve.data() + c * stride);
    }
    const std::size_t width = planes.size();
    for (std::size_t i = 0; i < count; ++i) {
      const long t = first + long(i);
      if (t >= 0 && t < rotations.frames) {
        const float* row = rotations.at(int(t), 0);
        for (std::size_t k = 0; k < width; ++k) planes[k][i] = row[k];
        continue;
      }
      for (int j = 0; j < rotations.joints; ++j) {
        float q[4];
        store_quat(extended_rotation(rotations, j, t, boundary), q);
        for (std::size_t c = 0; c < 4; ++c) planes[4 * std::size_t(j) + c][i] = q[c];
      }
    }
  }

  const float* at(int joint, long t) const {
    return joints[std::size_t(joint)].data() + std::size_t(t - first);
  }
};

// The distance joints' squared distances summed, then E[u][delta] = e(u, u + delta) in double,
// for u in [u_begin, u_end), 0 <= delta <= K; the lower half by symmetry.
class Band {
 public:
  void compute(const ChunkCurves& curves, const std::vector<int>& joints, long u_begin, long u_end,
               int search, double distance_cap) {
    const float cap_squared = distance_cap > 0 ? float(distance_cap * distance_cap)
                                               : std::numeric_limits<float>::infinity();
    u_begin_ = u_begin;
    const std::size_t count = std::size_t(u_end - u_begin);
    sums_.assign(std::size_t(search) * curves.stride, 0.0f);
    // In joint order, so that every e(u, v) sums its joints in the same order whatever the chunk.
    for (int joint : joints)
      accumulate_pose_band(curves.at(joint, u_begin), curves.stride, count, search, cap_squared,
                           sums_.data());
    width_ = std::size_t(search) + 1;
    values_.resize(count * width_);
    const double joint_count = double(joints.size());
    for (std::size_t u = 0; u < count; ++u) {
      values_[u * width_] = 0.0;  // e(u, u)
      for (std::size_t delta = 1; delta < width_; ++delta)
        values_[u * width_ + delta] = double(sums_[(delta - 1) * curves.stride + u]) / joint_count;
    }
  }

  double at(long u, int delta) const {
    if (delta < 0) {
      u += delta;
      delta = -delta;
    }
    return values_[std::size_t(u - u_begin_) * width_ + std::size_t(delta)];
  }

 private:
  std::vector<float> sums_;
  std::vector<double> values_;
  long u_begin_ = 0;
  std::size_t width_ = 0;
};

// The weights of frame t from its patch sums, as kernels/nlpm.cpp's window_weights: f(t, s) for s
// in the window (0 outside [0, F)), the self weight max_{s != t} f, and their sum.
double window_weights(long t, long frames, int search, int patch, double h,
                      const std::vector<double>& sums, double* f) {
  const long s_begin = std::max(0L, t - search), s_end = std::min(frames, t + search + 1);
  const double patch_frames = 2.0 * patch + 1.0;
  double d_min = INFINITY;
  for (long s = s_begin; s < s_end; ++s)
    if (s != t) d_min = std::min(d_min, sums[std::size_t(s - t + search)] / patch_frames);
  const double two_h2 = 2.0 * h * h;
  double self = 0, sum = 0;
  std::fill(f, f + 2 * search + 1, 0.0);
  for (long s = s_begin; s < s_end; ++s) {
    if (s == t) continue;
    const double excess = sums[std::size_t(s - t + search)] / patch_frames - d_min;
    const double w = excess == 0 ? 1.0 : std::exp(-excess / two_h2);
    f[s - t + search] = w;
    self = std::max(self, w);
    sum += w;
  }
  f[search] = self;
  return sum + self;
}

// The weights of one chunk's output frames [begin, end).
struct ChunkWeights {
  std::size_t wstride = 0;
  std::vector<double> f;       // [frame][2K + 1], the weights in double
  std::vector<float> rows;     // [2K + 1][wstride], for the vector average
  std::vector<float> inv_sum;  // [wstride]
  std::vector<double> inv_sum_d;
};

// Output frames [begin, end) of io's joints. The window of a frame near the clip's ends reaches
// extended frames: their weight is 0, and they are unit quaternions, so their Log stays finite.
void average_chunk(const NlpmJob& job, int search, long begin, long end, const ChunkWeights& w,
                   const ChunkCurves& curves, std::vector<std::vector<float>>& out) {
  const MotionIO& io = job.io;
  const std::size_t count = std::size_t(end - begin);
  out.resize(std::size_t(io.joint_stop() - io.joint_begin));
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    std::vector<float>& result = out[std::size_t(j - io.joint_begin)];
    result.resize(4 * curves.stride);
    if (job.params.range_sigma > 0) {
      const double range_sigma = job.params.range_sigma;
      HWY_DYNAMIC_DISPATCH(AverageTangentRange)
      (curves.at(j, begin - search), curves.stride, count, search, w.rows.data(),
       float(-1.0 / (2.0 * range_sigma * range_sigma)), w.wstride, result.data());
    } else {
      HWY_DYNAMIC_DISPATCH(AverageTangent)
      (curves.at(j, begin - search), curves.stride, count, search, w.rows.data(), w.inv_sum.data(),
       w.wstride, result.data());
    }
  }
  std::vector<const float*> planes;
  for (const auto& result : out)
    for (std::size_t c = 0; c < 4; ++c) planes.push_back(result.data() + c * curves.stride);
  for (std::size_t i = 0; i < count; ++i) {
    float* row = io.filtered_rotations.at(int(begin + long(i)), io.joint_begin);
    for (std::size_t k = 0; k < planes.size(); ++k) row[k] = planes[k][i];
  }
}

}  // namespace

void nlpm_tangent(const NlpmJob& job) {
  const MotionIO& io = job.io;
  const NlpmParams& params = job.params;
  const long frames = io.rotations.frames, frame_begin = io.frame_begin,
             frame_end = io.frame_stop();
  const int search = int(std::min<long>(params.search_radius, frames - 1));
  const int patch = params.patch_radius;
  const std::size_t width = 2 * std::size_t(search) + 1;
  const std::vector<int> joints = nlpm_distance_joints(job.distance_joints, io.rotations.joints);
  ChunkCurves curves;
  Band band;
  ChunkWeights w;
  std::vector<double> sums(width);
  std::vector<std::vector<float>> out;
  const long first_anchor = frame_begin / kNlpmAnchorFrames * kNlpmAnchorFrames;
  for (long chunk = first_anchor; chunk < frame_end; chunk += kChunkFrames) {
    const long chunk_end = std::min(chunk + kChunkFrames, frame_end);
    // As kernels/nlpm.cpp: D(t, t + delta) for t in the chunk reads E[u][delta] for u in
    // [t - P, t + P], and through symmetry down to u = chunk - P - K; E[u][delta] reads frame
    // u + delta. The averaging reads [t - K, t + K], inside the same range.
    const long u_begin = chunk - patch - search, u_end = chunk_end + patch;
    curves.load(io.rotations, params.boundary, u_begin, std::size_t(u_end + search - u_begin));
    band.compute(curves, joints, u_begin, u_end, search, params.distance_cap);
    const long out_begin = std::max(chunk, frame_begin);
    const std::size_t count = std::size_t(chunk_end - out_begin);
    w.wstride = plane_size(count);
    w.f.assign(count * width, 0.0);
    w.rows.assign(width * w.wstride, 0.0f);
    w.inv_sum.assign(w.wstride, 0.0f);
    w.inv_sum_d.assign(count, 0.0);
    for (long anchor = chunk; anchor < chunk_end; anchor += kNlpmAnchorFrames) {
      const long block_end = std::min(anchor + kNlpmAnchorFrames, chunk_end);
      for (int delta = -search; delta <= search; ++delta) {
        double sum = 0;
        for (long u = anchor - patch; u <= anchor + patch; ++u) sum += band.at(u, delta);
        sums[std::size_t(delta + search)] = sum;
      }
      for (long t = anchor; t < block_end; ++t) {
        if (t >= frame_begin) {
          const std::size_t i = std::size_t(t - out_begin);
          double* f = &w.f[i * width];
          const double total = window_weights(t, frames, search, patch, params.h, sums, f);
          w.inv_sum_d[i] = 1.0 / total;
          w.inv_sum[i] = float(w.inv_sum_d[i]);
          for (std::size_t s = 0; s < width; ++s) w.rows[s * w.wstride + i] = float(f[s]);
        }
        if (t + 1 < block_end)
          for (int delta = -search; delta <= search; ++delta)
            sums[std::size_t(delta + search)] +=
                band.at(t + 1 + patch, delta) - band.at(t - patch, delta);
      }
    }
    average_chunk(job, search, out_begin, chunk_end, w, curves, out);
  }
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
