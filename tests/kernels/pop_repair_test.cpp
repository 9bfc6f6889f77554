// Tests of the pop repair (kernels/pop_repair.hpp): nothing flagged on fast smooth motion or on
// clean real clips (also decimated to 30 fps), the spec's impulse noise ("Noise models") found
// and repaired on real clips, runs of 1-3 pops, detect-only mode, the skip mask, slices, short
// clips and parameter validation; the fast path of the residuals against the reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "io/bvh_reader.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/metrics.hpp"
#include "kernels/noise_model.hpp"
#include "kernels/pop_repair.hpp"
#include "kernels/pop_screen.hpp"
#include "kernels/simd/pop_residuals_simd.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

using test::Motion;

// A smooth motion whose joints turn at up to `max_speed` rad per frame: about a random axis by
// A sin(w t + phi) (peak speed A w drawn in [max_speed / 2, max_speed], w in [0.1, 0.3] rad per
// frame, so up to 0.135 rad/frame^2 of angular acceleration) or, for every third joint, a steady
// spin at max_speed, each times a slow wobble of 0.3 rad about a second axis.
Motion fast_smooth_motion(std::uint64_t seed, int frames, int joints, double max_speed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Motion m{frames, joints, std::vector<float>(std::size_t(frames) * joints * 4)};
  for (int j = 0; j < joints; ++j) {
    const Quat base = test::random_rotation(rng);
    const Vec3 axis = log(test::random_rotation(rng)),
               wobble_axis = log(test::random_rotation(rng));
    const Vec3 n1 = (1 / norm(axis)) * axis, n2 = (1 / norm(wobble_axis)) * wobble_axis;
    const double speed = max_speed * (0.5 + 0.5 * u(rng)), w = 0.1 + 0.2 * u(rng);
    const double phase = 6.3 * u(rng), wobble_phase = 6.3 * u(rng);
    for (int t = 0; t < frames; ++t) {
      const double theta = j % 3 == 2 ? max_speed * t : speed / w * std::sin(w * t + phase);
      const Quat q = base * exp(theta * n1) * exp((0.3 * std::sin(0.05 * t + wobble_phase)) * n2);
      store_quat(q, m.span().at(t, j));
    }
  }
  make_hemisphere_continuous(m.span());
  return m;
}

// Frames [1, 1 + frames) of a real clip, every `stride`-th: frame 0 of the CMU conversions is a
// synthetic T-pose (../shared/data/bvh/README.md), a jump no capture makes.
Motion real_motion(const std::filesystem::path& path, int frames, int stride = 1) {
  const io::BvhReadResult read = io::read_bvh(path);
  EXPECT_TRUE(read.clip) << path;
  if (!read.clip) return {};
  const Clip& clip = *read.clip;
  Motion m = test::every_nth_frame(clip.rotation_view(), 1, stride,
                                   std::min(frames, (clip.frames - 1) / stride));
  make_hemisphere_continuous(m.span());
  return m;
}

struct Result {
  Motion out;
  std::vector<int> per_joint;
  std::vector<std::uint8_t> flagged;
  Status status;
};

Result run_job(const Motion& in, const PopRepairParams& params = {},
               std::span<const std::uint8_t> skip = {}) {
  Result r{in,
           std::vector<int>(std::size_t(in.joints), -1),
           std::vector<std::uint8_t>(std::size_t(in.frames) * in.joints, 7),
           {}};
  std::fill(r.out.rotations.begin(), r.out.rotations.end(), 0.0f);
  PopRepairJob job;
  job.params = params;
  job.io.rotations = in.view();
  job.io.filtered_rotations = r.out.span();
  job.skip_joints = skip;
  job.flagged_per_joint = r.per_joint;
  job.flagged_samples = r.flagged;
  r.status = job.run();
  return r;
}

int total(const std::vector<int>& counts) {
  int sum = 0;
  for (int c : counts) sum += c;
  return sum;
}

// The joints to leave alone: those joint_quality does not call moving.
std::vector<std::uint8_t> garbage_mask(RotationView rotations) {
  std::vector<std::uint8_t> mask;
  for (const JointQuality& q : classify_joints(rotations))
    mask.push_back(is_garbage(q.joint_class) ? 1 : 0);
  return mask;
}

