// Property tests of the bilateral orientation filter (spec "Bilateral orientation filter" and
// "Translations"): the scalar bilateral filter of the angle on single-axis input, the Gaussian as
// sigma_g -> infinity, coordinate and time invariance, denoising, edge preservation around pops,
// boundary modes on short clips, slices, translations and parameter validation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "kernels/bilateral.hpp"
#include "kernels/linear_filter.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

const Vec3 kAxis{0.48, -0.6, 0.64};  // unit
constexpr Boundary kModes[] = {Boundary::mirror, Boundary::hold, Boundary::extrapolate};

// A clip's buffers and the MotionIO that borrows them.
struct Clip {
  int frames = 0, joints = 0;
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
    io.rotations = {rotations.data(), frames, joints};
    io.filtered_rotations = {filtered.data(), frames, joints};
    if (!translations.empty()) {
      io.translations = {translations.data(), frames, joints};
      io.filtered_translations = {filtered_translations.data(), frames, joints};
      io.translated_joints = translated;
    }
    return io;
  }
  RotationView output() const { return {filtered.data(), frames, joints}; }
};

Quat sample(const std::vector<float>& tensor, int joints, int t, int j) {
  return load_quat(tensor.data() + (std::size_t(t) * joints + j) * 4);
}

// The properties below hold for both implementations (the SIMD path up to float rounding).
constexpr Implementation kImplementations[] = {Implementation::fast, Implementation::reference};

Status run_bof(const BilateralParams& params, Clip& clip,
               Implementation implementation = Implementation::fast) {
  return BilateralJob{params, clip.io(), implementation}.run();
}

// The in-range index a mirror or hold read lands on, written out here independently.
long reflect(long t, long frames, Boundary boundary) {
  const long last = frames - 1;
  if (t >= 0 && t <= last) return t;
  if (boundary == Boundary::hold || frames == 1) return t < 0 ? 0 : last;
  long m = t % (2 * last);
  if (m < 0) m += 2 * last;
  return m <= last ? m : 2 * last - m;
}

template <class T>
T extended(const std::vector<T>& x, long t, Boundary boundary) {
  const long frames = long(x.size()), last = frames - 1;
  if (boundary != Boundary::extrapolate || (t >= 0 && t <= last))
    return x[reflect(t, frames, boundary)];
  return t < 0 ? x[0] + double(t) * (x[1] - x[0])
               : x[last] + double(t - last) * (x[last] - x[last - 1]);
}

// The scalar bilateral filter of an angle signal, `iterations` times, with the kernel of `p`.
std::vector<double> scalar_bilateral(std::vector<double> theta, const BilateralParams& p) {
  const int k = p.window > 0 ? p.window : int(std::ceil(3 * p.sigma_t));
  for (int it = 0; it < p.iterations; ++it) {
    std::vector<double> next(theta.size());
    for (long i = 0; i < long(theta.size()); ++i) {
      double weights = 0, sum = 0;
      for (int r = -k; r <= k; ++r) {
        const double value = extended(theta, i + r, p.boundary);
        const double d = std::abs(value - theta[i]);
        const double w = p.kernel == BilateralKernel::gaussian
                             ? std::exp(-double(r * r) / (2 * p.sigma_t * p.sigma_t)) *
                                   std::exp(-d * d / (2 * p.sigma_g * p.sigma_g))
                             : std::exp(-std::abs(double(r)) / (2 * p.sigma_t * p.sigma_t)) *
                                   std::exp(-(d / 2) / (2 * (p.sigma_g / 2) * (p.sigma_g / 2)));
        weights += w;
        sum += w * value;
      }
      next[i] = sum / weights;
    }
    theta = next;
  }
  return theta;
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

// Spec "Noise models", impulse: with probability `rate` per joint-sample, q := q Exp(n), |n|
// uniform in [0.3, 1.0] rad about a random axis. hit[t * joints + j] marks the pops.
std::vector<float> with_pops(std::vector<float> clean, int frames, int joints, double rate,
                             std::mt19937_64& rng, std::vector<bool>& hit) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n(0.0, 1.0);
  hit.assign(clean.size() / 4, false);
  for (std::size_t i = 0; i < clean.size(); i += 4) {
    if (u(rng) >= rate) continue;
    Vec3 axis{n(rng), n(rng), n(rng)};
    axis = (1.0 / norm(axis)) * axis;
    store_quat(load_quat(&clean[i]) * exp((0.3 + 0.7 * u(rng)) * axis), &clean[i]);
    hit[i / 4] = true;
  }
  make_hemisphere_continuous({clean.data(), frames, joints});
  return clean;
}

