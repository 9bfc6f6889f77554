// Tests of the position metrics (spec "Metrics") and of foot contact detection on synthetic
// tracks with known answers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/foot_contacts.hpp"
#include "kernels/position_metrics.hpp"

namespace mocap {
namespace {

using Track = std::vector<float>;  // [F][N][3]

TensorView<const float, 3> view(const Track& t, int frames, int points) {
  return {t.data(), frames, points};
}

// A walking foot at `fps`: planted for 0.6 s, swinging (up to 10 cm high, 70 cm forward) for
// 0.4 s, repeated. Units: cm, body height 170.
Track walking_foot(double fps, int frames, std::vector<ContactInterval>* planted) {
  Track track(std::size_t(frames) * 3);
  const double cycle = 1.0, stance = 0.6;
  int begin = -1;
  for (int t = 0; t < frames; ++t) {
    const double time = t / fps, phase = std::fmod(time, cycle);
    const int steps = int(time / cycle);
    double x = 70.0 * steps, y = 8.0;
    const bool down = phase < stance;
    if (!down) {
      const double s = (phase - stance) / (cycle - stance);  // 0..1 through the swing
      x += 70.0 * (0.5 - 0.5 * std::cos(kPi * s));
      y += 10.0 * std::sin(kPi * s);
    }
    track[std::size_t(t) * 3] = float(x);
    track[std::size_t(t) * 3 + 1] = float(y);
    track[std::size_t(t) * 3 + 2] = 0.0f;
    if (down && begin < 0) begin = t;
    if (!down && begin >= 0) {
      planted->push_back({begin, t});
      begin = -1;
    }
  }
  if (begin >= 0) planted->push_back({begin, frames});
  return track;
}

std::vector<ContactInterval> detect(const Track& track, int frames, double fps) {
  std::vector<std::vector<ContactInterval>> contacts;
  FootContactJob job;
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

TEST(PositionMetrics, KnownErrorsJitterAndSkating) {
  const int frames = 100, points = 2;
  Track truth(std::size_t(frames) * points * 3), result;
  for (int t = 0; t < frames; ++t)
    for (int p = 0; p < points; ++p) {
      float* v = &truth[(std::size_t(t) * points + p) * 3];
      v[0] = float(2.0 * t);  // constant velocity: no acceleration
      v[1] = float(p);
      v[2] = 0;
    }
  result = truth;
  // Offset by (3, 4, 0): every error is 5; alternating +-1 in z on point 1: its second
  // difference is 4 in magnitude at every frame.
  for (int t = 0; t < frames; ++t) {
    result[(std::size_t(t) * points) * 3] += 3;
    result[(std::size_t(t) * points) * 3 + 1] += 4;
    result[(std::size_t(t) * points + 1) * 3 + 2] = (t % 2 ? 1.0f : -1.0f);
  }
  const FrameRange all{0, frames};
  PositionSums s;
  add_position_error(view(result, frames, points), view(truth, frames, points), all, s);
  add_jitter(view(truth, frames, points), all, s);
  EXPECT_NEAR(s.mpjpe(), (5.0 + 1.0) / 2, 1e-6);
  EXPECT_NEAR(s.jitter(), 0.0, 1e-6);
  PositionSums r;
  add_jitter(view(result, frames, points), all, r);
  EXPECT_NEAR(r.jitter(), std::sqrt(16.0 / 2), 1e-6);  // point 0: 0, point 1: 4
  EXPECT_EQ(r.jitter_n, 2.0 * (frames - 2));
  add_acceleration_error(view(result, frames, points), view(truth, frames, points), all, r);
  EXPECT_NEAR(r.accel_error(), std::sqrt(16.0 / 2), 1e-6);
  // Skating: point 0 moves 2 per frame; over an interval of 10 frames, 9 steps of 2.
  PositionSums k;
  add_skating(view(truth, frames, points), 0, {{10, 20}}, all, k);
  EXPECT_EQ(k.skate_n, 9);
  EXPECT_NEAR(k.skating(), 2.0, 1e-9);
  PositionSums none;
  add_skating(view(truth, frames, points), 0, {{10, 20}}, {15, 18}, none);
  EXPECT_EQ(none.skate_n, 2);  // steps 15-16 and 16-17
}

}  // namespace
TEST(PositionMetrics, ScoredFramesLeaveOutATenthOfASecondAtMostAQuarter) {
  const FrameRange at120 = scored_frames(0, 600, 1.0 / 120);
  EXPECT_EQ(at120.first, 12);
  EXPECT_EQ(at120.last, 588);
  const FrameRange at30 = scored_frames(100, 400, 1.0 / 30);
  EXPECT_EQ(at30.first, 103);
  EXPECT_EQ(at30.last, 397);
  const FrameRange short_span = scored_frames(10, 30, 1.0 / 120);  // 20 frames: a quarter is 5
  EXPECT_EQ(short_span.first, 15);
  EXPECT_EQ(short_span.last, 25);
  EXPECT_EQ(score_edge_frames(3, 1.0 / 120), 0);
}

}  // namespace mocap
