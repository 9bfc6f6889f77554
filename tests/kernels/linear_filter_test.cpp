// Property tests of the linear filter job (spec "Lee-Shin construction" and "Translations"):
// coordinate and time invariance, denoising, boundary modes on short clips, slices, translations
// and parameter validation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "kernels/linear_filter.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

// A clip's buffers and the MotionIO that borrows them.
struct Clip {
  int frames = 0, joints = 0;
  double frame_time = 1.0 / 120.0;
  std::vector<float> rotations, filtered, translations, filtered_translations;
  std::vector<std::uint8_t> translated;

  Clip(std::vector<float> r, int f, int j)
      : frames(f), joints(j), rotations(std::move(r)), filtered(rotations.size(), 0.0f) {}
  void add_translations(std::vector<float> p, std::vector<std::uint8_t> which) {
    translations = std::move(p);
    filtered_translations.assign(translations.size(), 0.0f);
    translated = std::move(which);
  }
  MotionIO io() {
    MotionIO io;
    io.frame_time = frame_time;
    io.rotations = {rotations.data(), frames, joints};
    io.filtered_rotations = {filtered.data(), frames, joints};
    if (!translations.empty()) {
      io.translations = {translations.data(), frames, joints};
      io.filtered_translations = {filtered_translations.data(), frames, joints};
      io.translated_joints = translated;
    }
    return io;
  }
  RotationView input() const { return {rotations.data(), frames, joints}; }
  RotationView output() const { return {filtered.data(), frames, joints}; }
};

Quat sample(const std::vector<float>& tensor, int joints, int t, int j) {
  return load_quat(tensor.data() + (std::size_t(t) * joints + j) * 4);
}

// Spec "Noise models", gaussian: q := q Exp(n), n ~ N(0, sigma^2 I_3).
std::vector<float> with_gaussian_noise(std::vector<float> clean, int frames, int joints,
                                       double sigma, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, sigma);
  for (std::size_t i = 0; i < clean.size(); i += 4)
    store_quat(load_quat(&clean[i]) * exp(Vec3{n(rng), n(rng), n(rng)}), &clean[i]);
  make_hemisphere_continuous({clean.data(), frames, joints});
  return clean;
}

struct Case {
  const char* name;
  LinearParams params;
};

std::vector<Case> all_kinds() {
  LinearParams gaussian;
  LinearParams wide;
  wide.sigma_t = 2.5;
  LinearParams butterworth;
  butterworth.kind = LinearKind::butterworth;
  LinearParams butterworth4 = butterworth;
  butterworth4.order = 4;
  butterworth4.cutoff = 3.0;
  butterworth4.boundary = Boundary::extrapolate;
  LinearParams mean;
  mean.kind = LinearKind::moving_mean;
  LinearParams mean_hold = mean;
  mean_hold.passes = 2;
  mean_hold.boundary = Boundary::hold;
  return {{"gaussian", gaussian},       {"gaussian sigma 2.5", wide},
          {"butterworth", butterworth}, {"butterworth n4 3 Hz extrapolate", butterworth4},
          {"moving-mean", mean},        {"moving-mean 2 passes hold", mean_hold}};
}

// The properties below hold for both implementations (the SIMD path up to float rounding).
constexpr Implementation kImplementations[] = {Implementation::fast, Implementation::reference};

Status run_linear(const LinearParams& params, Clip& clip,
                  Implementation implementation = Implementation::fast) {
  LinearFilterJob job{params, clip.io(), implementation};
  return job.run();
}

TEST(LinearFilter, ParsesKinds) {
  EXPECT_EQ(parse_linear_kind("gaussian"), LinearKind::gaussian);
  EXPECT_EQ(parse_linear_kind("butterworth"), LinearKind::butterworth);
  EXPECT_EQ(parse_linear_kind("moving-mean"), LinearKind::moving_mean);
  EXPECT_EQ(parse_linear_kind("moving_mean"), std::nullopt);
  for (LinearKind kind : {LinearKind::gaussian, LinearKind::butterworth, LinearKind::moving_mean})
    EXPECT_EQ(parse_linear_kind(to_string(kind)), kind);
}

