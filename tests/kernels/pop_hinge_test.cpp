// Tests of the hinge test (kernels/pop_hinge.hpp): the distance to a hinge's curve is the angle
// off its axis and the projection the curve's nearest point; the job flags every pop that takes a
// hinge off its curve (the spec's impulse model, runs of one and two, the first frame too) and
// nothing else: not a joint that turns about several axes, not a noisy hinge, not real motion
// that leaves the axis for longer than a run; it keeps the flags it was given, skips joints, runs
// in slices to the same flags and says what is wrong with its inputs; on the clean shared clips
// it finds CMU's knees, elbows, wrists and toes and flags nothing, at 120 and 30 fps.
#include "kernels/pop_hinge.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
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

Vec3 random_axis(std::mt19937_64& rng) {
  return unit(log(test::random_rotation(rng)));
}

// A unit axis at right angles to a.
Vec3 perpendicular(Vec3 a, std::mt19937_64& rng) {
  const Vec3 b = log(test::random_rotation(rng));
  return unit(b - dot(a, b) * a);
}

// Joint 0 and 2: hinges (reference Exp(theta(t) axis)) swinging fast, 1.2 rad at 1.5 Hz plus 0.3
// rad at 4 Hz, at 30 fps: steps up to 0.4 rad; joint 1 turns about several axes
// (test::random_motion).
struct HingeClip {
  Motion motion;
  Hinge truth[3];
};

HingeClip hinge_clip(std::uint64_t seed, int frames = 300) {
  std::mt19937_64 rng(seed);
  HingeClip clip;
  clip.motion = {frames, 3, test::random_motion(rng, frames, 3, 1.0)};
  for (const int j : {0, 2}) {
    Hinge& h = clip.truth[j];
    h.found = true;
    h.reference = test::random_rotation(rng);
    h.axis = random_axis(rng);
    const double phase = std::uniform_real_distribution<double>(0, 6)(rng);
    for (int t = 0; t < frames; ++t) {
      const double s = t / 30.0;
      const double theta =
          1.2 * std::sin(2 * kPi * 1.5 * s + phase) + 0.3 * std::sin(2 * kPi * 4 * s);
      store_quat(h.reference * exp(theta * h.axis), clip.motion.span().at(t, j));
    }
  }
  make_hemisphere_continuous(clip.motion.span());
  return clip;
}

std::vector<std::uint8_t> run_job(const Motion& m, std::vector<Hinge>* hinges = nullptr) {
  std::vector<std::uint8_t> flags(std::size_t(m.frames) * std::size_t(m.joints), 0);
  PopHingeJob job;
  job.rotations = m.view();
  job.flags = flags;
  if (hinges) {
    hinges->assign(std::size_t(m.joints), Hinge{});
    job.hinges = *hinges;
  }
  EXPECT_TRUE(job.run().ok());
  return flags;
}

TEST(PopHinge, TheDistanceIsTheAngleOffTheAxisAndTheProjectionTheCurvesPoint) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 500; ++i) {
    Hinge h;
    h.found = true;
    h.reference = test::random_rotation(rng);
    h.axis = random_axis(rng);
    const double theta = std::uniform_real_distribution<double>(-3, 3)(rng);
    const double off = std::uniform_real_distribution<double>(0, 3)(rng);
    const Quat on = h.reference * exp(theta * h.axis);
    const Quat q = on * exp(off * perpendicular(h.axis, rng));
    EXPECT_NEAR(hinge_distance(h, on), 0.0, 1e-7) << i;
    EXPECT_NEAR(hinge_distance(h, q), off, 1e-7) << i;
    EXPECT_NEAR(geodesic(project_onto_hinge(h, q), on), 0.0, 1e-7) << i;
    EXPECT_GE(dot(project_onto_hinge(h, q), q), 0.0) << i;
    // No point of the curve is nearer than the projection.
    for (const double d : {-0.1, 0.1})
      EXPECT_LE(geodesic(q, project_onto_hinge(h, q)),
                geodesic(q, h.reference * exp((theta + d) * h.axis)) + 1e-9)
          << i;
  }
}

