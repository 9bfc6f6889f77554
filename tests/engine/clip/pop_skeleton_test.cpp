// Tests of the skeleton test of pop flags (kernels/pop_skeleton.hpp) and of the pop stage with a
// skeleton below 60 fps (engine/clip/clip_conditioning.hpp): at 30 fps a single-joint pop is still
// found and repaired (by auto where a clip's pops are many), while a one-frame excursion of a
// whole limb (a fast kick seen at 30 fps), which the per-joint test alone takes for pops, is left
// alone; at 120 fps a clip with many pops also loses those a fast joint hides from the per-joint
// test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "core/quaternion.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "kernels/median.hpp"
#include "kernels/pop_detour.hpp"
#include "kernels/pop_repair.hpp"
#include "kernels/pop_skeleton.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

constexpr int kFrames = 90, kJoints = 5, kAt = 45;
// Hips -> thigh -> shin -> foot -> toe.
const std::vector<int> kParents{-1, 0, 1, 2, 3};
constexpr double kFrameTime = 1.0 / 30;

// Each joint turns smoothly about its own axis (a walk-like swing, up to 0.5 rad); `excursion`
// adds a one-frame turn of `angle` rad at frame kAt to the joints it marks, about their swing
// axes (the whole limb moves together) or, for a pop, about `pop_axis`.
test::Motion limb(std::vector<int> excursion, double angle, Vec3 pop_axis = {0, 0, 0}) {
  test::Motion m{kFrames, kJoints, std::vector<float>(std::size_t(kFrames) * kJoints * 4)};
  std::mt19937_64 rng(7);
  for (int j = 0; j < kJoints; ++j) {
    const Quat base = test::random_rotation(rng);
    const Vec3 axis = log(test::random_rotation(rng));
    const Vec3 n = (1 / norm(axis)) * axis;
    const double phase = 0.7 * j;
    for (int t = 0; t < kFrames; ++t) {
      Quat q = base * exp((0.5 * std::sin(0.2 * t + phase)) * n);
      if (t == kAt && excursion[std::size_t(j)])
        q = q * exp(angle * (norm(pop_axis) > 0 ? pop_axis : n));
      store_quat(q, m.span().at(t, j));
    }
  }
  make_hemisphere_continuous(m.span());
  return m;
}

int flagged_at(const engine::ClipConditioning& c, int frame, int joint) {
  int n = 0;
  for (std::size_t p = 0; p + 1 < c.pop_samples.size(); p += 2)
    n += c.pop_samples[p] == frame && c.pop_samples[p + 1] == joint;
  return n;
}

TEST(PopSkeleton, ASingleJointPopAt30FpsIsRepaired) {
  const test::Motion clean = limb({0, 0, 0, 0, 0}, 0);
  test::Motion popped = limb({0, 0, 1, 0, 0}, 0.6, {0.6, 0.0, 0.8});
  const engine::ClipConditioning c =
      engine::condition_rotations(engine::PopsMode::repair, popped.span(), kFrameTime, kParents);
  EXPECT_EQ(c.pop_count(), 1u);
  EXPECT_EQ(flagged_at(c, kAt, 2), 1);
  // Repaired: back near the clean motion (the slerp between its neighbours), not 0.6 rad away.
  EXPECT_LT(geodesic(popped.at(kAt, 2), clean.at(kAt, 2)), 0.05);
  // auto below 60 fps: one pop in 450 samples (under kManyPopsFlagged) is found and
  // counted, the clip left as it came...
  test::Motion counted = limb({0, 0, 1, 0, 0}, 0.6, {0.6, 0.0, 0.8});
  ASSERT_LT(1.0, engine::kManyPopsFlagged * kFrames * kJoints);
  const engine::ClipConditioning a = engine::condition_rotations(
      engine::PopsMode::automatic, counted.span(), kFrameTime, kParents);
  EXPECT_FALSE(a.repaired);
  EXPECT_EQ(flagged_at(a, kAt, 2), 1);
  EXPECT_GT(geodesic(counted.at(kAt, 2), clean.at(kAt, 2)), 0.5);
  // ...and three (over it) are repaired.
  test::Motion many = limb({0, 0, 1, 0, 0}, 0.6, {0.6, 0.0, 0.8});
  const int more[2][2] = {{20, 1}, {70, 3}};
  for (const auto& [t, j] : more)
    store_quat(many.at(t, j) * exp(Vec3{0.0, 0.6, 0.0}), many.span().at(t, j));
  ASSERT_GE(3.0, engine::kManyPopsFlagged * kFrames * kJoints);
  const engine::ClipConditioning b =
      engine::condition_rotations(engine::PopsMode::automatic, many.span(), kFrameTime, kParents);
  EXPECT_TRUE(b.repaired);
  EXPECT_EQ(b.pop_count(), 3u);
  EXPECT_LT(geodesic(many.at(kAt, 2), clean.at(kAt, 2)), 0.05);
  for (const auto& [t, j] : more) EXPECT_LT(geodesic(many.at(t, j), clean.at(t, j)), 0.05) << t;
  // Below kAutoRepairMinFps (here the same samples at 15 fps) auto counts as many flags and
  // repairs nothing.
  test::Motion slow = limb({0, 0, 1, 0, 0}, 0.6, {0.6, 0.0, 0.8});
  for (const auto& [t, j] : more)
    store_quat(slow.at(t, j) * exp(Vec3{0.0, 0.6, 0.0}), slow.span().at(t, j));
  const test::Motion slow_before = slow;
  const engine::ClipConditioning d =
      engine::condition_rotations(engine::PopsMode::automatic, slow.span(), 1.0 / 15, kParents);
  ASSERT_LT(15.0, engine::kAutoRepairMinFps);
  EXPECT_GE(d.pop_count(), 3u);
  EXPECT_FALSE(d.repaired);
  EXPECT_EQ(slow.rotations, slow_before.rotations);
}

