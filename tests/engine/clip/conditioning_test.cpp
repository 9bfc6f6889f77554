// The engine's stage before the filters (engine/clip/clip_conditioning.hpp): pop repair by frame
// rate, garbage joints found, kept as they came and out of nlpm's distance; --pops off is the
// spec's filter exactly; --method auto; what the --json summary reports.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "core/quaternion.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "engine/clip/filter_settings.hpp"
#include "engine/library/demo_library.hpp"
#include "engine/run/pipeline.hpp"
#include "io/bvh_writer.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/noise_model.hpp"
#include "kernels/pop_hinge.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using engine::ClipConditioning;
using engine::FilterSettings;
using engine::Method;
using engine::PopsMode;

constexpr int kFlipping = 3, kConstant = 7, kPopped = 5;

// The demo's 120 fps walk with one joint flipping by ~pi every 6 frames (an uncaptured thumb),
// one constant joint, light jitter everywhere else, and pops on one joint: one, two and three in
// a row. `pops` receives the popped frames.
Clip test_clip(double fps_divisor, std::vector<int>* pops) {
  Clip clip = engine::make_demo_library()[0].clip;
  EXPECT_NEAR(clip.frame_time, 1.0 / 120, 1e-9);
  const int J = clip.joints();
  add_noise(GaussianNoise{0.003, 7}, clip.rotation_span());
  for (int t = 0; t < clip.frames; ++t) {
    float* c = &clip.rotations[(std::size_t(t) * J + kConstant) * 4];
    c[0] = 1, c[1] = c[2] = c[3] = 0;
    const Quat base = exp(Vec3{0, 0, 0.3});
    const Quat flip = (t / 6) % 2 ? base * exp(Vec3{3.04, 0, 0}) : base;  // 0.1 rad short of pi
    store_quat(flip, &clip.rotations[(std::size_t(t) * J + kFlipping) * 4]);
  }
  if (fps_divisor > 1) {  // every 4th frame: the same motion at 30 fps
    const int step = int(fps_divisor), frames = clip.frames / step;
    for (int t = 0; t < frames; ++t)
      std::memmove(&clip.rotations[std::size_t(t) * J * 4],
                   &clip.rotations[std::size_t(t) * step * J * 4], sizeof(float) * J * 4);
    clip.frames = frames;
    clip.frame_time *= step;
    clip.rotations.resize(std::size_t(frames) * J * 4);
    clip.translations.resize(std::size_t(frames) * J * 3);
  }
  for (int first : {20, 50, 90}) {
    const int run = first == 20 ? 1 : first == 50 ? 2 : 3;
    for (int t = first; t < first + run; ++t) {
      float* q = &clip.rotations[(std::size_t(t) * J + kPopped) * 4];
      store_quat(load_quat(q) * exp(Vec3{0, 0.7, 0.2}), q);
      if (pops) pops->push_back(t);
    }
  }
  make_hemisphere_continuous(clip.rotation_span());
  return clip;
}

// test_clip without its pops (rebuilt from the same seeds, each pop turned back).
Clip without_pops(double fps_divisor, const std::vector<int>& pops) {
  Clip clean = test_clip(fps_divisor, nullptr);
  for (int t : pops) {
    float* q = &clean.rotations[(std::size_t(t) * clean.joints() + kPopped) * 4];
    store_quat(load_quat(q) * exp(Vec3{0, -0.7, -0.2}), q);
  }
  return clean;
}

// The first frame where joint j's rotation differs in any bit between a and b; -1 if none.
int first_changed_frame(const Clip& a, const Clip& b, int j) {
  for (int t = 0; t < a.frames; ++t) {
    const std::size_t at = (std::size_t(t) * std::size_t(a.joints()) + std::size_t(j)) * 4;
    if (std::memcmp(&a.rotations[at], &b.rotations[at], 4 * sizeof(float)) != 0) return t;
  }
  return -1;
}

double error_at(const Clip& a, const Clip& b, int t, int j) {
  return test::rotation_error(a.rotation_view(), b.rotation_view(), t, j);
}

TEST(Conditioning, RepairsPopsAndFindsGarbageJointsAt120Fps) {
  std::vector<int> pops;
  Clip clip = test_clip(1, &pops);
  const Clip before = clip;
  const ClipConditioning c =
      engine::condition_rotations(PopsMode::automatic, clip.rotation_span(), clip.frame_time);
  EXPECT_TRUE(c.repaired);
  EXPECT_EQ(to_string(c.joints[kFlipping].joint_class), "flipping");
  EXPECT_EQ(to_string(c.joints[kConstant].joint_class), "constant");
  EXPECT_TRUE(c.garbage[kFlipping] && c.garbage[kConstant]);
  EXPECT_EQ(std::count(c.garbage.begin(), c.garbage.end(), 1), 2);
  // Every pop found, nothing else, and each repaired to within the jitter of its neighbours.
  EXPECT_EQ(c.pops[kPopped], int(pops.size()));
  EXPECT_EQ(c.pop_count(), pops.size());
  for (int t : pops) EXPECT_GT(error_at(before, clip, t, kPopped), 0.5) << "frame " << t;
  // The flipping joint (constant between flips, no pop) is left bit for bit as it came.
  EXPECT_EQ(first_changed_frame(clip, before, kFlipping), -1);
}

