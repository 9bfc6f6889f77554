// Micro-benchmarks of the filter kernels, scalar reference against Highway SIMD (the active
// target), in joint-frames per second (items_per_second). Each benchmark filters one synthetic
// clip (smooth random motion plus 0.03 rad noise) per iteration.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/foot_lock.hpp"
#include "kernels/forward_kinematics.hpp"
#include "kernels/hinge_projection.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/median.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/nlpm.hpp"
#include "kernels/noise_model.hpp"
#include "kernels/pop_detour.hpp"
#include "kernels/pop_hinge.hpp"
#include "kernels/pop_repair.hpp"
#include "kernels/pop_screen.hpp"
#include "kernels/simd/band_geodesics.hpp"
#include "kernels/simd/quat_batch.hpp"

namespace mocap {
namespace {

// Smooth random motion (a few sinusoids in the tangent space of a random base rotation per
// joint) plus gaussian noise; hemisphere-continuous.
std::vector<float> synthetic_motion(int frames, int joints, std::uint64_t seed = 7) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<float> out(std::size_t(frames) * std::size_t(joints) * 4);
  for (int j = 0; j < joints; ++j) {
    const Quat base = normalized({g(rng), g(rng), g(rng), g(rng)});
    const Vec3 amplitude{0.6 * u(rng), 0.6 * u(rng), 0.6 * u(rng)};
    const Vec3 frequency{0.05 * std::abs(u(rng)), 0.05 * std::abs(u(rng)), 0.05 * std::abs(u(rng))};
    for (int t = 0; t < frames; ++t) {
      const Vec3 v{amplitude.x * std::sin(frequency.x * t), amplitude.y * std::sin(frequency.y * t),
                   amplitude.z * std::sin(frequency.z * t + 1)};
      store_quat(base * exp(v), out.data() + (std::size_t(t) * std::size_t(joints) + j) * 4);
    }
  }
  add_noise(GaussianNoise{0.03, seed}, {out.data(), frames, joints});
  make_hemisphere_continuous({out.data(), frames, joints});
  return out;
}

struct Fixture {
  int frames, joints;
  std::vector<float> in, out;
  MotionIO io;
  Fixture(int f, int j) : frames(f), joints(j), in(synthetic_motion(f, j)), out(in.size()) {
    io.rotations = {in.data(), f, j};
    io.filtered_rotations = {out.data(), f, j};
  }
  void count(benchmark::State& state) const {
    state.SetItemsProcessed(state.iterations() * std::int64_t(frames) * joints);
    state.SetLabel(std::string(simd::active_target()));
  }
};

Implementation implementation_of(const benchmark::State& state) {
  return state.range(0) == 0 ? Implementation::reference : Implementation::fast;
}

// Args: implementation (0 reference, 1 fast), joints, frames.
void BM_Bof(benchmark::State& state) {
  Fixture f(int(state.range(2)), int(state.range(1)));
  const BilateralJob job{BilateralParams{}, f.io, implementation_of(state)};
  for (auto _ : state) {
    job.run();
    benchmark::DoNotOptimize(f.out.data());
  }
  f.count(state);
}
// 31 joints (CMU) x 1000 frames, and Courty's example: 75 joints x 150 frames.
BENCHMARK(BM_Bof)
    ->ArgNames({"fast", "J", "F"})
    ->Args({0, 31, 1000})
    ->Args({1, 31, 1000})
    ->Args({0, 75, 150})
    ->Args({1, 75, 150})
    ->Unit(benchmark::kMillisecond);

void BM_Nlpm(benchmark::State& state) {
  Fixture f(int(state.range(2)), int(state.range(1)));
  NlpmParams params;
  params.h = 0.03;
  const NlpmJob job{params, f.io, {}, implementation_of(state)};
  for (auto _ : state) {
    job.run();
    benchmark::DoNotOptimize(f.out.data());
  }
  f.count(state);
}
BENCHMARK(BM_Nlpm)
    ->ArgNames({"fast", "J", "F"})
    ->Args({0, 31, 1000})
    ->Args({1, 31, 1000})
    ->Unit(benchmark::kMillisecond);

// The pop stage (detect and repair) on the same motion; the fast path runs the residual fits of
// whole-window samples in double lanes.
void BM_PopRepair(benchmark::State& state) {
  Fixture f(int(state.range(2)), int(state.range(1)));
  PopRepairJob job;
  job.io = f.io;
  job.implementation = implementation_of(state);
  job.screen = state.range(3) != 0;  // kernels/pop_screen.hpp: the same flags
  for (auto _ : state) {
    job.run();
    benchmark::DoNotOptimize(f.out.data());
  }
  f.count(state);
}
BENCHMARK(BM_PopRepair)
    ->ArgNames({"fast", "J", "F", "screen"})
    ->Args({0, 31, 1000, 0})
    ->Args({1, 31, 1000, 0})
    ->Args({1, 31, 1000, 1})
    ->Unit(benchmark::kMillisecond);

// The pop screen's bound alone (kernels/pop_screen.hpp), every joint of the same motion: the part
// of the pop stage that every sample pays.
void BM_PopScreenBounds(benchmark::State& state) {
  Fixture f(int(state.range(2)), int(state.range(1)));
  const PopScreen screen{PopRepairParams{}};
  std::vector<std::vector<Quat>> curves(std::size_t(f.joints));
  for (int j = 0; j < f.joints; ++j)
    for (int t = 0; t < f.frames; ++t)
      curves[std::size_t(j)].push_back(load_quat(f.io.rotations.at(t, j)));
  std::vector<double> bounds(std::size_t(f.frames));
  for (auto _ : state) {
    for (const std::vector<Quat>& curve : curves)
      pop_residual_bounds(curve, screen, bounds, implementation_of(state));
    benchmark::DoNotOptimize(bounds.data());
  }
  f.count(state);
}
BENCHMARK(BM_PopScreenBounds)
    ->ArgNames({"fast", "J", "F"})
    ->Args({0, 31, 1000})
    ->Args({1, 31, 1000})
    ->Unit(benchmark::kMillisecond);

// The median as the noise estimate takes it: of the second differences' components of one joint
// (3 (F - 2) values, gaussian), copied afresh each time. Args: implementation, values.
void BM_Median(benchmark::State& state) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 0.01);
  std::vector<double> sample(std::size_t(state.range(1)));
  for (double& x : sample) x = g(rng);
  std::vector<double> work;
  for (auto _ : state) {
    work = sample;
    benchmark::DoNotOptimize(state.range(0) == 0 ? median_reference(work) : median(work));
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(sample.size()));
}
BENCHMARK(BM_Median)->ArgNames({"fast", "n"})->Args({0, 3400})->Args({1, 3400})->Args({1, 12000});

