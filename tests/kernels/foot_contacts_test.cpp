// Foot contact detection (kernels/foot_contacts.hpp) on synthetic tracks with known answers, and
// the widening of a noisy input's contacts by the filtered motion's (widen_contacts).
#include "kernels/foot_contacts.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/point_smoothing.hpp"

namespace mocap {
namespace {

using Track = std::vector<float>;  // [F][N][3]

TensorView<const float, 3> view(const Track& t, int frames, int points) {
  return {t.data(), frames, points};
}

// A foot stepping at `fps`: each cycle it stands for `stance` seconds, rolling forward at `roll`
// cm/s, then swings `stride` cm forward and up to `lift` cm high. Units: cm, body height 170.
struct Gait {
  double cycle, stance, stride, lift, roll;
};

Track stepping_foot(const Gait& gait, double fps, int frames,
                    std::vector<ContactInterval>* planted) {
  Track track(std::size_t(frames) * 3);
  int begin = -1;
  for (int t = 0; t < frames; ++t) {
    const double time = t / fps, phase = std::fmod(time, gait.cycle);
    const int steps = int(time / gait.cycle);
    double x = (gait.stride + gait.roll * gait.stance) * steps, y = 8.0;
    const bool down = phase < gait.stance;
    if (down) {
      x += gait.roll * phase;
    } else {
      const double s = (phase - gait.stance) / (gait.cycle - gait.stance);  // 0..1 of the swing
      x += gait.roll * gait.stance + gait.stride * (0.5 - 0.5 * std::cos(kPi * s));
      y += gait.lift * std::sin(kPi * s);
    }
    track[std::size_t(t) * 3] = float(x);
    track[std::size_t(t) * 3 + 1] = float(y);
    if (down && begin < 0) begin = t;
    if (!down && begin >= 0) {
      planted->push_back({begin, t});
      begin = -1;
    }
  }
  if (begin >= 0) planted->push_back({begin, frames});
  return track;
}

// A walking foot: planted for 0.6 s, swinging (up to 10 cm high, 70 cm forward) for 0.4 s.
Track walking_foot(double fps, int frames, std::vector<ContactInterval>* planted) {
  return stepping_foot({1.0, 0.6, 70.0, 10.0, 0.0}, fps, frames, planted);
}

std::vector<ContactInterval> detect(const Track& track, int frames, double fps,
                                    double noise_allowance = 0) {
  std::vector<std::vector<ContactInterval>> contacts;
  FootContactJob job;
  job.params.noise_allowance = noise_allowance;
  job.feet = view(track, frames, 1);
  job.frame_time = 1.0 / fps;
  job.body_height = 170;
  job.contacts = &contacts;
  EXPECT_TRUE(job.run().ok());
  return contacts.at(0);
}

// Frames where the detection and the truth agree, as a share of all frames.
double agreement(const std::vector<ContactInterval>& a, const std::vector<ContactInterval>& b,
                 int frames) {
  const auto ma = contact_mask(a, frames), mb = contact_mask(b, frames);
  int same = 0;
  for (int t = 0; t < frames; ++t) same += ma[std::size_t(t)] == mb[std::size_t(t)];
  return double(same) / frames;
}

TEST(FootContacts, FindsTheStancesOfASyntheticWalkAtEveryFrameRate) {
  for (double fps : {24.0, 30.0, 60.0, 120.0}) {
    const int frames = int(5 * fps);
    std::vector<ContactInterval> truth;
    const Track track = walking_foot(fps, frames, &truth);
    const auto found = detect(track, frames, fps);
    EXPECT_EQ(found.size(), truth.size()) << fps << " fps";
    // The edges of a stance are soft (the foot slows down and lowers), a few frames either way.
    EXPECT_GT(agreement(found, truth, frames), 0.85) << fps << " fps";
  }
}

TEST(FootContacts, NoiseDoesNotChatter) {
  // 7 mm of position noise (0.4 % of the body) on every frame: still one interval per stance.
  const double fps = 120;
  const int frames = 600;
  std::vector<ContactInterval> truth;
  Track track = walking_foot(fps, frames, &truth);
  std::mt19937_64 rng(3);
  std::normal_distribution<float> noise(0.0f, 0.7f);
  for (float& v : track) v += noise(rng);
  const auto found = detect(track, frames, fps);
  EXPECT_EQ(found.size(), truth.size());
  EXPECT_GT(agreement(found, truth, frames), 0.8);
}

// The ankle noise of eval's 0.02 rad + 0.004 body (about 1.8 % of the body per axis on the
// shared clips, 3 cm here) at 30 and 120 fps: one interval per stance (the smoothing is 4x fewer
// frames at 30 fps).
TEST(FootContacts, EvalsNoiseDoesNotChatterAtAnyFrameRate) {
  for (double fps : {30.0, 120.0}) {
    const int frames = int(6 * fps);
    std::vector<ContactInterval> truth;
    Track track = walking_foot(fps, frames, &truth);
    std::mt19937_64 rng(5);
    std::normal_distribution<float> noise(0.0f, 3.0f);
    for (float& v : track) v += noise(rng);
    const auto found = detect(track, frames, fps);
    EXPECT_EQ(found.size(), truth.size()) << fps << " fps";
    EXPECT_GT(agreement(found, truth, frames), 0.85) << fps << " fps";
  }
}

// A running foot: planted for 0.12 s while it rolls forward at 0.12 body heights per second (as
// the shared clips' runs do, 02_03), then 0.5 s in the air, 150 cm forward and up to 30 cm high.
Track running_foot(double fps, int frames, std::vector<ContactInterval>* planted) {
  return stepping_foot({0.62, 0.12, 150.0, 30.0, 0.12 * 170}, fps, frames, planted);
}

// Share of the truth's frames that `found` covers.
double coverage(const std::vector<ContactInterval>& found,
                const std::vector<ContactInterval>& truth, int frames) {
  const auto mf = contact_mask(found, frames), mt = contact_mask(truth, frames);
  int planted = 0, covered = 0;
  for (int t = 0; t < frames; ++t) {
    planted += mt[std::size_t(t)];
    covered += mt[std::size_t(t)] && mf[std::size_t(t)];
  }
  return planted > 0 ? double(covered) / planted : 1.0;
}

// With eval's 0.02 rad + 0.004 body of noise (3 cm per axis here), a runner's short, rolling
// stances read as moving: the noise's own speed is about 0.1 body heights per second after the
// smoothing at 120 fps, 0.2 at 30 fps, against an enter threshold of 0.25. The allowance lets
// them in; without noise it finds what the exact thresholds find.
TEST(FootContacts, TheNoiseAllowanceFindsARunnersStancesThroughNoise) {
  for (double fps : {30.0, 120.0}) {
    const int frames = int(8 * fps);
    std::vector<ContactInterval> truth;
    const Track clean = running_foot(fps, frames, &truth);
    const auto exact = detect(clean, frames, fps);
    EXPECT_EQ(detect(clean, frames, fps, 2.0).size(), exact.size()) << fps << " fps";
    EXPECT_GT(coverage(exact, truth, frames), 0.6) << fps << " fps";
    double without = 0, with = 0;
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      Track track = clean;
      std::mt19937_64 rng(seed);
      std::normal_distribution<float> noise(0.0f, 3.0f);
      for (float& v : track) v += noise(rng);
      without += coverage(detect(track, frames, fps), truth, frames) / 5;
      const auto found = detect(track, frames, fps, 2.0);
      with += coverage(found, truth, frames) / 5;
      for (const ContactInterval& c : found)  // nothing in the air (a stance may come in two)
        EXPECT_TRUE(std::any_of(
            truth.begin(), truth.end(),
            [&](const ContactInterval& u) { return u.begin < c.end && c.begin < u.end; }))
            << fps << " fps, seed " << seed << ": [" << c.begin << ", " << c.end << ")";
    }
    std::printf("%3.0f fps: stance frames found, exact thresholds %.0f %%, allowance 2 %.0f %%\n",
                fps, 100 * without, 100 * with);
    EXPECT_GT(with, without + 0.1) << fps << " fps";
    EXPECT_GT(with, 0.9) << fps << " fps";
  }
}

// The allowance's noise speed: smoothed_speed_gain against white noise run through the
// detector's own smoothing (point_smoothing.hpp), away from the mirrored ends, and against its
// continuous form 1 / (2 sqrt(pi) sigma^3) where the smoothing is wide (from 4 frames).
TEST(FootContacts, TheNoiseSpeedGainIsWhatSmoothedWhiteNoiseShows) {
  for (double sigma : {0.3, 1.2, 2.4, 4.8, 9.6}) {
    const int n = 200000;
    std::vector<Vec3> noise(static_cast<std::size_t>(n));
    std::mt19937_64 rng(11);
    std::normal_distribution<double> g(0.0, 1.0);
    for (Vec3& v : noise) v = {g(rng), 0.0, g(rng)};
    const std::vector<Vec3> s = sigma < 0.5 ? noise : smooth_mirrored(noise, sigma);
    double sum = 0;
    int count = 0;
    for (int t = 50; t + 50 < n; ++t, ++count) {
      const Vec3 d = s[std::size_t(t + 1)] - s[std::size_t(t - 1)];
      sum += (d.x * d.x + d.z * d.z) / 4;
    }
    EXPECT_NEAR(sum / count / smoothed_speed_gain(sigma), 1.0, 0.02) << "sigma " << sigma;
    // The central difference differentiates less than the derivative does at narrow widths:
    // 0.92 of the continuous form at 2.4 frames, 0.98 at 4.8.
    if (sigma >= 4) {
      EXPECT_NEAR(smoothed_speed_gain(sigma) * 2 * std::sqrt(kPi) * std::pow(sigma, 3), 1.0, 0.025)
          << "sigma " << sigma;
    }
  }
}

// A noise-free track has no noise to allow for: the same contacts with and without the allowance.
TEST(FootContacts, TheNoiseAllowanceLeavesANoiseFreeWalkAsItWas) {
  for (double fps : {24.0, 30.0, 60.0, 120.0}) {
    const int frames = int(5 * fps);
    std::vector<ContactInterval> truth;
    const Track track = walking_foot(fps, frames, &truth);
    const auto exact = detect(track, frames, fps), allowed = detect(track, frames, fps, 2.0);
    ASSERT_EQ(exact.size(), allowed.size()) << fps << " fps";
    for (std::size_t k = 0; k < exact.size(); ++k) {
      EXPECT_EQ(exact[k].begin, allowed[k].begin) << fps << " fps";
      EXPECT_EQ(exact[k].end, allowed[k].end) << fps << " fps";
    }
  }
}

// With eval's noise (3 cm per axis) and the lock's allowance, a foot gliding just above the floor
// at swing speed (1 body height per second) is never planted, at 120 and 30 fps (its first and
// last 0.1 s aside: the mirrored smoothing holds a clip's end frames still, noise or not).
// Limit: at 30 fps, where this noise reads as 0.2 body heights per second, a glide at 0.6 gets
// contacts of 2-3 frames (docs/feet.md, "Contacts").
TEST(FootContacts, TheNoiseAllowancePlantsNoFootAtSwingSpeed) {
  for (double fps : {30.0, 120.0}) {
    const int frames = int(4 * fps);
    Track track(std::size_t(frames) * 3);
    for (int t = 0; t < frames; ++t) {
      track[std::size_t(t) * 3] = float(170.0 * t / fps);
      track[std::size_t(t) * 3 + 1] = 8.0f;
    }
    const int start = int(std::lround(0.1 * fps));
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      Track noisy = track;
      std::mt19937_64 rng(seed);
      std::normal_distribution<float> noise(0.0f, 3.0f);
      for (float& v : noisy) v += noise(rng);
      for (const ContactInterval& c : detect(noisy, frames, fps, 2.0))
        EXPECT_TRUE(c.end <= start || c.begin >= frames - start)
            << fps << " fps, seed " << seed << ": [" << c.begin << ", " << c.end << ")";
    }
  }
}

