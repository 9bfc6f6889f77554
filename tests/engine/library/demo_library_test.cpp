// The built-in demo library (engine/library/demo_library.hpp): its turn is a body's turn, in
// steps about a standing foot, so foot locking has planted feet in the ground truth to keep.
#include "engine/library/demo_library.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "engine/clip/foot_stage.hpp"

namespace mocap::engine {
namespace {

const DemoClip& find(const std::vector<DemoClip>& clips, const std::string& name) {
  const auto it = std::find_if(clips.begin(), clips.end(),
                               [&](const DemoClip& c) { return c.relative_path == name; });
  EXPECT_NE(it, clips.end()) << name;
  return *it;
}

TEST(DemoLibrary, TheTurnStepsAboutAStandingFootThatHoldsStill) {
  const auto clips = make_demo_library();
  const Clip& turn = find(clips, "gesture/turn_30fps.bvh").clip;
  const std::vector<float> positions = joint_positions(turn);
  ASSERT_FALSE(positions.empty());
  const int J = turn.joints();
  int left = -1, right = -1;
  for (int j = 0; j < J; ++j) {
    if (turn.skeleton->joint_names[std::size_t(j)] == "LeftFoot") left = j;
    if (turn.skeleton->joint_names[std::size_t(j)] == "RightFoot") right = j;
  }
  ASSERT_GE(left, 0);
  ASSERT_GE(right, 0);
  auto at = [&](int t, int j, int axis) {
    return positions[(std::size_t(t) * std::size_t(J) + std::size_t(j)) * 3 + std::size_t(axis)];
  };
  // Half steps of 0.375 s (11.25 frames at 30 fps): the right foot stands while the left
  // lifts, then the other way round. Inside each half the standing ankle does not move.
  const double half = 0.375 / turn.frame_time;
  double root_travel = 0;
  for (int t = 1; t < turn.frames; ++t) {
    const int k = int(std::floor((t - 1) / half)), k_now = int(std::floor(t / half));
    root_travel += std::hypot(at(t, 0, 0) - at(t - 1, 0, 0), at(t, 0, 2) - at(t - 1, 0, 2));
    if (k != k_now) continue;  // a step across the change of feet
    const int standing = k % 2 == 0 ? right : left;
    for (int axis = 0; axis < 3; ++axis)
      EXPECT_NEAR(at(t, standing, axis), at(t - 1, standing, axis), 1e-3)
          << "frame " << t << ", axis " << axis;
  }
  // The body turns about the standing foot, so the root travels (a turn about the hips would
  // drag both feet around instead).
  EXPECT_GT(root_travel, 20.0);
}

}  // namespace
}  // namespace mocap::engine
