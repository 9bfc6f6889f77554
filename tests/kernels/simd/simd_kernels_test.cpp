// The Highway SIMD kernels (kernels/simd/) against their scalar double references, on every
// target Highway compiled that this machine supports: Log / Exp / geodesic, the band of geodesic
// distances (both layouts), bof, the linear filters and nlpm must agree with the reference within
// 1e-5 rad RMS and 1e-4 rad max (float32 rounding; the external check's tolerance), on random
// motions and on real clips; and the SIMD output must be bit-identical whatever slice computed it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "hwy/highway.h"
#include "hwy/tests/hwy_gtest.h"
#include "io/bvh_reader.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/nlpm.hpp"
#include "kernels/noise_model.hpp"
#include "kernels/simd/band_geodesics.hpp"
#include "kernels/simd/nlpm_simd.hpp"
#include "kernels/simd/quat_batch.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

constexpr double kRmsTolerance = 1e-5, kMaxTolerance = 1e-4;      // rad
constexpr float kNoCap = std::numeric_limits<float>::infinity();  // accumulate_pose_band: no cap

// A motion and where it came from, for messages.
struct Motion {
  std::string name;
  int frames = 0, joints = 0;
  std::vector<float> rotations;
  RotationView view() const { return {rotations.data(), frames, joints}; }
};

Motion noisy_random_motion(std::uint64_t seed, int frames, int joints, double noise) {
  std::mt19937_64 rng(seed);
  Motion m{"random seed " + std::to_string(seed), frames, joints,
           test::random_motion(rng, frames, joints, 2.0)};
  add_noise(GaussianNoise{noise, seed + 1}, {m.rotations.data(), frames, joints});
  return m;
}

// Real clips, cut to at most `max_frames` from `first` so that the double reference stays quick:
// a short run, a turn (01_01 turns around, so joints pass pi) and fast impacts.
const std::vector<Motion>& real_clips() {
  static const std::vector<Motion> clips = [] {
    std::vector<Motion> out;
    const std::tuple<const char*, int, int> wanted[] = {{"cmu_mb_02_03.bvh", 0, 120},
                                                        {"cmu_mb_01_01.bvh", 1300, 160},
                                                        {"cmu_mb_02_05.bvh", 600, 120}};
    for (const auto& path : test::shared_bvh_files())
      for (const auto& [name, first, count] : wanted) {
        if (path.filename() != name) continue;
        const io::BvhReadResult read = io::read_bvh(path);
        if (!read.clip) continue;
        const Clip& clip = *read.clip;
        const int begin = std::min(first, clip.frames - 1);
        const int frames = std::min(count, clip.frames - begin);
        const std::size_t row = std::size_t(clip.joints()) * 4;
        out.push_back({name, frames, clip.joints(),
                       std::vector<float>(clip.rotations.begin() + long(begin * row),
                                          clip.rotations.begin() + long((begin + frames) * row))});
      }
    return out;
  }();
  return clips;
}

// Joints whose input has a frame-to-frame step within 1e-6 rad of pi: the spec lets such a step's
// Log resolve either way and excludes it from comparisons between implementations.
std::vector<bool> ambiguous_joints(const Motion& m) {
  std::vector<bool> out(std::size_t(m.joints), false);
  for (int j = 0; j < m.joints; ++j)
    for (int t = 0; t + 1 < m.frames; ++t)
      if (geodesic(load_quat(m.view().at(t, j)), load_quat(m.view().at(t + 1, j))) > kPi - 1e-6)
        out[std::size_t(j)] = true;
  return out;
}

struct Agreement {
  double rms = 0, max = 0;
  int excluded_joints = 0;
};

Agreement agreement(const Motion& m, const std::vector<float>& a, const std::vector<float>& b) {
  const std::vector<bool> skip = ambiguous_joints(m);
  Agreement out;
  double sum = 0;
  long count = 0;
  for (int j = 0; j < m.joints; ++j) {
    if (skip[std::size_t(j)]) {
      ++out.excluded_joints;
      continue;
    }
    for (int t = 0; t < m.frames; ++t) {
      const std::size_t i = (std::size_t(t) * std::size_t(m.joints) + std::size_t(j)) * 4;
      const double e = geodesic(load_quat(&a[i]), load_quat(&b[i]));
      out.max = std::max(out.max, e);
      sum += e * e;
      ++count;
    }
  }
  out.rms = count > 0 ? std::sqrt(sum / double(count)) : 0.0;
  return out;
}