// The detour test of a pop (the low-rate pop stage's second test, kernels/pop_detour.hpp) on the
// same motion: measuring its own step angles (steps 0), or reading them from the joint
// classification's (steps 1), as the conditioning runs it.
void BM_PopDetour(benchmark::State& state) {
  Fixture f(int(state.range(1)), int(state.range(0)));
  std::vector<std::uint8_t> flags(std::size_t(f.frames) * std::size_t(f.joints));
  std::vector<double> angles(std::size_t(f.frames - 1) * std::size_t(f.joints));
  for (int j = 0; j < f.joints; ++j)
    for (int t = 0; t + 1 < f.frames; ++t)
      angles[std::size_t(j) * std::size_t(f.frames - 1) + std::size_t(t)] =
          geodesic(load_quat(f.io.rotations.at(t, j)), load_quat(f.io.rotations.at(t + 1, j)));
  const StepAngles steps{angles, f.frames, f.joints};
  PopDetourJob job;
  job.rotations = f.io.rotations;
  job.flags = flags;
  job.threshold = pop_detour_threshold(1.0 / 30);
  if (state.range(2) != 0) job.steps = &steps;
  for (auto _ : state) {
    job.run();
    benchmark::DoNotOptimize(flags.data());
  }
  f.count(state);
}
BENCHMARK(BM_PopDetour)
    ->ArgNames({"J", "F", "steps"})
    ->Args({31, 1000, 0})
    ->Args({31, 1000, 1})
    ->Unit(benchmark::kMillisecond);