// Clips shorter than the window that joins broken contacts (a 7-frame cut at 120 fps): a foot
// resting on the floor and lifting before the end gives one contact or none, and no crash (the
// join once looked at the previous contact when there was none).
TEST(FootContacts, ClipsShorterThanTheJoinWindowAreSafe) {
  for (int frames = 3; frames <= 12; ++frames) {
    Track track(std::size_t(frames) * 3);
    for (int t = 0; t < frames; ++t) track[std::size_t(t) * 3 + 1] = t < frames - 1 ? 0.0f : 40.0f;
    const auto found = detect(track, frames, 120);
    EXPECT_LE(found.size(), 1u) << frames << " frames";
    for (const ContactInterval& c : found) {
      EXPECT_GE(c.begin, 0);
      EXPECT_LE(c.end, frames);
    }
  }
}

TEST(FootContacts, AFootThatNeverLandsHasNoContact) {
  // Moving steadily at 1 m/s, never still.
  const int frames = 240;
  Track track(std::size_t(frames) * 3);
  for (int t = 0; t < frames; ++t) {
    track[std::size_t(t) * 3] = float(100.0 * t / 120.0);
    track[std::size_t(t) * 3 + 1] = 8.0f;
  }
  EXPECT_TRUE(detect(track, frames, 120).empty());
}