// The spec's impulse model (2 % pops of 0.3-1 rad about random axes) on the clip: a flag only on
// a popped sample off the hinge's curve, and on every one that the pop took more than
// kHingePopAngle off it (all but those popped nearly about the axis itself; at least 97 % of
// the popped samples in all); the free joint gets none.
TEST(PopHinge, FlagsEveryPopOffAHingeAndNothingElse) {
  int popped_hinge_samples = 0, caught = 0;
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    HingeClip clip = hinge_clip(seed);
    const Motion clean = clip.motion;
    ImpulseNoise noise;
    noise.rate = 0.02;
    noise.seed = seed;
    ASSERT_GT(add_noise(noise, clip.motion.span()), 0);
    std::vector<Hinge> hinges;
    const std::vector<std::uint8_t> flags = run_job(clip.motion, &hinges);
    const int F = clip.motion.frames;
    for (const int j : {0, 2}) {
      ASSERT_TRUE(hinges[std::size_t(j)].found) << seed << " " << j;
      EXPECT_GT(std::abs(dot(hinges[std::size_t(j)].axis, clip.truth[j].axis)), 1 - 1e-9);
    }
    EXPECT_FALSE(hinges[1].found) << seed;
    for (int t = 0; t < F; ++t) {
      EXPECT_EQ(flags[std::size_t(t) * 3 + 1], 0) << seed << " " << t;
      for (const int j : {0, 2}) {
        const bool popped = geodesic(clip.motion.at(t, j), clean.at(t, j)) > 1e-6;
        const double off = hinge_distance(clip.truth[j], clip.motion.at(t, j));
        // A run of three popped frames would be too long to be pops: the draws here have none.
        const auto popped_at = [&](int s) {
          return s >= 0 && s < F && geodesic(clip.motion.at(s, j), clean.at(s, j)) > 1e-6;
        };
        ASSERT_FALSE(popped_at(t) && popped_at(t + 1) && popped_at(t + 2)) << seed;
        const int flag = flags[std::size_t(t) * 3 + std::size_t(j)];
        if (!popped || off <= kHingeTolerance) {
          EXPECT_EQ(flag, 0) << seed << " frame " << t;
        }
        if (popped && off > kHingePopAngle) {
          EXPECT_EQ(flag, 1) << seed << " frame " << t;
        }
        popped_hinge_samples += popped;
        caught += flag;
      }
    }
  }
  EXPECT_GT(popped_hinge_samples, 100);
  EXPECT_GE(caught, 0.97 * popped_hinge_samples) << caught << " of " << popped_hinge_samples;
}

TEST(PopHinge, RunsOfTwoAndTheFirstAndLastFramesAreFlagged) {
  HingeClip clip = hinge_clip(3);
  const int F = clip.motion.frames;
  const Vec3 turn{0.3, -0.4, 0.2};
  for (const int t : {0, 50, 51, 120, F - 1})
    store_quat(clip.motion.at(t, 0) * exp(turn), clip.motion.span().at(t, 0));
  const std::vector<std::uint8_t> flags = run_job(clip.motion);
  for (int t = 0; t < F; ++t)
    EXPECT_EQ(flags[std::size_t(t) * 3], t == 0 || t == 50 || t == 51 || t == 120 || t == F - 1)
        << t;
  // Three in a row are no pops (kHingeMaxRun), the two alone are.
  store_quat(clip.motion.at(52, 0) * exp(turn), clip.motion.span().at(52, 0));
  const std::vector<std::uint8_t> three = run_job(clip.motion);
  EXPECT_EQ(three[50 * 3] + three[51 * 3] + three[52 * 3], 0);
  EXPECT_EQ(three[120 * 3], 1);
}

TEST(PopHinge, ACleanHingeANoisyHingeAndAFreeJointGiveNoFlags) {
  HingeClip clip = hinge_clip(5);
  std::vector<Hinge> hinges;
  std::vector<std::uint8_t> flags = run_job(clip.motion, &hinges);
  EXPECT_EQ(std::count(flags.begin(), flags.end(), 1), 0);
  EXPECT_TRUE(hinges[0].found);
  EXPECT_TRUE(hinges[2].found);
  EXPECT_FALSE(hinges[1].found);
  // Samples off the curve by more than the tolerance but less than kHingePopAngle (5 mrad: a
  // faint noise's tail) are no pops; one 0.1 rad off is.
  static_assert(0.005 > kHingeTolerance && 0.005 < kHingePopAngle);
  HingeClip faint = hinge_clip(5);
  std::mt19937_64 rng(6);
  for (const int t : {40, 90, 140, 190})
    store_quat(faint.motion.at(t, 0) * exp(0.005 * perpendicular(faint.truth[0].axis, rng)),
               faint.motion.span().at(t, 0));
  store_quat(faint.motion.at(240, 0) * exp(0.1 * perpendicular(faint.truth[0].axis, rng)),
             faint.motion.span().at(240, 0));
  flags = run_job(faint.motion, &hinges);
  EXPECT_TRUE(hinges[0].found);
  EXPECT_EQ(std::count(flags.begin(), flags.end(), 1), 1);
  EXPECT_EQ(flags[240 * 3], 1);
  // Sensor noise far below the spec's least (0.008 rad) already hides the axis: no test, no flag.
  GaussianNoise noise;
  noise.sigma = 0.002;
  add_noise(noise, clip.motion.span());
  flags = run_job(clip.motion, &hinges);
  EXPECT_EQ(std::count(flags.begin(), flags.end(), 1), 0);
  EXPECT_FALSE(hinges[0].found);
  EXPECT_FALSE(hinges[2].found);
}