TEST(LinearFilter, CoordinateInvariance) {
  // f(a q b) = a f(q) b for constant a, b.
  std::mt19937_64 rng(21);
  const int frames = 150, joints = 3;
  const std::vector<float> motion = test::random_motion(rng, frames, joints, 1.5);
  const Quat a = test::random_rotation(rng), b = test::random_rotation(rng);
  std::vector<float> moved(motion.size());
  for (std::size_t i = 0; i < motion.size(); i += 4)
    store_quat(a * load_quat(&motion[i]) * b, &moved[i]);
  for (Implementation impl : kImplementations)
    for (const Case& c : all_kinds()) {
      Clip plain(motion, frames, joints), transformed(moved, frames, joints);
      ASSERT_TRUE(run_linear(c.params, plain, impl).ok());
      ASSERT_TRUE(run_linear(c.params, transformed, impl).ok());
      double worst = 0;
      for (int t = 0; t < frames; ++t)
        for (int j = 0; j < joints; ++j)
          worst = std::max(worst, geodesic(a * sample(plain.filtered, joints, t, j) * b,
                                           sample(transformed.filtered, joints, t, j)));
      EXPECT_LT(worst, 1e-6) << c.name << " " << to_string(impl);
    }
}

TEST(LinearFilter, TimeInvariance) {
  // Shifting the input by s frames shifts the output, away from the ends.
  std::mt19937_64 rng(22);
  const int frames = 600, joints = 2, shift = 7;
  const std::vector<float> motion = with_gaussian_noise(
      test::random_motion(rng, frames + shift, joints), frames + shift, joints, 0.02, rng);
  const std::vector<float> later(motion.begin() + std::size_t(shift) * joints * 4, motion.end());
  for (Implementation impl : kImplementations)
    for (const Case& c : all_kinds()) {
      Clip whole(motion, frames + shift, joints), shifted(later, frames, joints);
      ASSERT_TRUE(run_linear(c.params, whole, impl).ok());
      ASSERT_TRUE(run_linear(c.params, shifted, impl).ok());
      const int k = int(linear_mask(c.params, whole.frame_time).mask.size() / 2);
      const int margin = k * linear_passes(c.params);
      ASSERT_LT(2 * margin, frames) << c.name;
      double worst = 0;
      for (int t = margin; t < frames - margin; ++t)
        for (int j = 0; j < joints; ++j)
          worst = std::max(worst, geodesic(sample(whole.filtered, joints, t + shift, j),
                                           sample(shifted.filtered, joints, t, j)));
      EXPECT_LT(worst, 1e-9) << c.name << " " << to_string(impl);
    }
}

TEST(LinearFilter, LowersTheErrorOfNoisySmoothMotion) {
  std::mt19937_64 rng(23);
  const int frames = 400, joints = 4;
  const std::vector<float> truth = test::random_motion(rng, frames, joints);
  const std::vector<float> noisy = with_gaussian_noise(truth, frames, joints, 0.03, rng);
  const RotationView truth_view{truth.data(), frames, joints};
  const double before = test::rotation_errors({noisy.data(), frames, joints}, truth_view).rms;
  for (const Case& c : all_kinds()) {
    Clip clip(noisy, frames, joints);
    ASSERT_TRUE(run_linear(c.params, clip).ok());
    const double after = test::rotation_errors(clip.output(), truth_view).rms;
    EXPECT_LT(after, 0.75 * before) << c.name << ": " << before << " -> " << after;
  }
}

TEST(LinearFilter, OneFrameClipIsCopied) {
  std::mt19937_64 rng(24);
  const std::vector<float> one = test::random_motion(rng, 1, 3);
  for (const Case& c : all_kinds()) {
    Clip clip(one, 1, 3);
    clip.add_translations({1.5f, -2, 3, 4, 5, 6, 7, 8, 9}, {1, 0, 1});
    ASSERT_TRUE(run_linear(c.params, clip).ok()) << c.name;
    EXPECT_EQ(clip.filtered, clip.rotations) << c.name;
    EXPECT_EQ(clip.filtered_translations, clip.translations) << c.name;
  }
}