// Copies the joints where keep[j] != 0 into a smaller motion (for PSNR over those joints).
Motion select_joints(const Motion& m, const std::vector<std::uint8_t>& keep) {
  Motion s;
  s.frames = m.frames;
  for (std::uint8_t k : keep) s.joints += k != 0;
  for (int t = 0; t < m.frames; ++t)
    for (int j = 0; j < m.joints; ++j)
      if (keep[std::size_t(j)])
        s.rotations.insert(s.rotations.end(), m.view().at(t, j), m.view().at(t, j) + 4);
  return s;
}

TEST(PopRepair, FastSmoothMotionFlagsNothing) {
  for (double speed : {0.45, 0.2, 0.05}) {
    const Motion m = fast_smooth_motion(11, 400, 24, speed);
    double fastest = 0;
    for (int t = 0; t + 1 < m.frames; ++t)
      for (int j = 0; j < m.joints; ++j)
        fastest = std::max(fastest, geodesic(m.at(t, j), m.at(t + 1, j)));
    EXPECT_GT(fastest, 0.9 * speed);  // the motion is as fast as it claims
    const Result r = run_job(m);
    ASSERT_TRUE(r.status) << r.status.message();
    EXPECT_EQ(total(r.per_joint), 0) << "speed " << speed;
    EXPECT_EQ(r.out.rotations, m.rotations);
  }
}

TEST(PopRepair, CleanRealClipsFlagAlmostNothing) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  // Measured on 300 frames of each clip, moving joints only: at 120 fps 23 of 64025 samples
  // (0.036%), one-frame jumps of 0.2-0.5 rad in the data (toes, fingers, 05_02's left foot) or a
  // clip's last frames; at 30 fps (every 4th frame) 69 of 41256 (0.17%), mostly knees, feet and
  // hands starting or stopping within a frame or two.
  for (int stride : {1, 4}) {
    long samples = 0, flagged = 0;
    double worst_change = 0, worst_rms_change = 0;
    for (const auto& path : test::shared_bvh_files()) {
      const Motion m = real_motion(path, 300, stride);
      const std::vector<std::uint8_t> skip = garbage_mask(m.view());
      const Result r = run_job(m, {}, skip);
      ASSERT_TRUE(r.status) << r.status.message();
      for (int j = 0; j < m.joints; ++j) samples += skip[std::size_t(j)] ? 0 : m.frames;
      flagged += total(r.per_joint);
      const test::ErrorStats change = test::rotation_errors(r.out.view(), m.view());
      worst_change = std::max(worst_change, change.max);
      worst_rms_change = std::max(worst_rms_change, change.rms);
    }
    std::printf(
        "clean real clips, stride %d: %ld of %ld samples flagged (%.4f%%), worst change "
        "%.4f rad, largest RMS change of a clip %.5f rad\n",
        stride, flagged, samples, 100.0 * double(flagged) / double(samples), worst_change,
        worst_rms_change);
    EXPECT_LT(double(flagged), (stride == 1 ? 5e-4 : 3e-3) * double(samples))
        << "stride " << stride;
    // Measured: 0.0077 rad (120 fps) and 0.0148 rad (30 fps) on the clip changed most.
    EXPECT_LT(worst_rms_change, stride == 1 ? 0.01 : 0.02) << "stride " << stride;
  }
}

