#pragma once
// The pose distance of ../shared/spec/filters.md, "Non-local pose means (nlpm)":
//
//     e(u, v) = (1/J_d) sum_{j in distance joints} d(q[u][j], q[v][j])^2
//
// over boundary-extended frames, and its band E[u][delta] = e(u, u + delta), |delta| <= K, from
// which nlpm's patch distances D(t, t + delta) are box sums along u.
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "core/quaternion.hpp"
#include "core/tensor.hpp"
#include "kernels/boundary.hpp"

namespace mocap {

// Where nlpm measures and averages poses.
//   tangent (default): d is the geodesic distance, the average is taken in the tangent space at
//                      the current pose (one Karcher-mean step).
//   log:               the paper literally, for comparison only. Each joint's absolute local
//                      rotation q (boundary-extended where needed) is mapped to Log(q), angle in
//                      [0, pi] (w >= 0 taken first); e(u, v) uses |Log q_u - Log q_v|^2 in place
//                      of d^2; the output is Exp(sum_s f Log(q_s) / sum_s f), with its sign chosen
//                      on q[t]'s side (dot >= 0) so the output stays hemisphere-continuous. It
//                      breaks where a rotation passes pi, where Log jumps to the antipode.
enum class NlpmSpace { tangent, log };

std::optional<NlpmSpace> parse_nlpm_space(std::string_view name);
std::string_view to_string(NlpmSpace space);

// The distance joints' samples of frames [first, first + count), boundary-extended (any frame
// index is allowed), in the representation e(u, v) reads: the rotation (tangent) or its Log
// (log, stored in x, y, z with w = 0). Each sample depends on its frame index only, never on
// `first` or `count`, so distances are the same whatever range a caller loads. `cap` > 0 (tangent
// only) caps each joint's term at cap^2 (NlpmParams::distance_cap).
class PoseTrack {
 public:
  void load(RotationView rotations, std::span<const int> distance_joints, Boundary boundary,
            NlpmSpace space, long first, long count, double cap = 0);

  // e(u, v) for u, v in [first, first + count). Symmetric bit for bit: e(u, v) == e(v, u).
  double distance(long u, long v) const;

  long first() const { return first_; }
  long count() const { return count_; }

 private:
  std::vector<Quat> samples_;  // [count][J_d]
  long first_ = 0, count_ = 0;
  int joints_ = 0;
  NlpmSpace space_ = NlpmSpace::tangent;
  double cap_squared_ = 0;  // +inf: no cap
};

// E[u][delta] = e(u, u + delta) for u in [u_begin, u_end) and 0 <= delta <= max_delta, the
// upper half of the band; the lower half follows from symmetry, E[u][-delta] = E[u - delta][delta],
// so each distance is evaluated once. Needs track frames [u_begin, u_end + max_delta).
class PoseDistanceBand {
 public:
  void compute(const PoseTrack& track, long u_begin, long u_end, int max_delta);

  // E[u][delta] for |delta| <= max_delta; u (and u + delta for delta < 0) in [u_begin, u_end).
  double at(long u, int delta) const {
    if (delta < 0) {
      u += delta;
      delta = -delta;
    }
    return values_[std::size_t(u - u_begin_) * std::size_t(max_delta_ + 1) + std::size_t(delta)];
  }

  long u_begin() const { return u_begin_; }
  long u_end() const { return u_end_; }
  int max_delta() const { return max_delta_; }

 private:
  std::vector<double> values_;  // [u_end - u_begin][max_delta + 1]
  long u_begin_ = 0, u_end_ = 0;
  int max_delta_ = 0;
};

}  // namespace mocap
