// The impossible-step split (kernels/motion_split.hpp): one joint's impossible turn, a whole
// body's jump at low frame rates, what must not be cut, and the T-pose of the shared CMU clips
// at 120 and 30 fps.
#include <gtest/gtest.h>

#include <random>
#include <span>
#include <string>
#include <vector>

#include "core/quaternion.hpp"
#include "io/bvh_reader.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/noise_model.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// A smooth random motion with one joint turned by `jump` rad between frames 49 and 50.
std::vector<float> motion_with_jump(double jump, int joint) {
  std::mt19937_64 rng(5);
  std::vector<float> m = test::random_motion(rng, 100, 6, 0.5);
  const Quat turn = exp(Vec3{0, jump, 0});
  for (int t = 50; t < 100; ++t) {
    float* q = &m[(std::size_t(t) * 6 + std::size_t(joint)) * 4];
    store_quat(load_quat(q) * turn, q);
  }
  make_hemisphere_continuous({m.data(), 100, 6});
  return m;
}

TEST(MotionSplit, FindsASyntheticTPoseJumpAndSplitsThere) {
  const std::vector<float> m = motion_with_jump(120 * kPi / 180, 3);
  const auto steps = find_impossible_steps({m.data(), 100, 6}, 1.0 / 120, MotionSplitParams{});
  ASSERT_EQ(steps.size(), 1u);
  EXPECT_EQ(steps[0].frame, 49);
  EXPECT_EQ(steps[0].joint, 3);
  EXPECT_NEAR(steps[0].angle, 120 * kPi / 180, 0.2);  // plus the motion's own step
  const auto segments = split_segments(100, steps);
  ASSERT_EQ(segments.size(), 2u);
  EXPECT_EQ(segments[0].begin, 0);
  EXPECT_EQ(segments[0].end, 50);
  EXPECT_EQ(segments[1].begin, 50);
  EXPECT_EQ(segments[1].end, 100);
}

TEST(MotionSplit, FastButPossibleMotionIsNotCut) {
  // 0.83 rad per frame at 120 fps (100 rad/s) on top of the random motion: fast, not impossible.
  const std::vector<float> m = motion_with_jump(0.83, 2);
  EXPECT_TRUE(find_impossible_steps({m.data(), 100, 6}, 1.0 / 120, MotionSplitParams{}).empty());
  // The same step is impossible at 30 fps only if it exceeds max_step: it does not.
  EXPECT_TRUE(find_impossible_steps({m.data(), 100, 6}, 1.0 / 30, MotionSplitParams{}).empty());
  EXPECT_DOUBLE_EQ(MotionSplitParams{}.step_threshold(1.0 / 120), 1.25);
  EXPECT_DOUBLE_EQ(MotionSplitParams{}.step_threshold(1.0 / 30), 2.0);
  EXPECT_EQ(split_segments(0, {}).size(), 0u);
  EXPECT_FALSE((MotionSplitParams{-1, 2}.validate().ok()));
}

// An Euler channel wrapping from 179 to -179 degrees is a 2-degree step, not a jump: the reader
// converts to quaternions and makes them hemisphere-continuous.
TEST(MotionSplit, EulerWrapAroundsAreNotSteps) {
  const std::string bvh =
      "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n"
      "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
      "  JOINT Arm\n  {\n    OFFSET 1 0 0\n    CHANNELS 3 Zrotation Yrotation Xrotation\n"
      "    End Site\n    {\n      OFFSET 1 0 0\n    }\n  }\n}\nMOTION\nFrames: 4\n"
      "Frame Time: 0.0083333\n"
      "0 0 0 178 10 0 -179 20 5\n0 0 0 179 10 0 179 20 5\n0 0 0 -179 10 0 -178 20 5\n"
      "0 0 0 -178 10 0 178 20 5\n";
  const io::BvhReadResult r = io::parse_bvh(bvh, "wrap.bvh");
  ASSERT_TRUE(r.clip) << r.error->what();
  const RotationView v = r.clip->rotation_view();
  for (int t = 0; t + 1 < 4; ++t)
    for (int j = 0; j < 2; ++j)
      EXPECT_LT(geodesic(load_quat(v.at(t, j)), load_quat(v.at(t + 1, j))), 0.08) << t << " " << j;
  EXPECT_TRUE(find_impossible_steps(v, r.clip->frame_time, MotionSplitParams{}).empty());
}