// A motion whose joints turn about one axis each (base Exp(theta(t) a), 1 rad of swing, as CMU's
// knees and elbows do), but every third joint, which turns about three (sinusoids in its tangent
// space); then `noise` (kernels/noise_model.hpp). Hemisphere-continuous.
template <class Noise>
std::vector<float> hinge_motion(int frames, int joints, const Noise& noise) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<float> out(std::size_t(frames) * std::size_t(joints) * 4);
  for (int j = 0; j < joints; ++j) {
    const Quat base = normalized({g(rng), g(rng), g(rng), g(rng)});
    const Vec3 a = [&] {
      const Vec3 v{g(rng), g(rng), g(rng)};
      return (1 / norm(v)) * v;
    }();
    for (int t = 0; t < frames; ++t) {
      const Vec3 v = j % 3 == 2 ? Vec3{0.5 * std::sin(0.03 * t), 0.4 * std::sin(0.05 * t + j),
                                       0.3 * std::sin(0.02 * t + 1)}
                                : std::sin(0.04 * t + j) * a;
      store_quat(base * exp(v), out.data() + (std::size_t(t) * std::size_t(joints) + j) * 4);
    }
  }
  add_noise(noise, {out.data(), frames, joints});
  make_hemisphere_continuous({out.data(), frames, joints});
  return out;
}

// The hinge test of a pop (kernels/pop_hinge.hpp), 31 joints x 1000 frames: on the noisy fixture
// (hinges 0: every joint ruled out on its probe, what a noisy library costs), or on exact hinges
// with the spec's pops (hinges 1: 21 joints found and tested over every frame, the worst case).
void BM_PopHinge(benchmark::State& state) {
  const int frames = 1000, joints = 31;
  Fixture f(frames, joints);
  if (state.range(0) != 0) {
    f.in = hinge_motion(frames, joints, ImpulseNoise{});
    f.io.rotations = {f.in.data(), frames, joints};
  }
  std::vector<std::uint8_t> flags(std::size_t(frames) * std::size_t(joints));
  PopHingeJob job;
  job.rotations = f.io.rotations;
  job.flags = flags;
  for (auto _ : state) {
    job.run();
    benchmark::DoNotOptimize(flags.data());
  }
  f.count(state);
}
BENCHMARK(BM_PopHinge)->ArgNames({"hinges"})->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// auto's hinge projection (kernels/hinge_projection.hpp), 31 joints x 1000 frames with 0.008 rad
// of noise, the filter's output standing in as its input: on the noisy fixture (hinges 0: every
// joint ruled out by the chordal screen) or on 21 noisy hinges (hinges 1: fitted and projected).
void BM_HingeProjection(benchmark::State& state) {
  const int frames = 1000, joints = 31;
  Fixture f(frames, joints);
  if (state.range(0) != 0) {
    f.in = hinge_motion(frames, joints, GaussianNoise{0.008, 3});
    f.io.rotations = {f.in.data(), frames, joints};
  }
  HingeProjectionJob job;
  job.input = f.io.rotations;
  job.output = f.io.filtered_rotations;
  job.noise_sigma = 0.008;
  for (auto _ : state) {
    state.PauseTiming();
    std::copy(f.in.begin(), f.in.end(), f.out.begin());
    state.ResumeTiming();
    job.run();
    benchmark::DoNotOptimize(f.out.data());
  }
  f.count(state);
}
BENCHMARK(BM_HingeProjection)->ArgNames({"hinges"})->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// Forward kinematics of the bof fixture's motion on a random 31-joint tree with a translated
// root, 1000 frames: every joint (as the motion guard and eval measure positions), or the two
// deepest joints' chains only (output_joints, as the foot stage reads the ankles). Args:
// implementation (0 reference, 1 fast), all joints (1) or two chains (0).
void BM_ForwardKinematics(benchmark::State& state) {
  const int frames = 1000, joints = 31;
  Fixture f(frames, joints);
  std::mt19937_64 rng(3);
  std::vector<int> parents{-1};
  std::vector<Vec3> offsets{{0, 0, 0}};
  for (int j = 1; j < joints; ++j) {
    parents.push_back(j < 4 ? j - 1 : int(rng() % std::uint64_t(j)));
    offsets.push_back({0.1, -0.2, 0.05});
  }
  std::vector<float> translations(std::size_t(frames) * joints * 3, 1.0f);
  std::vector<std::uint8_t> translated(joints, 0);
  translated[0] = 1;
  const std::vector<int> two_chains{joints - 1, joints - 2};
  const bool all = state.range(1) != 0;
  std::vector<float> positions(std::size_t(frames) * (all ? joints : 2) * 3);
  ForwardKinematicsJob fk;
  fk.parents = parents;
  fk.offsets = offsets;
  fk.rotations = {f.in.data(), frames, joints};
  fk.translations = {translations.data(), frames, joints};
  fk.translated_joints = translated;
  if (!all) fk.output_joints = two_chains;
  fk.positions = {positions.data(), frames, all ? joints : 2};
  fk.implementation = implementation_of(state);
  for (auto _ : state) {
    if (!fk.run().ok()) state.SkipWithError("forward kinematics failed");
    benchmark::DoNotOptimize(positions.data());
  }
  f.count(state);
}
BENCHMARK(BM_ForwardKinematics)
    ->ArgNames({"fast", "all"})
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({0, 0})
    ->Args({1, 0})
    ->Unit(benchmark::kMicrosecond);