// The clean clips have glitches of their own (one-frame jumps of 0.2-0.7 rad on toes, feet and
// fingers, see CleanRealClipsFlagAlmostNothing; 05_02's left foot and toe turn by up to 0.7 rad
// per frame at 120 fps), which the repair also removes or, on the wildest joints, hides pops
// among. The error bound is asserted on the steady joints: moving joints where the repair finds
// nothing in the clean clip. PSNR and pops found are over all moving joints, and the worst error
// on the other moving joints is printed.
TEST(PopRepair, ImpulseNoiseOnRealClipsIsFoundAndRepaired) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  long pops = 0, found = 0;
  double worst_steady = 0, worst_other = 0, lowest_psnr = 1e9;
  for (const auto& path : test::shared_bvh_files()) {
    const Motion clean = real_motion(path, 300);
    Motion noisy = clean;
    add_noise(ImpulseNoise{0.01, 0.3, 1.0, 1234}, noisy.span());
    // Classified on the noisy clip, as the engine sees it.
    const std::vector<std::uint8_t> skip = garbage_mask(noisy.view());
    EXPECT_EQ(skip, garbage_mask(clean.view())) << path;
    const Result r = run_job(noisy, {}, skip), reference = run_job(clean, {}, skip);
    ASSERT_TRUE(r.status) << r.status.message();

    std::vector<std::uint8_t> moving(skip.size()), steady(skip.size());
    for (std::size_t j = 0; j < skip.size(); ++j) {
      moving[j] = !skip[j];
      steady[j] = !skip[j] && reference.per_joint[j] == 0;
    }
    double worst = 0;
    for (int t = 0; t < clean.frames; ++t)
      for (int j = 0; j < clean.joints; ++j) {
        if (skip[std::size_t(j)]) continue;
        const bool popped = geodesic(clean.at(t, j), noisy.at(t, j)) > 0.29;
        pops += popped;
        found += popped && r.flagged[std::size_t(t) * clean.joints + j];
        const double error = geodesic(clean.at(t, j), r.out.at(t, j));
        if (steady[std::size_t(j)])
          worst = std::max(worst, error);
        else
          worst_other = std::max(worst_other, error);
      }
    worst_steady = std::max(worst_steady, worst);
    const Motion c = select_joints(clean, moving), n = select_joints(noisy, moving),
                 o = select_joints(r.out, moving);
    const Motion cs = select_joints(clean, steady), os = select_joints(r.out, steady);
    const double before = psnr(n.view(), c.view()), after = psnr(o.view(), c.view());
    lowest_psnr = std::min(lowest_psnr, after);
    std::printf(
        "%s: PSNR %.1f -> %.1f dB (steady joints: %.1f dB), worst error on steady "
        "joints %.4f rad\n",
        path.filename().string().c_str(), before, after, psnr(os.view(), cs.view()), worst);
    EXPECT_GE(psnr(os.view(), cs.view()), 45.0) << path;
    EXPECT_LE(worst, 0.1) << path;
  }
  std::printf(
      "pops found: %ld of %ld (%.2f%%); worst error %.4f rad on steady joints, %.4f on "
      "the other moving joints; lowest PSNR over all moving joints %.1f dB\n",
      found, pops, 100.0 * double(found) / double(pops), worst_steady, worst_other, lowest_psnr);
  EXPECT_GT(pops, 500);  // enough pops for the rate to mean something
  EXPECT_GE(double(found), 0.99 * double(pops));
  // Measured 47.7 dB (05_02, whose left foot and toe turn by 0.4-0.7 rad per frame in the clean
  // data); the others 50.8 dB and above.
  EXPECT_GE(lowest_psnr, 45.0);
}

// Pops of 0.3-1 rad in runs of 1, 2 and 3 inside the clip, on fast motion (up to 0.2 rad per
// frame, 0.06 rad/frame^2), and also at both ends on motion at up to 0.05 rad per frame (an end
// run is predicted by extrapolation alone): every popped sample is flagged, nothing else, and
// the repair lands within the slerp's (or the hold's) own error of the truth.
TEST(PopRepair, RunsOfOneTwoAndThreePops) {
  for (const double speed : {0.05, 0.2}) {
    const bool ends = speed < 0.1;
    const Motion clean = fast_smooth_motion(5, 200, 9, speed);
    for (int run = 1; run <= 3; ++run) {
      Motion noisy = clean;
      std::vector<std::uint8_t> popped(std::size_t(clean.frames) * clean.joints, 0);
      std::mt19937_64 rng(static_cast<std::uint64_t>(run));
      std::uniform_real_distribution<double> angle(0.3, 1.0);
      for (int j = 0; j < clean.joints; ++j)
        for (int start : {0, 37 + 13 * j, clean.frames - run}) {
          if (!ends && (start == 0 || start == clean.frames - run)) continue;
          for (int t = start; t < start + run; ++t) {
            const Vec3 axis = log(test::random_rotation(rng));
            store_quat(noisy.at(t, j) * exp((angle(rng) / norm(axis)) * axis),
                       noisy.span().at(t, j));
            popped[std::size_t(t) * clean.joints + j] = 1;
          }
        }
      make_hemisphere_continuous(noisy.span());
      const Result r = run_job(noisy);
      ASSERT_TRUE(r.status) << r.status.message();
      for (int t = 0; t < clean.frames; ++t)
        for (int j = 0; j < clean.joints; ++j) {
          const std::size_t i = std::size_t(t) * clean.joints + j;
          EXPECT_EQ(r.flagged[i], popped[i])
              << "speed " << speed << " run " << run << " frame " << t << " joint " << j;
          // Slerp over a gap of run + 1 frames against a path with up to 0.3 * speed
          // rad/frame^2 of acceleration: 0.3 speed (run + 1)^2 / 8 rad; held ends: run * speed.
          const bool held = t < run || t >= clean.frames - run;
          const double bound = held ? 1.4 * run * speed : 0.3 * speed * (run + 1) * (run + 1) / 8;
          EXPECT_LT(geodesic(r.out.at(t, j), clean.at(t, j)), bound + 1e-3)
              << "speed " << speed << " run " << run << " frame " << t << " joint " << j;
        }
    }
  }
}

