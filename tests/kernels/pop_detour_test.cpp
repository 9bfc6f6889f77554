// Tests of the detour test (kernels/pop_detour.hpp): the detour is never negative, zero for a
// turn at constant speed whatever its speed, and for a pop across a turn the spherical triangle's
// excess; the job flags the largest detour of a pop above its threshold and not its neighbours',
// keeps the flags it was given, leaves skipped joints and the frames next to the ends alone, reads
// step angles it is given and runs in joint slices to the same flags, and says what is wrong with
// its inputs; on the clean shared clips at 30 fps it flags next to nothing.
#include "kernels/pop_detour.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "io/bvh_reader.hpp"
#include "kernels/noise_model.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

using test::Motion;

Vec3 unit(Vec3 v) {
  return (1 / norm(v)) * v;
}

// Two unit axes at right angles.
std::pair<Vec3, Vec3> perpendicular_axes(std::mt19937_64& rng) {
  const Vec3 a = unit(log(test::random_rotation(rng)));
  Vec3 b = log(test::random_rotation(rng));
  b = unit(b - dot(a, b) * a);
  return {a, b};
}

TEST(PopDetour, NeverNegativeAndZeroForATurnAtConstantSpeed) {
  std::mt19937_64 rng(3);
  for (int i = 0; i < 2000; ++i) {
    const Quat a = test::random_rotation(rng), b = test::random_rotation(rng),
               c = test::random_rotation(rng);
    EXPECT_GE(pop_detour(a, b, c), -1e-12) << i;
  }
  for (const double speed : {0.01, 0.1, 0.5, 0.9, 1.4}) {
    const Quat base = test::random_rotation(rng);
    const Vec3 axis = unit(log(test::random_rotation(rng)));
    const Quat step = exp(speed * axis);
    EXPECT_NEAR(pop_detour(base, base * step, base * step * step), 0.0, 1e-9) << speed;
  }
}

// A pop of angle p about an axis at right angles to a turn of s per frame: each step through the
// popped sample is a rotation of angle 2 acos(cos(s/2) cos(p/2)), the direct step is 2s; on a
// joint that holds still (s = 0) the detour is 2p.
TEST(PopDetour, APopAcrossATurnAddsTheSphericalTrianglesExcess) {
  std::mt19937_64 rng(5);
  for (const double s : {0.0, 0.2, 0.5, 0.8})
    for (const double p : {0.3, 0.6, 1.0}) {
      const auto [turn, across] = perpendicular_axes(rng);
      const Quat base = test::random_rotation(rng);
      const Quat before = base, mid = base * exp(s * turn), after = base * exp(2 * s * turn);
      const double expected = 4 * std::acos(std::cos(s / 2) * std::cos(p / 2)) - 2 * s;
      EXPECT_NEAR(pop_detour(before, mid * exp(p * across), after), expected, 1e-9)
          << "s " << s << " p " << p;
      if (s == 0) {
        EXPECT_NEAR(expected, 2 * p, 1e-12);
      }
    }
}

// Joints turning at constant speeds (0.05-0.8 rad per frame), no detour anywhere; pops put where
// the detour is known.
Motion turning_motion(int frames, int joints) {
  std::mt19937_64 rng(11);
  Motion m{frames, joints, std::vector<float>(std::size_t(frames) * joints * 4)};
  for (int j = 0; j < joints; ++j) {
    const Quat base = test::random_rotation(rng);
    const Vec3 axis = unit(log(test::random_rotation(rng)));
    const double speed = 0.05 + 0.75 * j / std::max(joints - 1, 1);
    for (int t = 0; t < frames; ++t) store_quat(base * exp((speed * t) * axis), m.span().at(t, j));
  }
  return m;
}

