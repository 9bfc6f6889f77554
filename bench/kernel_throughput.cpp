// mocap-bench: kernel throughput on an in-memory synthetic library. Generates C clips of J joints
// x F frames (smooth random motions plus 0.03 rad gaussian noise, fixed seed), then filters them
// `repeat` times on T threads, sharded as the engine does (clip x joint block for bof and the
// linear filters, clip x time block for nlpm), and prints one JSON line:
//   {"method", "threads", "joint_frames", "seconds", "joint_frames_per_second", "implementation",
//    "target", "repeats", "seconds_all", "cpu_seconds"}
// where seconds is the median over the repeats of the kernel time alone (the jobs' own scratch
// memory included, the generation of the library excluded). The process keeps freed memory for
// reuse as mocap-clean does (engine/run/process_memory.hpp), so that the kernels' per-shard
// working blocks are not page-faulted afresh here when they are not in the program.
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <time.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/quaternion.hpp"
#include "engine/run/process_memory.hpp"
#include "kernels/bilateral.hpp"
#include "kernels/linear_filter.hpp"
#include "kernels/nlpm.hpp"
#include "kernels/noise_model.hpp"
#include "kernels/simd/quat_batch.hpp"

namespace {

using namespace mocap;

struct Options {
  std::string method = "bof";
  int joints = 31, frames = 1000, clips = 16, threads = 1, repeat = 5;
  int shard_joints = 8, shard_frames = 256;
  double h = 0.03;
  bool reference = false;
};

std::vector<float> synthetic_clip(int frames, int joints, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<float> out(std::size_t(frames) * std::size_t(joints) * 4);
  for (int j = 0; j < joints; ++j) {
    const Quat base = normalized({g(rng), g(rng), g(rng), g(rng)});
    Vec3 amplitude[3], frequency, phase;
    for (Vec3& a : amplitude) a = {0.4 * u(rng), 0.4 * u(rng), 0.4 * u(rng)};
    frequency = {0.05 * std::abs(u(rng)), 0.05 * std::abs(u(rng)), 0.05 * std::abs(u(rng))};
    phase = {3 * u(rng), 3 * u(rng), 3 * u(rng)};
    for (int t = 0; t < frames; ++t) {
      const Vec3 v = std::sin(frequency.x * t + phase.x) * amplitude[0] +
                     std::sin(frequency.y * t + phase.y) * amplitude[1] +
                     std::sin(frequency.z * t + phase.z) * amplitude[2];
      store_quat(base * exp(v), out.data() + (std::size_t(t) * std::size_t(joints) + j) * 4);
    }
  }
  add_noise(GaussianNoise{0.03, rng()}, {out.data(), frames, joints});
  make_hemisphere_continuous({out.data(), frames, joints});
  return out;
}

// One shard: a clip's joint block [joint_begin, joint_end) x time block [frame_begin, frame_end).
struct Shard {
  int clip, joint_begin, joint_end, frame_begin, frame_end;
};

std::vector<Shard> plan(const Options& o) {
  std::vector<Shard> shards;
  for (int c = 0; c < o.clips; ++c) {
    if (o.method == "nlpm")
      for (int f = 0; f < o.frames; f += o.shard_frames)
        shards.push_back({c, 0, o.joints, f, std::min(o.frames, f + o.shard_frames)});
    else
      for (int j = 0; j < o.joints; j += o.shard_joints)
        shards.push_back({c, j, std::min(o.joints, j + o.shard_joints), 0, o.frames});
  }
  return shards;
}

Status run_shard(const Options& o, const Shard& s, const std::vector<float>& in,
                 std::vector<float>& out) {
  MotionIO io;
  io.rotations = {in.data(), o.frames, o.joints};
  io.filtered_rotations = {out.data(), o.frames, o.joints};
  io.joint_begin = s.joint_begin;
  io.joint_end = s.joint_end;
  io.frame_begin = s.frame_begin;
  io.frame_end = s.frame_end;
  const Implementation impl = o.reference ? Implementation::reference : Implementation::fast;
  if (o.method == "bof") return BilateralJob{BilateralParams{}, io, impl}.run();
  if (o.method == "nlpm") {
    NlpmParams p;
    p.h = o.h;
    return NlpmJob{p, io, {}, impl}.run();
  }
  return LinearFilterJob{LinearParams{}, io, impl}.run();
}

}  // namespace

int main(int argc, char** argv) {
  mocap::engine::keep_freed_memory_for_reuse();
  Options o;
  CLI::App app{"mocap-bench: filter kernel throughput on an in-memory synthetic library"};
  app.add_option("--method", o.method, "bof | nlpm | gaussian")
      ->check(CLI::IsMember({"bof", "nlpm", "gaussian"}));
  app.add_option("--joints", o.joints, "joints per clip")->check(CLI::PositiveNumber);
  app.add_option("--frames", o.frames, "frames per clip")->check(CLI::Range(2, 10'000'000));
  app.add_option("--clips", o.clips, "clips in the library")->check(CLI::PositiveNumber);
  app.add_option("--threads", o.threads, "worker threads")->check(CLI::PositiveNumber);
  app.add_option("--repeat", o.repeat, "timed runs (the median is reported)")
      ->check(CLI::PositiveNumber);
  app.add_option("--h", o.h, "nlpm strength h, rad")->check(CLI::PositiveNumber);
  app.add_option("--shard-joints", o.shard_joints, "joints per task (bof, gaussian)")
      ->check(CLI::PositiveNumber);
  app.add_option("--shard-frames", o.shard_frames, "frames per task (nlpm)")
      ->check(CLI::PositiveNumber);
  app.add_flag("--reference", o.reference, "run the scalar double reference kernels");
  CLI11_PARSE(app, argc, argv);

  std::mt19937_64 rng(20260101);
  std::vector<std::vector<float>> inputs, outputs;
  for (int c = 0; c < o.clips; ++c) {
    inputs.push_back(synthetic_clip(o.frames, o.joints, rng));
    outputs.emplace_back(inputs.back().size(), 0.0f);
  }
  const std::vector<Shard> shards = plan(o);

  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(o.threads));
  // Wall time (what the targets are about) and process CPU time (to read wall times taken on a
  // machine shared with other work: joint_frames / cpu_seconds * threads is the unloaded rate).
  const auto cpu_now = [] {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
  };
  std::vector<double> seconds, cpu_seconds;
  std::atomic<bool> failed = false;
  for (int r = 0; r < o.repeat; ++r) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = cpu_now();
    tbb::parallel_for(std::size_t(0), shards.size(), [&](std::size_t i) {
      const Shard& s = shards[i];
      if (!run_shard(o, s, inputs[std::size_t(s.clip)], outputs[std::size_t(s.clip)]).ok())
        failed = true;
    });
    cpu_seconds.push_back(cpu_now() - cpu_start);
    seconds.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  if (failed) {
    std::fprintf(stderr, "mocap-bench: a shard failed\n");
    return 1;
  }
  const auto median_of = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const double median = median_of(seconds);
  const double joint_frames = double(o.joints) * o.frames * o.clips;
  const nlohmann::json line = {{"method", o.method},
                               {"threads", o.threads},
                               {"joint_frames", joint_frames},
                               {"seconds", median},
                               {"joint_frames_per_second", joint_frames / median},
                               {"implementation", o.reference ? "reference" : "fast"},
                               {"target", std::string(simd::active_target())},
                               {"repeats", o.repeat},
                               {"seconds_all", seconds},
                               {"cpu_seconds", median_of(cpu_seconds)}};
  std::printf("%s\n", line.dump().c_str());
  return 0;
}