// A flipping joint that moves between its flips (every 40 frames) with pops inside its pieces:
// at 120 fps the stage finds and repairs them piece by piece, and no flip counts as a pop.
// At 120 fps with auto's stage, and at 30 fps with --pops repair (where the skeleton test runs:
// a flipping joint, garbage, has no neighbours to ask there), a flipping joint's pops are found
// and repaired between its flips.
TEST(Conditioning, PopsOfAFlippingJointAreRepairedBetweenItsFlips) {
  for (const int divisor : {1, 4}) {
    Clip clip = test_clip(divisor, nullptr);
    const int J = clip.joints();
    ASSERT_GE(clip.frames, 120) << divisor;
    std::mt19937_64 rng(17);
    const std::vector<float> motion = test::random_motion(rng, clip.frames, 1, 0.4);
    const Quat flip = exp(Vec3{3.04, 0, 0});
    const int period = divisor == 1 ? 40 : 24;  // frames between flips: 3 flips or more
    for (int t = 0; t < clip.frames; ++t) {
      const Quat q = load_quat(&motion[std::size_t(t) * 4]);
      store_quat((t / period) % 2 ? q * flip : q,
                 &clip.rotations[(std::size_t(t) * J + kFlipping) * 4]);
    }
    const std::vector<int> popped{15, 57, 58, 100};
    for (int t : popped) {
      float* q = &clip.rotations[(std::size_t(t) * J + kFlipping) * 4];
      store_quat(load_quat(q) * exp(Vec3{0, 0.6, 0.3}), q);
    }
    make_hemisphere_continuous(clip.rotation_span());
    const Clip before = clip;
    const ClipConditioning c =
        divisor == 1 ? engine::condition_rotations(PopsMode::automatic, clip.rotation_span(),
                                                   clip.frame_time)
                     : engine::condition_rotations(PopsMode::repair, clip.rotation_span(),
                                                   clip.frame_time, clip.skeleton->parents);
    ASSERT_EQ(to_string(c.joints[kFlipping].joint_class), "flipping") << divisor;
    EXPECT_EQ(c.pops[kFlipping], int(popped.size())) << divisor;
    for (int t : popped) {
      EXPECT_GT(error_at(before, clip, t, kFlipping), 0.5) << divisor << " frame " << t;
      const Quat truth =
          load_quat(&motion[std::size_t(t) * 4]) * ((t / period) % 2 ? flip : Quat{});
      EXPECT_LT(geodesic(load_quat(&clip.rotations[(std::size_t(t) * J + kFlipping) * 4]), truth),
                0.05)
          << divisor << " frame " << t;
    }
    // Everything else on the joint as it came: the flips included.
    for (int t = 0; t < clip.frames; ++t) {
      if (std::find(popped.begin(), popped.end(), t) != popped.end()) continue;
      EXPECT_EQ(error_at(before, clip, t, kFlipping), 0.0) << divisor << " frame " << t;
    }
  }
}

// After a repair the conditioning hands resolve_for_clip the classes and segments of the
// repaired rotations, measuring again only the joints it changed: they must be what
// classify_joints and motion_segments find on those rotations, to the bit, and the settings
// resolved from them the same as from a fresh measure. At 120 fps (auto repairs) and 30 fps
// (--pops repair); with impossible steps (a frame every joint jumps away from) and without.
TEST(Conditioning, RepairedFactsAreThoseOfTheRepairedRotations) {
  for (const int divisor : {1, 4})
    for (const bool jump : {false, true}) {
      Clip clip = test_clip(divisor, nullptr);
      const int J = clip.joints();
      if (jump)  // a T-pose-like frame: every joint far from its neighbours' poses
        for (int j = 0; j < J; ++j) {
          float* q = &clip.rotations[(std::size_t(7) * J + std::size_t(j)) * 4];
          store_quat(load_quat(q) * exp(Vec3{1.5, 0.4, 0}), q);
        }
      make_hemisphere_continuous(clip.rotation_span());
      const ClipConditioning c = engine::condition_rotations(
          divisor == 1 ? PopsMode::automatic : PopsMode::repair, clip.rotation_span(),
          clip.frame_time, clip.skeleton->parents);
      const std::string what = "divisor " + std::to_string(divisor) + (jump ? ", jump" : "");
      ASSERT_TRUE(c.repaired) << what;
      ASSERT_GT(c.pops[kPopped], 0) << what;
      const engine::ClipFacts facts = c.facts();
      const std::vector<JointQuality> fresh = classify_joints(clip.rotation_view());
      ASSERT_EQ(facts.joints.size(), fresh.size()) << what;
      std::vector<std::uint8_t> flipping;
      for (std::size_t j = 0; j < fresh.size(); ++j) {
        const JointQuality &a = facts.joints[j], &b = fresh[j];
        EXPECT_EQ(a.joint_class, b.joint_class) << what << " joint " << j;
        EXPECT_EQ(std::memcmp(&a.median_step, &b.median_step, sizeof(double)), 0) << what;
        EXPECT_EQ(std::memcmp(&a.max_step, &b.max_step, sizeof(double)), 0) << what;
        EXPECT_EQ(a.near_pi_steps, b.near_pi_steps) << what;
        flipping.push_back(b.joint_class == JointClass::flipping);
      }
      // The popped joint's largest step (a pop's, or the jump's) changed with the repair where
      // the pops made it: its class was measured again.
      if (!jump) {
        EXPECT_NE(c.joints[kPopped].max_step, facts.joints[kPopped].max_step) << what;
      }
      const std::vector<Segment> segments =
          motion_segments(clip.rotation_view(), clip.frame_time, flipping);
      ASSERT_NE(facts.segments, nullptr) << what;
      ASSERT_EQ(facts.segments->size(), segments.size()) << what;
      for (std::size_t i = 0; i < segments.size(); ++i) {
        EXPECT_EQ((*facts.segments)[i].begin, segments[i].begin) << what;
        EXPECT_EQ((*facts.segments)[i].end, segments[i].end) << what;
      }
      if (jump) {
        EXPECT_GT(segments.size(), 1u) << what;
      }
      FilterSettings settings;
      settings.method = Method::automatic;
      settings.split_impossible = true;
      const nlohmann::json reused =
          engine::resolve_for_clip(settings, clip, c.garbage, facts).settings.to_json();
      const nlohmann::json measured =
          engine::resolve_for_clip(settings, clip, c.garbage).settings.to_json();
      EXPECT_EQ(reused, measured) << what;
    }
}