// PopFindJob flags what PopRepairJob repairs, in any joint slice (every flag written).
TEST(PopRepair, FindJobFlagsWhatTheRepairJobRepairs) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  Motion noisy = real_motion(test::shared_bvh_files().front(), 300);
  add_noise(ImpulseNoise{0.01, 0.3, 1.0, 9}, noisy.span());
  std::vector<std::uint8_t> skip(std::size_t(noisy.joints), 0);
  skip[3] = skip[7] = 1;
  const Result repaired = run_job(noisy, {}, skip);
  ASSERT_TRUE(repaired.status) << repaired.status.message();
  EXPECT_NE(repaired.out.rotations, noisy.rotations);
  EXPECT_GT(total(repaired.per_joint), 50);
  std::vector<std::uint8_t> flags(repaired.flagged.size(), 7);
  for (int j0 : {0, 5, 11}) {
    PopFindJob job;
    job.rotations = noisy.view();
    job.skip = skip;
    job.flags = flags;
    job.joint_begin = j0;
    job.joint_end = j0 == 0 ? 5 : j0 == 5 ? 11 : -1;
    ASSERT_TRUE(job.run());
  }
  EXPECT_EQ(flags, repaired.flagged);
  // Unflagged samples pass through bit for bit in the repair job.
  for (std::size_t i = 0; i < repaired.flagged.size(); ++i) {
    if (repaired.flagged[i]) continue;
    EXPECT_TRUE(std::equal(&noisy.rotations[4 * i], &noisy.rotations[4 * i + 4],
                           &repaired.out.rotations[4 * i]));
  }
}

TEST(PopRepair, FindJobExplainsWhatIsWrong) {
  const Motion m = fast_smooth_motion(4, 40, 3, 0.05);
  std::vector<std::uint8_t> flags(std::size_t(m.frames) * 3), short_flags(7), skip(2);
  PopFindJob job;
  job.rotations = m.view();
  job.flags = short_flags;
  EXPECT_NE(job.run().message().find("flags must have one entry per sample"), std::string::npos);
  job.flags = flags;
  job.skip = skip;
  EXPECT_NE(job.run().message().find("skip must have one entry per joint"), std::string::npos);
  job.skip = {};
  job.joint_end = 4;
  EXPECT_NE(job.run().message().find("outside the clip's 3 joints"), std::string::npos);
  job.joint_end = -1;
  // A screen made for other params: its candidates would not be the params' fits.
  PopRepairParams other;
  other.max_run = job.params.max_run + 1;
  const PopScreen foreign(other);
  job.screen_weights = &foreign;
  EXPECT_NE(job.run().message().find("screen_weights were made for"), std::string::npos);
  const PopScreen own(job.params);
  job.screen_weights = &own;
  EXPECT_TRUE(job.run().ok());
  job.params.max_run = 0;
  job.screen_weights = nullptr;
  EXPECT_FALSE(job.run());
}

TEST(PopRepair, SkippedJointsAreLeftAsTheyCame) {
  Motion noisy = fast_smooth_motion(3, 300, 6, 0.1);
  add_noise(ImpulseNoise{0.03, 0.3, 1.0, 4}, noisy.span());
  const std::vector<std::uint8_t> skip{1, 0, 0, 1, 0, 1};
  const Result r = run_job(noisy, {}, skip);
  ASSERT_TRUE(r.status) << r.status.message();
  for (int j = 0; j < noisy.joints; ++j) {
    bool same = true;
    for (int t = 0; t < noisy.frames; ++t)
      same = same &&
             std::equal(noisy.view().at(t, j), noisy.view().at(t, j) + 4, r.out.view().at(t, j));
    EXPECT_EQ(same, skip[std::size_t(j)] != 0) << "joint " << j;
    if (skip[std::size_t(j)]) {
      EXPECT_EQ(r.per_joint[std::size_t(j)], 0);
      for (int t = 0; t < noisy.frames; ++t)
        EXPECT_EQ(r.flagged[std::size_t(t) * noisy.joints + j], 0);
    } else {
      EXPECT_GT(r.per_joint[std::size_t(j)], 0);
    }
  }
}