TEST(PopDetourJob, FlagsTheLargestDetoursAboveItsThresholdAndKeepsTheFlagsItWasGiven) {
  constexpr int F = 60, J = 4;
  Motion m = turning_motion(F, J);
  // Joint 0 (0.05 rad per frame): a pop of 0.5 rad (detour about 0.99) at 10, of 0.2 (about 0.39,
  // below the default 0.6) at 20; joint 2 (0.55 rad per frame): a pop of 1 rad at 30 nearly along
  // its turn, whose next frame's detour passes the threshold too, and pops next to both ends;
  // joint 3 skipped with a pop of 1 rad at 30.
  std::mt19937_64 rng(17);
  auto pop = [&](int t, int j, double angle) {
    const Vec3 axis = unit(log(test::random_rotation(rng)));
    store_quat(m.at(t, j) * exp(angle * axis), m.span().at(t, j));
  };
  pop(10, 0, 0.5);
  pop(20, 0, 0.2);
  {
    // 15 degrees off the joint's own turn: the frame after the pop makes a detour of 0.76 rad.
    const Vec3 turn = unit(log(inverse(m.at(0, 2)) * m.at(1, 2)));
    const Vec3 other{0.3, 0.5, 0.8};
    const Vec3 across = unit(other - dot(other, turn) * turn);
    const double a = 15 * kPi / 180;
    store_quat(m.at(30, 2) * exp(std::cos(a) * turn + std::sin(a) * across), m.span().at(30, 2));
  }
  pop(0, 2, 1.0);
  pop(1, 2, 1.0);
  pop(F - 1, 2, 1.0);
  pop(30, 3, 1.0);
  auto detour_at = [&](int t, int j) {
    return pop_detour(m.at(t - 1, j), m.at(t, j), m.at(t + 1, j));
  };
  ASSERT_GT(detour_at(10, 0), kPopDetour);
  ASSERT_LT(detour_at(20, 0), kPopDetour);
  ASSERT_GT(std::max(detour_at(29, 2), detour_at(31, 2)), kPopDetour);
  ASSERT_GT(detour_at(30, 2), std::max(detour_at(29, 2), detour_at(31, 2)));

  std::vector<std::uint8_t> flags(std::size_t(F) * J, 0), skip{0, 0, 0, 1};
  flags[std::size_t(40) * J + 1] = 1;  // find_pops' flag: stays
  PopDetourJob job;
  job.rotations = m.view();
  job.skip = skip;
  job.flags = flags;
  ASSERT_TRUE(job.run().ok());
  // The largest detour of a pop, not its neighbours'; within two frames of an end (where the
  // detour may be the end frame's own pop) nothing; nothing on the skipped joint.
  for (int t = 0; t < F; ++t)
    for (int j = 0; j < J; ++j) {
      const bool expected = (t == 10 && j == 0) || (t == 30 && j == 2) || (t == 40 && j == 1);
      EXPECT_EQ(flags[std::size_t(t) * J + std::size_t(j)], expected ? 1 : 0)
          << "frame " << t << " joint " << j;
    }
  // A lower threshold takes the smaller pop too.
  std::fill(flags.begin(), flags.end(), 0);
  job.threshold = 0.3;
  ASSERT_TRUE(job.run().ok());
  EXPECT_EQ(std::count(flags.begin(), flags.end(), 1), 3);  // find_pops' flag was cleared
  EXPECT_EQ(flags[std::size_t(20) * J], 1);
}

// Below 30 fps a real motion's detour grows as the square of the frame time, and so does the
// threshold; at 30 fps and above it is kPopDetour.
TEST(PopDetour, TheThresholdGrowsAsTheSquareOfTheFrameTimeBelow30Fps) {
  EXPECT_EQ(pop_detour_threshold(1.0 / 30), kPopDetour);
  EXPECT_EQ(pop_detour_threshold(1.0 / 50), kPopDetour);
  EXPECT_EQ(pop_detour_threshold(1.0 / 120), kPopDetour);
  EXPECT_NEAR(pop_detour_threshold(1.0 / 24), kPopDetour * 1.25 * 1.25, 1e-12);
  EXPECT_NEAR(pop_detour_threshold(1.0 / 15), kPopDetour * 4, 1e-12);
}

// Given the step angles the classification measured (of a longer clip, from an offset), and run
// in joint slices, the job sets the same flags as on its own.
TEST(PopDetourJob, StepAnglesGivenAndJointSlicesSetTheSameFlags) {
  constexpr int F = 200, J = 5, kOffset = 30, kFrames = 120;
  Motion m = turning_motion(F, J);
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int t = 0; t < F; ++t)
    for (int j = 0; j < J; ++j)
      if (u(rng) < 0.06)
        store_quat(m.at(t, j) * exp((0.3 + 0.7 * u(rng)) * unit(log(test::random_rotation(rng)))),
                   m.span().at(t, j));
  std::vector<double> angles(std::size_t(J) * (F - 1));
  for (int j = 0; j < J; ++j)
    for (int t = 0; t + 1 < F; ++t)
      angles[std::size_t(j) * (F - 1) + std::size_t(t)] = geodesic(m.at(t, j), m.at(t + 1, j));
  const StepAngles steps{angles, F, J};
  const RotationView part{m.rotations.data() + std::size_t(kOffset) * J * 4, kFrames, J};

  std::vector<std::uint8_t> alone(std::size_t(kFrames) * J, 0), given = alone, sliced = alone;
  PopDetourJob job;
  job.rotations = part;
  job.flags = alone;
  ASSERT_TRUE(job.run().ok());
  ASSERT_GE(std::count(alone.begin(), alone.end(), 1), 5);
  job.flags = given;
  job.steps = &steps;
  job.step_offset = kOffset;
  ASSERT_TRUE(job.run().ok());
  EXPECT_EQ(given, alone);
  job.flags = sliced;
  for (int j = 0; j < J; j += 2) {
    job.joint_begin = j;
    job.joint_end = std::min(j + 2, J);
    ASSERT_TRUE(job.run().ok()) << j;
  }
  EXPECT_EQ(sliced, alone);

  job.joint_begin = 0;
  job.joint_end = J + 1;
  EXPECT_NE(job.validate().message().find("joints [0, 6) outside the clip's 5"), std::string::npos);
  job.joint_end = -1;
  job.step_offset = F - kFrames + 1;
  EXPECT_NE(job.validate().message().find("step angles do not cover"), std::string::npos);
}