TEST(Conditioning, RepairedPopsLandOnTheMotion) {
  std::vector<int> pops;
  Clip clip = test_clip(1, &pops);
  const Clip clean = without_pops(1, pops);
  engine::condition_rotations(PopsMode::repair, clip.rotation_span(), clip.frame_time);
  for (int t : pops) EXPECT_LT(error_at(clip, clean, t, kPopped), 0.03) << "frame " << t;
}

TEST(Conditioning, BelowSixtyFpsAutoOnlyCountsAndDetectNeverChangesAnything) {
  std::vector<int> pops;
  Clip clip = test_clip(4, &pops);
  const Clip before = clip;
  const ClipConditioning c =
      engine::condition_rotations(PopsMode::automatic, clip.rotation_span(), clip.frame_time);
  EXPECT_FALSE(c.repaired);
  EXPECT_GE(c.pops[kPopped], 1);
  EXPECT_EQ(clip.rotations, before.rotations);

  Clip fast = test_clip(1, nullptr);
  const Clip fast_before = fast;
  const ClipConditioning d =
      engine::condition_rotations(PopsMode::detect, fast.rotation_span(), fast.frame_time);
  EXPECT_FALSE(d.repaired);
  EXPECT_EQ(d.pops[kPopped], 6);
  EXPECT_EQ(fast.rotations, fast_before.rotations);
}

// A 30 fps chain whose frame 0 is a T-pose (every joint at identity; the root turns by more than
// kernels/motion_split.hpp's max_step to frame 1, so frame 0 is a segment of its own) and
// whose joint 2 is a hinge through identity (kernels/pop_hinge.hpp), the others turning about
// several axes. A pop off the hinge's axis on the T-pose frame is found by the hinge test alone
// (no other test reads a segment of one frame) and, repaired, put back on the hinge's curve: here
// the T-pose itself. A pop on the hinge mid-clip is repaired onto the motion; without pops nothing
// is flagged or changed; detect only counts.
TEST(Conditioning, AHingesPopsAreFoundEvenOnAFrameOfItsOwn) {
  constexpr int F = 120, J = 4, kHinge = 2;
  const std::vector<int> parents{-1, 0, 1, 2};
  std::mt19937_64 rng(21);
  Vec3 axes[J], sides[J];
  for (int j = 0; j < J; ++j) {
    const Vec3 a = log(test::random_rotation(rng)), b = log(test::random_rotation(rng));
    axes[j] = (1 / norm(a)) * a;
    sides[j] = (1 / norm(b - dot(b, axes[j]) * axes[j])) * (b - dot(b, axes[j]) * axes[j]);
  }
  test::Motion clean{F, J, std::vector<float>(std::size_t(F) * J * 4)};
  for (int t = 1; t < F; ++t)
    for (int j = 0; j < J; ++j) {
      const double theta = (j == 0 ? 2.4 : 1.0) + 0.3 * std::sin(0.05 * t + j);
      const double sway = j == kHinge ? 0.0 : 0.2 * std::sin(0.04 * t + 2 * j);
      store_quat(exp(theta * axes[j]) * exp(sway * sides[j]), clean.span().at(t, j));
    }
  for (int j = 0; j < J; ++j) store_quat(Quat{}, clean.span().at(0, j));
  make_hemisphere_continuous(clean.span());

  test::Motion popped = clean;
  store_quat(exp(0.5 * sides[kHinge]), popped.span().at(0, kHinge));
  store_quat(clean.at(60, kHinge) * exp(0.4 * sides[kHinge]), popped.span().at(60, kHinge));
  const auto flagged = [](const ClipConditioning& c, int t, int j) {
    for (std::size_t i = 0; i + 1 < c.pop_samples.size(); i += 2)
      if (c.pop_samples[i] == t && c.pop_samples[i + 1] == j) return true;
    return false;
  };

  test::Motion detected = popped;
  const ClipConditioning d =
      engine::condition_rotations(PopsMode::detect, detected.span(), 1.0 / 30, parents);
  ASSERT_FALSE(d.segments.empty());
  EXPECT_EQ(d.segments[0].begin, 0);
  EXPECT_EQ(d.segments[0].end, 1);
  EXPECT_TRUE(flagged(d, 0, kHinge));
  EXPECT_TRUE(flagged(d, 60, kHinge));
  EXPECT_EQ(detected.rotations, popped.rotations);

  test::Motion repaired = popped;
  const ClipConditioning r =
      engine::condition_rotations(PopsMode::repair, repaired.span(), 1.0 / 30, parents);
  EXPECT_TRUE(r.repaired);
  EXPECT_LT(geodesic(repaired.at(0, kHinge), Quat{}), 1e-5);
  EXPECT_LT(geodesic(repaired.at(60, kHinge), clean.at(60, kHinge)), 0.02);

  test::Motion untouched = clean;
  const ClipConditioning none =
      engine::condition_rotations(PopsMode::repair, untouched.span(), 1.0 / 30, parents);
  EXPECT_EQ(none.pop_count(), 0u);
  EXPECT_EQ(untouched.rotations, clean.rotations);
}

