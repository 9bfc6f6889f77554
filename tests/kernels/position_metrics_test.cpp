// Tests of the position metrics (spec "Metrics") on synthetic tracks with known answers.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/position_metrics.hpp"

namespace mocap {
namespace {

using Track = std::vector<float>;  // [F][N][3]

TensorView<const float, 3> view(const Track& t, int frames, int points) {
  return {t.data(), frames, points};
}

TEST(PositionMetrics, KnownErrorsJitterAndSkating) {
  const int frames = 100, points = 2;
  Track truth(std::size_t(frames) * points * 3), result;
  for (int t = 0; t < frames; ++t)
    for (int p = 0; p < points; ++p) {
      float* v = &truth[(std::size_t(t) * points + p) * 3];
      v[0] = float(2.0 * t);  // constant velocity: no acceleration
      v[1] = float(p);
      v[2] = 0;
    }
  result = truth;
  // Offset by (3, 4, 0): every error is 5; alternating +-1 in z on point 1: its second
  // difference is 4 in magnitude at every frame.
  for (int t = 0; t < frames; ++t) {
    result[(std::size_t(t) * points) * 3] += 3;
    result[(std::size_t(t) * points) * 3 + 1] += 4;
    result[(std::size_t(t) * points + 1) * 3 + 2] = (t % 2 ? 1.0f : -1.0f);
  }
  const FrameRange all{0, frames};
  PositionSums s;
  add_position_error(view(result, frames, points), view(truth, frames, points), all, s);
  add_jitter(view(truth, frames, points), all, s);
  EXPECT_NEAR(s.mpjpe(), (5.0 + 1.0) / 2, 1e-6);
  EXPECT_NEAR(s.jitter(), 0.0, 1e-6);
  PositionSums r;
  add_jitter(view(result, frames, points), all, r);
  EXPECT_NEAR(r.jitter(), std::sqrt(16.0 / 2), 1e-6);  // point 0: 0, point 1: 4
  EXPECT_EQ(r.jitter_n, 2.0 * (frames - 2));
  add_acceleration_error(view(result, frames, points), view(truth, frames, points), all, r);
  EXPECT_NEAR(r.accel_error(), std::sqrt(16.0 / 2), 1e-6);
  // Skating: point 0 moves 2 per frame; over an interval of 10 frames, 9 steps of 2.
  PositionSums k;
  add_skating(view(truth, frames, points), 0, {{10, 20}}, all, k);
  EXPECT_EQ(k.skate_n, 9);
  EXPECT_NEAR(k.skating(), 2.0, 1e-9);
  PositionSums none;
  add_skating(view(truth, frames, points), 0, {{10, 20}}, {15, 18}, none);
  EXPECT_EQ(none.skate_n, 2);  // steps 15-16 and 16-17
}

}  // namespace
TEST(PositionMetrics, ScoredFramesLeaveOutATenthOfASecondAtMostAQuarter) {
  const FrameRange at120 = scored_frames(0, 600, 1.0 / 120);
  EXPECT_EQ(at120.first, 12);
  EXPECT_EQ(at120.last, 588);
  const FrameRange at30 = scored_frames(100, 400, 1.0 / 30);
  EXPECT_EQ(at30.first, 103);
  EXPECT_EQ(at30.last, 397);
  const FrameRange short_span = scored_frames(10, 30, 1.0 / 120);  // 20 frames: a quarter is 5
  EXPECT_EQ(short_span.first, 15);
  EXPECT_EQ(short_span.last, 25);
  EXPECT_EQ(score_edge_frames(3, 1.0 / 120), 0);
}

}  // namespace mocap