// Foot locking (docs/feet.md) on the bof fixture's motion, 31 joints x 1000 frames: a chain
// skeleton with two legs (hip, knee, ankle, toe), each with four contacts of 150 frames (60 % of
// the clip locked). Each iteration restores the joints the lock writes (the legs' hips, knees and
// ankles), then locks them in place; compare with BM_Bof/fast:1/J:31/F:1000. Args: implementation
// (0 reference, 1 fast); scratch kept across runs; input: 0, one median pin per contact, 1, pins
// that follow the input's feet (input_anchors from the fixture's input motion, as the engine runs
// it).
void BM_FootLock(benchmark::State& state) {
  const int frames = 1000, joints = 31;
  Fixture f(frames, joints);
  std::vector<int> parents(joints);
  std::vector<Vec3> offsets(joints, Vec3{0, 0.1, 0});
  for (int j = 0; j < joints; ++j) parents[std::size_t(j)] = j - 1;  // a spine chain...
  const int legs_begin = joints - 8;
  for (int side = 0; side < 2; ++side) {  // ...and two legs from the root
    const int hip = legs_begin + 4 * side;
    parents[std::size_t(hip)] = 0;
    offsets[std::size_t(hip)] = {side ? -0.1 : 0.1, 0, 0};
    for (int k = 1; k < 4; ++k) {
      parents[std::size_t(hip + k)] = hip + k - 1;
      offsets[std::size_t(hip + k)] = k < 3 ? Vec3{0, -0.45, 0} : Vec3{0, -0.05, 0.12};
    }
  }
  std::vector<FootChain> legs;
  for (int side = 0; side < 2; ++side) {
    const int hip = legs_begin + 4 * side;
    legs.push_back({hip, hip + 1, hip + 2, hip + 3, side ? 'R' : 'L'});
  }
  std::vector<std::vector<ContactInterval>> contacts(2);
  for (int c = 0; c < 4; ++c) {
    contacts[0].push_back({c * 250, c * 250 + 150});
    contacts[1].push_back({c * 250 + 100, c * 250 + 250});
  }
  std::vector<float> translations(std::size_t(frames) * joints * 3, 0.0f);
  FootLockJob job;
  job.parents = parents;
  job.offsets = offsets;
  job.frame_time = 1.0 / 120;
  job.rotations = {f.out.data(), frames, joints};
  job.translations = {translations.data(), frames, joints};
  job.legs = legs;
  job.contacts = contacts;
  job.implementation = implementation_of(state);
  // scratch:1, as the engine runs it: one FootLockScratch kept across runs (clips).
  FootLockScratch scratch;
  if (state.range(1) != 0) job.scratch = &scratch;
  std::vector<float> anchors;
  if (state.range(2) != 0) {
    std::vector<int> points;
    for (const FootChain& leg : legs) points.insert(points.end(), {leg.ankle, leg.toe});
    anchors.resize(std::size_t(frames) * points.size() * 3);
    ForwardKinematicsJob fk;
    fk.parents = parents;
    fk.offsets = offsets;
    fk.rotations = {f.in.data(), frames, joints};
    fk.translations = {translations.data(), frames, joints};
    fk.output_joints = points;
    fk.positions = {anchors.data(), frames, int(points.size())};
    if (!fk.run().ok()) state.SkipWithError("forward kinematics failed");
    job.input_anchors = anchors;
    job.body_height = 1.8;
  }
  std::vector<int> written;
  for (const FootChain& leg : legs) written.insert(written.end(), {leg.hip, leg.knee, leg.ankle});
  std::copy(f.in.begin(), f.in.end(), f.out.begin());
  for (auto _ : state) {
    for (int t = 0; t < frames; ++t)
      for (int j : written) {
        const std::size_t at = (std::size_t(t) * joints + std::size_t(j)) * 4;
        std::copy(f.in.begin() + std::ptrdiff_t(at), f.in.begin() + std::ptrdiff_t(at + 4),
                  f.out.begin() + std::ptrdiff_t(at));
      }
    if (!job.run().ok()) state.SkipWithError("foot lock failed");
    benchmark::DoNotOptimize(f.out.data());
  }
  f.count(state);
}
BENCHMARK(BM_FootLock)
    ->ArgNames({"fast", "scratch", "input"})
    ->Args({0, 0, 0})
    ->Args({1, 0, 0})
    ->Args({1, 1, 0})
    ->Args({0, 0, 1})
    ->Args({1, 1, 1})
    ->Unit(benchmark::kMillisecond);