// Below 60 fps the pop test looks for runs of at most 2 and wants a flag 8 times further from
// its fit than the fit's error (engine/clip/clip_conditioning.hpp, pop_params_at); --pops repair
// there repairs single and double pops, and flags nothing on the same motion without pops.
TEST(Conditioning, RepairBelowSixtyFpsTakesTheLowRateParameters) {
  const PopRepairParams high = engine::pop_params_at(1.0 / 120),
                        low = engine::pop_params_at(1.0 / 30);
  EXPECT_EQ(high.max_run, PopRepairParams{}.max_run);
  EXPECT_EQ(high.local_threshold, PopRepairParams{}.local_threshold);
  EXPECT_EQ(low.max_run, 2);
  EXPECT_EQ(low.local_threshold, 8);
  EXPECT_EQ(engine::pop_params_at(1.0 / 60).max_run, high.max_run);

  std::vector<int> pops;
  Clip clip = test_clip(4, &pops);
  const Clip before = clip;
  const ClipConditioning c =
      engine::condition_rotations(PopsMode::repair, clip.rotation_span(), clip.frame_time);
  EXPECT_TRUE(c.repaired);
  for (int t : pops) {
    if (t >= 90) continue;  // the run of three is longer than the low rate's runs
    EXPECT_GT(error_at(before, clip, t, kPopped), 0.5) << "frame " << t;
  }
  Clip clean = without_pops(4, pops);
  const ClipConditioning none =
      engine::condition_rotations(PopsMode::repair, clean.rotation_span(), clean.frame_time);
  EXPECT_EQ(none.pop_count(), 0u);
}

TEST(Conditioning, PopsOffIsTheSpecsFilterOnEveryJoint) {
  Clip clip = test_clip(1, nullptr);
  FilterSettings s;
  s.method = Method::nlpm;
  s.pops = PopsMode::off;
  const Clip before = clip;
  const ClipConditioning c = engine::condition_clip(s, clip);
  EXPECT_EQ(clip.rotations, before.rotations);
  EXPECT_EQ(c.pop_count(), 0u);
  const auto resolved = engine::resolve_for_clip(s, clip, c.garbage);
  EXPECT_TRUE(resolved.kept_joints.empty());
  EXPECT_TRUE(resolved.distance_joints.empty());  // the whole pose, as the spec says
  // And the default of the settings struct is off.
  EXPECT_EQ(FilterSettings{}.pops, PopsMode::off);
}