// Sensor noise is not a pop (header, "Noise"): with 0.12 and 0.24 rad of white noise per axis on
// a slow 20-joint motion at 30 fps the job flags at most 0.25 % of the samples, below the 0.4 %
// from which `auto` repairs a clip at this rate (engine/clip/filter_settings.hpp,
// kManyPopsFlagged; with the fixed threshold alone, 4.6 % and 22 %), while a 1.2 rad pop on one
// joint through 0.12 rad is flagged.
TEST(PopDetourJob, NoiseIsNotAPopButAPopThroughNoiseIsFlagged) {
  const int frames = 300, joints = 20;
  for (const double sigma : {0.12, 0.24})
    for (const bool pop : {false, true}) {
      if (pop && sigma > 0.12) continue;
      std::mt19937_64 rng(31);
      std::vector<float> m = test::random_motion(rng, frames, joints, 0.05);
      add_noise(GaussianNoise{sigma, 9}, {m.data(), frames, joints});
      if (pop) {
        float* q = &m[(std::size_t(150) * joints + 4) * 4];
        store_quat(load_quat(q) * exp(Vec3{1.2, 0, 0}), q);
      }
      make_hemisphere_continuous({m.data(), frames, joints});
      std::vector<std::uint8_t> flags(std::size_t(frames) * joints, 0);
      PopDetourJob job;
      job.rotations = {m.data(), frames, joints};
      job.threshold = pop_detour_threshold(1.0 / 30);
      job.flags = flags;
      ASSERT_TRUE(job.run().ok());
      const long flagged = std::count(flags.begin(), flags.end(), std::uint8_t{1});
      std::printf("sigma %.2f%s: %ld of %d samples flagged\n", sigma, pop ? ", a pop" : "", flagged,
                  frames * joints);
      EXPECT_LE(flagged, 0.0025 * frames * joints) << sigma;
      if (pop) {
        EXPECT_EQ(flags[std::size_t(150) * joints + 4], 1) << sigma;
      }
    }
}

TEST(PopDetourJob, SaysWhatIsWrongWithItsInputs) {
  Motion m = turning_motion(10, 3);
  std::vector<std::uint8_t> flags(30, 0), short_flags(29, 0), skip(2, 0);
  PopDetourJob job;
  job.rotations = m.view();
  job.flags = short_flags;
  EXPECT_NE(job.validate().message().find("flags must have one entry per sample (30)"),
            std::string::npos);
  job.flags = flags;
  job.skip = skip;
  EXPECT_NE(job.validate().message().find("skip must have one entry per joint (3)"),
            std::string::npos);
  job.skip = {};
  for (const double bad : {0.0, -1.0, std::nan("")}) {
    job.threshold = bad;
    EXPECT_FALSE(job.validate().ok()) << bad;
  }
  job.threshold = kPopDetour;
  EXPECT_TRUE(job.validate().ok());
}

// The shared clips at 30 fps (every 4th frame; frame 0, CMU's synthetic T-pose, left out), with no
// noise added: the detour flags at most 0.05 % of their samples (the budget of false
// repairs on a clean capture, and some of these are the captures' own one-frame glitches).
TEST(PopDetourJob, FlagsNextToNothingOnCleanCapturesAt30Fps) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  std::size_t samples = 0, flagged = 0;
  for (const auto& path : test::shared_bvh_files()) {
    const io::BvhReadResult read = io::read_bvh(path);
    ASSERT_TRUE(read.clip) << path;
    const Clip& clip = *read.clip;
    const Motion m = test::every_nth_frame(clip.rotation_view(), 1, 4, (clip.frames - 1) / 4);
    std::vector<std::uint8_t> flags(std::size_t(m.frames) * std::size_t(m.joints), 0);
    PopDetourJob job;
    job.rotations = m.view();
    job.flags = flags;
    ASSERT_TRUE(job.run().ok()) << path;
    samples += flags.size();
    flagged += std::size_t(std::count(flags.begin(), flags.end(), 1));
  }
  ASSERT_GT(samples, 50000u);
  EXPECT_LE(double(flagged), 0.0005 * double(samples)) << flagged << " of " << samples;
}

}  // namespace
}  // namespace mocap
