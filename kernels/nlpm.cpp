#include "kernels/nlpm.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/format.hpp"
#include "kernels/simd/nlpm_simd.hpp"
#include "kernels/translation_filter.hpp"

namespace mocap {
namespace {

// Frames per pass over the band: a whole number of anchor blocks, so chunking changes nothing but
// memory ((chunk + 2P + 2K) x J_d samples at a time).
constexpr long kChunkFrames = 16 * kNlpmAnchorFrames;
static_assert(kChunkFrames % kNlpmAnchorFrames == 0);

// The translations of io's slice (nlpm.hpp, "Translations"): the Gaussian of
// translation_sigma_t frames on the joints with position channels, a copy elsewhere (and
// everywhere when translation_sigma_t is 0).
void filter_translations(const MotionIO& io, const NlpmParams& params) {
  if (!io.has_translations()) return;
  const int frames = io.translations.frames;
  const int begin = io.frame_begin, end = io.frame_stop();
  const std::size_t n = static_cast<std::size_t>(frames);
  std::vector<Vec3> path(n), path_out(n);
  CurveScratch scratch;
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    const bool filtered =
        io.translated_joints[std::size_t(j)] != 0 && params.translation_sigma_t > 0 && frames > 1;
    if (!filtered) {
      for (int t = begin; t < end; ++t)
        std::copy_n(io.translations.at(t, j), 3, io.filtered_translations.at(t, j));
      continue;
    }
    for (int t = 0; t < frames; ++t) path[std::size_t(t)] = load_vec3(io.translations.at(t, j));
    bilateral_filter_translations(path, params.translation_sigma_t, INFINITY,
                                  params.translation_reach(), 1, params.boundary, path_out, begin,
                                  end, scratch);
    for (int t = begin; t < end; ++t)
      store_vec3(path_out[std::size_t(t)], io.filtered_translations.at(t, j));
  }
}

// A one-frame clip has no s != t: its output is its input.
void copy_slice(const MotionIO& io) {
  for (int t = io.frame_begin; t < io.frame_stop(); ++t)
    for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
      std::copy_n(io.rotations.at(t, j), 4, io.filtered_rotations.at(t, j));
      if (io.has_translations())
        std::copy_n(io.translations.at(t, j), 3, io.filtered_translations.at(t, j));
    }
}

// The weights f(t, s) of spec "nlpm" from the patch distances D(t, t + delta) = sums[delta + K] /
// (2P+1) of frame t's window [s_begin, s_end); returns their sum.
double window_weights(long t, long s_begin, long s_end, int search, int patch, double h,
                      const std::vector<double>& sums, std::vector<double>& weights) {
  const double patch_frames = 2.0 * patch + 1.0;
  double d_min = INFINITY;
  for (long s = s_begin; s < s_end; ++s)
    if (s != t) d_min = std::min(d_min, sums[std::size_t(s - t + search)] / patch_frames);
  const double two_h2 = 2.0 * h * h;
  double self = 0, sum = 0;
  for (long s = s_begin; s < s_end; ++s) {
    if (s == t) continue;
    const double excess = sums[std::size_t(s - t + search)] / patch_frames - d_min;
    // excess == 0 stays exactly 1 even if 2 h^2 underflowed to 0.
    const double f = excess == 0 ? 1.0 : std::exp(-excess / two_h2);
    weights[std::size_t(s - s_begin)] = f;
    self = std::max(self, f);
    sum += f;
  }
  weights[std::size_t(t - s_begin)] = self;  // the paper's self-weight rule
  return sum + self;
}

// The range form's q'[t][j] (nlpm.hpp): the weights f(t, s) times exp(-d^2 / (2 range_sigma^2)),
// d = |Log(q_t^-1 q_s)| the geodesic distance (Log's atan2 keeps small angles accurate), the self
// weight f(t, t) as it is.
Quat range_mean(const MotionIO& io, int j, long t, long s_begin, long s_end, double range_sigma,
                const std::vector<double>& weights) {
  const Quat qt = load_quat(io.rotations.at(int(t), j));
  const Quat qt_inv = inverse(qt);
  const double neg_inv_two_sigma2 = -1.0 / (2.0 * range_sigma * range_sigma);
  double weight_sum = weights[std::size_t(t - s_begin)];
  Vec3 acc;
  for (long s = s_begin; s < s_end; ++s) {
    if (s == t) continue;
    const Vec3 v = log(qt_inv * load_quat(io.rotations.at(int(s), j)));
    const double d2 = dot(v, v);
    // d2 == 0 stays exactly f even if 1 / (2 sigma^2) overflowed to infinity.
    const double w =
        weights[std::size_t(s - s_begin)] * (d2 == 0 ? 1.0 : std::exp(d2 * neg_inv_two_sigma2));
    acc += w * v;
    weight_sum += w;
  }
  return qt * exp((1.0 / weight_sum) * acc);
}