TEST(LinearFilter, ReachLongerThanTheClipInEveryBoundaryMode) {
  // F = 3, k = 10: the job returns what the curve filter (checked against the scalar
  // correlation in lee_shin_test) gives, unit and finite, in every mode.
  std::mt19937_64 rng(25);
  const int frames = 3, joints = 2;
  const std::vector<float> motion = test::random_motion(rng, frames, joints, 2.0);
  for (Boundary boundary : {Boundary::mirror, Boundary::hold, Boundary::extrapolate}) {
    LinearParams params;
    params.sigma_t = 4;
    params.window = 10;
    params.boundary = boundary;
    Clip clip(motion, frames, joints);
    ASSERT_TRUE(run_linear(params, clip).ok()) << to_string(boundary);
    const std::vector<double> mask = gaussian_mask(4, 10);
    CurveScratch scratch;
    for (int j = 0; j < joints; ++j) {
      std::vector<Quat> curve(frames), out(frames);
      for (int t = 0; t < frames; ++t) curve[t] = sample(motion, joints, t, j);
      linear_filter_rotations(curve, mask, 1, boundary, out, 0, frames, scratch);
      double change = 0;
      for (int t = 0; t < frames; ++t) {
        const Quat q = sample(clip.filtered, joints, t, j);
        EXPECT_NEAR(std::sqrt(dot(q, q)), 1.0, 1e-6);
        EXPECT_LT(geodesic(q, out[t]), 1e-6) << to_string(boundary);
        change = std::max(change, geodesic(q, curve[t]));
      }
      // A reach of 10 must visibly smooth a 3-frame clip of a moving joint (extrapolate keeps a
      // nearly constant-velocity clip nearly as it is, which is right).
      if (boundary != Boundary::extrapolate) {
        EXPECT_GT(change, 1e-2) << to_string(boundary);
      }
    }
  }
}

TEST(LinearFilter, SlicesGiveBitIdenticalOutput) {
  std::mt19937_64 rng(26);
  const int frames = 90, joints = 5;
  const std::vector<float> motion =
      with_gaussian_noise(test::random_motion(rng, frames, joints), frames, joints, 0.03, rng);
  std::vector<float> positions(std::size_t(frames) * joints * 3);
  std::normal_distribution<double> n(0.0, 5.0);
  for (float& p : positions) p = float(n(rng));
  const std::vector<std::uint8_t> which{1, 0, 1, 1, 0};
  for (Implementation impl : kImplementations)
    for (const Case& c : all_kinds()) {
      Clip full(motion, frames, joints);
      full.add_translations(positions, which);
      ASSERT_TRUE(run_linear(c.params, full, impl).ok());
      Clip sliced(motion, frames, joints);
      sliced.add_translations(positions, which);
      const float sentinel = 42.0f;
      std::fill(sliced.filtered.begin(), sliced.filtered.end(), sentinel);
      std::fill(sliced.filtered_translations.begin(), sliced.filtered_translations.end(), sentinel);
      // Joint blocks {0}, {1, 2}, {3, 4} over all frames, except frames [40, 50) of block {3, 4}.
      const int blocks[][4] = {{0, 1, 0, -1}, {1, 3, 0, -1}, {3, 5, 0, 40}, {3, 5, 50, -1}};
      for (const auto& s : blocks) {
        MotionIO io = sliced.io();
        io.joint_begin = s[0];
        io.joint_end = s[1];
        io.frame_begin = s[2];
        io.frame_end = s[3];
        ASSERT_TRUE((LinearFilterJob{c.params, io, impl}.run().ok()));
      }
      for (int t = 0; t < frames; ++t)
        for (int j = 0; j < joints; ++j) {
          const bool hole = j >= 3 && t >= 40 && t < 50;
          const float* r = &sliced.filtered[(std::size_t(t) * joints + j) * 4];
          const float* p = &sliced.filtered_translations[(std::size_t(t) * joints + j) * 3];
          if (hole) {
            EXPECT_EQ(r[0], sentinel) << c.name << ": wrote outside its slice";
            EXPECT_EQ(p[0], sentinel) << c.name << ": wrote outside its slice";
          } else {
            EXPECT_EQ(std::memcmp(r, &full.filtered[(std::size_t(t) * joints + j) * 4], 16), 0)
                << c.name << " t " << t << " j " << j;
            EXPECT_EQ(
                std::memcmp(p, &full.filtered_translations[(std::size_t(t) * joints + j) * 3], 12),
                0)
                << c.name << " t " << t << " j " << j;
          }
        }
    }
}