// The worst agreement seen by a test, printed at its end for the record (docs/performance.md).
struct Worst {
  const char* what;
  double rms = 0, max = 0;
  int excluded = 0;  // joints left out of comparisons (a step within 1e-6 rad of pi)
  void add(const Agreement& a) {
    rms = std::max(rms, a.rms);
    max = std::max(max, a.max);
    excluded = std::max(excluded, a.excluded_joints);
  }
  ~Worst() {
    std::printf("[ accuracy ] %s: worst rms %.3g rad, worst max %.3g rad (%d joints excluded)\n",
                what, rms, max, excluded);
  }
};

MotionIO io_of(const Motion& m, std::vector<float>& out) {
  out.assign(m.rotations.size(), 0.0f);
  MotionIO io;
  io.rotations = m.view();
  io.filtered_rotations = {out.data(), m.frames, m.joints};
  return io;
}

// The reference output of a (motion, parameters) case, computed once and shared by the targets.
template <class Run>
const std::vector<float>& cached_reference(const std::string& key, Run run) {
  static std::map<std::string, std::vector<float>> cache;
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, run()).first;
  return it->second;
}

std::vector<float> run_bof(const Motion& m, const BilateralParams& p, Implementation impl,
                           int joint_begin = 0, int joint_end = -1, int frame_begin = 0,
                           int frame_end = -1, float fill = 0.0f) {
  std::vector<float> out;
  MotionIO io = io_of(m, out);
  std::fill(out.begin(), out.end(), fill);
  io.joint_begin = joint_begin;
  io.joint_end = joint_end;
  io.frame_begin = frame_begin;
  io.frame_end = frame_end;
  const Status s = BilateralJob{p, io, impl}.run();
  EXPECT_TRUE(s.ok()) << s.message();
  return out;
}

std::vector<float> run_nlpm(const Motion& m, const NlpmParams& p, Implementation impl,
                            int frame_begin = 0, int frame_end = -1, int joint_begin = 0,
                            int joint_end = -1, float fill = 0.0f) {
  std::vector<float> out;
  MotionIO io = io_of(m, out);
  std::fill(out.begin(), out.end(), fill);
  io.joint_begin = joint_begin;
  io.joint_end = joint_end;
  io.frame_begin = frame_begin;
  io.frame_end = frame_end;
  const Status s = NlpmJob{p, io, {}, impl}.run();
  EXPECT_TRUE(s.ok()) << s.message();
  return out;
}

std::vector<float> run_linear(const Motion& m, const LinearParams& p, Implementation impl,
                              int joint_begin = 0, int joint_end = -1, int frame_begin = 0,
                              int frame_end = -1, float fill = 0.0f) {
  std::vector<float> out;
  MotionIO io = io_of(m, out);
  std::fill(out.begin(), out.end(), fill);
  io.frame_time = 1.0 / 120.0;
  io.joint_begin = joint_begin;
  io.joint_end = joint_end;
  io.frame_begin = frame_begin;
  io.frame_end = frame_end;
  const Status s = LinearFilterJob{p, io, impl}.run();
  EXPECT_TRUE(s.ok()) << s.message();
  return out;
}

std::string describe(const BilateralParams& p) {
  return "bof kernel " + std::string(to_string(p.kernel)) + " sigma_t " +
         std::to_string(p.sigma_t) + " sigma_g " + std::to_string(p.sigma_g) + " iterations " +
         std::to_string(p.iterations) + " boundary " + std::string(to_string(p.boundary));
}

std::string describe(const NlpmParams& p) {
  return "nlpm K " + std::to_string(p.search_radius) + " P " + std::to_string(p.patch_radius) +
         " h " + std::to_string(p.h) + " range_sigma " + std::to_string(p.range_sigma) +
         " distance_cap " + std::to_string(p.distance_cap) + " boundary " +
         std::string(to_string(p.boundary));
}