TEST(PopRepair, TranslationsAreCopied) {
  Motion noisy = fast_smooth_motion(2, 40, 3, 0.1);
  add_noise(ImpulseNoise{0.05, 0.3, 1.0, 3}, noisy.span());
  std::vector<float> translations(std::size_t(noisy.frames) * noisy.joints * 3);
  for (std::size_t i = 0; i < translations.size(); ++i) translations[i] = float(i) * 0.37f - 5;
  std::vector<float> out_translations(translations.size(), 0.0f);
  const std::vector<std::uint8_t> translated{1, 0, 1};
  Motion out = noisy;
  PopRepairJob job;
  job.io.rotations = noisy.view();
  job.io.filtered_rotations = out.span();
  job.io.translations = {translations.data(), noisy.frames, noisy.joints};
  job.io.filtered_translations = {out_translations.data(), noisy.frames, noisy.joints};
  job.io.translated_joints = translated;
  ASSERT_TRUE(job.run());
  EXPECT_EQ(out_translations, translations);
  EXPECT_NE(out.rotations, noisy.rotations);
}

// Each output sample is bit-identical whatever slice computed it; counts cover the frame slice.
TEST(PopRepair, SlicesAgreeWithTheWholeClip) {
  Motion noisy = fast_smooth_motion(8, 120, 5, 0.2);
  add_noise(ImpulseNoise{0.03, 0.3, 1.0, 2}, noisy.span());
  const Result whole = run_job(noisy);
  Motion out = noisy;
  std::fill(out.rotations.begin(), out.rotations.end(), 0.0f);
  std::vector<std::uint8_t> flagged(whole.flagged.size(), 9);
  std::vector<int> counts(std::size_t(noisy.joints), 0);
  for (int j0 : {0, 2})
    for (int f0 : {0, 50}) {
      std::vector<int> slice_counts(std::size_t(noisy.joints), -1);
      PopRepairJob job;
      job.io.rotations = noisy.view();
      job.io.filtered_rotations = out.span();
      job.io.joint_begin = j0;
      job.io.joint_end = j0 == 0 ? 2 : -1;
      job.io.frame_begin = f0;
      job.io.frame_end = f0 == 0 ? 50 : -1;
      job.flagged_per_joint = slice_counts;
      job.flagged_samples = flagged;
      ASSERT_TRUE(job.run());
      for (int j = 0; j < noisy.joints; ++j) {
        if (j >= j0 && j < job.io.joint_stop())
          counts[std::size_t(j)] += slice_counts[std::size_t(j)];
        else
          EXPECT_EQ(slice_counts[std::size_t(j)], -1);  // outside the slice: untouched
      }
    }
  EXPECT_EQ(out.rotations, whole.out.rotations);
  EXPECT_EQ(flagged, whole.flagged);
  EXPECT_EQ(counts, whole.per_joint);
}

TEST(PopRepair, ShortClipsAreSafe) {
  const Motion m = fast_smooth_motion(4, 12, 3, 0.05);
  for (int frames = 1; frames <= 12; ++frames) {
    Motion shorter{frames, 3,
                   std::vector<float>(m.rotations.begin(), m.rotations.begin() + frames * 12)};
    store_quat(shorter.at(frames / 2, 1) * exp(Vec3{0.9, 0, 0}), shorter.span().at(frames / 2, 1));
    make_hemisphere_continuous(shorter.span());
    const Result r = run_job(shorter);
    ASSERT_TRUE(r.status) << r.status.message();
    if (frames < kPopRepairMinFrames) {
      EXPECT_EQ(r.out.rotations, shorter.rotations) << frames;
      EXPECT_EQ(total(r.per_joint), 0);
    }
    for (int t = 0; t < frames; ++t)
      for (int j = 0; j < 3; ++j) {
        const Quat q = r.out.at(t, j);
        EXPECT_NEAR(std::sqrt(dot(q, q)), 1.0, 1e-6);
      }
  }
  // From about 8 frames on the fit has enough samples to find the 0.9 rad pop, and only it.
  for (int frames = 8; frames <= 12; ++frames) {
    Motion shorter{frames, 3,
                   std::vector<float>(m.rotations.begin(), m.rotations.begin() + frames * 12)};
    store_quat(shorter.at(frames / 2, 1) * exp(Vec3{0.9, 0, 0}), shorter.span().at(frames / 2, 1));
    make_hemisphere_continuous(shorter.span());
    const Result r = run_job(shorter);
    EXPECT_EQ(r.per_joint, (std::vector<int>{0, 1, 0})) << frames;
  }
}