TEST(Conditioning, GarbageJointsAreKeptAsTheyCameAndLeftOutOfNlpmsDistance) {
  Clip clip = test_clip(1, nullptr);
  FilterSettings s;
  s.method = Method::nlpm;
  s.pops = PopsMode::repair;
  const ClipConditioning c = engine::condition_clip(s, clip);
  const auto resolved = engine::resolve_for_clip(s, clip, c.garbage);
  ASSERT_EQ(resolved.kept_joints.size(), std::size_t(clip.joints()));
  EXPECT_EQ(resolved.kept_joints[kFlipping], 1);
  EXPECT_EQ(resolved.distance_joints[kFlipping], 0);
  // The flipping joint is then filtered with its flips taken out (clip/flip_pieces.hpp): here it
  // holds still between them, so it too comes out as it came, up to the float rounding of taking
  // the flips out and putting them back.
  ASSERT_EQ(resolved.flip_joints.size(), std::size_t(clip.joints()));
  EXPECT_EQ(resolved.flip_joints[kFlipping], 1);
  EXPECT_EQ(resolved.flip_joints[kConstant], 0);
  EXPECT_EQ(resolved.distance_joints[kPopped], 1);
  Clip out = clip;
  std::fill(out.rotations.begin(), out.rotations.end(), 0.0f);
  ASSERT_TRUE(engine::run_shard(resolved, clip, out, {0, clip.joints(), 0, clip.frames}).ok());
  EXPECT_EQ(first_changed_frame(out, clip, kConstant), -1);
  for (int t = 0; t < clip.frames; ++t)
    EXPECT_LT(error_at(out, clip, t, kFlipping), 1e-6) << "frame " << t;
  // The other joints were filtered.
  EXPECT_GT(test::rotation_errors(out.rotation_view(), clip.rotation_view()).max, 1e-4);

  // --garbage-joints filter: filtered like the others, still out of the distance.
  s.keep_garbage_joints = false;
  const auto filtered = engine::resolve_for_clip(s, clip, c.garbage);
  EXPECT_TRUE(filtered.kept_joints.empty());
  EXPECT_EQ(filtered.distance_joints[kFlipping], 0);
}

// auto and a flipping joint (clip/flip_pieces.hpp, flip_piece_settings): on a capture with no
// noise to speak of (0.003 rad here, below kAutoCleanBelow) it comes out as it came; with noise
// it is filtered between its flips by auto's bof, and comes out different.
TEST(Conditioning, AutoKeepsTheFlippingJointOfACleanCaptureAndFiltersANoisyOnesPieces) {
  FilterSettings s;
  s.method = Method::automatic;
  s.pops = PopsMode::automatic;
  for (const double noise : {0.0, 0.03}) {
    Clip clip = test_clip(1, nullptr);
    if (noise > 0) add_noise(GaussianNoise{noise, 11}, clip.rotation_span());
    make_hemisphere_continuous(clip.rotation_span());
    const ClipConditioning c = engine::condition_clip(s, clip);
    const auto resolved = engine::resolve_for_clip(s, clip, c.garbage);
    ASSERT_TRUE(c.garbage[kFlipping]) << noise;
    Clip out = clip;
    ASSERT_TRUE(engine::run_shard(resolved, clip, out, {0, clip.joints(), 0, clip.frames}).ok());
    if (noise == 0) {
      EXPECT_LT(resolved.noise_sigma, engine::kAutoCleanBelow);
      EXPECT_TRUE(resolved.flip_joints.empty());
      EXPECT_EQ(first_changed_frame(out, clip, kFlipping), -1);
    } else {
      ASSERT_EQ(resolved.flip_joints.size(), std::size_t(clip.joints()));
      EXPECT_EQ(resolved.flip_joints[kFlipping], 1);
      EXPECT_EQ(resolved.flip_settings.method, Method::bof);
      EXPECT_NE(first_changed_frame(out, clip, kFlipping), -1);
    }
  }
}

TEST(Conditioning, AutoPicksNlpmWithItsRangeTermAtLowNoiseAndBofAtHighNoise) {
  FilterSettings s;
  s.method = Method::automatic;
  // No noise to speak of (a clean capture): the floored nlpm with its range term.
  const FilterSettings low = engine::choose_automatic(s, 0.002);
  EXPECT_EQ(low.method, Method::nlpm);
  EXPECT_LT(low.param<NlpmParams>().range_sigma, 0);  // automatic: resolved from sigma_hat
  // At 60 fps and above only: below, a clean capture's motion reads as noise of that size, and
  // the same estimate gets bof's one pass.
  EXPECT_EQ(engine::choose_automatic(s, 0.002, false, 1.0 / 120).method, Method::nlpm);
  EXPECT_EQ(engine::choose_automatic(s, 0.002, false, 1.0 / engine::kAutoNlpmMinFps).method,
            Method::nlpm);
  const FilterSettings low_rate = engine::choose_automatic(s, 0.002, false, 1.0 / 30);
  EXPECT_EQ(low_rate.method, Method::bof);
  EXPECT_EQ(low_rate.param<BilateralParams>().iterations, 1);
  // Measurable noise: bof, one pass at light noise, more at heavy noise.
  const FilterSettings light = engine::choose_automatic(s, 0.01);
  EXPECT_EQ(light.method, Method::bof);
  EXPECT_EQ(light.param<BilateralParams>().iterations, 1);
  EXPECT_NEAR(light.param<BilateralParams>().sigma_g, engine::kAutoSigmaGFactor * 0.01, 1e-12);
  const FilterSettings high = engine::choose_automatic(s, 0.24);
  EXPECT_EQ(high.method, Method::bof);
  EXPECT_EQ(high.param<BilateralParams>().iterations, 4);
  EXPECT_GT(high.param<BilateralParams>().sigma_t, light.param<BilateralParams>().sigma_t);

  Clip clip = test_clip(1, nullptr);
  s.pops = PopsMode::automatic;
  const ClipConditioning c = engine::condition_clip(s, clip);
  const auto resolved = engine::resolve_for_clip(s, clip, c.garbage);
  ASSERT_FALSE(resolved.unchanged);
  EXPECT_EQ(resolved.settings.method, Method::nlpm);  // jitter of 0.003 rad: a clean capture
  // At this light a noise auto's floors decide (engine/clip/filter_settings.hpp).
  EXPECT_NEAR(resolved.settings.param<NlpmParams>().h,
              std::max(engine::kNlpmAutoFactor * resolved.noise_sigma, engine::kAutoNlpmMinH),
              1e-12);
  EXPECT_NEAR(
      resolved.settings.param<NlpmParams>().range_sigma,
      std::max(engine::kNlpmAutoRangeFactor * resolved.noise_sigma, engine::kAutoNlpmMinRange),
      1e-12);
  // Each joint's term of the pose distance capped at twice the range width, so a glitch on one
  // joint cannot make whole patches unlike their neighbours.
  EXPECT_EQ(resolved.settings.param<NlpmParams>().distance_cap,
            engine::kAutoNlpmDistanceCap * resolved.settings.param<NlpmParams>().range_sigma);
  EXPECT_GT(resolved.settings.param<NlpmParams>().distance_cap, 0);
  // The flipping joint is left out of the noise estimate: it stays near the added jitter.
  EXPECT_GT(resolved.noise_sigma, 0.001);
  EXPECT_LT(resolved.noise_sigma, 0.006);
}

