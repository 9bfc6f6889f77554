// Tests of the joint classification (kernels/joint_quality.hpp): constant, rounding-only,
// flipping and moving joints, robustness to the spec's impulse noise and to one synthetic first
// frame, short clips, and what it finds on the shared CMU clips.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/quaternion.hpp"
#include "io/bvh_reader.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/noise_estimate.hpp"
#include "kernels/noise_model.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

using test::Motion;

// Joint 0 constant, 1 rounding jitter (each component of a fixed rotation moved by -1, 0 or +1
// ulp per frame), 2 flipping (a slow motion whose every 4th frame is turned by pi - 0.05 rad,
// the way an uncaptured thumb's Euler channels flip), 3 and 4 ordinary motion.
Motion kinds_of_joints(int frames, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Motion m{frames, 5, test::random_motion(rng, frames, 5)};
  const Quat fixed = test::random_rotation(rng);
  const Vec3 flip_axis{0.6, 0.0, 0.8};
  std::uniform_int_distribution<int> ulps(-1, 1);
  for (int t = 0; t < frames; ++t) {
    store_quat(fixed, m.span().at(t, 0));
    float* r = m.span().at(t, 1);
    store_quat(fixed, r);
    for (int c = 0; c < 4; ++c)
      for (int k = ulps(rng); k != 0; k -= k > 0 ? 1 : -1)
        r[c] = std::nextafter(r[c], k > 0 ? 2.0f : -2.0f);
    if (t % 4 == 3) {
      float* f = m.span().at(t, 2);
      store_quat(load_quat(f) * exp((kPi - 0.05) * flip_axis), f);
    }
  }
  return m;
}

TEST(JointQuality, TellsTheKindsOfJointsApart) {
  const Motion m = kinds_of_joints(400, 3);
  const std::vector<JointQuality> q = classify_joints(m.view());
  ASSERT_EQ(q.size(), 5u);
  EXPECT_EQ(q[0].joint_class, JointClass::constant);
  EXPECT_EQ(q[0].median_step, 0.0);
  EXPECT_EQ(q[0].max_step, 0.0);
  EXPECT_EQ(q[1].joint_class, JointClass::rounding);
  EXPECT_GT(q[1].median_step, 0.0);
  EXPECT_LT(q[1].max_step, 1e-6);  // float rounding of a unit quaternion: ~1e-7 rad
  EXPECT_EQ(q[2].joint_class, JointClass::flipping);
  // Two near-pi steps per flipped frame (there and back): half of all steps.
  EXPECT_NEAR(q[2].near_pi_fraction, 0.5, 0.01);
  EXPECT_GT(q[2].max_step, kFlipStep);
  for (int j : {3, 4}) {
    EXPECT_EQ(q[std::size_t(j)].joint_class, JointClass::moving) << j;
    EXPECT_GT(q[std::size_t(j)].median_step, kMovingJointStep);
    EXPECT_EQ(q[std::size_t(j)].near_pi_steps, 0);
  }
  // classify_joint agrees with classify_joints, entry by entry.
  for (int j = 0; j < 5; ++j) {
    const JointQuality one = classify_joint(m.view(), j);
    EXPECT_EQ(one.joint_class, q[std::size_t(j)].joint_class);
    EXPECT_EQ(one.median_step, q[std::size_t(j)].median_step);
  }
}

TEST(JointQuality, SameClassesUnderImpulseNoise) {
  const Motion clean = kinds_of_joints(600, 5);
  for (std::uint64_t seed : {1, 2, 3}) {
    Motion noisy = clean;
    add_noise(ImpulseNoise{0.01, 0.3, 1.0, seed}, noisy.span());
    const std::vector<JointQuality> a = classify_joints(clean.view()),
                                    b = classify_joints(noisy.view());
    for (std::size_t j = 0; j < a.size(); ++j)
      EXPECT_EQ(a[j].joint_class, b[j].joint_class) << "joint " << j << " seed " << seed;
  }
}

