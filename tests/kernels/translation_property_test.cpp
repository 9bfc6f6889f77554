// The translation properties of ../shared/spec/filters.md, "Translations", for every method:
// a constant-velocity trajectory is reproduced exactly away from the clip's ends, whatever the
// rotations do, and a capture with no added noise gets no added jitter (RMS second difference
// at most 1.05x the input's).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "kernels/bilateral.hpp"
#include "kernels/kalman.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/nlpm.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

constexpr int kFrames = 240, kJoints = 3;

struct Case {
  std::string name;
  int reach;  // frames near each end where the boundary extension may act
  std::function<Status(const MotionIO&)> run;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  // A finite sigma_p must stay well above the root's travel per frame: at 0.5 (against 1.2 units a
  // frame) the range term reweights the window unevenly from frame to frame and the walk below
  // came out with 3.0x its jitter (docs/positions.md, "Translations").
  for (double sigma_p : {std::numeric_limits<double>::infinity(), 5.0}) {
    BilateralParams p;
    p.sigma_p = sigma_p;
    out.push_back({"bof sigma_p " + std::to_string(sigma_p), p.reach() * p.iterations,
                   [p](const MotionIO& io) {
                     return BilateralJob{p, io}.run();
                   }});
  }
  for (double ts : {1.0, 3.0, 7.5}) {
    NlpmParams p;
    p.h = 0.02;
    p.translation_sigma_t = ts;
    out.push_back({"nlpm translation_sigma_t " + std::to_string(ts), p.translation_reach(),
                   [p](const MotionIO& io) {
                     return NlpmJob{p, io, {}}.run();
                   }});
    p.range_sigma = 0.1;
    out.push_back({"nlpm range, translation_sigma_t " + std::to_string(ts), p.translation_reach(),
                   [p](const MotionIO& io) {
                     return NlpmJob{p, io, {}}.run();
                   }});
  }
  for (LinearKind kind : {LinearKind::gaussian, LinearKind::butterworth, LinearKind::moving_mean}) {
    LinearParams p;
    p.kind = kind;
    // Butterworth's forward-backward IIR reaches the whole clip in principle; its response has
    // decayed below float rounding after ~60 frames at 6 Hz and 120 fps.
    const int reach = kind == LinearKind::butterworth ? 60 : kind == LinearKind::gaussian ? 3 : 10;
    out.push_back({"linear " + std::to_string(int(kind)), reach, [p](const MotionIO& io) {
                     return LinearFilterJob{p, io}.run();
                   }});
  }
  KalmanParams k;
  k.lambda = 1e-3;
  const int kalman_reach = int(kalman_mask(k.lambda).size() / 2);
  out.push_back({"kalman", kalman_reach, [k](const MotionIO& io) {
                   return KalmanJob{k, io}.run();
                 }});
  return out;
}

struct Clip {
  std::vector<float> rotations, translations;
  std::vector<std::uint8_t> translated{1, 0, 1};
};

Clip make_clip(std::uint64_t seed, const std::function<Vec3(int)>& path) {
  std::mt19937_64 rng(seed);
  Clip c;
  c.rotations = test::random_motion(rng, kFrames, kJoints, 1.0);
  c.translations.assign(std::size_t(kFrames) * kJoints * 3, 0.0f);
  for (int t = 0; t < kFrames; ++t)
    for (int j = 0; j < kJoints; ++j) {
      const Vec3 p = j == 1 ? Vec3{1, 2, 3} : path(t);
      store_vec3(j == 2 ? 0.5 * p : p, &c.translations[(std::size_t(t) * kJoints + j) * 3]);
    }
  return c;
}

std::vector<float> run_case(const Case& c, const Clip& clip) {
  std::vector<float> rot(clip.rotations.size()), trans(clip.translations.size());
  MotionIO io;
  io.rotations = {clip.rotations.data(), kFrames, kJoints};
  io.filtered_rotations = {rot.data(), kFrames, kJoints};
  io.translations = {clip.translations.data(), kFrames, kJoints};
  io.filtered_translations = {trans.data(), kFrames, kJoints};
  io.translated_joints = clip.translated;
  const Status s = c.run(io);
  EXPECT_TRUE(s.ok()) << c.name << ": " << s.message();
  return trans;
}

// Over the frames away from the ends (spec "Metrics": the boundary extension dominates there; a
// mirrored trajectory turns back at the clip's end).
double jitter(const std::vector<float>& p, int joint, int reach) {
  double sum = 0;
  for (int t = reach + 1; t + 1 < kFrames - reach; ++t)
    for (int c = 0; c < 3; ++c) {
      auto at = [&](int f) { return double(p[(std::size_t(f) * kJoints + joint) * 3 + c]); };
      const double a = at(t + 1) - 2 * at(t) + at(t - 1);
      sum += a * a;
    }
  return std::sqrt(sum / (kFrames - 2 - 2 * reach));
}

TEST(Translations, ConstantVelocityIsReproducedAwayFromTheEndsByEveryMethod) {
  // A root walking 1.4 units a frame forward, drifting sideways and rising slowly.
  const auto line = [](int t) { return Vec3{5 + 1.4 * t, 17 + 0.01 * t, -3 - 0.2 * t}; };
  const Clip clip = make_clip(7, line);
  for (const Case& c : cases()) {
    const std::vector<float> out = run_case(c, clip);
    double worst = 0;
    for (int t = c.reach; t < kFrames - c.reach; ++t)
      for (int j : {0, 2})
        for (int k = 0; k < 3; ++k) {
          const std::size_t i = (std::size_t(t) * kJoints + j) * 3 + k;
          worst = std::max(worst, std::abs(double(out[i]) - clip.translations[i]));
        }
    // Float storage of values up to ~340: a few ulps (3e-5 each).
    EXPECT_LT(worst, 2e-4) << c.name;
    // The untranslated joint is copied.
    for (int t = 0; t < kFrames; ++t)
      EXPECT_EQ(out[(std::size_t(t) * kJoints + 1) * 3], 1.0f) << c.name;
  }
}

TEST(Translations, ACaptureWithNoAddedNoiseGetsNoAddedJitter) {
  // A walking root: forward at 1.2 units/frame with a vertical bob and a sideways sway at the
  // step frequencies, plus the sub-millimetre jitter a real capture carries.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> tiny(0.0, 0.003);
  std::vector<Vec3> jitter_of_capture(kFrames);
  for (Vec3& v : jitter_of_capture) v = {tiny(rng), tiny(rng), tiny(rng)};
  const auto walk = [&](int t) {
    const double w = 2 * kPi * t / 60.0;
    return Vec3{1.2 * t, 17 + 0.4 * std::sin(2 * w), 0.6 * std::sin(w)} +
           jitter_of_capture[std::size_t(t)];
  };
  for (std::uint64_t seed : {1, 2, 3}) {
    const Clip clip = make_clip(seed, walk);
    for (const Case& c : cases()) {
      const std::vector<float> out = run_case(c, clip);
      for (int j : {0, 2})
        EXPECT_LE(jitter(out, j, c.reach), 1.05 * jitter(clip.translations, j, c.reach))
            << c.name << " joint " << j << " seed " << seed;
    }
  }
}

}  // namespace
}  // namespace mocap