void BM_Gaussian(benchmark::State& state) {
  Fixture f(int(state.range(2)), int(state.range(1)));
  const LinearFilterJob job{LinearParams{}, f.io, implementation_of(state)};
  for (auto _ : state) {
    job.run();
    benchmark::DoNotOptimize(f.out.data());
  }
  f.count(state);
}
BENCHMARK(BM_Gaussian)
    ->ArgNames({"fast", "J", "F"})
    ->Args({0, 31, 1000})
    ->Args({1, 31, 1000})
    ->Unit(benchmark::kMillisecond);

// The band of geodesic distances d(q_t, q_{t+r}), 1 <= r <= k, of every joint: the layout
// decision. Args: layout (0 scalar double, 1 lanes = time, 2 lanes = joints), joints, frames, k.
void BM_BandGeodesics(benchmark::State& state) {
  Fixture f(int(state.range(2)), int(state.range(1)));
  const int k = int(state.range(3));
  std::vector<float> out;
  std::vector<double> scalar(std::size_t(f.frames) * std::size_t(f.joints) * std::size_t(k));
  for (auto _ : state) {
    switch (state.range(0)) {
      case 0: {
        const RotationView view = f.io.rotations;
        std::size_t i = 0;
        for (int j = 0; j < f.joints; ++j)
          for (int r = 1; r <= k; ++r)
            for (int t = 0; t + r < f.frames; ++t)
              scalar[i++] = geodesic(load_quat(view.at(t, j)), load_quat(view.at(t + r, j)));
        benchmark::DoNotOptimize(scalar.data());
        break;
      }
      case 1:
        simd::band_geodesics_lanes_time(f.io.rotations, k, out);
        break;
      default:
        simd::band_geodesics_lanes_joints(f.io.rotations, k, out);
    }
    benchmark::DoNotOptimize(out.data());
  }
  f.count(state);
}
BENCHMARK(BM_BandGeodesics)
    ->ArgNames({"layout", "J", "F", "k"})
    ->ArgsProduct({{0, 1, 2}, {31, 8, 5}, {1000}, {3, 10}});

// Log and Exp of 4096 samples: scalar double (quaternion.hpp) against the vector batch.
// Arg: 0 scalar, 1 SIMD. Items: samples.
void BM_Log(benchmark::State& state) {
  const std::size_t n = 4096;
  const std::vector<float> q = synthetic_motion(int(n), 1);
  std::vector<float> planes(4 * n), out(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t c = 0; c < 4; ++c) planes[c * n + i] = q[4 * i + c];
  for (auto _ : state) {
    if (state.range(0) == 0) {
      for (std::size_t i = 0; i < n; ++i) {
        const Vec3 v = log(load_quat(&q[4 * i]));
        out[i] = float(v.x);
        out[n + i] = float(v.y);
        out[2 * n + i] = float(v.z);
      }
    } else {
      simd::log_planes(planes, out, n);
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(n));
}
BENCHMARK(BM_Log)->Arg(0)->Arg(1);

void BM_Exp(benchmark::State& state) {
  const std::size_t n = 4096;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 0.5);
  std::vector<float> planes(3 * n), out(4 * n);
  for (float& x : planes) x = float(g(rng));
  for (auto _ : state) {
    if (state.range(0) == 0) {
      for (std::size_t i = 0; i < n; ++i) {
        const Quat q = exp(Vec3{planes[i], planes[n + i], planes[2 * n + i]});
        out[i] = float(q.w);
        out[n + i] = float(q.x);
        out[2 * n + i] = float(q.y);
        out[3 * n + i] = float(q.z);
      }
    } else {
      simd::exp_planes(planes, out, n);
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * std::int64_t(n));
}
BENCHMARK(BM_Exp)->Arg(0)->Arg(1);

}  // namespace
}  // namespace mocap