// The 120 fps test clip written as in/walk.bvh, and `mocap-clean clean` run on it.
class ConditioningCli : public ::testing::Test {
 protected:
  void SetUp() override {
    clip = test_clip(1, &pops);
    std::string error;
    fs::create_directories(dir / "in");
    ASSERT_TRUE(io::write_bvh(clip, dir / "in/walk.bvh", &error)) << error;
  }
  // `clean in -o OUT OPTIONS`, over an earlier OUT.
  test::CommandResult clean(const std::string& out, const std::string& options) {
    fs::remove_all(dir / out);
    return test::run_cli("clean '" + (dir / "in").string() + "' -o '" + (dir / out).string() +
                         "' " + options);
  }
  test::TempDir dir{"conditioning"};
  std::vector<int> pops;
  Clip clip;
};

TEST_F(ConditioningCli, TheJsonSummaryCountsPopsPerJointAndNamesGarbageJoints) {
  // clean's defaults: --method auto, with the pop stage in `auto` mode.
  const auto r = clean("out", "--json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["pops"]["mode"], "auto");
  EXPECT_EQ(j["pops"]["samples"].get<int>(), int(pops.size())) << j["pops"].dump();
  EXPECT_EQ(j["pops"]["repaired"].get<int>(), int(pops.size()));
  EXPECT_EQ(j["pops"]["by_joint"][clip.skeleton->joint_names[kPopped]].get<int>(),
            int(pops.size()));
  ASSERT_EQ(j["garbage_joints"]["joints"].get<int>(), 2) << j["garbage_joints"].dump();
  const auto& listed = j["garbage_joints"]["by_clip"][0]["joints"];
  EXPECT_EQ(listed[0]["joint"], clip.skeleton->joint_names[kFlipping]);
  EXPECT_EQ(listed[0]["class"], "flipping");
  EXPECT_EQ(j["garbage_joints"]["handling"],
            "kept (flipping joints filtered between their flips; by auto only in a noisy clip)");

  // Without --json the closing line says it too.
  const auto human = clean("out2", "--method bof --pops auto");
  ASSERT_EQ(human.exit_code, 0) << human.err;
  EXPECT_NE(human.err.find("pops: 6 found in 1 clips"), std::string::npos) << human.err;
  EXPECT_NE(human.err.find("garbage joints"), std::string::npos) << human.err;

  // `info --joints` names them too, from the library.
  const std::string lib = (dir / "lib.h5").string();
  ASSERT_EQ(test::run_cli("import '" + (dir / "in").string() + "' -o '" + lib + "'").exit_code, 0);
  const auto info = test::run_cli("info '" + lib + "' --joints --json");
  ASSERT_EQ(info.exit_code, 0) << info.err;
  const auto i = nlohmann::json::parse(info.out);
  EXPECT_EQ(i["garbage_joints"]["joints"], 2);
  EXPECT_EQ(i["garbage_joints"]["by_clip"][0]["joints"][1]["joint"],
            clip.skeleton->joint_names[kConstant]);
  EXPECT_EQ(i["garbage_joints"]["by_clip"][0]["joints"][1]["class"], "constant");
}

TEST_F(ConditioningCli, ANamedMethodIsTheSpecsFilterUnlessAPopStageIsAsked) {
  const auto summary = [&](const std::string& out, const std::string& options) {
    const auto r = clean(out, options + " --json");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(r.out);
  };
  const auto read = [&](const std::string& out) { return test::read_text(dir / out / "walk.bvh"); };
  for (const std::string method : {"bof", "nlpm", "gaussian"}) {
    const auto named = summary("named", "--method " + method);
    EXPECT_EQ(named["pops"]["mode"], "off") << method;
    EXPECT_FALSE(named.contains("garbage_joints")) << method;
    summary("off", "--method " + method + " --pops off");
    summary("auto", "--method " + method + " --pops auto");
    EXPECT_EQ(read("named"), read("off")) << method;
    EXPECT_NE(read("named"), read("auto")) << method << ": the pops were not repaired";
  }
}

TEST_F(ConditioningCli, TheSummarySaysWhatTheAutomaticParametersBecame) {
  auto r = clean("out", "--json");  // --method auto
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j.contains("automatic")) << r.out;
  const auto& chosen = j["automatic"]["by_clip"][0];
  EXPECT_EQ(chosen["clip"], "walk.bvh");
  EXPECT_EQ(chosen["method"], "nlpm");  // light jitter: nlpm with its range term
  const double sigma = chosen["noise_sigma"].get<double>();
  EXPECT_GT(sigma, 0.001);
  EXPECT_LT(sigma, 0.006);
  // auto's floors (engine/clip/filter_settings.hpp) hold at this light a noise.
  EXPECT_NEAR(chosen["parameters"]["h"].get<double>(),
              std::max(engine::kNlpmAutoFactor * sigma, engine::kAutoNlpmMinH), 1e-12);
  EXPECT_NEAR(chosen["parameters"]["range_sigma"].get<double>(),
              std::max(engine::kNlpmAutoRangeFactor * sigma, engine::kAutoNlpmMinRange), 1e-12);
  EXPECT_EQ(chosen["parameters"]["distance_cap"].get<double>(),
            engine::kAutoNlpmDistanceCap * chosen["parameters"]["range_sigma"].get<double>());
  EXPECT_GE(chosen["parameters"]["translation_sigma_t"].get<double>(), 0.0);
  EXPECT_EQ(j["automatic"]["methods"]["nlpm"], 1);

  // bof asked for its automatic widths: the widths it used.
  r = clean("out", "--method bof --sigma-g 0 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(
      j["automatic"]["by_clip"][0]["parameters"]["sigma_g"].get<double>(),
      engine::kBofAutoSigmaGFactor * j["automatic"]["by_clip"][0]["noise_sigma"].get<double>(),
      1e-12);
  EXPECT_EQ(j["automatic"]["by_clip"][0]["parameters"]["sigma_t"], 1.0);  // given, kept

  // Nothing automatic, nothing reported; the closing line says it otherwise.
  r = clean("out", "--method bof --json");
  EXPECT_FALSE(nlohmann::json::parse(r.out).contains("automatic")) << r.out;
  r = clean("out", "");
  EXPECT_NE(r.err.find("automatic parameters: nlpm on 1 clip; estimated noise"), std::string::npos)
      << r.err;
}