TEST(PopSkeleton, ACoherentOneFrameLimbSwingAt30FpsIsLeftAlone) {
  const test::Motion swing = limb({0, 1, 1, 1, 1}, 0.6);
  // The per-joint test alone takes the swing for pops on every joint of the limb...
  test::Motion alone = swing;
  const engine::ClipConditioning without =
      engine::condition_rotations(engine::PopsMode::repair, alone.span(), kFrameTime);
  for (int j = 1; j < kJoints; ++j) EXPECT_EQ(flagged_at(without, kAt, j), 1) << j;
  // ...the skeleton sees the whole limb move and flags nothing: the clip comes out bit for bit.
  test::Motion with = swing;
  const engine::ClipConditioning c =
      engine::condition_rotations(engine::PopsMode::repair, with.span(), kFrameTime, kParents);
  EXPECT_EQ(c.pop_count(), 0u);
  EXPECT_EQ(with.rotations, swing.rotations);
}

// Two pops side by side in one frame (thigh and shin, about unrelated axes): each joint's
// neighbour leaves its quadratic too, but it is flagged itself and the group is a pair, not a
// limb: both stay flagged and are repaired. With every flagged neighbour counting (pop_group 0)
// the pair vetoes itself.
TEST(PopSkeleton, TwoNeighbouringPopsInOneFrameAreRepaired) {
  const test::Motion clean = limb({0, 0, 0, 0, 0}, 0);
  test::Motion popped = limb({0, 1, 1, 0, 0}, 0.6, {0.6, 0.0, 0.8});
  // The shin's pop about another axis than the thigh's.
  store_quat(clean.at(kAt, 2) * exp(Vec3{-0.5, 0.2, 0.1}), popped.span().at(kAt, 2));
  make_hemisphere_continuous(popped.span());
  test::Motion counted = popped;
  const engine::ClipConditioning c =
      engine::condition_rotations(engine::PopsMode::repair, popped.span(), kFrameTime, kParents);
  EXPECT_EQ(flagged_at(c, kAt, 1), 1);
  EXPECT_EQ(flagged_at(c, kAt, 2), 1);
  for (int j : {1, 2}) EXPECT_LT(geodesic(popped.at(kAt, j), clean.at(kAt, j)), 0.05) << j;

  std::vector<std::uint8_t> flags(std::size_t(kFrames) * kJoints, 0);
  flags[std::size_t(kAt) * kJoints + 1] = flags[std::size_t(kAt) * kJoints + 2] = 1;
  PopSkeletonJob job;
  job.params = engine::pop_params_at(kFrameTime);
  job.rotations = counted.view();
  job.parents = kParents;
  job.flags = flags;
  job.pop_group = 0;
  ASSERT_TRUE(job.run().ok());
  EXPECT_EQ(flags[std::size_t(kAt) * kJoints + 1] + flags[std::size_t(kAt) * kJoints + 2], 0);
}

