// Foot locking (kernels/foot_lock.hpp): on a synthetic walk whose planted foot slides, the
// locked foot holds still, the rest of the body is untouched, and the blend adds no jump.
#include "kernels/foot_lock.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "kernels/forward_kinematics.hpp"

namespace mocap {
namespace {

// root (translated) -> spine -> head; root -> hip -> knee -> ankle -> toe, for each side.
struct Walk {
  static constexpr int kJoints = 11;
  static constexpr int kRoot = 0, kSpine = 1, kHead = 2;
  static constexpr int kLeftHip = 3, kLeftKnee = 4, kLeftAnkle = 5, kLeftToe = 6;
  static constexpr int kRightHip = 7, kRightKnee = 8, kRightAnkle = 9, kRightToe = 10;
  std::vector<int> parents{-1, 0, 1, 0, 3, 4, 5, 0, 7, 8, 9};
  std::vector<Vec3> offsets{{0, 0, 0},     {0, 0.1, 0},   {0, 0.5, 0},      {0.1, 0, 0},
                            {0, -0.45, 0}, {0, -0.45, 0}, {0, -0.05, 0.12}, {-0.1, 0, 0},
                            {0, -0.45, 0}, {0, -0.45, 0}, {0, -0.05, 0.12}};
  std::vector<std::uint8_t> translated{1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  int frames;
  double frame_time;
  std::vector<float> rotations, translations;

  // The body moves forward (z) at `speed` m/s while the legs swing in antiphase at 1 Hz about x,
  // knees bent, the ankle under the hip at mid-stance. At the default speed each ankle stands still
  // at the middle of its stance (left at t = 0, 1, 2 s; right at 0.5, 1.5 s: the hip's swing
  // cancels the body's speed there) and slides slowly around it, as a filtered capture does; faster
  // speeds make it slide more.
  static constexpr double kPlantedSpeed =
      0.45 * 0.3 * 2 * kPi * 2 * 0.9689124217106447;  // cos 0.25
  Walk(int f, double ft, double speed = kPlantedSpeed) : frames(f), frame_time(ft) {
    rotations.assign(std::size_t(frames) * kJoints * 4, 0.0f);
    translations.assign(std::size_t(frames) * kJoints * 3, 0.0f);
    for (int t = 0; t < frames; ++t) {
      const double s = t * frame_time, w = 2 * kPi;
      for (int j = 0; j < kJoints; ++j) {
        store_quat(Quat{}, at_rotation(t, j));
        store_vec3(offsets[std::size_t(j)], at_translation(t, j));
      }
      store_vec3({0.01 * std::sin(w * s), 0.84 + 0.01 * std::sin(2 * w * s), speed * s},
                 at_translation(t, kRoot));
      store_quat(exp(Vec3{0.05 * std::sin(w * s), 0.1 * std::sin(w * s), 0}),
                 at_rotation(t, kSpine));
      store_quat(exp(Vec3{0.3 * std::sin(w * s) - 0.25, 0, 0}), at_rotation(t, kLeftHip));
      store_quat(exp(Vec3{0.35 + 0.15 * std::cos(w * s), 0, 0}), at_rotation(t, kLeftKnee));
      store_quat(exp(Vec3{-0.2 * std::sin(w * s), 0, 0.05}), at_rotation(t, kLeftAnkle));
      store_quat(exp(Vec3{-0.3 * std::sin(w * s) - 0.25, 0, 0}), at_rotation(t, kRightHip));
      store_quat(exp(Vec3{0.35 - 0.15 * std::cos(w * s), 0, 0}), at_rotation(t, kRightKnee));
      store_quat(exp(Vec3{0.2 * std::sin(w * s), 0, 0}), at_rotation(t, kRightAnkle));
    }
  }
  float* at_rotation(int t, int j) { return &rotations[(std::size_t(t) * kJoints + j) * 4]; }
  float* at_translation(int t, int j) { return &translations[(std::size_t(t) * kJoints + j) * 3]; }
  const float* at_translation(int t, int j) const {
    return &translations[(std::size_t(t) * kJoints + j) * 3];
  }

  std::vector<float> positions() const {
    std::vector<float> out(std::size_t(frames) * kJoints * 3);
    ForwardKinematicsJob fk;
    fk.parents = parents;
    fk.offsets = offsets;
    fk.rotations = {rotations.data(), frames, kJoints};
    fk.translations = {translations.data(), frames, kJoints};
    fk.translated_joints = translated;
    fk.positions = {out.data(), frames, kJoints};
    EXPECT_TRUE(fk.run().ok());
    return out;
  }
  // Global rotation of joint j at frame t.
  Quat global_rotation(int t, int j) const {
    Quat q = load_quat(&rotations[(std::size_t(t) * kJoints + j) * 4]);
    for (int p = parents[std::size_t(j)]; p >= 0; p = parents[std::size_t(p)])
      q = load_quat(&rotations[(std::size_t(t) * kJoints + p) * 4]) * q;
    return q;
  }
};

std::vector<FootChain> walk_legs() {
  FootChain left{Walk::kLeftHip, Walk::kLeftKnee, Walk::kLeftAnkle, Walk::kLeftToe, 'L'};
  FootChain right{Walk::kRightHip, Walk::kRightKnee, Walk::kRightAnkle, Walk::kRightToe, 'R'};
  return {left, right};
}

// `anchors` (optional): the pins follow them (FootLockJob::input_anchors, body height 1 unit).
FootLockStats lock(Walk& walk, const std::vector<std::vector<ContactInterval>>& contacts,
                   FootLockParams params = {}, std::span<const float> anchors = {}) {
  const std::vector<FootChain> legs = walk_legs();
  FootLockStats stats;
  FootLockJob job;
  job.params = params;
  job.parents = walk.parents;
  job.offsets = walk.offsets;
  job.translated_joints = walk.translated;
  job.frame_time = walk.frame_time;
  job.rotations = {walk.rotations.data(), walk.frames, Walk::kJoints};
  job.translations = {walk.translations.data(), walk.frames, Walk::kJoints};
  job.legs = legs;
  job.contacts = contacts;
  job.input_anchors = anchors;
  job.body_height = 1;
  job.stats = &stats;
  const Status s = job.run();
  EXPECT_TRUE(s.ok()) << s.message();
  return stats;
}

Vec3 point(const std::vector<float>& positions, int t, int j) {
  return load_vec3(&positions[(std::size_t(t) * Walk::kJoints + j) * 3]);
}
double horizontal(Vec3 v) {
  return std::hypot(v.x, v.z);
}

// The largest per-frame step of joint j over frames [begin, end).
double largest_step(const std::vector<float>& positions, int j, int begin, int end) {
  double largest = 0;
  for (int t = begin + 1; t < end; ++t)
    largest = std::max(largest, norm(point(positions, t, j) - point(positions, t - 1, j)));
  return largest;
}

bool same_bits(const float* a, const float* b, int n) {
  return std::equal(a, a + n, b);
}

TEST(FootLock, APlantedFootThatSlidesComesOutPinned) {
  Walk walk(240, 1.0 / 120);
  const std::vector<float> before = walk.positions();
  const ContactInterval contact{108, 132};
  // The synthetic foot does slide over its contact: the test would pass vacuously otherwise.
  double slide = 0;
  for (int t = contact.begin + 1; t < contact.end; ++t)
    slide +=
        horizontal(point(before, t, Walk::kLeftAnkle) - point(before, t - 1, Walk::kLeftAnkle));
  ASSERT_GT(slide, 0.01);
  // The IK's geometry: without the knee's speed limit (the synthetic knee turns slowly, so the
  // limit would let the foot miss its pin by a millimetre; see TheKneeTurnsNoFaster...).
  FootLockParams exact;
  exact.max_knee_speed = -1;
  const FootLockStats stats = lock(walk, {{contact}, {}}, exact);
  EXPECT_EQ(stats.contacts, 1);
  EXPECT_EQ(stats.locked_frames, 24);
  EXPECT_EQ(stats.lowered_frames, 0);
  const std::vector<float> after = walk.positions();
  // Held in place horizontally; its height stays the filter's.
  const Vec3 pin = point(after, contact.begin, Walk::kLeftAnkle);
  for (int t = contact.begin; t < contact.end; ++t) {
    EXPECT_LT(horizontal(point(after, t, Walk::kLeftAnkle) - pin), 1e-5) << "frame " << t;
    EXPECT_NEAR(point(after, t, Walk::kLeftAnkle).y, point(before, t, Walk::kLeftAnkle).y, 1e-5)
        << "frame " << t;
  }
  // The pin is the median of the filtered ankle over the contact.
  std::vector<double> zs;
  for (int t = contact.begin; t < contact.end; ++t)
    zs.push_back(point(before, t, Walk::kLeftAnkle).z);
  std::sort(zs.begin(), zs.end());
  EXPECT_NEAR(pin.z, 0.5 * (zs[11] + zs[12]), 1e-5);
  // The foot's global orientation is kept at every frame.
  const Walk reference(240, 1.0 / 120);
  for (int t = 0; t < walk.frames; ++t)
    for (int j : {Walk::kLeftAnkle, Walk::kLeftToe})
      EXPECT_LT(geodesic(walk.global_rotation(t, j), reference.global_rotation(t, j)), 1e-5)
          << "frame " << t << " joint " << j;
}

TEST(FootLock, AFootWithoutContactsAndTheUpperBodyAreBitIdentical) {
  Walk walk(360, 1.0 / 120);
  const Walk original(360, 1.0 / 120);
  lock(walk, {{{108, 132}, {228, 252}}, {}});
  const int blend = 12;  // 0.1 s at 120 fps
  for (int t = 0; t < walk.frames; ++t) {
    for (int j = 0; j < Walk::kJoints; ++j) {
      const bool left_leg = j == Walk::kLeftHip || j == Walk::kLeftKnee || j == Walk::kLeftAnkle;
      const bool near_contact =
          (t >= 108 - blend && t < 132 + blend) || (t >= 228 - blend && t < 252 + blend);
      const bool same = same_bits(&walk.rotations[(std::size_t(t) * Walk::kJoints + j) * 4],
                                  &original.rotations[(std::size_t(t) * Walk::kJoints + j) * 4], 4);
      if (!left_leg || !near_contact) {
        EXPECT_TRUE(same) << "frame " << t << " joint " << j;
      }
      if (left_leg && t >= 108 && t < 132 && j != Walk::kLeftAnkle) {
        EXPECT_FALSE(same) << "the locked leg was not moved at frame " << t;
      }
    }
  }
  EXPECT_EQ(walk.translations, original.translations);  // reachable: the root stays
}

TEST(FootLock, NoContactsLeaveTheMotionBitIdentical) {
  Walk walk(120, 1.0 / 120);
  const Walk original(120, 1.0 / 120);
  const FootLockStats stats = lock(walk, {{}, {}});
  EXPECT_EQ(stats.contacts, 0);
  EXPECT_EQ(walk.rotations, original.rotations);
  EXPECT_EQ(walk.translations, original.translations);
}

TEST(FootLock, TheBlendAddsNoStepLargerThanTheInputs) {
  for (const double frame_time : {1.0 / 120, 1.0 / 30}) {
    // Stances of 0.2 s around the still frames, and one of 0.1 s at the clip's start.
    const int f = int(std::lround(2.0 / frame_time)), s = int(std::lround(0.1 / frame_time));
    Walk walk(f, frame_time);
    const std::vector<float> before = walk.positions();
    lock(walk, {{{0, s / 2}, {f / 2 - s, f / 2 + s}},
                {{f / 4 - s, f / 4 + s}, {3 * f / 4 - s, 3 * f / 4 + s}}});
    const std::vector<float> after = walk.positions();
    for (int j : {Walk::kLeftAnkle, Walk::kRightAnkle, Walk::kLeftKnee, Walk::kRightKnee}) {
      EXPECT_LE(largest_step(after, j, 0, f), largest_step(before, j, 0, f))
          << "joint " << j << " at " << 1 / frame_time << " fps";
    }
  }
}

TEST(FootLock, AnUnreachablePinLowersTheRootAndTheFootStillHolds) {
  // Fast enough that the hip runs 0.4 m past the pin: the leg cannot reach.
  Walk walk(240, 1.0 / 120, 4.0);
  const Walk original(240, 1.0 / 120, 4.0);
  const ContactInterval contact{100, 140};
  FootLockParams exact;  // the reach's geometry, without the knee's speed limit
  exact.max_knee_speed = -1;
  const FootLockStats stats = lock(walk, {{contact}, {}}, exact);
  EXPECT_GT(stats.lowered_frames, 0);
  EXPECT_GT(stats.max_drop, 0);
  const std::vector<float> after = walk.positions();
  const Vec3 pin = point(after, 120, Walk::kLeftAnkle);
  for (int t = contact.begin; t < contact.end; ++t)
    EXPECT_LT(horizontal(point(after, t, Walk::kLeftAnkle) - pin), 1e-4) << "frame " << t;
  // Only the root's height changed among the translations, and only downwards.
  for (int t = 0; t < walk.frames; ++t)
    for (int j = 0; j < Walk::kJoints; ++j)
      for (int c = 0; c < 3; ++c) {
        const float a = walk.translations[(std::size_t(t) * Walk::kJoints + j) * 3 + c];
        const float b = original.translations[(std::size_t(t) * Walk::kJoints + j) * 3 + c];
        if (j == Walk::kRoot && c == 1) {
          EXPECT_LE(a, b);
        } else {
          EXPECT_EQ(a, b) << "frame " << t << " joint " << j << " channel " << c;
        }
      }
}

// The input's anchors as FootLockJob::input_anchors takes them, [F][legs][ankle, toe][3], from
// `track(leg, which, t)`.
template <class Track>
std::vector<float> input_anchors(int frames, Track track) {
  std::vector<float> out;
  for (int t = 0; t < frames; ++t)
    for (int leg = 0; leg < 2; ++leg)
      for (int which = 0; which < 2; ++which) {
        const Vec3 v = track(leg, which, t);
        out.insert(out.end(), {float(v.x), float(v.y), float(v.z)});
      }
  return out;
}

// Gaussian draws from Box-Muller on a 64-bit LCG: the same on every platform.
struct Draws {
  std::uint64_t state;
  double operator()() {
    auto uniform = [&] {
      state = state * 6364136223846793005ull + 1442695040888963407ull;
      return (double(state >> 11) + 0.5) / 9007199254740992.0;
    };
    const double u = uniform(), v = uniform();
    return std::sqrt(-2 * std::log(u)) * std::cos(2 * kPi * v);
  }
};

// A pin out of the leg's reach at a contact's ends while the filter left the thigh a hair off
// on every other frame (as noise does): lowering the root by each frame's own need makes it step
// down and back up from frame to frame where that need comes and goes (docs/feet.md, "Reach").
// The drops' envelope (header, "Reach") lowers no frame less than it needs minus the input
// anchors' own noise m (0 without them) nor deeper than the deepest need within w frames; the
// ankle lands where the per-frame lock put it, or short of it by no more than the root was
// raised above its need (so at most m); and the root's height is less jerky at 30 and at 120
// fps (most of what remains is the reach's own ramp at the contact's ends, which both share).
TEST(FootLock, TheRootGoesDownSmoothlyAndTheFootMissesByNoMoreThanItsInputsNoise) {
  for (const double anchor_noise : {0.0, 0.004})
    for (const double frame_time : {1.0 / 30, 1.0 / 120}) {
      const int frames = int(std::lround(2.0 / frame_time));
      Walk input(frames, frame_time, 1.3 * Walk::kPlantedSpeed);
      const std::vector<float> original = input.positions();
      for (int t = 1; t < frames; t += 2) {  // the filter's leftover noise on the thigh
        float* q = input.at_rotation(t, Walk::kLeftHip);
        store_quat(exp(Vec3{0.02, 0, 0}) * load_quat(q), q);
      }
      const ContactInterval contact{int(std::lround(0.8 / frame_time)),
                                    int(std::lround(1.25 / frame_time))};
      Draws gaussian{777};
      std::vector<float> anchors;
      if (anchor_noise > 0)  // the capture's feet, the left one planted through the contact
        anchors = input_anchors(frames, [&](int leg, int which, int t) {
          const int j = leg == 0 ? (which == 0 ? Walk::kLeftAnkle : Walk::kLeftToe)
                                 : (which == 0 ? Walk::kRightAnkle : Walk::kRightToe);
          const bool planted = leg == 0 && t >= contact.begin && t < contact.end;
          return point(original, planted ? (contact.begin + contact.end) / 2 : t, j) +
                 anchor_noise * Vec3{gaussian(), gaussian(), gaussian()};
        });
      FootLockParams stepwise, enveloped;  // the reach's geometry, without the knee's speed limit
      stepwise.max_knee_speed = enveloped.max_knee_speed = -1;
      stepwise.drop_time = 0;
      Walk by_frame = input, smooth = input;
      const FootLockStats a = lock(by_frame, {{contact}, {}}, stepwise, anchors);
      const FootLockStats b = lock(smooth, {{contact}, {}}, enveloped, anchors);
      ASSERT_GT(a.lowered_frames, 0) << "the pin must be out of reach, or the test is vacuous";
      const double m = b.anchor_noise;  // body height 1 unit
      if (anchor_noise > 0) {
        EXPECT_GT(m, 0.5 * anchor_noise);
      }
      auto height = [](const Walk& w, int t) {
        return double(w.at_translation(t, Walk::kRoot)[1]);
      };
      // The root height's jerkiness: RMS of its second differences over the clip.
      auto jerkiness = [&](const Walk& w) {
        double sum = 0;
        for (int t = 1; t + 1 < frames; ++t) {
          const double second = height(w, t + 1) - 2 * height(w, t) + height(w, t - 1);
          sum += second * second;
        }
        return std::sqrt(sum / (frames - 2));
      };
      const double jerk_in = jerkiness(input), jerk_by_frame = jerkiness(by_frame),
                   jerk = jerkiness(smooth);
      const int w = int(std::lround(FootLockParams{}.drop_time / frame_time));
      auto needed = [&](int t) { return height(input, t) - height(by_frame, t); };
      const std::vector<float> exact = by_frame.positions(), after = smooth.positions();
      double worst_miss = 0;
      for (int t = 0; t < frames; ++t) {
        double deepest = 0;
        for (int k = std::max(0, t - w); k <= std::min(frames - 1, t + w); ++k)
          deepest = std::max(deepest, needed(k));
        const double drop = height(input, t) - height(smooth, t);
        EXPECT_GE(drop, needed(t) - m - 1e-6) << "frame " << t;
        EXPECT_LE(drop, deepest + 1e-6) << "frame " << t;
        const double miss =
            norm(point(after, t, Walk::kLeftAnkle) - point(exact, t, Walk::kLeftAnkle));
        EXPECT_LT(miss, std::max(0.0, needed(t) - drop) + 1e-4) << "frame " << t;
        worst_miss = std::max(worst_miss, miss);
      }
      std::printf(
          "%.0f fps, anchors' noise %.4f (m %.4f): %d -> %d frames lowered; root height's RMS "
          "second difference: input %.5f, per frame %.5f, envelope %.5f; the ankle's largest "
          "distance from the per-frame lock's %.5f\n",
          1 / frame_time, anchor_noise, m, a.lowered_frames, b.lowered_frames, jerk_in,
          jerk_by_frame, jerk, worst_miss);
      if (anchor_noise == 0) {
        EXPECT_LT(worst_miss, 1e-4);
      }
      EXPECT_GT(jerk_by_frame, 1.5 * jerk_in) << "no jerk to smooth: the test is vacuous";
      EXPECT_LT(jerk, 0.95 * jerk_by_frame);
    }
}

// With the input's anchors, the pin is the input's own foot, not one point per contact: where
// the input shows no noise its slow real motion during the contact (here a steady heel turn of
// 1 mm per frame, while the filtered foot slides its own way) comes out as the input had it,
// exactly without smoothing and, with the default smoothing (a Gaussian is exact on a straight
// line), at every frame more than its three widths from the contact's ends.
TEST(FootLock, ThePinsFollowTheInputsOwnFootWhereItHasNoNoise) {
  const ContactInterval contact{96, 144};
  const Walk original(240, 1.0 / 120);
  const std::vector<float> before = original.positions();
  const Vec3 start = point(before, contact.begin, Walk::kLeftAnkle);
  auto track = [&](int, int, int t) { return start + Vec3{0, 0, 0.001 * (t - contact.begin)}; };
  const std::vector<float> anchors = input_anchors(original.frames, track);
  for (double min_sigma : {0.0, FootLockParams{}.min_pin_sigma}) {
    Walk walk(240, 1.0 / 120);
    FootLockParams params;
    params.max_knee_speed = -1;  // the IK's geometry alone (see APlantedFootThatSlides...)
    params.min_pin_sigma = min_sigma;
    const FootLockStats stats = lock(walk, {{contact}, {}}, params, anchors);
    EXPECT_LT(stats.anchor_noise, 1e-6);
    EXPECT_NEAR(stats.pin_sigma, min_sigma, 1e-12);
    const std::vector<float> after = walk.positions();
    const int edge = int(std::ceil(3 * min_sigma / walk.frame_time));
    double filtered_slide = 0;
    for (int t = contact.begin + edge; t < contact.end - edge; ++t) {
      const Vec3 got = point(after, t, Walk::kLeftAnkle), want = track(0, 0, t);
      EXPECT_LT(horizontal(got - want), 2e-5) << "frame " << t << " sigma " << min_sigma;
      EXPECT_NEAR(got.y, point(before, t, Walk::kLeftAnkle).y, 1e-5) << "frame " << t;
      filtered_slide =
          std::max(filtered_slide, horizontal(point(before, t, Walk::kLeftAnkle) - want));
    }
    EXPECT_GT(filtered_slide, 0.005) << "the filtered foot was already there: vacuous";
  }
}

// A noisy input: the anchors' noise is measured (white noise of 0.01 body heights on x and z),
// the pin's width follows from it (pin_width frames per body height), and the locked foot holds
// near the point the input stands on with a small part of the input's step to step jitter.
TEST(FootLock, TheInputsNoiseIsMeasuredAndSmoothedOutOfThePins) {
  const ContactInterval contact{72, 168};
  const Walk original(240, 1.0 / 120);
  const std::vector<float> before = original.positions();
  const Vec3 stand = point(before, 120, Walk::kLeftAnkle);
  Draws gaussian{12345};
  const double noise = 0.01;
  std::vector<Vec3> track(std::size_t(original.frames));
  for (Vec3& v : track) v = stand + Vec3{noise * gaussian(), 0, noise * gaussian()};
  const std::vector<float> anchors =
      input_anchors(original.frames, [&](int, int, int t) { return track[std::size_t(t)]; });
  Walk walk(240, 1.0 / 120);
  FootLockParams params;
  params.max_knee_speed = -1;
  const FootLockStats stats = lock(walk, {{contact}, {}}, params, anchors);
  EXPECT_NEAR(stats.anchor_noise, noise, 0.15 * noise);
  EXPECT_NEAR(stats.pin_sigma, params.pin_width * stats.anchor_noise * walk.frame_time, 1e-12);
  const std::vector<float> after = walk.positions();
  double input_step = 0, locked_step = 0, off = 0;
  for (int t = contact.begin + 1; t < contact.end; ++t) {
    input_step += horizontal(track[std::size_t(t)] - track[std::size_t(t - 1)]);
    locked_step +=
        horizontal(point(after, t, Walk::kLeftAnkle) - point(after, t - 1, Walk::kLeftAnkle));
    off = std::max(off, horizontal(point(after, t, Walk::kLeftAnkle) - stand));
  }
  std::printf(
      "noise %.5f (added %.5f), pin sigma %.4f s, mean step input %.5f locked %.5f, "
      "farthest from the stand %.5f\n",
      stats.anchor_noise, noise, stats.pin_sigma, input_step / 95, locked_step / 95, off);
  EXPECT_LT(locked_step, 0.25 * input_step);
  EXPECT_LT(off, 1.5 * noise);
}

// The lift (header, "Lift"): with noisy input anchors a few mm off the filtered foot, the
// horizontal-only target bends the knee of the leaning leg to reach them; lifted within the
// anchors' noise m, the hip alone reaches them: the knee's local rotation moves less than half as
// much, the ankle lands on the same horizontal point, and its height stays within m of the filtered
// one's.
TEST(FootLock, TheLiftSwingsTheHipInsteadOfBendingTheKnee) {
  for (const double frame_time : {1.0 / 30, 1.0 / 120}) {
    const int frames = int(std::lround(2.0 / frame_time));
    const Walk input(frames, frame_time);
    const std::vector<float> before = input.positions();
    const ContactInterval contact{int(std::lround(0.8 / frame_time)),
                                  int(std::lround(1.2 / frame_time))};
    Draws gaussian{2024};
    const std::vector<float> anchors = input_anchors(frames, [&](int leg, int which, int t) {
      const int j = leg == 0 ? (which == 0 ? Walk::kLeftAnkle : Walk::kLeftToe)
                             : (which == 0 ? Walk::kRightAnkle : Walk::kRightToe);
      // The capture's foot 5 mm ahead of the filtered one, under 4 mm of noise.
      return point(before, t, j) + Vec3{0, 0, 0.005} +
             0.004 * Vec3{gaussian(), gaussian(), gaussian()};
    });
    FootLockParams flat, lifted;
    flat.max_knee_speed = lifted.max_knee_speed = -1;  // the IK's geometry alone
    flat.lift = 0;
    Walk a = input, b = input;
    lock(a, {{contact}, {}}, flat, anchors);
    const FootLockStats stats = lock(b, {{contact}, {}}, lifted, anchors);
    const double m = stats.anchor_noise;  // body height 1 unit
    ASSERT_GT(m, 0.002);
    EXPECT_EQ(stats.lowered_frames, 0);
    const std::vector<float> pa = a.positions(), pb = b.positions();
    auto knee_turn = [&](const Walk& w, int t) {
      const float* q = &w.rotations[(std::size_t(t) * Walk::kJoints + Walk::kLeftKnee) * 4];
      const float* r = &input.rotations[(std::size_t(t) * Walk::kJoints + Walk::kLeftKnee) * 4];
      return 2 * std::acos(std::min(1.0, std::abs(dot(load_quat(q), load_quat(r)))));
    };
    double turn_flat = 0, turn_lifted = 0, highest = 0;
    for (int t = 0; t < frames; ++t) {
      turn_flat += knee_turn(a, t);
      turn_lifted += knee_turn(b, t);
      const Vec3 ankle = point(pb, t, Walk::kLeftAnkle);
      highest = std::max(highest, std::abs(ankle.y - point(before, t, Walk::kLeftAnkle).y));
      EXPECT_LT(horizontal(ankle - point(pa, t, Walk::kLeftAnkle)), 1e-5) << "frame " << t;
    }
    std::printf(
        "%.0f fps, m %.5f: the knee's turn summed over the clip %.4f rad without the lift, %.4f "
        "with it; the ankle's largest change of height %.5f\n",
        1 / frame_time, m, turn_flat, turn_lifted, highest);
    EXPECT_GT(turn_flat, 0.01) << "the knee did not bend: the test would be vacuous";
    EXPECT_LT(turn_lifted, 0.5 * turn_flat);  // measured 0.36x at 30 fps, 0.10x at 120
    EXPECT_LE(highest, m + 1e-5);
    EXPECT_GT(highest, 0.1 * m) << "nothing was lifted: the test would be vacuous";
  }
}

// The fast path against the reference with pins that follow noisy input anchors, at 120 and 30
// fps, toe contacts included.
TEST(FootLock, TheFastPathMatchesTheReferenceWithInputAnchors) {
  for (double frame_time : {1.0 / 120, 1.0 / 30}) {
    const int frames = int(std::lround(2 / frame_time));
    const Walk original(frames, frame_time);
    const std::vector<float> before = original.positions();
    std::vector<float> anchors = input_anchors(frames, [&](int leg, int which, int t) {
      const int j = leg == 0 ? (which == 0 ? Walk::kLeftAnkle : Walk::kLeftToe)
                             : (which == 0 ? Walk::kRightAnkle : Walk::kRightToe);
      const Vec3 v = point(before, t, j);
      return v + Vec3{0.004 * std::sin(1.7 * t + leg), 0, 0.004 * std::cos(2.3 * t + which)};
    });
    const auto at = [&](int t120) { return int(std::lround(t120 / 120.0 / frame_time)); };
    const std::vector<std::vector<ContactInterval>> contacts{{{at(100), at(140)}},
                                                             {{at(50), at(80)}}};
    const std::vector<std::vector<ContactInterval>> toes{{{at(140), at(148)}}, {}};
    Walk walks[2] = {Walk(frames, frame_time), Walk(frames, frame_time)};
    FootLockStats stats[2];
    for (int i = 0; i < 2; ++i) {
      const std::vector<FootChain> legs = walk_legs();
      FootLockJob job;
      job.parents = walks[i].parents;
      job.offsets = walks[i].offsets;
      job.translated_joints = walks[i].translated;
      job.frame_time = frame_time;
      job.rotations = {walks[i].rotations.data(), frames, Walk::kJoints};
      job.translations = {walks[i].translations.data(), frames, Walk::kJoints};
      job.legs = legs;
      job.contacts = contacts;
      job.toe_contacts = toes;
      job.input_anchors = anchors;
      job.body_height = 1;
      job.stats = &stats[i];
      job.implementation = i == 0 ? Implementation::reference : Implementation::fast;
      ASSERT_TRUE(job.run().ok());
    }
    EXPECT_EQ(stats[0].anchor_noise, stats[1].anchor_noise);
    EXPECT_GT(stats[0].anchor_noise, 0);
    double largest = 0, moved = 0;
    for (std::size_t i = 0; i < walks[0].rotations.size(); ++i) {
      largest = std::max(largest, double(std::abs(walks[0].rotations[i] - walks[1].rotations[i])));
      moved = std::max(moved, double(std::abs(walks[0].rotations[i] - original.rotations[i])));
    }
    EXPECT_LE(largest, 1e-6) << frame_time;
    EXPECT_GT(moved, 1e-3) << frame_time << ": the lock did nothing, the test would be vacuous";
  }
}

// The largest angular speed of joint j's local rotation, rad/s.
double peak_speed(const Walk& walk, int j) {
  double peak = 0;
  for (int t = 1; t < walk.frames; ++t)
    peak = std::max(
        peak, geodesic(load_quat(&walk.rotations[(std::size_t(t - 1) * Walk::kJoints + j) * 4]),
                       load_quat(&walk.rotations[(std::size_t(t) * Walk::kJoints + j) * 4])));
  return peak / walk.frame_time;
}

// Mean horizontal step of joint j over the steps inside [begin, end).
double mean_slide(const std::vector<float>& positions, int j, int begin, int end) {
  double sum = 0;
  for (int t = begin + 1; t < end; ++t)
    sum += horizontal(point(positions, t, j) - point(positions, t - 1, j));
  return sum / (end - begin - 1);
}

// A walk fast enough that the planted foot slides far, with long contacts whose ends come where
// the hip has moved on and the leg is near straight: pinning the foot there asks the knee to
// catch up with the motion in a frame or two (a pop, checked to happen without the limit), as on
// real clips at a contact's end. With the default limit the knee turns no faster than 1.2x the
// input's peak (issue 14's target; the limit is the motion's own peak) and the foot still slides
// far less than unlocked.
TEST(FootLock, TheKneeTurnsNoFasterThanTheInputsPeakAtAContactsEnds) {
  for (const double frame_time : {1.0 / 30, 1.0 / 120}) {
    const int frames = int(std::lround(2.0 / frame_time));
    const double speed = 1.6 * Walk::kPlantedSpeed;
    const Walk input(frames, frame_time, speed);
    const std::vector<float> before = input.positions();
    // Left stance around t = 1 s, from 0.8 s to 1.25 s (its end where the hip has passed).
    const ContactInterval contact{int(std::lround(0.8 / frame_time)),
                                  int(std::lround(1.25 / frame_time))};
    const double input_peak = peak_speed(input, Walk::kLeftKnee);
    Walk unlimited = input, limited = input;
    FootLockParams no_limit;
    no_limit.max_knee_speed = -1;
    lock(unlimited, {{contact}, {}}, no_limit);
    lock(limited, {{contact}, {}});
    const double fps = 1 / frame_time;
    const double pop = peak_speed(unlimited, Walk::kLeftKnee) / input_peak;
    const double ratio = peak_speed(limited, Walk::kLeftKnee) / input_peak;
    const double slide_in = mean_slide(before, Walk::kLeftAnkle, contact.begin, contact.end);
    const double slide =
        mean_slide(limited.positions(), Walk::kLeftAnkle, contact.begin, contact.end);
    std::printf("%.0f fps: knee peak x input, no limit %.2f, limit %.2f; slide %.5f -> %.5f\n", fps,
                pop, ratio, slide_in, slide);
    EXPECT_GT(pop, 1.2) << fps << " fps: no pop to prevent, the test would pass vacuously";
    EXPECT_LE(ratio, 1.2) << fps << " fps";
    EXPECT_LT(slide, 0.25 * slide_in) << fps << " fps";
  }
}

// A left leg that the filter leaves straight through its stance, its knee wobbling a little to
// either side and sideways (noise about a straight leg, as on CMU's 05_02 at 0.008 rad), bent
// forwards (+x) in its swing. There the bend plane's normal is the noise's: the lock turned the
// knee about it, backwards on half the frames (a 43.6 rad/s knee step on that clip). Now (header,
// "Bend side") every turn the lock gives the knee is about its hinge (x in the thigh's frame, to
// 5 degrees), it bends no further backwards than the input, and the knee turns no faster than
// 1.2x the input's peak; the fast path agrees with the reference.
TEST(FootLock, AStraightKneeBendsAboutItsHingeOnTheClipsSide) {
  const double frame_time = 1.0 / 120;
  const int frames = 240;
  Walk input(frames, frame_time, 1.6 * Walk::kPlantedSpeed);
  for (int t = 0; t < frames; ++t) {
    const double swing = std::max(0.0, std::sin(2 * kPi * t * frame_time));
    const double sign = t % 2 == 0 ? 1 : -1;
    store_quat(
        exp(Vec3{0.6 * swing * swing + 0.006 * sign, 0, 0.004 * sign * (t % 3 == 0 ? -1 : 1)}),
        input.at_rotation(t, Walk::kLeftKnee));
  }
  const ContactInterval contact{66, 114};  // 0.55 to 0.95 s: the knee straight
  const double input_peak = peak_speed(input, Walk::kLeftKnee);
  Walk locked[2] = {input, input};
  const std::vector<FootChain> legs = walk_legs();
  const std::vector<std::vector<ContactInterval>> contacts = {{contact}, {}};
  for (int i = 0; i < 2; ++i) {
    FootLockJob job;
    job.parents = input.parents;
    job.offsets = input.offsets;
    job.translated_joints = input.translated;
    job.frame_time = frame_time;
    job.rotations = {locked[i].rotations.data(), frames, Walk::kJoints};
    job.translations = {locked[i].translations.data(), frames, Walk::kJoints};
    job.legs = legs;
    job.contacts = contacts;
    job.implementation = i == 0 ? Implementation::reference : Implementation::fast;
    const Status s = job.run();
    ASSERT_TRUE(s.ok()) << s.message();
  }
  const auto knee = [&](const Walk& w, int t) {
    return load_quat(&w.rotations[(std::size_t(t) * Walk::kJoints + Walk::kLeftKnee) * 4]);
  };
  double most_backwards_in = 0;
  for (int t = 0; t < frames; ++t)
    most_backwards_in = std::min(most_backwards_in, log(knee(input, t)).x);
  for (int i = 0; i < 2; ++i) {
    int turned = 0;
    for (int t = 0; t < frames; ++t) {
      const Vec3 turn = log(knee(locked[i], t) * inverse(knee(input, t)));  // in the thigh's frame
      if (norm(turn) < 1e-3) continue;
      ++turned;
      EXPECT_LE(std::hypot(turn.y, turn.z), std::sin(5 * kPi / 180) * norm(turn))
          << "frame " << t << ": the knee turned about (" << turn.x << ", " << turn.y << ", "
          << turn.z << ")";
      EXPECT_GE(log(knee(locked[i], t)).x, most_backwards_in - 1e-4) << "frame " << t;
    }
    EXPECT_GT(turned, 20) << "the lock should bend the straight knee: the test would be vacuous";
    const double ratio = peak_speed(locked[i], Walk::kLeftKnee) / input_peak;
    std::printf("%s: %d frames turned, knee peak %.2fx the input's\n",
                i == 0 ? "reference" : "fast", turned, ratio);
    EXPECT_LE(ratio, 1.2);
  }
  for (int t = 0; t < frames; ++t)
    EXPECT_LT(geodesic(knee(locked[0], t), knee(locked[1], t)), 1e-5) << "frame " << t;
}

// The fast path (planes through kernels/simd/foot_lock_simd.hpp) against the scalar reference:
// the same rotations and root heights to within the float they are stored in (a few ulps: the
// two round differently, fused multiply-adds and Highway's acos), and the same statistics. Cases:
// both legs locked with toe contacts, a gap between touched frames, an unreachable pin (the root
// lowered), without the knee's speed limit, with it binding, a step that is not motion
// (counted_steps) inside a contact, at 30 and 120 fps; and clips long enough that the fast path
// takes their touched frames in several chunks.
TEST(FootLock, TheFastPathMatchesTheReference) {
  struct Case {
    double frame_time, speed, knee_speed;
    std::vector<std::vector<ContactInterval>> contacts, toes;
    int uncounted_step = -1;  // a frame t whose step t-1 -> t is not motion
    double seconds = 2;
  };
  const std::vector<Case> cases = {
      {1.0 / 120,
       Walk::kPlantedSpeed,
       0,
       {{{0, 12}, {100, 140}}, {{50, 80}, {170, 200}}},
       {{{12, 20}}, {{80, 86}}}},
      {1.0 / 30, Walk::kPlantedSpeed, 0, {{{2, 10}, {25, 35}}, {{14, 20}}}, {}},
      {1.0 / 120, 4.0, -1, {{{100, 140}}, {}}, {}},
      {1.0 / 120, 1.6 * Walk::kPlantedSpeed, 0, {{{96, 150}}, {{30, 60}}}, {}},
      {1.0 / 30, 1.6 * Walk::kPlantedSpeed, 0, {{{24, 38}}, {}}, {}},
      {1.0 / 120, 1.6 * Walk::kPlantedSpeed, 0, {{{96, 150}}, {{30, 60}}}, {}, 120},
      // Over 512 touched frames: the fast path's planes hold them in several chunks.
      {1.0 / 120,
       Walk::kPlantedSpeed,
       0,
       {{{0, 12}, {100, 140}, {250, 420}, {600, 700}}, {{50, 80}, {170, 200}, {450, 560}}},
       {{{12, 20}}, {{80, 86}}},
       -1,
       6},
      {1.0 / 120,
       1.6 * Walk::kPlantedSpeed,
       0,
       {{{96, 150}, {240, 330}, {700, 900}}, {{30, 60}, {500, 700}}},
       {},
       300,
       8},
      {1.0 / 120, 4.0, -1, {{{150, 300}, {450, 700}}, {{330, 430}}}, {}, -1, 6},
  };
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const Case& k = cases[c];
    const int frames = int(std::lround(k.seconds / k.frame_time));
    Walk walks[2] = {Walk(frames, k.frame_time, k.speed), Walk(frames, k.frame_time, k.speed)};
    FootLockStats stats[2];
    const std::vector<FootChain> legs = walk_legs();
    std::vector<std::uint8_t> counted;
    if (k.uncounted_step >= 0) {
      counted.assign(std::size_t(frames), 1);
      counted[std::size_t(k.uncounted_step)] = 0;
    }
    for (int i = 0; i < 2; ++i) {
      FootLockJob job;
      job.params.max_knee_speed = k.knee_speed;
      job.parents = walks[i].parents;
      job.offsets = walks[i].offsets;
      job.translated_joints = walks[i].translated;
      job.frame_time = k.frame_time;
      job.rotations = {walks[i].rotations.data(), frames, Walk::kJoints};
      job.translations = {walks[i].translations.data(), frames, Walk::kJoints};
      job.legs = legs;
      job.contacts = k.contacts;
      job.toe_contacts = k.toes;
      job.counted_steps = counted;
      job.stats = &stats[i];
      job.implementation = i == 0 ? Implementation::reference : Implementation::fast;
      const Status s = job.run();
      ASSERT_TRUE(s.ok()) << s.message();
    }
    EXPECT_EQ(stats[0].contacts, stats[1].contacts) << "case " << c;
    EXPECT_EQ(stats[0].locked_frames, stats[1].locked_frames) << "case " << c;
    EXPECT_EQ(stats[0].lowered_frames, stats[1].lowered_frames) << "case " << c;
    EXPECT_NEAR(stats[0].max_drop, stats[1].max_drop, 1e-6) << "case " << c;
    const Walk original(frames, k.frame_time, k.speed);
    double largest = 0, moved = 0;
    for (std::size_t i = 0; i < walks[0].rotations.size(); ++i) {
      largest = std::max(largest, double(std::abs(walks[0].rotations[i] - walks[1].rotations[i])));
      moved = std::max(moved, double(std::abs(walks[0].rotations[i] - original.rotations[i])));
    }
    for (std::size_t i = 0; i < walks[0].translations.size(); ++i)
      largest =
          std::max(largest, double(std::abs(walks[0].translations[i] - walks[1].translations[i])));
    std::printf("case %zu: largest difference %.3g (the lock moved components by up to %.3g)\n", c,
                largest, moved);
    EXPECT_LE(largest, 1e-6) << "case " << c;
    EXPECT_GT(moved, 1e-3) << "case " << c << ": the lock did nothing, the test would be vacuous";
  }
}

// One scratch reused across clips of different sizes (FootLockScratch: what a run leaves in it
// means nothing to the next) gives the bits a fresh one gives, on both paths; and once it has
// held the largest clip, smaller and equal ones reuse its planes (nothing allocated per clip).
TEST(FootLock, AReusedScratchGivesTheResultsOfAFreshOne) {
  struct Case {
    int frames;
    double frame_time, speed;
    std::vector<std::vector<ContactInterval>> contacts, toes;
  };
  const std::vector<Case> clips = {
      {240,
       1.0 / 120,
       Walk::kPlantedSpeed,
       {{{0, 12}, {100, 140}}, {{50, 80}, {170, 200}}},
       {{{12, 20}}, {{80, 86}}}},
      {60, 1.0 / 30, Walk::kPlantedSpeed, {{{2, 10}, {25, 35}}, {{14, 20}}}, {}},
      {300, 1.0 / 120, 4.0, {{{100, 140}}, {{200, 260}}}, {}},  // the root lowered
      {45, 1.0 / 30, 1.6 * Walk::kPlantedSpeed, {{{24, 38}}, {}}, {}},
      {240, 1.0 / 120, Walk::kPlantedSpeed, {{{30, 90}}, {{120, 180}}}, {}},
      {720,  // several chunks of planes
       1.0 / 120,
       Walk::kPlantedSpeed,
       {{{0, 12}, {100, 140}, {250, 420}, {600, 700}}, {{50, 80}, {170, 200}, {450, 560}}},
       {{{12, 20}}, {{80, 86}}}},
  };
  const std::vector<FootChain> legs = walk_legs();
  for (Implementation implementation : {Implementation::fast, Implementation::reference}) {
    FootLockScratch reused;
    const double* steady_planes = nullptr;
    for (int pass = 0; pass < 2; ++pass)
      for (std::size_t c = 0; c < clips.size(); ++c) {
        const Case& k = clips[c];
        Walk walks[2] = {Walk(k.frames, k.frame_time, k.speed),
                         Walk(k.frames, k.frame_time, k.speed)};
        FootLockStats stats[2];
        FootLockScratch fresh;
        for (int i = 0; i < 2; ++i) {
          FootLockJob job;
          job.parents = walks[i].parents;
          job.offsets = walks[i].offsets;
          job.translated_joints = walks[i].translated;
          job.frame_time = k.frame_time;
          job.rotations = {walks[i].rotations.data(), k.frames, Walk::kJoints};
          job.translations = {walks[i].translations.data(), k.frames, Walk::kJoints};
          job.legs = legs;
          job.contacts = k.contacts;
          job.toe_contacts = k.toes;
          job.stats = &stats[i];
          job.scratch = i == 0 ? &fresh : &reused;
          job.implementation = implementation;
          const Status s = job.run();
          ASSERT_TRUE(s.ok()) << s.message();
        }
        const std::string what = std::string(to_string(implementation)) + ", pass " +
                                 std::to_string(pass) + ", clip " + std::to_string(c);
        EXPECT_TRUE(same_bits(walks[0].rotations.data(), walks[1].rotations.data(),
                              int(walks[0].rotations.size())))
            << what;
        EXPECT_TRUE(same_bits(walks[0].translations.data(), walks[1].translations.data(),
                              int(walks[0].translations.size())))
            << what;
        EXPECT_EQ(stats[0].contacts, stats[1].contacts) << what;
        EXPECT_EQ(stats[0].locked_frames, stats[1].locked_frames) << what;
        EXPECT_EQ(stats[0].lowered_frames, stats[1].lowered_frames) << what;
        EXPECT_EQ(stats[0].max_drop, stats[1].max_drop) << what;
        const Walk original(k.frames, k.frame_time, k.speed);
        EXPECT_FALSE(same_bits(walks[1].rotations.data(), original.rotations.data(),
                               int(original.rotations.size())))
            << what << ": the lock did nothing, the test would be vacuous";
        // The second pass: every clip has been seen, so the planes stay where they are.
        if (pass == 0 && c + 1 == clips.size()) steady_planes = reused.planes.get();
        if (pass == 1) {
          EXPECT_EQ(reused.planes.get(), steady_planes) << what << ": reallocated";
        }
      }
    if (implementation == Implementation::fast) {
      EXPECT_NE(steady_planes, nullptr);
    }
  }
}

TEST(FootLock, ValidateExplainsWhatIsWrong) {
  Walk walk(10, 1.0 / 120);
  std::vector<FootChain> legs = walk_legs();
  legs[0].knee = Walk::kRightKnee;  // not the child of the left hip
  const std::vector<std::vector<ContactInterval>> contacts{{}, {}};
  FootLockJob job;
  job.parents = walk.parents;
  job.offsets = walk.offsets;
  job.translated_joints = walk.translated;
  job.rotations = {walk.rotations.data(), walk.frames, Walk::kJoints};
  job.translations = {walk.translations.data(), walk.frames, Walk::kJoints};
  job.legs = legs;
  job.contacts = contacts;
  EXPECT_NE(job.validate().message().find("hip -> knee -> ankle"), std::string::npos);
  legs = walk_legs();
  job.legs = legs;
  const std::vector<std::vector<ContactInterval>> unordered{{{20, 30}, {5, 8}}, {}};
  job.contacts = unordered;
  EXPECT_NE(job.validate().message().find("ordered"), std::string::npos);
  job.contacts = std::span<const std::vector<ContactInterval>>(contacts.data(), 1);
  EXPECT_NE(job.validate().message().find("1 contact lists for 2 legs"), std::string::npos);
  job.contacts = contacts;
  const std::vector<float> anchors(std::size_t(walk.frames) * 2 * 6 - 3);
  job.input_anchors = anchors;
  EXPECT_NE(job.validate().message().find("input_anchors must be [frames][legs][2][3]"),
            std::string::npos);
  const std::vector<float> whole(std::size_t(walk.frames) * 2 * 6);
  job.input_anchors = whole;
  EXPECT_NE(job.validate().message().find("body_height"), std::string::npos);
  job.body_height = 1.7;
  EXPECT_TRUE(job.validate().ok());
  job.params.min_pin_sigma = 2;
  EXPECT_NE(job.validate().message().find("min_pin_sigma"), std::string::npos);
  job.params = {};
  job.params.lift = -0.5;
  EXPECT_NE(job.validate().message().find("lift must be finite and >= 0"), std::string::npos);
}

}  // namespace
}  // namespace mocap