TEST(FootContacts, RejectsBadParameters) {
  std::vector<std::vector<ContactInterval>> contacts;
  FootContactJob job;
  job.frame_time = 0;
  job.body_height = 170;
  job.contacts = &contacts;
  EXPECT_NE(job.validate().message().find("frame_time"), std::string::npos);
  job.frame_time = 1.0 / 120;
  job.body_height = -1;
  EXPECT_NE(job.validate().message().find("body_height"), std::string::npos);
  job.body_height = 170;
  job.params.noise_allowance = -1;
  EXPECT_NE(job.validate().message().find("noise_allowance"), std::string::npos);
}

TEST(FootContacts, FindsFeetByNameOrAsTheLowestLeaves) {
  // CMU-like leg: Hips -> LeftUpLeg -> LeftLeg -> LeftFoot -> LeftToeBase, and the right side.
  const std::vector<std::string> names = {"Hips",     "LeftUpLeg",   "LeftLeg",
                                          "LeftFoot", "LeftToeBase", "RightUpLeg",
                                          "RightLeg", "RightFoot",   "RightToeBase"};
  const std::vector<int> parents = {-1, 0, 1, 2, 3, 0, 5, 6, 7};
  const std::vector<Vec3> offsets = {{0, 0, 0},  {1, 0, 0},  {0, -4, 0}, {0, -4, 0}, {0, -1, 1},
                                     {-1, 0, 0}, {0, -4, 0}, {0, -4, 0}, {0, -1, 1}};
  const auto feet = find_feet(names, parents, offsets);
  ASSERT_EQ(feet.size(), 2u);
  EXPECT_EQ(feet[0].side, 'L');
  EXPECT_EQ(feet[0].ankle, 3);
  EXPECT_EQ(feet[0].knee, 2);
  EXPECT_EQ(feet[0].hip, 1);
  EXPECT_EQ(feet[0].toe, 4);
  EXPECT_EQ(feet[1].ankle, 7);
  const std::vector<std::string> anonymous(names.size(), "j");
  const auto leaves = find_feet(anonymous, parents, offsets);
  ASSERT_EQ(leaves.size(), 2u);
  EXPECT_TRUE((leaves[0].ankle == 4 && leaves[1].ankle == 8) ||
              (leaves[0].ankle == 8 && leaves[1].ankle == 4));
  const std::vector<std::pair<int, Vec3>> sites = {{4, {0, -0.5, 0}}};
  EXPECT_DOUBLE_EQ(rest_height(parents, offsets, sites), 9.5);
}