std::vector<BilateralParams> parameter_sets() {
  BilateralParams defaults;
  BilateralParams paper;
  paper.kernel = BilateralKernel::paper;
  paper.sigma_g = 0.3;
  BilateralParams wide;
  wide.sigma_t = 2.0;
  wide.sigma_g = 0.1;
  wide.iterations = 2;
  wide.boundary = Boundary::extrapolate;
  BilateralParams hold;
  hold.window = 2;
  hold.boundary = Boundary::hold;
  return {defaults, paper, wide, hold};
}

std::string describe(const BilateralParams& p) {
  return "kernel " + std::string(to_string(p.kernel)) + " sigma_t " + std::to_string(p.sigma_t) +
         " sigma_g " + std::to_string(p.sigma_g) + " iterations " + std::to_string(p.iterations) +
         " boundary " + std::string(to_string(p.boundary));
}

TEST(Bilateral, ParsesKernels) {
  EXPECT_EQ(parse_bilateral_kernel("gaussian"), BilateralKernel::gaussian);
  EXPECT_EQ(parse_bilateral_kernel("paper"), BilateralKernel::paper);
  EXPECT_EQ(parse_bilateral_kernel("courty"), std::nullopt);
  for (BilateralKernel k : {BilateralKernel::gaussian, BilateralKernel::paper})
    EXPECT_EQ(parse_bilateral_kernel(to_string(k)), k);
}

TEST(Bilateral, SingleAxisIsTheScalarBilateralFilterOfTheAngle) {
  // Angles beyond pi overall, steps small enough that |theta_{i+r} - theta_i| < pi in a window,
  // and a 0.8 rad step edge so that the range weights matter.
  std::mt19937_64 rng(31);
  std::normal_distribution<double> noise(0.0, 0.06);
  std::vector<double> theta(200);
  for (int i = 0; i < 200; ++i)
    theta[i] = 3.5 * std::sin(0.03 * i + 0.2) + 1.0 + (i >= 120 ? 0.8 : 0.0) + noise(rng);
  std::vector<Quat> curve;
  for (double a : theta) curve.push_back(exp(a * kAxis));
  CurveScratch scratch;
  for (BilateralParams p : parameter_sets()) {
    for (Boundary boundary : kModes) {
      p.boundary = boundary;
      const std::vector<double> expected = scalar_bilateral(theta, p);
      std::vector<Quat> out(curve.size());
      bilateral_filter_rotations(curve, p, out, 0, int(curve.size()), scratch);
      double worst = 0, moved = 0;
      for (std::size_t i = 0; i < curve.size(); ++i) {
        worst = std::max(worst, geodesic(out[i], exp(expected[i] * kAxis)));
        moved = std::max(moved, std::abs(expected[i] - theta[i]));
      }
      EXPECT_LT(worst, 1e-9) << describe(p);
      EXPECT_GT(moved, 0.01) << describe(p);  // the filter did something
    }
  }
}