// The CMU "Motionbuilder-friendly" clips start with a synthetic T-pose: exactly one cut, after
// frame 0, in every clip but one. 06_14's LThumb (a joint CMU did not capture) flips by pi at
// gimbal lock 16 times; those are the only other cuts (docs/eval.md).
TEST(MotionSplit, SharedCmuClipsAreCutAfterTheirTPoseFrame) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  int exactly_one = 0;
  for (const fs::path& file : test::shared_bvh_files()) {
    const io::BvhReadResult r = io::read_bvh(file);
    ASSERT_TRUE(r.clip) << file;
    const auto steps =
        find_impossible_steps(r.clip->rotation_view(), r.clip->frame_time, MotionSplitParams{});
    ASSERT_FALSE(steps.empty()) << file;
    EXPECT_EQ(steps[0].frame, 0) << file;
    EXPECT_GT(steps[0].angle, 1.4) << file;
    exactly_one += steps.size() == 1 ? 1 : 0;
    for (std::size_t i = 1; i < steps.size(); ++i) {
      EXPECT_EQ(r.clip->skeleton->joint_names[std::size_t(steps[i].joint)], "LThumb")
          << file << " frame " << steps[i].frame;
      EXPECT_GT(steps[i].angle, 3.0) << file << " frame " << steps[i].frame;
    }
  }
  EXPECT_GE(exactly_one, int(test::shared_bvh_files().size()) - 1);
}

// At 30 fps the T-pose's worst joint turns less than max_step on 7 of the 9 clips: the pose step
// (the whole body jumping) cuts it, and nothing else is cut but 06_14's flipping thumb.
TEST(MotionSplit, SharedCmuClipsAreCutAfterTheirTPoseFrameAtThirtyFps) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  const MotionSplitParams params;
  int by_pose_only = 0;
  for (const fs::path& file : test::shared_bvh_files()) {
    const io::BvhReadResult r = io::read_bvh(file);
    ASSERT_TRUE(r.clip) << file;
    const Clip quarter = decimate(*r.clip, 4);  // 30 fps, as eval --frame-step 4
    const double frame_time = quarter.frame_time;
    const auto steps = find_impossible_steps(quarter.rotation_view(), frame_time, params);
    ASSERT_FALSE(steps.empty()) << file;
    EXPECT_EQ(steps[0].frame, 0) << file;
    EXPECT_GT(steps[0].pose_step, params.pose_step_threshold(frame_time)) << file;
    by_pose_only += steps[0].angle <= params.step_threshold(frame_time) ? 1 : 0;
    for (std::size_t i = 1; i < steps.size(); ++i) {
      EXPECT_EQ(r.clip->skeleton->joint_names[std::size_t(steps[i].joint)], "LThumb")
          << file << " frame " << steps[i].frame;
      EXPECT_LT(steps[i].pose_step, params.pose_step_threshold(frame_time)) << file;
    }
  }
  EXPECT_GE(by_pose_only, 5);  // what the per-joint rule alone missed
}

// The shared clips with eval's gaussian noise (0.03, 0.08 and 0.12 rad per axis): the noisy
// clip's cuts are the clean clip's at 120 and 30 fps (the T-pose frame, 06_14's flipping thumb),
// as `clean` finds them, so eval's split of the clean clip is what a user's noisy clip gets.
TEST(MotionSplit, SharedCmuClipsWithNoiseAreCutWhereTheCaptureIs) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  for (const fs::path& file : test::shared_bvh_files()) {
    const io::BvhReadResult r = io::read_bvh(file);
    ASSERT_TRUE(r.clip) << file;
    for (const int step : {1, 4}) {
      const Clip clip = decimate(*r.clip, step);
      const auto frames_of = [&](const std::vector<float>& rotations) {
        std::vector<int> cut;
        for (const ImpossibleStep& s :
             find_impossible_steps({rotations.data(), clip.frames, clip.joints()}, clip.frame_time,
                                   MotionSplitParams{}))
          cut.push_back(s.frame);
        return cut;
      };
      const std::vector<int> clean = frames_of(clip.rotations);
      for (const double sigma : {0.03, 0.08, 0.12}) {
        std::vector<float> noisy = clip.rotations;
        add_noise(GaussianNoise{sigma, 3}, {noisy.data(), clip.frames, clip.joints()});
        EXPECT_EQ(frames_of(noisy), clean)
            << file.filename() << " at " << std::lround(1 / clip.frame_time) << " fps, " << sigma
            << " rad";
      }
    }
  }
}