TEST(LinearFilter, TranslationsGetTheSameMaskAndUntranslatedJointsAreCopied) {
  std::mt19937_64 rng(27);
  const int frames = 60, joints = 2;
  std::vector<float> positions(std::size_t(frames) * joints * 3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < joints; ++j)
      for (int c = 0; c < 3; ++c)
        positions[(std::size_t(t) * joints + j) * 3 + c] =
            float(10 * std::sin(0.1 * t + c + j) + 0.5 * n(rng) + 3 * c);
  auto position = [&](long t, int c) {  // joint 0, mirror extension written out here
    const long last = frames - 1;
    long m = t % (2 * last);
    if (m < 0) m += 2 * last;
    if (m > last) m = 2 * last - m;
    return double(positions[(std::size_t(m) * joints) * 3 + c]);
  };
  for (const Case& c : all_kinds()) {
    if (c.params.boundary != Boundary::mirror) continue;
    Clip clip(test::random_motion(rng, frames, joints), frames, joints);
    clip.add_translations(positions, {1, 0});
    ASSERT_TRUE(run_linear(c.params, clip).ok());
    const std::vector<double> mask = linear_mask(c.params, clip.frame_time).mask;
    const int k = int(mask.size() / 2);
    std::vector<std::vector<double>> expected(3, std::vector<double>(frames));
    for (int ch = 0; ch < 3; ++ch) {
      std::vector<double> current(frames);
      for (int t = 0; t < frames; ++t) current[t] = position(t, ch);
      for (int pass = 0; pass < linear_passes(c.params); ++pass) {
        std::vector<double> next(frames);
        for (int t = 0; t < frames; ++t) {
          double sum = 0;
          for (int r = -k; r <= k; ++r) {
            long m = (t + r) % (2 * (frames - 1));
            if (m < 0) m += 2 * (frames - 1);
            if (m > frames - 1) m = 2 * (frames - 1) - m;
            sum += mask[r + k] * current[m];
          }
          next[t] = sum;
        }
        current = next;
      }
      expected[ch] = current;
    }
    for (int t = 0; t < frames; ++t) {
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR(clip.filtered_translations[(std::size_t(t) * joints) * 3 + ch], expected[ch][t],
                    1e-5)
            << c.name;
        EXPECT_EQ(clip.filtered_translations[(std::size_t(t) * joints + 1) * 3 + ch],
                  positions[(std::size_t(t) * joints + 1) * 3 + ch]);
      }
    }
  }
}

TEST(LinearFilter, InvalidParametersAreExplained) {
  LinearParams p;
  p.sigma_t = -1;
  EXPECT_EQ(p.validate().message(), "sigma_t must be > 0, got -1");
  p = {};
  p.window = -2;
  EXPECT_EQ(p.validate().message(), "window must be >= 0, got -2");
  p = {};
  p.kind = LinearKind::moving_mean;
  p.passes = 0;
  EXPECT_EQ(p.validate().message(), "passes must be >= 1, got 0");
  p = {};
  p.kind = LinearKind::butterworth;
  p.order = 9;
  EXPECT_EQ(p.validate().message(), "butterworth order must be in [1, 8], got 9");
  p.order = 2;
  p.cutoff = -3;
  EXPECT_EQ(p.validate().message(), "cutoff must be > 0 Hz, got -3");
  EXPECT_TRUE(LinearParams{}.validate().ok());

  // The cut-off is checked against the clip's own frame rate, by the job; nothing is written.
  std::mt19937_64 rng(28);
  Clip clip(test::random_motion(rng, 20, 1), 20, 1);
  p.cutoff = 58;
  LinearFilterJob job{p, clip.io()};
  const std::string expected =
      "cutoff 58 Hz is too close to the Nyquist frequency of this clip's 120.00 fps (must be "
      "below 57 Hz)";
  EXPECT_EQ(job.validate().message(), expected);
  EXPECT_EQ(job.run().message(), expected);
  EXPECT_EQ(clip.filtered, std::vector<float>(clip.filtered.size(), 0.0f));
  job.params.cutoff = 56;
  EXPECT_TRUE(job.validate().ok());
  // Invalid IO is reported too.
  job.io.joint_end = 2;
  EXPECT_FALSE(job.run().ok());
  EXPECT_NE(job.run().message().find("joint slice"), std::string::npos) << job.run().message();
}