TEST(PopSkeleton, AtHighFrameRatesTheSkeletonIsNotAsked) {
  // 120 fps: the per-joint test's flags (docs/pops.md), parents or not; the detour test a clip
  // with many pops adds (the test below) keeps none of a limb that moves together.
  test::Motion a = limb({0, 1, 1, 1, 1}, 0.6), b = a;
  const auto with =
      engine::condition_rotations(engine::PopsMode::detect, a.span(), 1.0 / 120, kParents);
  const auto without = engine::condition_rotations(engine::PopsMode::detect, b.span(), 1.0 / 120);
  EXPECT_EQ(with.pop_samples, without.pop_samples);
}

TEST(PopSkeleton, ValidateExplains) {
  test::Motion m = limb({0, 0, 0, 0, 0}, 0);
  std::vector<std::uint8_t> flags(std::size_t(kFrames) * kJoints, 0);
  PopSkeletonJob job;
  job.rotations = m.view();
  job.flags = flags;
  const std::vector<int> short_parents{-1, 0};
  job.parents = short_parents;
  EXPECT_NE(job.validate().message().find("parents must have one entry per joint"),
            std::string::npos);
  const std::vector<int> cyclic{-1, 1, 1, 2, 3};
  job.parents = cyclic;
  EXPECT_NE(job.validate().message().find("joint 1 has parent 1"), std::string::npos);
  job.parents = kParents;
  EXPECT_TRUE(job.validate().ok());
  std::vector<std::uint8_t> few(3);
  job.flags = few;
  EXPECT_NE(job.validate().message().find("flags must have one entry per sample"),
            std::string::npos);
  job.flags = flags;
  job.coherence = 0;
  EXPECT_FALSE(job.validate().ok());
}

