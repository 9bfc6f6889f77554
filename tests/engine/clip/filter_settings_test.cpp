// Tests of auto's per-joint cut-offs (engine/clip/filter_settings.hpp, automatic_joint_cutoffs):
// the rule's bounds and exact values, the legs that keep the clip's cut-off, and a clip with
// noisy positions where one joint moves fast.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/quaternion.hpp"
#include "engine/clip/filter_settings.hpp"
#include "engine/library/demo_library.hpp"
#include "kernels/noise_model.hpp"

namespace mocap {
namespace {

using engine::automatic_joint_cutoffs;
using engine::kAutoJointCutoffMaxFactor;
using engine::kAutoJointCutoffSnr;

TEST(AutoJointCutoffs, OnlyEverRaisedByTheCubeRootOfTheSnrAndBounded) {
  const double sigma = 0.02, noise = 6 * sigma * sigma, f = 4.0, dt = 1.0 / 30;
  // snr = (P - noise) / noise: below the noise, at it, 8x the reference (factor 2), far above.
  const std::vector<double> power = {0.5 * noise, noise, noise * (1 + 8 * kAutoJointCutoffSnr),
                                     noise * 1e6};
  const std::vector<double> out = automatic_joint_cutoffs(f, sigma, power, {}, dt);
  ASSERT_EQ(out.size(), power.size());
  EXPECT_EQ(out[0], f);
  EXPECT_EQ(out[1], f);
  EXPECT_NEAR(out[2], 2 * f, 1e-12);
  EXPECT_EQ(out[3], kAutoJointCutoffMaxFactor * f);
  // Never above 0.8 Nyquist (12 Hz at 30 fps), whatever the factor.
  EXPECT_EQ(automatic_joint_cutoffs(10.0, sigma, power, {}, dt)[3], 12.0);
  // Monotone in the power.
  double last = 0;
  for (double p = 0; p < 20 * noise; p += 0.25 * noise) {
    const double c = automatic_joint_cutoffs(f, sigma, std::vector<double>{p}, {}, dt)[0];
    EXPECT_GE(c, last);
    last = c;
  }
  // No noise level, no per-joint rule.
  EXPECT_TRUE(automatic_joint_cutoffs(f, 0.0, power, {}, dt).empty());
}

TEST(AutoJointCutoffs, TheLegsHipsAndKneesKeepTheClipsCutOff) {
  const std::vector<FootChain> feet = {{1, 2, 3, 4, 'L'}, {5, 6, 7, -1, 'R'}};
  const std::vector<std::uint8_t> legs = engine::leg_joints_of(feet, 9);
  EXPECT_EQ(legs, (std::vector<std::uint8_t>{0, 1, 1, 0, 0, 1, 1, 0, 0}));
  const std::vector<double> fast(9, 1.0);  // far above the noise on every joint
  const std::vector<double> out = automatic_joint_cutoffs(4.0, 0.02, fast, legs, 1.0 / 120);
  for (int j = 0; j < 9; ++j)
    EXPECT_EQ(out[std::size_t(j)], legs[std::size_t(j)] ? 4.0 : 12.0) << "joint " << j;
}

TEST(AutoJointCutoffs, LagCoversAThirtiethOfASecond) {
  EXPECT_EQ(engine::joint_cutoff_lag(1.0 / 120), 4);
  EXPECT_EQ(engine::joint_cutoff_lag(1.0 / 60), 2);
  EXPECT_EQ(engine::joint_cutoff_lag(1.0 / 30), 1);
  EXPECT_EQ(engine::joint_cutoff_lag(1.0 / 24), 1);
  EXPECT_EQ(engine::joint_cutoff_lag(1.0 / 10), 1);
}

TEST(AutoJointCutoffs, AFastJointOfANoisySolveGetsAHigherCutOff) {
  // The demo walk with 0.02 rad and 0.004 body heights of noise (auto's low-pass branch), its
  // left forearm shaking at 6 Hz by 0.4 rad: that joint's cut-off rises, the legs' hips and knees
  // and the slow joints keep the clip's.
  Clip clip = engine::make_demo_library()[0].clip;
  const Skeleton& sk = *clip.skeleton;
  int forearm = -1;
  for (int j = 0; j < clip.joints(); ++j)
    if (sk.joint_names[std::size_t(j)] == "LeftForeArm") forearm = j;
  ASSERT_GE(forearm, 0);
  for (int t = 0; t < clip.frames; ++t) {
    float* q = &clip.rotations[(std::size_t(t) * clip.joints() + forearm) * 4];
    store_quat(load_quat(q) * exp(Vec3{0, 0, 0.4 * std::sin(2 * kPi * 6 * t * clip.frame_time)}),
               q);
  }
  add_noise(GaussianNoise{0.02, 3}, clip.rotation_span());
  add_noise(PositionNoise{0.004 * engine::body_height(sk), 5}, clip.translation_span(),
            sk.translated_mask());
  engine::FilterSettings s;
  s.method = engine::Method::automatic;
  const engine::ResolvedSettings r = engine::resolve_for_clip(s, clip);
  ASSERT_EQ(r.settings.method, engine::Method::butterworth);
  const LinearParams& l = r.settings.param<LinearParams>();
  ASSERT_EQ(l.joint_cutoffs.size(), std::size_t(clip.joints()));
  EXPECT_GT(l.joint_cutoffs[std::size_t(forearm)], 1.5 * l.cutoff);
  const std::vector<std::uint8_t> legs =
      engine::leg_joints_of(find_feet(sk.joint_names, sk.parents, sk.offsets), clip.joints());
  int kept = 0;
  for (int j = 0; j < clip.joints(); ++j) {
    EXPECT_GE(l.joint_cutoffs[std::size_t(j)], l.cutoff);
    if (legs[std::size_t(j)]) {
      EXPECT_EQ(l.joint_cutoffs[std::size_t(j)], l.cutoff) << sk.joint_names[std::size_t(j)];
      ++kept;
    }
  }
  EXPECT_EQ(kept, 4);  // two hips, two knees
}

}  // namespace
}  // namespace mocap