std::vector<Motion> test_motions() {
  std::vector<Motion> out = {noisy_random_motion(101, 120, 5, 0.03),
                             noisy_random_motion(102, 23, 3, 0.1)};
  for (const Motion& m : real_clips()) out.push_back(m);
  return out;
}

class SimdKernels : public hwy::TestWithParamTarget {};
HWY_TARGET_INSTANTIATE_TEST_SUITE_P(SimdKernels);

TEST_P(SimdKernels, DispatchesToTheTargetUnderTest) {
  EXPECT_EQ(simd::active_target(), hwy::TargetName(GetParam()));
}

// Rotations of angle `angle` about random axes, as float planes, plus the same samples in double.
std::vector<float> rotation_planes(const std::vector<double>& angles, std::mt19937_64& rng,
                                   std::vector<Quat>& samples) {
  const std::size_t n = angles.size();
  std::vector<float> planes(4 * n);
  std::normal_distribution<double> g(0.0, 1.0);
  samples.clear();
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 axis{g(rng), g(rng), g(rng)};
    axis = (1.0 / norm(axis)) * axis;
    Quat q = exp(angles[i] * axis);
    if (i % 3 == 1) q = negate(q);  // Log takes w >= 0 first
    float stored[4];
    store_quat(q, stored);
    samples.push_back(load_quat(stored));
    for (std::size_t c = 0; c < 4; ++c) planes[c * n + i] = stored[c];
  }
  return planes;
}

TEST_P(SimdKernels, LogIsAccurateNearZeroAndNearPi) {
  std::mt19937_64 rng(1);
  std::vector<double> angles;
  for (double a = 1e-9; a < 4; a *= 1.7) angles.push_back(std::min(a, kPi));
  for (double gap = 1e-2; gap > 1e-6; gap /= 3) angles.push_back(kPi - gap);
  std::vector<Quat> q;
  const std::vector<float> planes = rotation_planes(angles, rng, q);
  const std::size_t n = q.size();
  std::vector<float> out(3 * n);
  simd::log_planes(planes, out, n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 expected = log(q[i]);  // of the same float sample, in double
    const Vec3 got{out[i], out[n + i], out[2 * n + i]};
    const double angle = norm(expected);
    // Float rounding of a float input: relative near 0 (no cancellation), absolute near pi.
    EXPECT_LT(norm(got - expected), 1e-6 * angle + 1e-6 * (angle > 1 ? 1 : 0)) << "angle " << angle;
  }
}

TEST_P(SimdKernels, ExpIsAccurateForSmallAndLargeAngles) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Vec3> v;
  for (double a = 1e-9; a < 10; a *= 1.5) {
    Vec3 axis{g(rng), g(rng), g(rng)};
    v.push_back((a / norm(axis)) * axis);
  }
  v.push_back({0, 0, 0});
  const std::size_t n = v.size();
  std::vector<float> planes(3 * n), out(4 * n);
  for (std::size_t i = 0; i < n; ++i) {
    planes[i] = float(v[i].x);
    planes[n + i] = float(v[i].y);
    planes[2 * n + i] = float(v[i].z);
    v[i] = {planes[i], planes[n + i], planes[2 * n + i]};
  }
  simd::exp_planes(planes, out, n);
  for (std::size_t i = 0; i < n; ++i) {
    const Quat expected = exp(v[i]);
    const Quat got{out[i], out[n + i], out[2 * n + i], out[3 * n + i]};
    // Components: a few float ulps of values <= 1; the vector part relative for small angles.
    EXPECT_LT(std::abs(got.w - expected.w), 3e-7) << norm(v[i]);
    const Vec3 gv{got.x, got.y, got.z}, ev{expected.x, expected.y, expected.z};
    EXPECT_LE(norm(gv - ev), 1e-6 * std::min(1.0, norm(v[i]))) << norm(v[i]);
  }
  EXPECT_EQ(out[n - 1], 1.0f);  // Exp(0) is the identity to the bit
  EXPECT_EQ(out[2 * n - 1], 0.0f);
}