TEST(Bilateral, HugeSigmaGIsTheGaussianFilter) {
  std::mt19937_64 rng(32);
  const int frames = 150;
  const std::vector<float> motion =
      with_gaussian_noise(test::random_motion(rng, frames, 1, 2.0), frames, 1, 0.05, rng);
  std::vector<Quat> curve(frames);
  for (int t = 0; t < frames; ++t) curve[t] = sample(motion, 1, t, 0);
  CurveScratch scratch;
  for (Boundary boundary : kModes) {
    for (int iterations : {1, 3}) {
      BilateralParams p;
      p.sigma_g = 1e6;
      p.sigma_t = 1.5;
      p.iterations = iterations;
      p.boundary = boundary;
      std::vector<Quat> bof(frames), gaussian(frames);
      bilateral_filter_rotations(curve, p, bof, 0, frames, scratch);
      linear_filter_rotations(curve, gaussian_mask(1.5, 5), iterations, boundary, gaussian, 0,
                              frames, scratch);
      double worst = 0;
      for (int t = 0; t < frames; ++t) worst = std::max(worst, geodesic(bof[t], gaussian[t]));
      EXPECT_LT(worst, 1e-9) << to_string(boundary) << " iterations " << iterations;
    }
  }
}

TEST(Bilateral, CoordinateInvariance) {
  std::mt19937_64 rng(33);
  const int frames = 120, joints = 3;
  const std::vector<float> motion =
      with_gaussian_noise(test::random_motion(rng, frames, joints, 1.5), frames, joints, 0.05, rng);
  const Quat a = test::random_rotation(rng), b = test::random_rotation(rng);
  std::vector<float> moved(motion.size());
  for (std::size_t i = 0; i < motion.size(); i += 4)
    store_quat(a * load_quat(&motion[i]) * b, &moved[i]);
  for (Implementation impl : kImplementations)
    for (const BilateralParams& p : parameter_sets()) {
      Clip plain(motion, frames, joints), transformed(moved, frames, joints);
      ASSERT_TRUE(run_bof(p, plain, impl).ok());
      ASSERT_TRUE(run_bof(p, transformed, impl).ok());
      double worst = 0;
      for (int t = 0; t < frames; ++t)
        for (int j = 0; j < joints; ++j)
          worst = std::max(worst, geodesic(a * sample(plain.filtered, joints, t, j) * b,
                                           sample(transformed.filtered, joints, t, j)));
      EXPECT_LT(worst, 1e-6) << describe(p) << " " << to_string(impl);
    }
}

TEST(Bilateral, TimeInvariance) {
  std::mt19937_64 rng(34);
  const int frames = 200, joints = 2, shift = 5;
  const std::vector<float> motion = with_gaussian_noise(
      test::random_motion(rng, frames + shift, joints), frames + shift, joints, 0.05, rng);
  const std::vector<float> later(motion.begin() + std::size_t(shift) * joints * 4, motion.end());
  for (Implementation impl : kImplementations)
    for (const BilateralParams& p : parameter_sets()) {
      Clip whole(motion, frames + shift, joints), shifted(later, frames, joints);
      ASSERT_TRUE(run_bof(p, whole, impl).ok());
      ASSERT_TRUE(run_bof(p, shifted, impl).ok());
      const int margin = p.reach() * p.iterations;
      double worst = 0;
      for (int t = margin; t < frames - margin; ++t)
        for (int j = 0; j < joints; ++j)
          worst = std::max(worst, geodesic(sample(whole.filtered, joints, t + shift, j),
                                           sample(shifted.filtered, joints, t, j)));
      EXPECT_LT(worst, 1e-9) << describe(p) << " " << to_string(impl);
    }
}

TEST(Bilateral, LowersTheErrorOfNoisySmoothMotion) {
  std::mt19937_64 rng(35);
  const int frames = 400, joints = 4;
  const std::vector<float> truth = test::random_motion(rng, frames, joints);
  const std::vector<float> noisy = with_gaussian_noise(truth, frames, joints, 0.03, rng);
  const RotationView truth_view{truth.data(), frames, joints};
  const double before = test::rotation_errors({noisy.data(), frames, joints}, truth_view).rms;
  for (Implementation impl : kImplementations)
    for (const BilateralParams& p : parameter_sets()) {
      Clip clip(noisy, frames, joints);
      ASSERT_TRUE(run_bof(p, clip, impl).ok());
      const double after = test::rotation_errors(clip.output(), truth_view).rms;
      EXPECT_LT(after, 0.75 * before)
          << describe(p) << " " << to_string(impl) << ": " << before << " -> " << after;
    }
}

