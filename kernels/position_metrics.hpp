#pragma once
// The position metrics of ../shared/spec/filters.md, "Metrics", on global joint positions from
// forward kinematics ([F][N][3], file units). Each returns sums and counts, so that scores pool
// over clips by adding; the caller converts units (mm) and takes the root of a mean.
//
//   MPJPE:              mean over frames and points of |P_r[t] - P_g[t]|
//   jitter:             RMS over frames and points of |P[t+1] - 2 P[t] + P[t-1]|
//   acceleration error: RMS of |a_r[t] - a_g[t]|, a = the second difference above
//   foot skating:       over the frames where a foot is planted in the reference (its contact
//                       intervals, kernels/foot_contacts.hpp), mean horizontal (x, z)
//                       displacement |P[t+1] - P[t]| of that foot per frame, counting a step
//                       when both its frames are planted.
//
// Every score covers frames [first, last) only: the caller leaves out the ends where the
// boundary extension dominates (second differences need t - 1 and t + 1 inside the range).
#include <cstdint>
#include <span>
#include <vector>

#include "core/tensor.hpp"
#include "kernels/foot_contacts.hpp"

namespace mocap {

struct PositionSums {
  double error = 0, error_n = 0;           // sum of |P_r - P_g|
  double jitter_sq = 0, jitter_n = 0;      // sum of |a|^2
  double accel_error_sq = 0, accel_n = 0;  // sum of |a_r - a_g|^2
  double skate = 0, skate_n = 0;           // sum of horizontal steps over planted steps

  void add(const PositionSums& other);
  double mpjpe() const;        // file units; NaN without samples
  double jitter() const;       // file units per frame^2
  double accel_error() const;  // file units per frame^2
  double skating() const;      // file units per frame
};

struct FrameRange {
  int first = 0, last = 0;  // [first, last)
};

// Frames left out at each end of a span for the position scores (spec "Metrics": the boundary
// extension dominates there), at most a quarter of the span; eval and the motion check of
// clean/filter both score [begin, end) so.
inline constexpr double kScoreEdgeSeconds = 0.1;
int score_edge_frames(int frames, double frame_time);
FrameRange scored_frames(int begin, int end, double frame_time);

// |P_r - P_g| summed over the range; the shapes must agree.
void add_position_error(TensorView<const float, 3> result, TensorView<const float, 3> truth,
                        FrameRange range, PositionSums& sums);
// Jitter of `positions` over second differences centred in the range.
void add_jitter(TensorView<const float, 3> positions, FrameRange range, PositionSums& sums);
// Acceleration error of result against truth.
void add_acceleration_error(TensorView<const float, 3> result, TensorView<const float, 3> truth,
                            FrameRange range, PositionSums& sums);
// Skating of foot point `point` of `positions` over the steps inside `contacts` and the range.
void add_skating(TensorView<const float, 3> positions, int point,
                 const std::vector<ContactInterval>& contacts, FrameRange range,
                 PositionSums& sums);

}  // namespace mocap