TEST_P(SimdKernels, GeodesicKeepsSmallAnglesAccurate) {
  std::mt19937_64 rng(3);
  std::vector<double> angles;
  for (double a = 1e-6; a < 3.2; a *= 1.3) angles.push_back(std::min(a, kPi));
  std::vector<Quat> a_samples;
  const std::vector<float> a =
      rotation_planes(std::vector<double>(angles.size(), 1.0), rng, a_samples);
  // b = a * Exp(angle about a random axis), rounded to float.
  const std::size_t n = angles.size();
  std::vector<float> b(4 * n);
  std::vector<Quat> b_samples;
  std::vector<Quat> steps;
  const std::vector<float> step_planes = rotation_planes(angles, rng, steps);
  for (std::size_t i = 0; i < n; ++i) {
    float stored[4];
    store_quat(a_samples[i] * steps[i], stored);
    b_samples.push_back(load_quat(stored));
    for (std::size_t c = 0; c < 4; ++c) b[c * n + i] = stored[c];
  }
  std::vector<float> out(n);
  simd::geodesic_planes(a, b, out, n);
  for (std::size_t i = 0; i < n; ++i) {
    const double expected = geodesic(a_samples[i], b_samples[i]);
    // 2 acos|a.b| in float would be off by up to 1e-3 rad here; the chord form keeps ~1e-7
    // relative (and 2e-7 absolute near pi).
    EXPECT_LT(std::abs(out[i] - expected), 1e-6 * expected + 2e-7) << "angle " << expected;
  }
}

// Log, Exp and the squared geodesic take a root-free shortcut when every lane of a vector has a
// small angle. A lane's result must not depend on its neighbours: the same small-angle samples,
// alone and then interleaved with large angles (so that their vectors take the general path),
// give the same bits.
TEST_P(SimdKernels, ShortcutsDoNotDependOnTheOtherLanes) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> small(0.0, 0.9), large(2.2, 3.1);
  const std::size_t n = 64;
  std::vector<double> alone(n), mixed(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    alone[i] = mixed[2 * i] = small(rng);
    mixed[2 * i + 1] = large(rng);
  }
  std::mt19937_64 same_axes(10);
  std::vector<Quat> unused;
  std::vector<float> q_alone = rotation_planes(alone, same_axes, unused);
  std::vector<float> q_mixed = rotation_planes(mixed, rng, unused);
  for (std::size_t i = 0; i < n; ++i)  // the small samples of `mixed` are those of `alone`
    for (std::size_t c = 0; c < 4; ++c) q_mixed[c * 2 * n + 2 * i] = q_alone[c * n + i];
  std::vector<float> log_alone(3 * n), log_mixed(6 * n);
  simd::log_planes(q_alone, log_alone, n);
  simd::log_planes(q_mixed, log_mixed, 2 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t c = 0; c < 3; ++c)
      ASSERT_EQ(log_alone[c * n + i], log_mixed[c * 2 * n + 2 * i]) << "Log, sample " << i;
  // Exp of those rotation vectors (|v| up to 0.9 vs up to 3.1).
  std::vector<float> exp_alone(4 * n), exp_mixed(8 * n);
  simd::exp_planes(log_alone, exp_alone, n);
  simd::exp_planes(log_mixed, exp_mixed, 2 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t c = 0; c < 4; ++c)
      ASSERT_EQ(exp_alone[c * n + i], exp_mixed[c * 2 * n + 2 * i]) << "Exp, sample " << i;
  // Squared geodesics (nlpm's band) between the identity and each sample.
  const std::size_t stride = 4 * n + 32;  // >= the longest curve (4n) + 1 + a vector, whole vectors
  auto band_of = [&](const std::vector<float>& q, std::size_t count) {
    std::vector<float> planes(4 * stride, 0.0f), band(stride, 0.0f);
    std::fill_n(planes.begin(), stride, 1.0f);
    for (std::size_t i = 0; i < count; ++i)  // curve: identity, sample, identity, sample, ...
      for (std::size_t c = 0; c < 4; ++c) planes[c * stride + 2 * i + 1] = q[c * count + i];
    simd::accumulate_pose_band(planes.data(), stride, 2 * count, 1, kNoCap, band.data());
    return band;
  };
  const std::vector<float> band_alone = band_of(q_alone, n), band_mixed = band_of(q_mixed, 2 * n);
  for (std::size_t i = 0; i < n; ++i)
    ASSERT_EQ(band_alone[2 * i], band_mixed[4 * i]) << "squared geodesic, sample " << i;
}