TEST(JointQuality, OneSyntheticFirstFrameIsNotFlipping) {
  Motion m = kinds_of_joints(300, 7);
  // A T-pose first frame, pi away from the motion (the CMU conversions' frame 0).
  store_quat(load_quat(m.view().at(1, 3)) * exp(Vec3{0, kPi - 0.01, 0}), m.span().at(0, 3));
  const JointQuality q = classify_joint(m.view(), 3);
  EXPECT_EQ(q.near_pi_steps, 1);
  EXPECT_EQ(q.joint_class, JointClass::moving);
}

TEST(JointQuality, ShortClips) {
  const Motion m = kinds_of_joints(3, 9);
  Motion one{1, 5, std::vector<float>(m.rotations.begin(), m.rotations.begin() + 20)};
  for (const JointQuality& q : classify_joints(one.view())) {
    EXPECT_EQ(q.joint_class, JointClass::constant);
    EXPECT_EQ(q.max_step, 0.0);
  }
  Motion two{2, 5, std::vector<float>(m.rotations.begin(), m.rotations.begin() + 40)};
  const std::vector<JointQuality> q = classify_joints(two.view());
  EXPECT_EQ(q[0].joint_class, JointClass::constant);
  EXPECT_EQ(q[3].joint_class, JointClass::moving);
  EXPECT_EQ(q[3].median_step, q[3].max_step);  // one step
  EXPECT_TRUE(classify_joints(RotationView{}).empty());
}

TEST(JointQuality, Names) {
  EXPECT_EQ(to_string(JointClass::moving), "moving");
  EXPECT_EQ(to_string(JointClass::constant), "constant");
  EXPECT_EQ(to_string(JointClass::rounding), "rounding");
  EXPECT_EQ(to_string(JointClass::flipping), "flipping");
  EXPECT_FALSE(is_garbage(JointClass::moving));
  EXPECT_TRUE(is_garbage(JointClass::flipping));
}

// What the data shows (../shared/data/bvh/README.md and a look at the channels): the hip-joint
// connectors and the shoulders are never keyed (constant); the index fingers are constant but for
// the synthetic T-pose frame 0 (one step of 0.12 rad); 06_14's LThumb sits near gimbal lock and
// its Euler channels jump by more than 90 degrees 16 times (flipping); the body is moving.
TEST(JointQuality, SharedClips) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  auto expected = [](const std::string& clip, const std::string& joint) {
    if (joint == "LHipJoint" || joint == "RHipJoint" || joint == "LeftShoulder" ||
        joint == "RightShoulder" || joint == "LeftHandIndex1" || joint == "RightHandIndex1")
      return JointClass::constant;
    if (clip == "cmu_mb_06_14.bvh" && joint == "LThumb") return JointClass::flipping;
    return JointClass::moving;
  };
  for (const auto& path : test::shared_bvh_files()) {
    const io::BvhReadResult read = io::read_bvh(path);
    ASSERT_TRUE(read.clip) << path;
    const Clip& clip = *read.clip;
    const std::vector<JointQuality> q = classify_joints(clip.rotation_view());
    std::printf("%s (%d frames):", path.filename().string().c_str(), clip.frames);
    for (int j = 0; j < clip.joints(); ++j) {
      const JointQuality& jq = q[std::size_t(j)];
      const std::string& name = clip.skeleton->joint_names[std::size_t(j)];
      EXPECT_EQ(jq.joint_class, expected(path.filename().string(), name))
          << path << " " << name << " median step " << jq.median_step;
      if (jq.joint_class != JointClass::moving)
        std::printf(" %s=%s(median %.2g, max %.2g, near-pi %d)", name.c_str(),
                    std::string(to_string(jq.joint_class)).c_str(), jq.median_step, jq.max_step,
                    jq.near_pi_steps);
    }
    std::printf("\n");
  }
}

}  // namespace
}  // namespace mocap
