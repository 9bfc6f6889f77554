#include "kernels/nlpm_direct.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mocap {
namespace {

// e(u, v), written out independently of PoseTrack so that the oracle checks it.
double pose_distance(const NlpmParams& params, RotationView rotations,
                     const std::vector<int>& joints, long u, long v) {
  double sum = 0;
  for (int j : joints) {
    const Quat a = extended_rotation(rotations, j, u, params.boundary);
    const Quat b = extended_rotation(rotations, j, v, params.boundary);
    if (params.space == NlpmSpace::tangent) {
      const double d = geodesic(a, b);
      // distance_cap (nlpm.hpp): each joint's term at most cap^2.
      sum += params.distance_cap > 0 ? std::min(d * d, params.distance_cap * params.distance_cap)
                                     : d * d;
    } else {
      const Vec3 diff = log(a) - log(b);
      sum += dot(diff, diff);
    }
  }
  return sum / double(joints.size());
}

}  // namespace

Status nlpm_direct(const NlpmParams& params, const MotionIO& io,
                   std::span<const std::uint8_t> distance_joints) {
  if (Status s = NlpmJob{params, io, distance_joints}.validate(); !s) return s;
  const RotationView q = io.rotations;
  const long frames = q.frames;
  const int search = params.search_radius, patch = params.patch_radius;
  const std::vector<int> joints = nlpm_distance_joints(distance_joints, q.joints);

  if (frames == 1) {  // no s != t: the clip is returned unchanged
    for (int t = io.frame_begin; t < io.frame_stop(); ++t)
      for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
        std::copy_n(q.at(t, j), 4, io.filtered_rotations.at(t, j));
        if (io.has_translations())
          std::copy_n(io.translations.at(t, j), 3, io.filtered_translations.at(t, j));
      }
    return {};
  }
  for (long t = io.frame_begin; t < io.frame_stop(); ++t) {
    const long s_begin = std::max(0L, t - search), s_end = std::min(frames, t + search + 1);
    std::vector<double> patch_distance(std::size_t(s_end - s_begin));
    double d_min = INFINITY;
    for (long s = s_begin; s < s_end; ++s) {
      double sum = 0;
      for (int o = -patch; o <= patch; ++o) sum += pose_distance(params, q, joints, t + o, s + o);
      patch_distance[std::size_t(s - s_begin)] = sum / (2.0 * patch + 1.0);
      if (s != t) d_min = std::min(d_min, patch_distance[std::size_t(s - s_begin)]);
    }
    std::vector<double> f(patch_distance.size(), 0.0);
    double self = 0;
    for (long s = s_begin; s < s_end; ++s) {
      if (s == t) continue;
      const double excess = patch_distance[std::size_t(s - s_begin)] - d_min;
      f[std::size_t(s - s_begin)] =
          excess == 0 ? 1.0 : std::exp(-excess / (2 * params.h * params.h));
      self = std::max(self, f[std::size_t(s - s_begin)]);
    }
    f[std::size_t(t - s_begin)] = self;
    double f_sum = 0;
    for (double w : f) f_sum += w;

    for (int j = io.joint_begin; j < io.joint_stop(); ++j) {
      const Quat qt = load_quat(q.at(int(t), j));
      Vec3 acc;
      Quat out;
      if (params.range_sigma > 0) {  // w_j(t, s) of the range form, literally
        const double two_sigma2 = 2 * params.range_sigma * params.range_sigma;
        double w_sum = 0;
        for (long s = s_begin; s < s_end; ++s) {
          const Quat qs = load_quat(q.at(int(s), j));
          const double d = geodesic(qt, qs);
          const double w =
              f[std::size_t(s - s_begin)] * (d == 0 ? 1.0 : std::exp(-d * d / two_sigma2));
          acc += w * log(inverse(qt) * qs);
          w_sum += w;
        }
        out = qt * exp((1.0 / w_sum) * acc);
      } else if (params.space == NlpmSpace::tangent) {
        for (long s = s_begin; s < s_end; ++s)
          acc += f[std::size_t(s - s_begin)] * log(inverse(qt) * load_quat(q.at(int(s), j)));
        out = qt * exp((1.0 / f_sum) * acc);
      } else {
        for (long s = s_begin; s < s_end; ++s)
          acc += f[std::size_t(s - s_begin)] * log(load_quat(q.at(int(s), j)));
        out = exp((1.0 / f_sum) * acc);
        if (dot(out, qt) < 0) out = negate(out);
      }
      store_quat(out, io.filtered_rotations.at(int(t), j));
      if (!io.has_translations()) continue;
      // Translations: the Gaussian of nlpm.hpp, summed literally from extended samples.
      Vec3 p = load_vec3(io.translations.at(int(t), j));
      const double ts = params.translation_sigma_t;
      if (io.translated_joints[std::size_t(j)] != 0 && ts > 0 && frames > 1) {
        const int k = params.translation_reach();
        Vec3 sum;
        double norm_sum = 0;
        for (int r = -k; r <= k; ++r) {
          const double m = std::exp(-double(r) * r / (2 * ts * ts));
          sum += m * extended_translation(io.translations, j, t + r, params.boundary);
          norm_sum += m;
        }
        p = (1.0 / norm_sum) * sum;
      }
      store_vec3(p, io.filtered_translations.at(int(t), j));
    }
  }
  return {};
}

}  // namespace mocap