// Strong detours (kernels/pop_skeleton.hpp): a pop of 0.8 rad on the shin (detour about 1.6 rad)
// beside a thigh whose quadratic misses at that frame for reasons of its own (glitches 2 and 3
// frames either side: a fit that leaves out t and one block keeps the others) but whose curve
// does not turn back there. The residual test alone takes the thigh for motion and clears the
// flag; with strong_detour the thigh must also detour, and the flag stays. A limb that swings out
// and back in one frame (every joint detours) is still motion.
TEST(PopSkeleton, AStrongDetourIsVetoedOnlyByANeighbourThatTurnsBackToo) {
  test::Motion m = limb({0, 0, 1, 0, 0}, 0.8, {0.6, 0.0, 0.8});
  for (int t : {kAt - 3, kAt - 2, kAt + 2, kAt + 3})
    store_quat(m.at(t, 1) * exp(Vec3{0.0, 1.2, 0.0}), m.span().at(t, 1));
  make_hemisphere_continuous(m.span());
  const PopRepairParams params = engine::pop_params_at(kFrameTime);
  // The premises: the thigh's residual at kAt vetoes (>= coherence x the shin's), its detour
  // there is small, the shin's is strong.
  std::vector<double> residuals[2], spreads(kFrames), fit_errors(kFrames);
  for (int j : {1, 2}) {
    std::vector<Quat> curve(kFrames);
    for (int t = 0; t < kFrames; ++t) curve[std::size_t(t)] = m.at(t, j);
    residuals[j - 1].resize(kFrames);
    pop_residuals(curve, params, residuals[j - 1], spreads, fit_errors);
  }
  const auto detour = [&](int j) {
    return pop_detour(m.at(kAt - 1, j), m.at(kAt, j), m.at(kAt + 1, j));
  };
  ASSERT_GE(residuals[0][kAt], kPopCoherence * residuals[1][kAt]);
  ASSERT_GT(detour(2), kPopStrongDetour);
  ASSERT_LT(detour(1), kPopCoherence * detour(2));

  // The verdict on the shin's flag, with the joints' median detours measured by the skeleton
  // test itself and, as the pop stage runs it, handed over by the detour test: the same verdict.
  const auto verdict = [&](const test::Motion& motion, double strong_detour,
                           std::span<const double> medians) {
    std::vector<std::uint8_t> flags(std::size_t(kFrames) * kJoints, 0);
    flags[std::size_t(kAt) * kJoints + 2] = 1;
    PopSkeletonJob job;
    job.params = params;
    job.rotations = motion.view();
    job.parents = kParents;
    job.flags = flags;
    job.strong_detour = strong_detour;
    job.median_detours = medians;
    EXPECT_TRUE(job.run().ok());
    return flags[std::size_t(kAt) * kJoints + 2] == 1;
  };
  const auto kept = [&](const test::Motion& motion, double strong_detour) {
    std::vector<std::uint8_t> detour_flags(std::size_t(kFrames) * kJoints, 0);
    std::vector<double> medians(kJoints, -1.0);
    PopDetourJob detours;
    detours.rotations = motion.view();
    detours.flags = detour_flags;
    detours.median_detours = medians;
    EXPECT_TRUE(detours.run().ok());
    const bool alone = verdict(motion, strong_detour, {});
    EXPECT_EQ(verdict(motion, strong_detour, medians), alone);
    return alone;
  };
  EXPECT_FALSE(kept(m, 0));
  EXPECT_TRUE(kept(m, kPopStrongDetour));
  // Below the shin's detour the rule does not apply.
  EXPECT_FALSE(kept(m, detour(2) + 0.01));

  // Where the shin's own detours are large everywhere (white noise on every other frame of it),
  // the bar rises to kStrongDetourOverMedian x their median and the residual test decides again.
  test::Motion noisy = m;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.2);
  for (int t = 0; t < kFrames; t += 2)
    if (std::abs(t - kAt) > 1)
      store_quat(noisy.at(t, 2) * exp(Vec3{noise(rng), noise(rng), noise(rng)}),
                 noisy.span().at(t, 2));
  make_hemisphere_continuous(noisy.span());
  std::vector<double> shin_detours;
  for (int t = 1; t + 1 < kFrames; ++t)
    shin_detours.push_back(pop_detour(noisy.at(t - 1, 2), noisy.at(t, 2), noisy.at(t + 1, 2)));
  std::nth_element(shin_detours.begin(), shin_detours.begin() + shin_detours.size() / 2,
                   shin_detours.end());
  ASSERT_GT(kStrongDetourOverMedian * shin_detours[shin_detours.size() / 2], detour(2));
  EXPECT_FALSE(kept(noisy, kPopStrongDetour));
  // A median handed over is read, not measured again: the clean shin's with the noisy one's.
  {
    std::vector<std::uint8_t> detour_flags(std::size_t(kFrames) * kJoints, 0);
    std::vector<double> medians(kJoints, std::nan(""));
    PopDetourJob detours;
    detours.rotations = noisy.view();
    detours.flags = detour_flags;
    detours.median_detours = medians;
    ASSERT_TRUE(detours.run().ok());
    std::vector<double> all = shin_detours;  // the spec's median: of 88, the middle two's mean
    EXPECT_EQ(medians[2], median(all));
    EXPECT_FALSE(verdict(m, kPopStrongDetour, medians));
    EXPECT_TRUE(verdict(m, kPopStrongDetour, {}));
  }

  const test::Motion swing = limb({0, 1, 1, 1, 1}, 0.8);
  ASSERT_GT(pop_detour(swing.at(kAt - 1, 2), swing.at(kAt, 2), swing.at(kAt + 1, 2)),
            kPopStrongDetour);
  EXPECT_FALSE(kept(swing, kPopStrongDetour));
  EXPECT_FALSE(kept(swing, 0));

  PopSkeletonJob job;
  job.params = params;
  job.rotations = m.view();
  job.parents = kParents;
  std::vector<std::uint8_t> flags(std::size_t(kFrames) * kJoints, 0);
  job.flags = flags;
  job.strong_detour = -1;
  EXPECT_NE(job.validate().message().find("strong_detour"), std::string::npos);
}