// Output frame t of the job's joint slice from the window's weights.
void write_frame(const NlpmJob& job, long t, long s_begin, long s_end,
                 const std::vector<double>& weights, double weight_sum) {
  const MotionIO& io = job.io;
  const double inv_sum = 1.0 / weight_sum;
  const int frame = int(t);
  for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
    const Quat qt = load_quat(io.rotations.at(frame, j));
    Vec3 acc;
    Quat out;
    if (job.params.range_sigma > 0) {
      out = range_mean(io, j, t, s_begin, s_end, job.params.range_sigma, weights);
    } else if (job.params.space == NlpmSpace::tangent) {
      const Quat qt_inv = inverse(qt);
      for (long s = s_begin; s < s_end; ++s) {
        if (s == t) continue;  // Log(q_t^-1 q_t) = 0
        const Quat qs = load_quat(io.rotations.at(int(s), j));
        acc += weights[std::size_t(s - s_begin)] * log(qt_inv * qs);
      }
      out = qt * exp(inv_sum * acc);
    } else {
      for (long s = s_begin; s < s_end; ++s)
        acc += weights[std::size_t(s - s_begin)] * log(load_quat(io.rotations.at(int(s), j)));
      out = exp(inv_sum * acc);
      if (dot(out, qt) < 0) out = negate(out);  // keep the input's hemisphere
    }
    store_quat(out, io.filtered_rotations.at(frame, j));
  }
}

// Calls visit(t, sums) for t = frame_begin, ..., frame_end - 1 in turn, with
// sums[delta + K'] = (2P+1) D(t, t + delta) for |delta| <= K' = min(K, F - 1) (F >= 2).
// This is where the determinism contract lives: D(t, .) depends on t's anchor block only.
template <class Visit>
void for_each_patch_sum(const NlpmParams& params, RotationView rotations,
                        const std::vector<int>& joints, long frame_begin, long frame_end,
                        Visit&& visit) {
  // Only s in [0, F) take part, so |delta| <= F - 1 whatever K says; D itself does not depend on K.
  const int search = std::min(params.search_radius, rotations.frames - 1);
  const int patch = params.patch_radius;
  PoseTrack track;
  PoseDistanceBand band;
  std::vector<double> sums(2 * std::size_t(search) + 1);
  const long first_anchor = frame_begin / kNlpmAnchorFrames * kNlpmAnchorFrames;
  for (long chunk = first_anchor; chunk < frame_end; chunk += kChunkFrames) {
    const long chunk_end = std::min(chunk + kChunkFrames, frame_end);
    // D(t, t + delta) for t in the chunk reads E[u][delta] for u in [t - P, t + P], and through
    // symmetry E[u + delta][-delta] down to u + delta = chunk - P - K.
    const long u_begin = chunk - patch - search, u_end = chunk_end + patch;
    track.load(rotations, joints, params.boundary, params.space, u_begin, u_end - u_begin + search,
               params.distance_cap);
    band.compute(track, u_begin, u_end, search);

    for (long anchor = chunk; anchor < chunk_end; anchor += kNlpmAnchorFrames) {
      const long block_end = std::min(anchor + kNlpmAnchorFrames, chunk_end);
      // A fresh, explicit patch sum at each anchor: the sum at t depends on t's anchor only.
      for (int delta = -search; delta <= search; ++delta) {
        double sum = 0;
        for (long u = anchor - patch; u <= anchor + patch; ++u) sum += band.at(u, delta);
        sums[std::size_t(delta + search)] = sum;
      }
      for (long t = anchor; t < block_end; ++t) {
        if (t >= frame_begin) visit(t, sums);
        if (t + 1 < block_end)
          for (int delta = -search; delta <= search; ++delta)
            sums[std::size_t(delta + search)] +=
                band.at(t + 1 + patch, delta) - band.at(t - patch, delta);
      }
    }
  }
}

Status check_mask(std::span<const std::uint8_t> mask, int joints) {
  if (!mask.empty() && mask.size() != std::size_t(joints))
    return Status::error("distance_joints must be empty or have one entry per joint (" +
                         std::to_string(joints) + "), got " + std::to_string(mask.size()));
  if (!mask.empty() && std::none_of(mask.begin(), mask.end(), [](auto m) { return m != 0; }))
    return Status::error("distance_joints marks no joint: the pose distance needs at least one");
  return {};
}

}  // namespace