TEST_P(SimdKernels, BandGeodesicsMatchTheDoubleDistanceInBothLayouts) {
  const Motion m = noisy_random_motion(4, 37, 5, 0.05);
  const int k = 4;
  std::vector<float> by_time, by_joint;
  simd::band_geodesics_lanes_time(m.view(), k, by_time);
  const int padded = simd::band_geodesics_lanes_joints(m.view(), k, by_joint);
  ASSERT_GE(padded, m.joints);
  for (int j = 0; j < m.joints; ++j)
    for (int r = 1; r <= k; ++r)
      for (int t = 0; t < m.frames; ++t) {
        const float time = by_time[(std::size_t(j) * k + std::size_t(r - 1)) * m.frames + t];
        const float joint = by_joint[(std::size_t(t) * k + std::size_t(r - 1)) * padded + j];
        if (t + r >= m.frames) {
          EXPECT_EQ(time, 0.0f);
          continue;
        }
        const double expected =
            geodesic(load_quat(m.view().at(t, j)), load_quat(m.view().at(t + r, j)));
        EXPECT_LT(std::abs(time - expected), 1e-6 * expected + 2e-7);
        EXPECT_EQ(time, joint) << "the layouts run the same lane code";
      }
}

std::vector<BilateralParams> bof_cases() {
  std::vector<BilateralParams> out;
  for (Boundary boundary : {Boundary::mirror, Boundary::hold, Boundary::extrapolate})
    for (int iterations : {1, 5}) {
      BilateralParams p;
      p.boundary = boundary;
      p.iterations = iterations;
      out.push_back(p);
    }
  for (double sigma_g : {0.05, 1e6}) {
    BilateralParams p;
    p.sigma_g = sigma_g;
    out.push_back(p);
  }
  BilateralParams paper;
  paper.kernel = BilateralKernel::paper;
  paper.sigma_g = 0.3;
  out.push_back(paper);
  BilateralParams wide;
  wide.sigma_t = 2.5;
  wide.iterations = 2;
  wide.boundary = Boundary::extrapolate;
  out.push_back(wide);
  return out;
}

TEST_P(SimdKernels, BofAgreesWithTheReference) {
  Worst worst{"bof"};
  for (const Motion& m : test_motions())
    for (const BilateralParams& p : bof_cases()) {
      const std::string label = m.name + " " + describe(p);
      const std::vector<float>& expected =
          cached_reference(label, [&] { return run_bof(m, p, Implementation::reference); });
      const Agreement a = agreement(m, run_bof(m, p, Implementation::fast), expected);
      worst.add(a);
      EXPECT_LT(a.rms, kRmsTolerance) << label;
      EXPECT_LT(a.max, kMaxTolerance) << label;
      EXPECT_LT(a.excluded_joints, m.joints) << label;
    }
}

std::vector<LinearParams> linear_cases() {
  std::vector<LinearParams> out;
  for (Boundary boundary : {Boundary::mirror, Boundary::hold, Boundary::extrapolate}) {
    LinearParams p;
    p.boundary = boundary;
    out.push_back(p);
  }
  LinearParams butterworth;
  butterworth.kind = LinearKind::butterworth;
  out.push_back(butterworth);
  LinearParams moving;
  moving.kind = LinearKind::moving_mean;
  out.push_back(moving);
  return out;
}