TEST(PopRepair, ValidateExplains) {
  const Motion m = fast_smooth_motion(4, 20, 3, 0.2);
  auto message = [&](PopRepairParams p) { return run_job(m, p).status.message(); };
  EXPECT_EQ(message({0, 2, 8, 0.2}), "max_run must be in [1, 8], got 0");
  EXPECT_EQ(message({3, 2, 8, 0.2, -1}), "local_threshold must be finite and >= 0, got -1");
  EXPECT_EQ(message({9, 2, 8, 0.2}), "max_run must be in [1, 8], got 9");
  EXPECT_EQ(message({3, 1, 8, 0.2}),
            "reach must be >= 2 (a quadratic needs clean neighbours), got 1");
  EXPECT_EQ(message({3, 2, -1, 0.2}), "threshold must be finite and > 0, got -1");
  EXPECT_EQ(message({3, 2, 8, 0}), "floor must be finite and > 0 rad, got 0");
  Motion out = m;
  std::vector<std::uint8_t> skip(2), samples(5);
  std::vector<int> counts(4);
  PopRepairJob job;
  job.io.rotations = m.view();
  job.io.filtered_rotations = out.span();
  job.skip_joints = skip;
  EXPECT_EQ(job.run().message(), "skip_joints must have one entry per joint (3), got 2");
  job.skip_joints = {};
  job.flagged_per_joint = counts;
  EXPECT_EQ(job.run().message(), "flagged_per_joint must have one entry per joint (3), got 4");
  job.flagged_per_joint = {};
  job.flagged_samples = samples;
  EXPECT_EQ(job.run().message(), "flagged_samples must have one entry per sample (60), got 5");
  job.flagged_samples = {};
  job.io.filtered_rotations = {out.rotations.data(), 19, 3};
  EXPECT_EQ(job.run().message(), "filtered_rotations must have the input's shape");
}

// The largest differences between the fast path and the reference over several curves.
struct PathDifferences {
  double residual = 0, spread = 0, fit_error_squared = 0;
  long samples = 0, different_bits = 0, different_flags = 0;
};

// Runs both implementations of pop_residuals and find_pops on joint j of m.
void compare_paths(const Motion& m, int j, PathDifferences& diff,
                   const PopRepairParams& params = {}) {
  const std::size_t frames = std::size_t(m.frames);
  std::vector<Quat> curve(frames);
  for (int t = 0; t < m.frames; ++t) curve[std::size_t(t)] = m.at(t, j);
  std::vector<double> residuals[2], spreads[2], fit_errors[2];
  std::vector<std::uint8_t> flags[2];
  for (int k = 0; k < 2; ++k) {
    residuals[k].resize(frames);
    spreads[k].resize(frames);
    fit_errors[k].resize(frames);
    flags[k].resize(frames);
  }
  pop_residuals(curve, params, residuals[0], spreads[0], fit_errors[0]);
  simd::pop_residuals(curve, params, residuals[1], spreads[1], fit_errors[1]);
  find_pops(curve, params, flags[0], Implementation::reference);
  find_pops(curve, params, flags[1], Implementation::fast);
  for (std::size_t t = 0; t < frames; ++t) {
    diff.residual = std::max(diff.residual, std::abs(residuals[1][t] - residuals[0][t]));
    diff.spread = std::max(diff.spread, std::abs(spreads[1][t] - spreads[0][t]));
    diff.fit_error_squared = std::max(
        diff.fit_error_squared,
        std::abs(fit_errors[1][t] * fit_errors[1][t] - fit_errors[0][t] * fit_errors[0][t]));
    diff.different_bits += residuals[1][t] != residuals[0][t] || spreads[1][t] != spreads[0][t] ||
                           fit_errors[1][t] != fit_errors[0][t];
    diff.different_flags += flags[1][t] != flags[0][t];
  }
  diff.samples += long(frames);
}