// The filter of the settings over the whole clip, shard by shard as the engine runs it.
Clip filtered(const FilterSettings& settings, const Clip& clip) {
  const auto resolved = engine::resolve_for_clip(settings, clip);
  Clip out = clip;
  for (const auto& shard : engine::plan_shards(resolved.settings, clip.frames, clip.joints()))
    EXPECT_TRUE(engine::run_shard(resolved, clip, out, shard).ok());
  return out;
}

TEST(Conditioning, SplitImpossibleFiltersEachSegmentAsAClipOfItsOwn) {
  Clip clip = test_clip(1, nullptr);
  const int J = clip.joints();
  // A synthetic "T-pose" frame 0: one joint 2.5 rad away from frame 1.
  float* q = &clip.rotations[(0 * std::size_t(J) + 2) * 4];
  store_quat(load_quat(&clip.rotations[(std::size_t(J) + 2) * 4]) * exp(Vec3{2.5, 0, 0}), q);
  make_hemisphere_continuous(clip.rotation_span());
  for (Method method : {Method::bof, Method::nlpm, Method::gaussian}) {
    FilterSettings s;
    s.method = method;
    s.edit<BilateralParams>().sigma_g = 0.1;
    s.edit<NlpmParams>().h = 0.02;
    s.shard_frames = 64;  // nlpm's time blocks straddle nothing special: any block works
    s.split_impossible = true;
    const auto resolved = engine::resolve_for_clip(s, clip);
    ASSERT_EQ(resolved.segments.size(), 2u);
    EXPECT_EQ(resolved.segments[0].end, 1);
    const Clip split = filtered(s, clip);
    // Frame 0 alone: a 1-frame clip comes back unchanged.
    EXPECT_EQ(std::memcmp(split.rotations.data(), clip.rotations.data(), 4 * J * sizeof(float)), 0);
    // The rest is exactly the filter of the clip without frame 0.
    Clip rest = clip;
    rest.frames -= 1;
    rest.rotations.erase(rest.rotations.begin(), rest.rotations.begin() + 4 * J);
    rest.translations.erase(rest.translations.begin(), rest.translations.begin() + 3 * J);
    s.split_impossible = false;
    const Clip expected = filtered(s, rest);
    EXPECT_TRUE(std::equal(expected.rotations.begin(), expected.rotations.end(),
                           split.rotations.begin() + 4 * J))
        << to_string(method);
    // Without the split the jump is smeared into frame 1 (bof, whose range weights see the jump
    // as an edge, smears it least).
    const Clip smeared = filtered(s, clip);
    EXPECT_GT(test::rotation_error(smeared.rotation_view(), split.rotation_view(), 1, 2),
              method == Method::bof ? 1e-4 : 1e-2)
        << to_string(method);
  }
}