TEST_P(SimdKernels, LinearFiltersAgreeWithTheReference) {
  Worst worst{"linear"};
  for (const Motion& m : test_motions())
    for (const LinearParams& p : linear_cases()) {
      const std::string label = m.name + " linear " + std::string(to_string(p.kind)) + " " +
                                std::string(to_string(p.boundary));
      const std::vector<float>& expected =
          cached_reference(label, [&] { return run_linear(m, p, Implementation::reference); });
      const Agreement a = agreement(m, run_linear(m, p, Implementation::fast), expected);
      worst.add(a);
      EXPECT_LT(a.rms, kRmsTolerance) << label;
      EXPECT_LT(a.max, kMaxTolerance) << label;
    }
}

std::vector<NlpmParams> nlpm_cases() {
  std::vector<NlpmParams> out;
  for (double h : {0.005, 0.03, 0.2}) {
    NlpmParams p;
    p.h = h;
    out.push_back(p);
  }
  for (Boundary boundary : {Boundary::hold, Boundary::extrapolate}) {
    NlpmParams p;
    p.h = 0.05;
    p.search_radius = 3;
    p.patch_radius = 1;
    p.boundary = boundary;
    out.push_back(p);
  }
  NlpmParams tiny;
  tiny.h = 0.02;
  tiny.search_radius = 1;
  tiny.patch_radius = 0;
  out.push_back(tiny);
  // auto's form: range terms and a distance cap at twice their width, and a cap alone.
  NlpmParams capped;
  capped.h = 0.015;
  capped.range_sigma = 0.1;
  capped.distance_cap = 0.2;
  out.push_back(capped);
  capped.range_sigma = 0;
  capped.distance_cap = 0.05;
  out.push_back(capped);
  return out;
}

TEST_P(SimdKernels, NlpmAgreesWithTheReference) {
  Worst worst{"nlpm"};
  for (const Motion& m : test_motions())
    for (const NlpmParams& p : nlpm_cases()) {
      const std::string label = m.name + " " + describe(p);
      const std::vector<float>& expected =
          cached_reference(label, [&] { return run_nlpm(m, p, Implementation::reference); });
      const Agreement a = agreement(m, run_nlpm(m, p, Implementation::fast), expected);
      worst.add(a);
      EXPECT_LT(a.rms, kRmsTolerance) << label;
      EXPECT_LT(a.max, kMaxTolerance) << label;
    }
}

TEST_P(SimdKernels, PoseBandSumsSquaredGeodesics) {
  // Without a cap and with one (NlpmParams::distance_cap) that clips part of the terms: each
  // joint's term is min(d^2, cap^2).
  const Motion m = noisy_random_motion(5, 45, 4, 0.05);
  const int search = 6;
  const std::size_t count = 30, stride = 64;  // >= count + search + 16, whole vectors
  for (const double cap : {0.0, 0.3}) {
    const float cap_squared = cap > 0 ? float(cap * cap) : kNoCap;
    std::vector<float> band(std::size_t(search) * stride, 0.0f);
    for (int j = 0; j < m.joints; ++j) {
      std::vector<float> planes(4 * stride, 0.0f);
      std::fill_n(planes.begin(), stride, 1.0f);
      for (std::size_t t = 0; t < count + std::size_t(search); ++t)
        for (std::size_t c = 0; c < 4; ++c) planes[c * stride + t] = m.view().at(int(t), j)[c];
      simd::accumulate_pose_band(planes.data(), stride, count, search, cap_squared, band.data());
    }
    long capped = 0, uncapped = 0;
    for (std::size_t u = 0; u < count; ++u)
      for (int delta = 1; delta <= search; ++delta) {
        double expected = 0;
        for (int j = 0; j < m.joints; ++j) {
          const double d = geodesic(load_quat(m.view().at(int(u), j)),
                                    load_quat(m.view().at(int(u) + delta, j)));
          if (cap > 0 && d > cap) {
            expected += cap * cap;
            ++capped;
          } else {
            expected += d * d;
            ++uncapped;
          }
        }
        EXPECT_NEAR(band[std::size_t(delta - 1) * stride + u], expected, 1e-6 * expected + 1e-12)
            << "cap " << cap;
      }
    if (cap > 0) {  // not vacuous: the cap clipped some terms and left others
      EXPECT_GT(capped, 0);
      EXPECT_GT(uncapped, 0);
    }
  }
}