// The fast path does the reference's IEEE operations (+, -, x, /, sqrt, each correctly rounded
// in a lane as in a scalar) in the reference's order, with no fused multiply-add (-ffp-contract=
// off in the SIMD sources; the scalar build targets baseline x86-64), so on this build the two
// agree to the bit (different_bits 0). The bounds are the few ulps a rounding change could cost
// where it leaves the same block chosen: ~1e-14 rad on the intercept (sums of o^k v, |v| <= 2.5
// rad, over 10 points) and ~1e-15 rad^2 on sse, a difference of sums, whose square root would
// magnify it near 0 (hence the fit error compared squared). A variant of the fits with fused
// multiply-adds measured at most 7.5e-16 rad and 9.4e-15 rad^2, but it also flipped near-tied
// candidates (spreads differed by up to 0.11, no flag changed) and was no faster: what the
// spread bound guards against.
void expect_paths_agree(const PathDifferences& diff, const std::string& what) {
  std::printf(
      "fast vs reference, %s: %ld samples, %ld differ in any bit, max |residual| diff %.3g rad, "
      "|spread| %.3g, |fit error^2| %.3g rad^2, %ld flags differ\n",
      what.c_str(), diff.samples, diff.different_bits, diff.residual, diff.spread,
      diff.fit_error_squared, diff.different_flags);
  EXPECT_LE(diff.residual, 1e-12) << what;
  EXPECT_LE(diff.spread, 1e-12) << what;
  EXPECT_LE(diff.fit_error_squared, 1e-12) << what;
  EXPECT_EQ(diff.different_flags, 0) << what;
}

TEST(PopRepair, FastPathMatchesReferenceOnRealClips) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  for (int noise = 0; noise < 3; ++noise) {
    PathDifferences diff;
    for (const auto& path : test::shared_bvh_files()) {
      Motion m = real_motion(path, 1 << 30);
      if (noise == 1) add_noise(GaussianNoise{0.03, 17}, m.span());
      if (noise == 2) add_noise(ImpulseNoise{}, m.span());
      make_hemisphere_continuous(m.span());
      for (int j = 0; j < m.joints; ++j) compare_paths(m, j, diff);
    }
    expect_paths_agree(diff, std::string("real clips, ") + (noise == 0   ? "no noise"
                                                            : noise == 1 ? "gaussian 0.03"
                                                                         : "impulse"));
  }
}

TEST(PopRepair, FastPathMatchesReferenceOnSyntheticMotion) {
  for (const double speed : {0.05, 0.2, 0.45}) {
    Motion m = fast_smooth_motion(21, 500, 12, speed);
    PathDifferences diff;
    for (int noise = 0; noise < 3; ++noise) {
      Motion noisy = m;
      if (noise == 1) add_noise(GaussianNoise{0.03, 3}, noisy.span());
      if (noise == 2) add_noise(ImpulseNoise{0.03, 0.3, 1.0, 5}, noisy.span());
      make_hemisphere_continuous(noisy.span());
      for (int j = 0; j < noisy.joints; ++j) compare_paths(noisy, j, diff);
    }
    // Other windows: the candidate list (and the lanes' padding) changes with max_run and reach.
    for (const PopRepairParams params : {PopRepairParams{1, 2}, PopRepairParams{8, 4}})
      for (int j = 0; j < m.joints; ++j) compare_paths(m, j, diff, params);
    expect_paths_agree(diff, "synthetic motion at " + std::to_string(speed) + " rad/frame");
  }
}

