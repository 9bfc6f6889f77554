// The guard after auto's filter (engine/clip/motion_guard.hpp): a clip that came out with more
// jitter or skating than it went in with falls back, in order, to the filter without the lock,
// the input locked, the input, the clip as read; a clip the filter improved is left alone.
// The "filters" here are stand-ins with a known effect (noise added, noise removed), so each
// branch is reached on purpose; the demo library's 120 fps walk has legs and contacts.
#include <gtest/gtest.h>

#include <vector>

#include "engine/clip/foot_stage.hpp"
#include "engine/clip/motion_check.hpp"
#include "engine/clip/motion_guard.hpp"
#include "engine/library/demo_library.hpp"
#include "kernels/noise_model.hpp"

namespace mocap {
namespace {

using engine::Kept;
using engine::MotionGuardJob;
using engine::MotionMeasure;

Clip walk() {
  return engine::make_demo_library()[0].clip;
}

Clip with_noise(Clip clip, double sigma, std::uint64_t seed) {
  add_noise(GaussianNoise{sigma, seed}, clip.rotation_span());
  return clip;
}

struct Guarded {
  Kept kept;
  Clip output;
  MotionMeasure before, after;
  bool locked = false;
};

Guarded guard(const Clip& raw, const Clip& input, Clip output, bool lock, bool on = true) {
  const std::vector<Segment> segments;
  Guarded r;
  r.before = engine::measure_motion(raw, nullptr, segments);
  engine::ClipFeet feet = engine::detect_feet(input);
  MotionGuardJob g;
  g.input = &input;
  g.raw = &raw;
  g.before = &r.before;
  g.segments = &segments;
  g.feet = lock ? &feet : nullptr;
  g.guard = on;
  g.output = &output;
  EXPECT_TRUE(g.run().ok());
  r.kept = g.kept;
  r.after = g.after;
  r.output = std::move(output);
  r.locked = feet.locked;
  return r;
}

TEST(MotionGuard, TheWalkHasFeetToLock) {
  const Clip clip = walk();
  const engine::ClipFeet feet = engine::detect_feet(clip);
  ASSERT_FALSE(feet.legs.empty());
  std::size_t contacts = 0;
  for (const auto& c : feet.contacts) contacts += c.size();
  EXPECT_GT(contacts, 0u) << "no contact: the locked branches below would be vacuous";
}

// The guard takes the lock back by restoring only the columns of the legs' joints and of their
// hips' ancestors (motion_guard.cpp, LegColumns): the lock must change nothing else.
TEST(MotionGuard, TheLockChangesOnlyTheColumnsTheGuardKeeps) {
  const Clip noisy = with_noise(walk(), 0.02, 7);
  engine::ClipFeet feet = engine::detect_feet(noisy);
  Clip locked = noisy;
  ASSERT_TRUE(engine::lock_feet_in_segments(feet, locked, {}).ok());
  ASSERT_TRUE(feet.locked);
  const std::vector<int>& parents = noisy.skeleton->parents;
  std::vector<bool> kept(parents.size(), false);
  for (const FootChain& leg : feet.legs) {
    for (int j : {leg.hip, leg.knee, leg.ankle, leg.toe})
      if (j >= 0) kept[std::size_t(j)] = true;
    for (int a = leg.hip; a >= 0; a = parents[std::size_t(a)]) kept[std::size_t(a)] = true;
  }
  const std::size_t J = parents.size();
  std::size_t changed_kept = 0;
  for (std::size_t t = 0; t < std::size_t(noisy.frames); ++t)
    for (std::size_t j = 0; j < J; ++j) {
      bool same = true;
      for (std::size_t c = 0; c < 4; ++c)
        same =
            same && locked.rotations[(t * J + j) * 4 + c] == noisy.rotations[(t * J + j) * 4 + c];
      for (std::size_t c = 0; c < 3; ++c)
        same = same &&
               locked.translations[(t * J + j) * 3 + c] == noisy.translations[(t * J + j) * 3 + c];
      if (kept[j]) {
        changed_kept += !same;
      } else {
        EXPECT_TRUE(same) << "frame " << t << ", joint " << j;
      }
    }
  EXPECT_GT(changed_kept, 0u) << "the lock changed nothing: the test would be vacuous";
}

TEST(MotionGuard, AFilterThatRemovesNoiseIsKept) {
  const Clip clean = walk();
  const Clip noisy = with_noise(clean, 0.03, 1);
  for (bool lock : {false, true}) {
    const Guarded r = guard(noisy, noisy, clean, lock);
    EXPECT_EQ(r.kept, lock ? Kept::filtered_locked : Kept::filtered) << lock;
    EXPECT_LT(r.after.jitter, r.before.jitter);
    EXPECT_EQ(r.locked, lock);
    if (!lock) {
      EXPECT_EQ(r.output.rotations, clean.rotations);
    }
  }
}

TEST(MotionGuard, AFilterThatAddsJitterToACleanCaptureFallsBackToTheInput) {
  const Clip clean = walk();
  const Guarded r = guard(clean, clean, with_noise(clean, 0.01, 2), /*lock=*/false);
  EXPECT_EQ(r.kept, Kept::input);
  EXPECT_EQ(r.output.rotations, clean.rotations);
  EXPECT_EQ(r.output.translations, clean.translations);
  EXPECT_EQ(r.after.jitter, r.before.jitter);
  EXPECT_EQ(r.after.skating, r.before.skating);
}

TEST(MotionGuard, WithTheLockEveryCandidateIsMeasuredAndNoneRaisesTheInputs) {
  const Clip clean = walk();
  const Guarded r = guard(clean, clean, with_noise(clean, 0.01, 3), /*lock=*/true);
  EXPECT_NE(r.kept, Kept::filtered_locked);
  EXPECT_NE(r.kept, Kept::filtered);
  EXPECT_FALSE(engine::raises_motion(r.after, r.before));
  EXPECT_EQ(r.locked, r.kept == Kept::input_locked);
}

// The pops' own jitter must not hide what a filter adds: when the pop stage repaired the clip
// and that raised nothing, the filtered candidates must not raise the repaired input's jitter
// or skating (measured at 30 fps: a clean jog through bof, kept against the clip as read).
TEST(MotionGuard, AFilterMeasuresAgainstTheRepairedInputNotThePops) {
  const Clip clean = walk();
  Clip popped = clean;
  ASSERT_GT(add_noise(ImpulseNoise{0.01, 0.3, 1.0, 6}, popped.rotation_span()), 0);
  const Clip filtered = with_noise(clean, 0.002, 7);  // a filter that adds a little jitter
  const std::vector<Segment> segments;
  const MotionMeasure as_read = engine::measure_motion(popped, nullptr, segments);
  const MotionMeasure repaired = engine::measure_motion(clean, &as_read, segments);
  ASSERT_FALSE(engine::raises_motion(engine::measure_motion(filtered, &as_read, segments), as_read))
      << "the pops do not hide the filter's jitter: the test would be vacuous";
  ASSERT_TRUE(
      engine::raises_motion(engine::measure_motion(filtered, &as_read, segments), repaired));
  for (bool lock : {false, true}) {
    const Guarded r = guard(popped, clean, filtered, lock);
    EXPECT_TRUE(r.kept == Kept::input || r.kept == Kept::input_locked) << lock;
    EXPECT_FALSE(engine::raises_motion(r.after, repaired)) << lock;
    if (r.kept == Kept::input) {
      EXPECT_EQ(r.output.rotations, clean.rotations);
    }
  }
  // Without a repair (the input is the clip as read) the bar stays the clip as read.
  const Guarded kept = guard(popped, popped, filtered, /*lock=*/false);
  EXPECT_EQ(kept.kept, Kept::filtered);
}

TEST(MotionGuard, AnInputTheConditioningMadeWorseFallsBackToTheClipAsRead) {
  const Clip raw = walk();
  const Clip worse_input = with_noise(raw, 0.01, 4);  // a pop stage that added jitter
  const Guarded r = guard(raw, worse_input, with_noise(raw, 0.02, 5), /*lock=*/false);
  EXPECT_EQ(r.kept, Kept::as_read);
  EXPECT_EQ(r.output.rotations, raw.rotations);
}

TEST(MotionGuard, OffKeepsTheFilterWhateverItMeasures) {
  const Clip clean = walk();
  const Clip rough = with_noise(clean, 0.01, 6);
  const Guarded r = guard(clean, clean, rough, /*lock=*/false, /*on=*/false);
  EXPECT_EQ(r.kept, Kept::filtered);
  EXPECT_EQ(r.output.rotations, rough.rotations);
  EXPECT_TRUE(engine::raises_motion(r.after, r.before));
}

// Off and with no measure, the job is the lock alone (how clean --guard off, eval and the Python
// module run a named method with --feet lock): bit for bit lock_feet_in_segments, on a clip
// that the guard would have taken back to its input.
TEST(MotionGuard, OffWithoutItsInputsIsTheLockAlone) {
  const Clip clean = walk();
  const Clip rough = with_noise(clean, 0.01, 6);
  const std::vector<Segment> segments;
  engine::ClipFeet feet = engine::detect_feet(clean), expected_feet = feet;
  Clip expected = rough;
  ASSERT_TRUE(engine::lock_feet_in_segments(expected_feet, expected, segments).ok());
  ASSERT_TRUE(expected_feet.locked);
  Clip output = rough;
  MotionGuardJob g;
  g.guard = false;
  g.segments = &segments;
  g.feet = &feet;
  g.output = &output;
  ASSERT_TRUE(g.run().ok());
  EXPECT_EQ(g.kept, Kept::filtered_locked);
  EXPECT_EQ(output.rotations, expected.rotations);
  EXPECT_EQ(output.translations, expected.translations);
  EXPECT_TRUE(feet.locked);
  EXPECT_EQ(feet.contacts, expected_feet.contacts);
  EXPECT_EQ(g.after.contact_steps, 0) << "measured with no measure to compare against";
  EXPECT_EQ(g.after.jitter, 0.0);
}

TEST(MotionGuard, OnItNeedsTheInputAndTheMeasureOfTheClipAsRead) {
  const Clip clean = walk();
  const std::vector<Segment> segments;
  const MotionMeasure before = engine::measure_motion(clean);
  for (const bool with_input : {false, true}) {
    Clip output = clean;
    MotionGuardJob g;
    g.input = with_input ? &clean : nullptr;
    g.before = with_input ? nullptr : &before;
    g.segments = &segments;
    g.output = &output;
    const Status s = g.run();
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("needs the input and the measure"), std::string::npos)
        << s.message();
    EXPECT_EQ(output.rotations, clean.rotations) << "a refused run changed its output";
  }
}

TEST(MotionGuard, ClipsOfDifferentShapesAreRefused) {
  const Clip clean = walk();
  Clip shorter = clean;
  shorter.frames -= 1;
  shorter.rotations.resize(shorter.rotations.size() - std::size_t(clean.joints()) * 4);
  shorter.translations.resize(shorter.translations.size() - std::size_t(clean.joints()) * 3);
  const std::vector<Segment> segments;
  const MotionMeasure before = engine::measure_motion(clean);
  MotionGuardJob g;
  g.input = &clean;
  g.before = &before;
  g.segments = &segments;
  g.output = &shorter;
  const Status s = g.run();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("not the same clip"), std::string::npos) << s.message();
}

TEST(MotionGuard, SegmentsLeaveImpossibleStepsOutOfTheMeasure) {
  Clip clip = walk();
  const int J = clip.joints(), mid = clip.frames / 2;
  // A jump on one frame, as CMU's T-pose frame: between two segments it is not motion.
  for (int j = 0; j < J; ++j) {
    float* q = &clip.rotations[(std::size_t(mid) * std::size_t(J) + std::size_t(j)) * 4];
    q[0] = 1, q[1] = q[2] = q[3] = 0;
  }
  const std::vector<Segment> split{{0, mid}, {mid, mid + 1}, {mid + 1, clip.frames}};
  const MotionMeasure whole = engine::measure_motion(clip);
  const MotionMeasure parts = engine::measure_motion(clip, nullptr, split);
  const MotionMeasure smooth = engine::measure_motion(walk(), nullptr, split);
  EXPECT_GT(whole.jitter, 3 * parts.jitter);
  EXPECT_NEAR(parts.jitter, smooth.jitter, 1e-9 * smooth.jitter);
}

}  // namespace
}  // namespace mocap