TEST(LinearFilter, PerJointCutOffsFilterEachJointAsItsOwnCutOffWould) {
  // Joints are independent: with joint_cutoffs each joint comes out as the whole clip run at its
  // cut-off, bit for bit, in both implementations; the position channels take `cutoff`; equal
  // per-joint cut-offs are the plain run.
  std::mt19937_64 rng(29);
  const int frames = 90, joints = 4;
  const std::vector<float> motion =
      with_gaussian_noise(test::random_motion(rng, frames, joints), frames, joints, 0.03, rng);
  std::vector<float> positions(std::size_t(frames) * joints * 3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (float& x : positions) x = float(n(rng));
  const std::vector<std::uint8_t> translated = {1, 0, 1, 0};
  LinearParams base;
  base.kind = LinearKind::butterworth;
  base.order = 4;
  base.cutoff = 5;
  const std::vector<double> cutoffs = {5, 9.5, 15, 5};
  const auto run = [&](const LinearParams& p, Implementation implementation) {
    Clip clip(motion, frames, joints);
    clip.add_translations(positions, translated);
    EXPECT_TRUE(run_linear(p, clip, implementation).ok());
    return clip;
  };
  for (Implementation implementation : {Implementation::fast, Implementation::reference}) {
    LinearParams per_joint = base;
    per_joint.joint_cutoffs = cutoffs;
    const Clip mixed = run(per_joint, implementation);
    for (int j = 0; j < joints; ++j) {
      LinearParams whole = base;
      whole.cutoff = cutoffs[std::size_t(j)];
      const Clip alone = run(whole, implementation);
      for (int t = 0; t < frames; ++t)
        ASSERT_EQ(std::memcmp(&mixed.filtered[(std::size_t(t) * joints + j) * 4],
                              &alone.filtered[(std::size_t(t) * joints + j) * 4], 16),
                  0)
            << "joint " << j << " frame " << t;
    }
    const Clip plain = run(base, implementation);
    EXPECT_EQ(mixed.filtered_translations, plain.filtered_translations);
    EXPECT_NE(mixed.filtered, plain.filtered);  // not vacuous: the cut-offs mattered
    per_joint.joint_cutoffs.assign(joints, base.cutoff);
    EXPECT_EQ(run(per_joint, implementation).filtered, plain.filtered);
  }
}

TEST(LinearFilter, InvalidPerJointCutOffsAreExplained) {
  LinearParams p;
  p.kind = LinearKind::butterworth;
  p.joint_cutoffs = {4, 0};
  EXPECT_EQ(p.validate().message(), "joint_cutoffs[1] must be > 0 Hz, got 0");
  p.kind = LinearKind::gaussian;
  p.joint_cutoffs = {4, 4};
  EXPECT_EQ(p.validate().message(), "joint_cutoffs are a butterworth parameter");
  // Against the clip, by the job: one per joint, each below Nyquist; nothing written.
  std::mt19937_64 rng(30);
  Clip clip(test::random_motion(rng, 20, 2), 20, 2);
  p.kind = LinearKind::butterworth;
  p.joint_cutoffs = {4, 4, 4};
  LinearFilterJob job{p, clip.io()};
  EXPECT_EQ(job.run().message(), "joint_cutoffs has 3 entries for 2 joints");
  job.params.joint_cutoffs = {4, 58};
  EXPECT_NE(job.run().message().find("cutoff 58 Hz is too close to the Nyquist"), std::string::npos)
      << job.run().message();
  EXPECT_EQ(clip.filtered, std::vector<float>(clip.filtered.size(), 0.0f));
  job.params.joint_cutoffs = {4, 56};
  EXPECT_TRUE(job.run().ok());
}

}  // namespace
}  // namespace mocap