// A hinge whose last 20 frames also turn about a second axis (real motion, slowly): the joint is
// still a hinge for 93 % of its steps, but those frames leave the curve together, not as pops.
TEST(PopHinge, MotionThatLeavesTheAxisForLongerThanARunIsNoPop) {
  HingeClip clip = hinge_clip(9);
  const int F = clip.motion.frames;
  std::mt19937_64 rng(4);
  const Vec3 side = perpendicular(clip.truth[0].axis, rng);
  for (int t = F - 20; t < F; ++t)
    store_quat(clip.motion.at(t, 0) * exp(0.02 * (t - (F - 21)) * side),
               clip.motion.span().at(t, 0));
  std::vector<Hinge> hinges;
  const std::vector<std::uint8_t> flags = run_job(clip.motion, &hinges);
  EXPECT_TRUE(hinges[0].found);
  EXPECT_EQ(std::count(flags.begin(), flags.end(), 1), 0);
}

TEST(PopHinge, KeepsGivenFlagsSkipsJointsAndRunsInSlicesToTheSameFlags) {
  HingeClip clip = hinge_clip(2);
  ImpulseNoise noise;
  noise.rate = 0.03;
  noise.seed = 8;
  add_noise(noise, clip.motion.span());
  const std::vector<std::uint8_t> whole = run_job(clip.motion);
  ASSERT_GT(std::count(whole.begin(), whole.end(), 1), 5);

  std::vector<std::uint8_t> sliced(whole.size(), 0);
  for (int j = 0; j < 3; ++j) {
    PopHingeJob job;
    job.rotations = clip.motion.view();
    job.flags = sliced;
    job.joint_begin = j;
    job.joint_end = j + 1;
    ASSERT_TRUE(job.run().ok());
  }
  EXPECT_EQ(sliced, whole);

  std::vector<std::uint8_t> given(whole.size(), 0), skip{1, 0, 0};
  given[7 * 3 + 1] = 1;  // a flag of another test, on the free joint
  PopHingeJob job;
  job.rotations = clip.motion.view();
  job.flags = given;
  job.skip = skip;
  ASSERT_TRUE(job.run().ok());
  EXPECT_EQ(given[7 * 3 + 1], 1);
  for (int t = 0; t < clip.motion.frames; ++t) {
    EXPECT_EQ(given[std::size_t(t) * 3], 0) << t;
    EXPECT_EQ(given[std::size_t(t) * 3 + 2], whole[std::size_t(t) * 3 + 2]) << t;
  }
}

TEST(PopHinge, ValidateSaysWhatIsWrong) {
  const HingeClip clip = hinge_clip(1, 40);
  std::vector<std::uint8_t> flags(40 * 3, 0);
  std::vector<Hinge> hinges(2);
  PopHingeJob job;
  job.rotations = clip.motion.view();
  job.flags = flags;
  EXPECT_TRUE(job.validate().ok());
  job.tolerance = 0;
  EXPECT_NE(job.validate().message().find("tolerance"), std::string::npos);
  job.tolerance = kHingeTolerance;
  job.share = 1.5;
  EXPECT_NE(job.validate().message().find("share"), std::string::npos);
  job.share = kHingeShare;
  job.max_run = 0;
  EXPECT_NE(job.validate().message().find("max_run"), std::string::npos);
  job.max_run = kHingeMaxRun;
  job.pop_angle = 0.5 * kHingeTolerance;
  EXPECT_NE(job.validate().message().find("pop_angle"), std::string::npos);
  job.pop_angle = kHingePopAngle;
  job.hinges = hinges;
  EXPECT_NE(job.validate().message().find("hinges"), std::string::npos);
  job.hinges = {};
  job.joint_end = 4;
  EXPECT_NE(job.validate().message().find("joints"), std::string::npos);
  job.joint_end = -1;
  job.flags = std::span<std::uint8_t>(flags).first(10);
  EXPECT_FALSE(job.validate().ok());
}

// The shared clips as they come (120 fps, CMU's T-pose frame 0 included) and every 4th frame
// (30 fps): CMU's solver drives the knees, elbows, wrists and toes about one axis each, and the
// T-pose lies on their curves; no sample leaves them, so nothing is flagged.
TEST(PopHinge, FindsCmusHingesAndFlagsNothingOnCleanCaptures) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  const std::vector<std::string> expected{"LeftLeg",      "RightLeg",    "LeftToeBase",
                                          "RightToeBase", "LeftForeArm", "RightForeArm",
                                          "LeftHand",     "RightHand"};
  for (const auto& path : test::shared_bvh_files()) {
    const io::BvhReadResult read = io::read_bvh(path);
    ASSERT_TRUE(read.clip) << path;
    const Clip& clip = *read.clip;
    for (const int step : {1, 4}) {
      const Motion m =
          test::every_nth_frame(clip.rotation_view(), 0, step, (clip.frames - 1) / step + 1);
      std::vector<Hinge> hinges;
      const std::vector<std::uint8_t> flags = run_job(m, &hinges);
      EXPECT_EQ(std::count(flags.begin(), flags.end(), 1), 0) << path << " step " << step;
      for (const std::string& name : expected) {
        const auto& names = clip.skeleton->joint_names;
        const auto at = std::find(names.begin(), names.end(), name);
        ASSERT_NE(at, names.end()) << path << " " << name;
        EXPECT_TRUE(hinges[std::size_t(at - names.begin())].found)
            << path << " " << name << " step " << step;
      }
    }
  }
}

}  // namespace
}  // namespace mocap