// A synthetic whole-body jump: each of 31 joints turns 0.35 rad in one step at 30 fps, far below
// max_step, and the step is cut; the same turn on 3 joints only is fast motion and is not.
TEST(MotionSplit, AWholeBodyJumpIsCutWhereAFewFastJointsAreNot) {
  const int frames = 60, joints = 31;
  for (int turned : {31, 3}) {
    std::mt19937_64 rng(11);
    std::vector<float> m = test::random_motion(rng, frames, joints, 0.05);
    const Quat turn = exp(Vec3{0.35, 0, 0});
    for (int t = 30; t < frames; ++t)
      for (int j = 0; j < turned; ++j) {
        float* q = &m[(std::size_t(t) * joints + std::size_t(j)) * 4];
        store_quat(load_quat(q) * turn, q);
      }
    make_hemisphere_continuous({m.data(), frames, joints});
    const auto steps = find_impossible_steps({m.data(), frames, joints}, 1.0 / 30, {});
    if (turned == joints) {
      ASSERT_EQ(steps.size(), 1u);
      EXPECT_EQ(steps[0].frame, 29);
      EXPECT_LT(steps[0].angle, MotionSplitParams{}.step_threshold(1.0 / 30));
    } else {
      EXPECT_TRUE(steps.empty()) << steps.size();
    }
  }
}

// Sensor noise is not a jump (header, "Noise"): eval's gaussian levels on a smooth 31-joint
// motion cut nothing at 120 or 30 fps (before the thresholds followed the clip's own steps, from
// about 0.09 rad every step was cut by the pose step, and at 0.24 rad and 120 fps about one step
// in nine by a joint), while a whole-body jump of 0.6 rad per joint is still cut through 0.12 rad
// of noise.
TEST(MotionSplit, NoiseIsNotAJumpButAJumpThroughNoiseIsCut) {
  const int frames = 600, joints = 31;
  for (const double frame_time : {1.0 / 120, 1.0 / 30})
    for (const double sigma : {0.03, 0.08, 0.12, 0.24})
      for (const bool jump : {false, true}) {
        if (jump && sigma > 0.12) continue;  // a 0.6 rad jump drowns in 0.24 rad of noise
        std::mt19937_64 rng(21);
        std::vector<float> m = test::random_motion(rng, frames, joints, 0.02);
        if (jump)
          for (int t = 300; t < frames; ++t)
            for (int j = 0; j < joints; ++j) {
              float* q = &m[(std::size_t(t) * joints + std::size_t(j)) * 4];
              store_quat(load_quat(q) * exp(Vec3{0.6, 0, 0}), q);
            }
        add_noise(GaussianNoise{sigma, 7}, {m.data(), frames, joints});
        make_hemisphere_continuous({m.data(), frames, joints});
        const auto steps = find_impossible_steps({m.data(), frames, joints}, frame_time, {});
        const std::string what = "sigma " + std::to_string(sigma) + ", " +
                                 std::to_string(int(std::lround(1 / frame_time))) + " fps";
        if (jump) {
          ASSERT_EQ(steps.size(), 1u) << what;
          EXPECT_EQ(steps[0].frame, 299) << what;
        } else {
          EXPECT_TRUE(steps.empty()) << what << ": " << steps.size() << " steps cut";
        }
      }
}

// A joint that flips by pi (uncaptured, Euler gimbal lock) counts at most 1 rad in the pose
// step; skipped, it does not count at all.
TEST(MotionSplit, OneFlippingJointIsNotAWholeBodyJump) {
  const int frames = 40, joints = 31;
  std::mt19937_64 rng(12);
  std::vector<float> m = test::random_motion(rng, frames, joints, 0.02);
  for (int t = 20; t < frames; ++t) {
    float* q = &m[(std::size_t(t) * joints + 5) * 4];
    store_quat(load_quat(q) * exp(Vec3{0, 0, 3.1}), q);
  }
  make_hemisphere_continuous({m.data(), frames, joints});
  const RotationView v{m.data(), frames, joints};
  const auto steps = find_impossible_steps(v, 1.0 / 30, {});
  ASSERT_EQ(steps.size(), 1u);  // the per-joint rule: 3.1 rad > max_step
  EXPECT_EQ(steps[0].joint, 5);
  EXPECT_LT(steps[0].pose_step, MotionSplitParams{}.pose_step_threshold(1.0 / 30));
  std::vector<std::uint8_t> skip(joints, 0);
  skip[5] = 1;
  EXPECT_TRUE(find_impossible_steps(v, 1.0 / 30, {}, skip).empty());
  EXPECT_EQ(motion_segments(v, 1.0 / 30, skip).size(), 1u);
  // A skip that is not one entry per joint marks none (and is never read past its end).
  const std::vector<std::uint8_t> short_skip(skip.begin(), skip.begin() + 6);
  EXPECT_EQ(find_impossible_steps(v, 1.0 / 30, {}, short_skip).size(), 1u);
}