Status NlpmParams::validate() const {
  if (search_radius < 1 || search_radius > kNlpmMaxRadius)
    return Status::error("search_radius (K) must be in [1, " + std::to_string(kNlpmMaxRadius) +
                         "], got " + std::to_string(search_radius));
  if (patch_radius < 0 || patch_radius > kNlpmMaxRadius)
    return Status::error("patch_radius (P) must be in [0, " + std::to_string(kNlpmMaxRadius) +
                         "], got " + std::to_string(patch_radius));
  if (!(h >= 0) || !std::isfinite(h))
    return Status::error(
        "h must be a finite angle >= 0 rad (0 = derive it from the noise level), got " +
        format("%g", h));
  if (!(range_sigma >= 0) || !std::isfinite(range_sigma))
    return Status::error("range_sigma must be a finite angle >= 0 rad (0 = off), got " +
                         format("%g", range_sigma));
  if (!(distance_cap >= 0) || !std::isfinite(distance_cap))
    return Status::error("distance_cap must be a finite angle >= 0 rad (0 = off), got " +
                         format("%g", distance_cap));
  if (distance_cap > 0 && space != NlpmSpace::tangent)
    return Status::error("distance_cap > 0 needs space tangent, got space " +
                         std::string(to_string(space)));
  if (range_sigma > 0 && space != NlpmSpace::tangent)
    return Status::error(
        "range_sigma > 0 needs space tangent (the log space is the paper's, "
        "for comparison only), got space " +
        std::string(to_string(space)));
  if (!(translation_sigma_t >= 0) || !(translation_sigma_t <= kNlpmMaxRadius))
    return Status::error("translation_sigma_t must be in [0, " + std::to_string(kNlpmMaxRadius) +
                         "] frames (0 = translations unchanged), got " +
                         format("%g", translation_sigma_t));
  return {};
}

int NlpmParams::translation_reach() const {
  return int(std::ceil(3.0 * translation_sigma_t));
}

std::vector<int> nlpm_distance_joints(std::span<const std::uint8_t> mask, int joints) {
  std::vector<int> out;
  for (int j = 0; j < joints; ++j)
    if (mask.empty() || mask[std::size_t(j)] != 0) out.push_back(j);
  return out;
}

Status NlpmJob::validate() const {
  if (Status s = params.validate(); !s) return s;
  if (!(params.h > 0))
    return Status::error("h must be > 0 rad to run nlpm, got " + format("%g", params.h) +
                         " (derive it from the clip's noise level first)");
  if (Status s = io.validate(); !s) return s;
  if (implementation != Implementation::fast && implementation != Implementation::reference)
    return Status::error("unknown implementation");
  return check_mask(distance_joints, io.rotations.joints);
}

Status NlpmJob::run() const {
  if (Status s = validate(); !s) return s;
  const int frames = io.rotations.frames;
  if (io.frame_begin == io.frame_stop() || io.joint_begin == io.joint_stop()) return {};
  if (frames == 1) {
    copy_slice(io);
    return {};
  }
  filter_translations(io, params);
  if (implementation == Implementation::fast && params.space == NlpmSpace::tangent) {
    simd::nlpm_tangent(*this);
    return {};
  }
  const int search = std::min(params.search_radius, frames - 1);
  std::vector<double> weights(2 * std::size_t(search) + 1);
  for_each_patch_sum(
      params, io.rotations, nlpm_distance_joints(distance_joints, io.rotations.joints),
      io.frame_begin, io.frame_stop(), [&](long t, const std::vector<double>& sums) {
        const long s_begin = std::max(0L, t - search);
        const long s_end = std::min(long(frames), t + search + 1);
        const double weight_sum =
            window_weights(t, s_begin, s_end, search, params.patch_radius, params.h, sums, weights);
        write_frame(*this, t, s_begin, s_end, weights, weight_sum);
      });
  return {};
}

Status nlpm_patch_distances(const NlpmParams& params, RotationView rotations,
                            std::span<const std::uint8_t> distance_joints, int frame_begin,
                            int frame_end, std::vector<double>& out) {
  if (Status s = params.validate(); !s) return s;
  if (rotations.empty()) return Status::error("the clip has no frames or no joints");
  if (Status s = check_mask(distance_joints, rotations.joints); !s) return s;
  if (frame_begin < 0 || frame_end > rotations.frames || frame_begin > frame_end)
    return Status::error("frame range [" + std::to_string(frame_begin) + ", " +
                         std::to_string(frame_end) + ") is outside the clip's " +
                         std::to_string(rotations.frames) + " frames");
  const int search = std::min(params.search_radius, rotations.frames - 1);
  const std::size_t width = 2 * std::size_t(search) + 1;
  const double patch_frames = 2.0 * params.patch_radius + 1.0;
  out.assign(std::size_t(frame_end - frame_begin) * width, 0.0);
  for_each_patch_sum(params, rotations, nlpm_distance_joints(distance_joints, rotations.joints),
                     frame_begin, frame_end, [&](long t, const std::vector<double>& sums) {
                       double* row = out.data() + std::size_t(t - frame_begin) * width;
                       for (std::size_t i = 0; i < width; ++i) row[i] = sums[i] / patch_frames;
                     });
  return {};
}

}  // namespace mocap