// The end samples' candidates made once (pop_detail::end_window_blocks, issue 15) against each
// fit counting its own points and inverting its own moments: the same bits for every sample of
// every joint, slow and fast (whose far neighbours leave the chart, so its ends take the
// counting path), clean and noisy, for the default window and two others.
TEST(PopRepair, EndWindowsMadeOnceGiveTheBitsOfTheirOwnFits) {
  long end_samples = 0;
  for (const double speed : {0.05, 0.45}) {
    for (int noise = 0; noise < 2; ++noise) {
      Motion m = fast_smooth_motion(23, 200, 9, speed);
      if (noise == 1) add_noise(GaussianNoise{0.03, 5}, m.span());
      make_hemisphere_continuous(m.span());
      for (const PopRepairParams params :
           {PopRepairParams{}, PopRepairParams{1, 2}, PopRepairParams{8, 4}}) {
        const auto whole = pop_detail::whole_window_blocks(params);
        const auto ends = pop_detail::end_window_blocks(params);
        for (int j = 0; j < m.joints; ++j) {
          std::vector<Quat> curve(std::size_t(m.frames));
          for (int t = 0; t < m.frames; ++t) curve[std::size_t(t)] = m.at(t, j);
          std::vector<double> r[2], s[2], e[2];
          for (int k = 0; k < 2; ++k) {
            r[k].assign(curve.size(), -1);
            s[k].assign(curve.size(), -1);
            e[k].assign(curve.size(), -1);
            pop_detail::ChartScratch scratch(curve.size());
            for (int t = 0; t < m.frames; ++t)
              pop_detail::sample_residual(
                  curve, params, whole, t, scratch, r[k], s[k], e[k],
                  k == 0 ? std::span<const std::vector<pop_detail::BlockFit>>{} : ends);
          }
          for (int t = 0; t < m.frames; ++t) {
            end_samples += t < params.window() || t >= m.frames - params.window();
            EXPECT_EQ(r[0][std::size_t(t)], r[1][std::size_t(t)]) << "joint " << j << " t " << t;
            EXPECT_EQ(s[0][std::size_t(t)], s[1][std::size_t(t)]) << "joint " << j << " t " << t;
            EXPECT_EQ(e[0][std::size_t(t)], e[1][std::size_t(t)]) << "joint " << j << " t " << t;
          }
        }
      }
    }
  }
  EXPECT_GT(end_samples, 500);
}

// A joint that speeds up from 0.1 to 0.7 rad per frame mid-clip: from there on its neighbours
// leave the chart's reach (5 x 0.7 > 2.5 rad), so interior samples take the scalar code between
// samples that take the lanes.
TEST(PopRepair, FastPathMatchesReferenceWhenNeighboursLeaveTheChart) {
  Motion m{300, 1, std::vector<float>(300 * 4)};
  double angle = 0;
  std::mt19937_64 rng(12);
  const Vec3 axis = log(test::random_rotation(rng));
  for (int t = 0; t < m.frames; ++t) {
    angle += t < 150 ? 0.1 : 0.1 + 0.6 * std::min(1.0, (t - 150) / 20.0);
    store_quat(exp((angle / norm(axis)) * axis), m.span().at(t, 0));
  }
  add_noise(GaussianNoise{0.01, 4}, m.span());
  add_noise(ImpulseNoise{0.02, 0.3, 1.0, 6}, m.span());
  make_hemisphere_continuous(m.span());
  int out_of_reach = 0;
  for (int t = 5; t + 5 < m.frames; ++t) out_of_reach += geodesic(m.at(t, 0), m.at(t + 5, 0)) > 2.5;
  EXPECT_GT(out_of_reach, 20);
  EXPECT_LT(out_of_reach, 200);
  PathDifferences diff;
  compare_paths(m, 0, diff);
  expect_paths_agree(diff, "a joint leaving the chart's reach");
}

// With window() = 5, clips of 5 and 6 frames have no whole sample, 11 and 12 frames one and two.
TEST(PopRepair, FastPathMatchesReferenceOnShortClips) {
  const Motion m = fast_smooth_motion(4, 12, 3, 0.2);
  for (int frames : {5, 6, 11, 12}) {
    Motion shorter{frames, 3,
                   std::vector<float>(m.rotations.begin(), m.rotations.begin() + frames * 12)};
    store_quat(shorter.at(frames / 2, 1) * exp(Vec3{0.9, 0, 0}), shorter.span().at(frames / 2, 1));
    make_hemisphere_continuous(shorter.span());
    PathDifferences diff;
    for (int j = 0; j < shorter.joints; ++j) compare_paths(shorter, j, diff);
    expect_paths_agree(diff, std::to_string(frames) + " frames");
  }
}

// Not a bound on the machine, a number for docs/pops.md.
TEST(PopRepair, RunTime) {
  Motion noisy = fast_smooth_motion(6, 600, 31, 0.1);
  add_noise(ImpulseNoise{}, noisy.span());
  const auto start = std::chrono::steady_clock::now();
  const Result r = run_job(noisy);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(r.status);
  std::printf("pop repair: %.3f s for %d joint-frames, %.2f us per joint-frame\n", seconds,
              noisy.frames * noisy.joints, 1e6 * seconds / (noisy.frames * noisy.joints));
}

}  // namespace
}  // namespace mocap