// With fewer than kPoseStepMinJoints joints there is no body to jump: 4 of 5 joints turning
// 0.6 rad at once at 30 fps (a limb swinging) is motion, though their mean turn is 0.48 rad.
TEST(MotionSplit, TheWholeBodyRuleNeedsABody) {
  const int frames = 40;
  for (int joints : {5, kPoseStepMinJoints}) {
    std::mt19937_64 rng(13);
    std::vector<float> m = test::random_motion(rng, frames, joints, 0.02);
    for (int t = 20; t < frames; ++t)
      for (int j = 0; j < joints; ++j)
        if (joints > 5 || j > 0) {
          float* q = &m[(std::size_t(t) * joints + std::size_t(j)) * 4];
          store_quat(load_quat(q) * exp(Vec3{0, 0.6, 0}), q);
        }
    make_hemisphere_continuous({m.data(), frames, joints});
    const auto steps = find_impossible_steps({m.data(), frames, joints}, 1.0 / 30, {});
    EXPECT_EQ(steps.size(), joints > 5 ? 1u : 0u) << joints;
  }
}

TEST(MotionSplit, PoseStepThresholdRisesAtLowFrameRates) {
  const MotionSplitParams p;
  EXPECT_DOUBLE_EQ(p.pose_step_threshold(1.0 / 120), 0.2);
  EXPECT_DOUBLE_EQ(p.pose_step_threshold(1.0 / 30), 0.2);
  EXPECT_DOUBLE_EQ(p.pose_step_threshold(1.0 / 15), 0.3);
  MotionSplitParams bad;
  bad.min_pose_step = 0;
  EXPECT_FALSE(bad.validate().ok());
  bad = {};
  bad.max_pose_speed = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(bad.validate().ok());
}

// The test from the step angles the joint classification keeps finds the same steps, bit for
// bit, as the one that measures them itself: on random motion with jumps of one joint, of the
// whole body and a flipping joint skipped.
TEST(MotionSplit, StepAnglesFromTheClassificationFindTheSameSteps) {
  std::mt19937_64 rng(23);
  const int frames = 300, joints = 12;
  std::vector<float> data(std::size_t(frames) * joints * 4);
  std::normal_distribution<double> small(0.0, 0.02);
  for (int j = 0; j < joints; ++j) {
    Quat q = test::random_rotation(rng);
    for (int t = 0; t < frames; ++t) {
      q = normalized(q * exp(Vec3{small(rng), small(rng), small(rng)}));
      if (t == 100 && j == 3) q = q * exp(Vec3{2.5, 0, 0});    // one joint jumps
      if (t == 200) q = q * exp(Vec3{0, 0.6, 0});              // the whole body jumps
      if (j == 7 && t % 9 == 0) q = q * exp(Vec3{0, 0, 3.1});  // a flipping joint
      store_quat(q, &data[(std::size_t(t) * joints + std::size_t(j)) * 4]);
    }
  }
  const RotationView view{data.data(), frames, joints};
  std::vector<double> angles(std::size_t(frames - 1) * joints), medians, inflated;
  for (int j = 0; j < joints; ++j) {
    const JointQuality q = classify_joint(
        view, j, std::span<double>(angles).subspan(std::size_t(j) * (frames - 1), frames - 1));
    medians.push_back(q.median_step);
    inflated.push_back(100 * q.median_step);
  }
  const StepAngles kept{angles, frames, joints};
  for (double frame_time : {1.0 / 120, 1.0 / 30}) {
    for (const std::vector<std::uint8_t>& skip :
         {std::vector<std::uint8_t>{},
          std::vector<std::uint8_t>{0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0}}) {
      const auto measured = find_impossible_steps(view, frame_time, MotionSplitParams{}, skip);
      const auto from_kept = find_impossible_steps(kept, frame_time, MotionSplitParams{}, skip);
      // With the classification's median steps too (what the conditioning hands it).
      const auto with_medians =
          find_impossible_steps(kept, frame_time, MotionSplitParams{}, skip, medians);
      for (const auto* found : {&from_kept, &with_medians}) {
        ASSERT_EQ(measured.size(), found->size());
        ASSERT_FALSE(measured.empty());
        for (std::size_t i = 0; i < measured.size(); ++i) {
          EXPECT_EQ(measured[i].frame, (*found)[i].frame);
          EXPECT_EQ(measured[i].joint, (*found)[i].joint);
          EXPECT_EQ(measured[i].angle, (*found)[i].angle);
          EXPECT_EQ(measured[i].pose_step, (*found)[i].pose_step);
        }
      }
      // The medians are read: a floor 100 times higher hides the one joint's jump.
      EXPECT_LT(find_impossible_steps(kept, frame_time, MotionSplitParams{}, skip, inflated).size(),
                measured.size());
    }
  }
}

}  // namespace
}  // namespace mocap