TEST(Bilateral, PopsDoNotSpreadIntoTheirNeighbours) {
  // Impulse noise (rate 0.01, 0.3-1.0 rad). A pop is an edge to bof with sigma_g = 0.2: its
  // neighbours give it almost no weight, so the clean samples around it stay clean, where the
  // Gaussian smears it over its whole window.
  std::mt19937_64 rng(36);
  const int frames = 400, joints = 4;
  const std::vector<float> truth = test::random_motion(rng, frames, joints);
  std::vector<bool> hit;
  const std::vector<float> noisy = with_pops(truth, frames, joints, 0.01, rng, hit);
  Clip bof(noisy, frames, joints), gaussian(noisy, frames, joints);
  ASSERT_TRUE(run_bof(BilateralParams{}, bof).ok());
  ASSERT_TRUE((LinearFilterJob{LinearParams{}, gaussian.io()}.run().ok()));
  const RotationView truth_view{truth.data(), frames, joints};
  auto clean_rmse = [&](const Clip& c) {
    double sum = 0;
    int n = 0;
    for (int t = 0; t < frames; ++t)
      for (int j = 0; j < joints; ++j)
        if (!hit[std::size_t(t) * joints + j]) {
          const double e = test::rotation_error(c.output(), truth_view, t, j);
          sum += e * e;
          ++n;
        }
    return std::sqrt(sum / n);
  };
  int pops = 0;
  for (bool h : hit) pops += h;
  ASSERT_GT(pops, 5);
  const double bof_error = clean_rmse(bof), gaussian_error = clean_rmse(gaussian);
  EXPECT_LT(bof_error, 0.5 * gaussian_error) << bof_error << " vs " << gaussian_error;
}

TEST(Bilateral, KeepsAnIsolatedLargePop) {
  // The flip side of edge preservation: a 1 rad pop is > 4 sigma_g from its neighbours, so its
  // mask is almost a delta and bof returns it nearly as it is (spec kernel, one iteration).
  std::mt19937_64 rng(37);
  const int frames = 60;
  std::vector<float> motion = test::random_motion(rng, frames, 1, 0.5);
  const Quat clean = sample(motion, 1, 30, 0);
  store_quat(clean * exp(Vec3{0, 1.0, 0}), &motion[30 * 4]);
  make_hemisphere_continuous({motion.data(), frames, 1});
  BilateralParams p;
  p.iterations = 1;
  for (Implementation impl : kImplementations) {
    Clip bof(motion, frames, 1);
    ASSERT_TRUE(run_bof(p, bof, impl).ok());
    EXPECT_LT(geodesic(sample(bof.filtered, 1, 30, 0), sample(motion, 1, 30, 0)), 1e-3);
    EXPECT_GT(geodesic(sample(bof.filtered, 1, 30, 0), clean), 0.99);
  }
}

TEST(Bilateral, OneFrameClipIsCopied) {
  std::mt19937_64 rng(38);
  const std::vector<float> one = test::random_motion(rng, 1, 3);
  for (Implementation impl : kImplementations)
    for (const BilateralParams& p : parameter_sets()) {
      Clip clip(one, 1, 3);
      clip.add_translations({1.5f, -2, 3, 4, 5, 6, 7, 8, 9}, {1, 0, 1});
      ASSERT_TRUE(run_bof(p, clip, impl).ok()) << describe(p);
      EXPECT_EQ(clip.filtered, clip.rotations) << describe(p);
      EXPECT_EQ(clip.filtered_translations, clip.translations) << describe(p);
    }
}