// Runs `run(slice)` for the full clip and for slices covering it, and checks every sample of the
// pieces against the full run with memcmp.
template <class Run>
void expect_bit_identical_slices(const Motion& m, Run run,
                                 const std::vector<std::array<int, 4>>& slices,
                                 const std::string& label) {
  const std::vector<float> full = run(0, -1, 0, -1, 0.0f);
  const float sentinel = 777.0f;
  for (const auto& s : slices) {  // joint_begin, joint_end, frame_begin, frame_end
    const std::vector<float> part = run(s[0], s[1], s[2], s[3], sentinel);
    const int joint_end = s[1] < 0 ? m.joints : s[1], frame_end = s[3] < 0 ? m.frames : s[3];
    for (int t = 0; t < m.frames; ++t)
      for (int j = 0; j < m.joints; ++j) {
        const std::size_t i = (std::size_t(t) * std::size_t(m.joints) + std::size_t(j)) * 4;
        const bool inside = j >= s[0] && j < joint_end && t >= s[2] && t < frame_end;
        if (inside)
          ASSERT_EQ(std::memcmp(&part[i], &full[i], 4 * sizeof(float)), 0)
              << label << " t " << t << " j " << j << " slice " << s[0] << " " << s[1] << " "
              << s[2] << " " << s[3];
        else
          ASSERT_EQ(part[i], sentinel) << label << ": wrote outside its slice";
      }
  }
}

TEST_P(SimdKernels, BofSlicesAreBitIdentical) {
  const Motion m = noisy_random_motion(6, 203, 9, 0.05);
  // Frame slices starting at every offset modulo a vector, joint blocks of odd sizes.
  const std::vector<std::array<int, 4>> slices = {
      {0, 3, 0, -1},   {3, 4, 0, -1},   {4, 9, 0, 1}, {4, 9, 1, 18},   {4, 9, 17, 35},
      {4, 9, 35, 202}, {4, 9, 202, -1}, {0, 9, 5, 6}, {0, 9, 100, 117}};
  for (const BilateralParams& p : {bof_cases()[0], bof_cases()[5], bof_cases().back()})
    expect_bit_identical_slices(
        m,
        [&](int jb, int je, int fb, int fe, float fill) {
          return run_bof(m, p, Implementation::fast, jb, je, fb, fe, fill);
        },
        slices, describe(p));
}

TEST_P(SimdKernels, LinearSlicesAreBitIdentical) {
  const Motion m = noisy_random_motion(7, 151, 5, 0.05);
  const std::vector<std::array<int, 4>> slices = {{0, 2, 0, -1},  {2, 5, 0, 7},    {2, 5, 7, 9},
                                                  {2, 5, 9, 150}, {2, 5, 150, -1}, {0, 5, 33, 34}};
  for (const LinearParams& p : linear_cases())
    expect_bit_identical_slices(
        m,
        [&](int jb, int je, int fb, int fe, float fill) {
          return run_linear(m, p, Implementation::fast, jb, je, fb, fe, fill);
        },
        slices, std::string(to_string(p.kind)));
}

TEST_P(SimdKernels, NlpmSlicesAreBitIdentical) {
  // Longer than a chunk of the band (1024 frames): time blocks that cut anchor blocks and chunks
  // at every offset, and joint slices.
  const Motion m = noisy_random_motion(8, 1100, 5, 0.03);
  const std::vector<std::array<int, 4>> slices = {
      {0, -1, 0, 1},      {0, -1, 1, 64},      {0, -1, 64, 65},  {0, -1, 65, 256},
      {0, -1, 256, 1030}, {0, -1, 1030, 1100}, {1, 4, 700, 900}, {4, 5, 1023, 1025}};
  NlpmParams p;
  p.h = 0.03;
  expect_bit_identical_slices(
      m,
      [&](int jb, int je, int fb, int fe, float fill) {
        return run_nlpm(m, p, Implementation::fast, fb, fe, jb, je, fill);
      },
      slices, describe(p));
}

}  // namespace
}  // namespace mocap