// auto's bof: lower estimated noise never gives more passes, a wider range kernel or a wider
// temporal width in seconds, at any frame rate; and at a lower frame rate the width in frames
// never grows (a frame is longer).
TEST(Conditioning, AutoSmoothingIsMonotoneInTheNoiseAndTheFrameRate) {
  FilterSettings s;
  s.method = Method::automatic;
  for (double fps : {24.0, 30.0, 60.0, 120.0, 240.0}) {
    const double dt = 1.0 / fps;
    FilterSettings previous;
    bool first = true;
    for (double sigma = engine::kAutoCleanBelow; sigma <= 0.5; sigma *= 1.05) {
      const FilterSettings c = engine::choose_automatic(s, sigma, false, dt);
      ASSERT_EQ(c.method, Method::bof) << sigma;
      EXPECT_GE(c.param<BilateralParams>().iterations, 1);
      EXPECT_LE(c.param<BilateralParams>().iterations, 5);
      if (!first) {
        EXPECT_LE(previous.param<BilateralParams>().iterations,
                  c.param<BilateralParams>().iterations)
            << sigma << " " << fps;
        // All passes together: width sigma_t sqrt(n) and range sigma_g sqrt(n) never shrink.
        const auto total = [](const BilateralParams& p, double v) {
          return v * std::sqrt(double(p.iterations));
        };
        EXPECT_LE(
            total(previous.param<BilateralParams>(), previous.param<BilateralParams>().sigma_t),
            total(c.param<BilateralParams>(), c.param<BilateralParams>().sigma_t) + 1e-12)
            << sigma << " " << fps;
        EXPECT_LE(
            total(previous.param<BilateralParams>(), previous.param<BilateralParams>().sigma_g),
            total(c.param<BilateralParams>(), c.param<BilateralParams>().sigma_g) + 1e-12)
            << sigma << " " << fps;
      }
      const FilterSettings slower = engine::choose_automatic(s, sigma, false, 2 * dt);
      EXPECT_LE(slower.param<BilateralParams>().sigma_t, c.param<BilateralParams>().sigma_t)
          << sigma << " " << fps;
      EXPECT_GE(slower.param<BilateralParams>().sigma_t * 2 * dt,
                c.param<BilateralParams>().sigma_t * dt - 1e-12)
          << sigma << " " << fps;
      previous = c;
      first = false;
    }
  }
}

// The noisy-positions branch: an order-4 Butterworth whose cut-off falls as the noise rises and
// rises with the frame rate, 4 Hz at 0.02 rad and 30 fps, always below the Nyquist frequency.
TEST(AutomaticParameters, NoisyPositionsGetALowPassThatFollowsNoiseAndFrameRate) {
  FilterSettings s;
  s.method = Method::automatic;
  const auto cutoff = [&](double sigma, double fps) {
    const FilterSettings c = engine::choose_automatic(s, sigma, true, 1.0 / fps);
    EXPECT_EQ(c.method, Method::butterworth);
    EXPECT_EQ(c.param<LinearParams>().kind, LinearKind::butterworth);
    EXPECT_EQ(c.param<LinearParams>().order, engine::kAutoButterworthOrder);
    EXPECT_TRUE(c.filter_translations);
    EXPECT_TRUE(c.validate().ok());
    return c.param<LinearParams>().cutoff;
  };
  EXPECT_NEAR(cutoff(0.02, 30), 4.0, 1e-12);
  double previous = 1e9;
  for (double sigma : {0.005, 0.01, 0.02, 0.03, 0.12}) {
    const double at30 = cutoff(sigma, 30), at120 = cutoff(sigma, 120);
    EXPECT_LT(at30, previous) << sigma;
    EXPECT_GT(at120, at30) << sigma;
    previous = at30;
  }
  // Never at or past Nyquist, whatever the rate or the noise: 8 fps, noise next to nothing.
  EXPECT_LE(cutoff(1e-9, 8), 0.8 * 4);
  EXPECT_LE(cutoff(0.02, 1), 0.8 * 0.5);  // 1 fps: under the 1 Hz floor, still below Nyquist
  EXPECT_GE(cutoff(10, 120), engine::kAutoCutoffMinHz);
}

}  // namespace
}  // namespace mocap