// At 120 fps the per-joint test alone decides, unless a clip has many pops: there the detour test
// (kernels/pop_detour.hpp) adds the pops a fast joint's fit error hides, each kept only where no
// skeleton neighbour moves with it.
namespace fast {

constexpr int kFrames = 240, kJoints = 5, kAt = 120;
constexpr double kFrameTime = 1.0 / 120;

// The limb above at 120 fps, but joints 2 and 3 (shin and foot) shake fast (0.25 rad at 15 Hz):
// a quadratic over +-5 frames cannot follow them. Every joint also sways about a second axis, so
// that none is a hinge (kernels/pop_hinge.hpp would see these pops off its axis).
test::Motion shaking_limb() {
  test::Motion m{kFrames, kJoints, std::vector<float>(std::size_t(kFrames) * kJoints * 4)};
  std::mt19937_64 rng(11);
  for (int j = 0; j < kJoints; ++j) {
    const Quat base = test::random_rotation(rng);
    const Vec3 axis = log(test::random_rotation(rng));
    const Vec3 n = (1 / norm(axis)) * axis;
    const Vec3 other = log(test::random_rotation(rng));
    const Vec3 sway = (1 / norm(other - dot(other, n) * n)) * (other - dot(other, n) * n);
    const bool shakes = j == 2 || j == 3;
    for (int t = 0; t < kFrames; ++t) {
      const double angle = shakes ? 0.25 * std::sin(2 * kPi * 15 * kFrameTime * t)
                                  : 0.5 * std::sin(0.05 * t + 0.7 * j);
      store_quat(base * exp(angle * n) * exp(0.1 * std::sin(0.1 * t + j) * sway),
                 m.span().at(t, j));
    }
  }
  make_hemisphere_continuous(m.span());
  return m;
}

void pop(test::Motion& m, int t, int j, Vec3 turn) {
  store_quat(m.at(t, j) * exp(turn), m.span().at(t, j));
}

// Six easy pops on the slow joints: 7 flags or more in 1,200 samples put the clip over
// kManyPopsFlagged.
void add_easy_pops(test::Motion& m) {
  for (const auto& [t, j] : {std::pair{20, 0}, {60, 1}, {100, 4}, {150, 0}, {190, 1}, {220, 4}})
    pop(m, t, j, {0.0, 0.6, 0.0});
}

}  // namespace fast

TEST(PopSkeleton, At120FpsAClipWithManyPopsLosesTheOnesFastMotionHides) {
  const Vec3 turn{0.5, 0.4, 0.3};
  // Alone in its clip, the pop on the shaking shin is hidden from the per-joint test.
  test::Motion few = fast::shaking_limb();
  fast::pop(few, fast::kAt, 2, turn);
  const auto alone =
      engine::condition_rotations(engine::PopsMode::detect, few.span(), fast::kFrameTime, kParents);
  ASSERT_EQ(flagged_at(alone, fast::kAt, 2), 0)
      << "the per-joint test found it: the test proves nothing";
  ASSERT_LT(double(alone.pop_count()), engine::kManyPopsFlagged * fast::kFrames * fast::kJoints);

  // With the easy pops beside it, the clip has many, and the detour test finds it too.
  test::Motion many = fast::shaking_limb();
  const test::Motion clean = many;
  fast::pop(many, fast::kAt, 2, turn);
  fast::add_easy_pops(many);
  const auto found = engine::condition_rotations(engine::PopsMode::repair, many.span(),
                                                 fast::kFrameTime, kParents);
  ASSERT_GE(double(found.pop_count()), engine::kManyPopsFlagged * fast::kFrames * fast::kJoints);
  EXPECT_EQ(flagged_at(found, fast::kAt, 2), 1);
  EXPECT_EQ(found.pop_count(), 7u);
  EXPECT_LT(geodesic(many.at(fast::kAt, 2), clean.at(fast::kAt, 2)), 0.1);

  // The same turn on the shin and the foot in one frame moves them together: no pop.
  test::Motion pair = fast::shaking_limb();
  fast::pop(pair, fast::kAt, 2, turn);
  fast::pop(pair, fast::kAt, 3, turn);
  fast::add_easy_pops(pair);
  const auto coherent = engine::condition_rotations(engine::PopsMode::detect, pair.span(),
                                                    fast::kFrameTime, kParents);
  EXPECT_EQ(flagged_at(coherent, fast::kAt, 2) + flagged_at(coherent, fast::kAt, 3), 0);
  EXPECT_EQ(coherent.pop_count(), 6u);
}

}  // namespace
}  // namespace mocap