TEST(Bilateral, ReachLongerThanTheClipInEveryBoundaryMode) {
  // F = 3, k = 10, single-axis: the job matches the scalar bilateral filter of the angle. The
  // distances the scalar model sees must stay below pi (the geodesic distance wraps there), so
  // extrapolate, which reaches 10 steps out, gets small steps.
  for (Boundary boundary : kModes) {
    const std::vector<double> theta = boundary == Boundary::extrapolate
                                          ? std::vector<double>{0.4, 0.55, 0.62}
                                          : std::vector<double>{0.4, 1.1, 2.9};
    std::vector<float> motion(12);
    for (int t = 0; t < 3; ++t) store_quat(exp(theta[t] * kAxis), &motion[4 * t]);
    BilateralParams p;
    p.window = 10;
    p.sigma_t = 4;
    p.sigma_g = 1.0;
    p.iterations = 2;
    p.boundary = boundary;
    const std::vector<double> expected = scalar_bilateral(theta, p);
    for (Implementation impl : kImplementations) {
      Clip clip(motion, 3, 1);
      ASSERT_TRUE(run_bof(p, clip, impl).ok()) << to_string(boundary);
      for (int t = 0; t < 3; ++t) {
        EXPECT_LT(geodesic(sample(clip.filtered, 1, t, 0), exp(expected[t] * kAxis)), 1e-6)
            << to_string(boundary) << " frame " << t << " " << to_string(impl);
        EXPECT_GT(std::abs(expected[t] - theta[t]), 1e-3) << to_string(boundary);
      }
    }
  }
}

TEST(Bilateral, SlicesGiveBitIdenticalOutput) {
  std::mt19937_64 rng(39);
  const int frames = 80, joints = 5;
  const std::vector<float> motion =
      with_gaussian_noise(test::random_motion(rng, frames, joints), frames, joints, 0.05, rng);
  std::vector<float> positions(std::size_t(frames) * joints * 3);
  std::normal_distribution<double> n(0.0, 5.0);
  for (float& p : positions) p = float(n(rng));
  const std::vector<std::uint8_t> which{1, 0, 1, 1, 0};
  for (Implementation impl : kImplementations)
    for (BilateralParams p : parameter_sets()) {
      p.sigma_p = 3.0;
      Clip full(motion, frames, joints);
      full.add_translations(positions, which);
      ASSERT_TRUE(run_bof(p, full, impl).ok());
      Clip sliced(motion, frames, joints);
      sliced.add_translations(positions, which);
      const float sentinel = 42.0f;
      std::fill(sliced.filtered.begin(), sliced.filtered.end(), sentinel);
      std::fill(sliced.filtered_translations.begin(), sliced.filtered_translations.end(), sentinel);
      const int blocks[][4] = {{0, 2, 0, -1}, {2, 3, 0, -1}, {3, 5, 0, 30}, {3, 5, 45, -1}};
      for (const auto& s : blocks) {
        MotionIO io = sliced.io();
        io.joint_begin = s[0];
        io.joint_end = s[1];
        io.frame_begin = s[2];
        io.frame_end = s[3];
        ASSERT_TRUE((BilateralJob{p, io, impl}.run().ok()));
      }
      for (int t = 0; t < frames; ++t)
        for (int j = 0; j < joints; ++j) {
          const bool hole = j >= 3 && t >= 30 && t < 45;
          const float* r = &sliced.filtered[(std::size_t(t) * joints + j) * 4];
          const float* q = &sliced.filtered_translations[(std::size_t(t) * joints + j) * 3];
          if (hole) {
            EXPECT_EQ(r[0], sentinel) << describe(p) << ": wrote outside its slice";
            EXPECT_EQ(q[0], sentinel) << describe(p) << ": wrote outside its slice";
          } else {
            EXPECT_EQ(std::memcmp(r, &full.filtered[(std::size_t(t) * joints + j) * 4], 16), 0)
                << describe(p) << " t " << t << " j " << j;
            EXPECT_EQ(
                std::memcmp(q, &full.filtered_translations[(std::size_t(t) * joints + j) * 3], 12),
                0)
                << describe(p) << " t " << t << " j " << j;
          }
        }
    }
}