TEST(FootContacts, LegsNeverShareAJoint) {
  // A tree without names whose two lowest leaves are siblings (as in mocap-library-bench's
  // synthetic skeleton): as two legs they would share their knee and hip, and the foot lock would
  // refuse the clip. Root 0; hips 1, 2; knees 3 (of 1), 4 (of 2); ankles 5, 6 (of 3), 7 (of 4).
  const std::vector<int> parents = {-1, 0, 0, 1, 2, 3, 3, 4};
  const std::vector<Vec3> offsets = {{0, 0, 0},  {1, -1, 0},   {-1, -1, 0},   {0, -2, 0},
                                     {0, -2, 0}, {0.3, -2, 0}, {-0.3, -2, 0}, {0, -1.5, 0}};
  const std::vector<std::string> anonymous(parents.size(), "j");
  const auto legs = find_feet(anonymous, parents, offsets);
  ASSERT_EQ(legs.size(), 2u);
  EXPECT_EQ(legs[0].ankle, 5);  // the lowest leaf (y -5; 6 ties it and shares its knee)
  EXPECT_EQ(legs[1].ankle, 7);  // the lowest leaf of the other leg (y -4.5)
  std::set<int> joints;
  for (const FootChain& leg : legs)
    for (int j : {leg.hip, leg.knee, leg.ankle}) {
      if (j >= 0) {
        EXPECT_TRUE(joints.insert(j).second) << "joint " << j << " in two legs";
      }
    }
  // Named feet on one chain (LeftFoot and RightFoot siblings under one knee): one leg, not two.
  const std::vector<std::string> named = {"Hips", "Leg", "Knee", "RightFoot", "LeftFoot"};
  const std::vector<int> chain = {-1, 0, 1, 2, 2};
  const std::vector<Vec3> down(chain.size(), Vec3{0, -1, 0});
  EXPECT_EQ(find_feet(named, chain, down).size(), 1u);
}

