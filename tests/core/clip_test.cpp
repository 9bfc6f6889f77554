// core/clip.hpp: decimate, the lower frame rate eval's --frame-step and the 30 fps tests use.
#include <gtest/gtest.h>

#include "core/clip.hpp"

namespace mocap {
namespace {

Clip numbered_clip(int frames, bool with_angles) {
  auto skeleton = std::make_shared<Skeleton>();
  skeleton->joint_names = {"root", "child"};
  skeleton->parents = {-1, 0};
  skeleton->offsets = {{0, 0, 0}, {0, 1, 0}};
  skeleton->channels = {{}, {}};
  skeleton->end_sites = {std::nullopt, std::nullopt};
  Clip c;
  c.skeleton = skeleton;
  c.frame_time = 1.0 / 120;
  c.frames = frames;
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < 2; ++j) {
      for (int k = 0; k < 4; ++k) c.rotations.push_back(float(100 * t + 10 * j + k));
      for (int k = 0; k < 3; ++k) c.translations.push_back(float(-100 * t - 10 * j - k));
      if (with_angles)
        for (int k = 0; k < 3; ++k) c.source_angles.push_back(float(1000 * t + j + k));
    }
  c.provenance.contacts = {1, 0, frames};
  return c;
}

TEST(Clip, DecimateKeepsEveryStepthFrameOfEachTensor) {
  for (bool angles : {false, true}) {
    const Clip full = numbered_clip(10, angles);
    const Clip quarter = decimate(full, 4);
    ASSERT_EQ(quarter.frames, 3);  // frames 0, 4, 8
    EXPECT_DOUBLE_EQ(quarter.frame_time, 4.0 / 120);
    ASSERT_EQ(quarter.rotations.size(), 3u * 2 * 4);
    ASSERT_EQ(quarter.translations.size(), 3u * 2 * 3);
    ASSERT_EQ(quarter.source_angles.size(), angles ? 3u * 2 * 3 : 0u);
    for (int t = 0; t < 3; ++t)
      for (int j = 0; j < 2; ++j) {
        EXPECT_EQ(quarter.rotation_view().at(t, j)[1], full.rotation_view().at(4 * t, j)[1]);
        EXPECT_EQ(quarter.translation_view().at(t, j)[2], full.translation_view().at(4 * t, j)[2]);
        if (angles) {
          EXPECT_EQ(quarter.source_angles[(std::size_t(t) * 2 + std::size_t(j)) * 3],
                    full.source_angles[(std::size_t(4 * t) * 2 + std::size_t(j)) * 3]);
        }
      }
    EXPECT_TRUE(quarter.provenance.contacts.empty());  // frame numbers of the full clip
    EXPECT_EQ(decimate(full, 1).rotations, full.rotations);
  }
}

}  // namespace
}  // namespace mocap