TEST(Bilateral, TranslationsGetTheEuclideanBilateralFilter) {
  std::mt19937_64 rng(40);
  const int frames = 70, joints = 2;
  std::vector<float> positions(std::size_t(frames) * joints * 3);
  std::normal_distribution<double> n(0.0, 0.3);
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < joints; ++j)
      for (int c = 0; c < 3; ++c)
        positions[(std::size_t(t) * joints + j) * 3 + c] =
            float(5 * std::sin(0.08 * t + c) + (t >= 35 ? 4.0 : 0.0) + n(rng));
  std::vector<Vec3> path(frames);
  for (int t = 0; t < frames; ++t) path[t] = load_vec3(&positions[std::size_t(t) * joints * 3]);
  for (double sigma_p : {0.5, 2.0, std::numeric_limits<double>::infinity()}) {
    for (Boundary boundary : kModes) {
      BilateralParams p;
      p.sigma_p = sigma_p;
      p.iterations = 3;
      p.boundary = boundary;
      Clip clip(test::random_motion(rng, frames, joints), frames, joints);
      clip.add_translations(positions, {1, 0});
      ASSERT_TRUE(run_bof(p, clip).ok());
      // Expected: exp(-r^2 / (2 sigma_t^2)) exp(-|p_{i+r} - p_i|^2 / (2 sigma_p^2)), normalised.
      std::vector<Vec3> current = path;
      for (int it = 0; it < p.iterations; ++it) {
        std::vector<Vec3> next(frames);
        for (int i = 0; i < frames; ++i) {
          Vec3 sum;
          double weights = 0;
          for (int r = -3; r <= 3; ++r) {
            const Vec3 v = extended(current, i + r, boundary), d = v - current[i];
            const double w =
                std::exp(-r * r / 2.0) *
                (std::isinf(sigma_p) ? 1.0 : std::exp(-dot(d, d) / (2 * sigma_p * sigma_p)));
            sum += w * v;
            weights += w;
          }
          next[i] = (1.0 / weights) * sum;
        }
        current = next;
      }
      for (int t = 0; t < frames; ++t) {
        const Vec3 got = load_vec3(&clip.filtered_translations[std::size_t(t) * joints * 3]);
        EXPECT_LT(norm(got - current[t]), 1e-5)
            << "sigma_p " << sigma_p << " " << to_string(boundary) << " frame " << t;
        EXPECT_EQ(std::memcmp(&clip.filtered_translations[(std::size_t(t) * joints + 1) * 3],
                              &positions[(std::size_t(t) * joints + 1) * 3], 12),
                  0);
      }
    }
  }
}

TEST(Bilateral, InvalidParametersAreExplained) {
  auto message = [](auto change) {
    BilateralParams p;
    change(p);
    return p.validate().message();
  };
  EXPECT_TRUE(BilateralParams{}.validate().ok());
  EXPECT_EQ(message([](auto& p) { p.sigma_t = -1; }), "sigma_t must be > 0, got -1");
  EXPECT_EQ(message([](auto& p) { p.sigma_g = 0; }), "sigma_g must be > 0, got 0");
  EXPECT_EQ(message([](auto& p) { p.window = -1; }), "window must be >= 0, got -1");
  EXPECT_EQ(message([](auto& p) { p.iterations = 0; }), "iterations must be >= 1, got 0");
  EXPECT_EQ(message([](auto& p) { p.sigma_p = -2; }), "sigma_p must be > 0, got -2");
  EXPECT_EQ(message([](auto& p) { p.sigma_g = std::nan(""); }), "sigma_g must be > 0, got nan");

  std::mt19937_64 rng(41);
  Clip clip(test::random_motion(rng, 10, 1), 10, 1);
  BilateralJob job{BilateralParams{}, clip.io()};
  job.params.iterations = -3;
  EXPECT_EQ(job.run().message(), "iterations must be >= 1, got -3");
  EXPECT_EQ(clip.filtered, std::vector<float>(clip.filtered.size(), 0.0f));
  job.params.iterations = 1;
  job.io.frame_end = 11;
  EXPECT_NE(job.validate().message().find("frame slice"), std::string::npos);
}

}  // namespace
}  // namespace mocap