std::vector<Vec3> points(const Track& t) {
  std::vector<Vec3> out;
  for (std::size_t i = 0; i + 2 < t.size(); i += 3) out.push_back(load_vec3(&t[i]));
  return out;
}

// A foot planted at x = 0 for frames [0, 40), stepping to x = 50 over [40, 50), planted there
// over [50, 100): the input found the stances in fragments and with clipped ends.
Track stepping_foot() {
  Track track;
  for (int t = 0; t < 100; ++t) {
    const double s = std::clamp((t - 40) / 10.0, 0.0, 1.0);
    const double x = 50.0 * (0.5 - 0.5 * std::cos(kPi * s));
    track.insert(track.end(), {float(x), 8.0f, 0.0f});
  }
  return track;
}

TEST(WidenContacts, GrowsOverTheFilteredStanceAndJoinsFragmentsOfOneStance) {
  const Track track = stepping_foot();
  // Noise broke the first stance into [2, 12) and [18, 33), clipped the second to [60, 80).
  const std::vector<ContactInterval> input{{2, 12}, {18, 33}, {60, 80}};
  const std::vector<ContactInterval> filtered{{0, 38}, {52, 100}};
  const auto out = widen_contacts(input, filtered, points(track), 3.4);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].begin, 0);
  EXPECT_EQ(out[0].end, 38);
  EXPECT_EQ(out[1].begin, 52);
  EXPECT_EQ(out[1].end, 100);
}

TEST(WidenContacts, StopsWhereTheFootMovesPastTheReachAndNeverJoinsTwoSteps) {
  const Track track = stepping_foot();
  // Low steps: the filtered motion holds the foot planted through the step itself.
  const std::vector<ContactInterval> input{{5, 35}, {55, 95}};
  const std::vector<ContactInterval> filtered{{0, 100}};
  const auto out = widen_contacts(input, filtered, points(track), 3.4);
  ASSERT_EQ(out.size(), 2u);
  // The foot leaves x = 0 by more than 3.4 during the step: each stance grows only to where
  // it is still within reach of its own pin.
  for (std::size_t k = 0; k < out.size(); ++k)
    for (int t = out[k].begin; t < out[k].end; ++t) {
      const double x = track[std::size_t(t) * 3];
      EXPECT_LT(std::abs(x - (k == 0 ? 0.0 : 50.0)), 3.4) << "frame " << t;
    }
  EXPECT_LE(out[0].end, 45);
  EXPECT_GE(out[1].begin, 45);
  EXPECT_EQ(out[0].begin, 0);
  EXPECT_EQ(out[1].end, 100);
}

TEST(WidenContacts, AddsNothingTheInputDidNotFindAndKeepsWhatItFound) {
  const Track track = stepping_foot();
  const std::vector<ContactInterval> filtered{{0, 38}, {52, 100}};
  // No input contact: nothing, whatever the filtered motion holds.
  EXPECT_TRUE(widen_contacts({}, filtered, points(track), 3.4).empty());
  // No filtered contact: the input as it came, even where the foot moves.
  const std::vector<ContactInterval> input{{10, 20}, {38, 45}, {70, 80}};
  const auto out = widen_contacts(input, {}, points(track), 3.4);
  ASSERT_EQ(out.size(), input.size());
  for (std::size_t k = 0; k < input.size(); ++k) {
    EXPECT_EQ(out[k].begin, input[k].begin);
    EXPECT_EQ(out[k].end, input[k].end);
  }
  // Every widened contact holds its input contact, and only frames the filtered motion plants.
  const std::vector<ContactInterval> some{{10, 20}, {70, 80}};
  const auto widened = widen_contacts(some, filtered, points(track), 3.4);
  const auto planted = contact_mask(filtered, 100), kept = contact_mask(some, 100),
             now = contact_mask(widened, 100);
  for (int t = 0; t < 100; ++t) {
    if (kept[std::size_t(t)]) {
      EXPECT_TRUE(now[std::size_t(t)]) << "frame " << t;
    }
    if (now[std::size_t(t)] && !kept[std::size_t(t)]) {
      EXPECT_TRUE(planted[std::size_t(t)]) << "frame " << t;
    }
  }
}

}  // namespace
}  // namespace mocap
