// mocap-library-bench: the end-to-end driver. Generates a synthetic library of a given size
// (random smooth motions with noise, fixed seed), or takes a library file (--library), then runs
// `mocap-clean filter` on it (HDF5 -> HDF5) and, with --paths clean, `mocap-clean clean` on its
// BVH export (BVH -> BVH, the export made once beforehand), for each method x pop stage x
// compression (filter only) x thread count as a child process, and prints one JSON line per
// configuration, the run of median wall time of --repeat:
// {"path", "method", "pops", "compression", "threads", "clips", "joint_frames", "seconds",
//  "joint_frames_per_second", "peak_rss_mb", "runs", "stages"} (wall time and peak RSS of the
// child; "stages": the child's --json seconds per stage, engine/run/stage_times.hpp).
#include <fcntl.h>
#include <fmt/core.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "core/quaternion.hpp"
#include "io/library_writer.hpp"

namespace {

namespace fs = std::filesystem;
using namespace mocap;

std::shared_ptr<const Skeleton> chain_skeleton(int joints) {
  auto s = std::make_shared<Skeleton>();
  for (int j = 0; j < joints; ++j) {
    s->joint_names.push_back("joint" + std::to_string(j));
    s->parents.push_back(j == 0 ? -1 : (j - 1) / 2);  // a binary tree, like limbs off a spine
    s->offsets.push_back({0, j == 0 ? 0.0 : 10.0, 0});
    std::vector<Channel> channels;
    if (j == 0) channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
    channels.insert(channels.end(), {Channel::Zrotation, Channel::Yrotation, Channel::Xrotation});
    s->channels.push_back(channels);
    s->end_sites.push_back(std::nullopt);
  }
  return s;
}

// A smooth random motion per joint (three sinusoids in the tangent space) with gaussian jitter.
Clip synthetic_clip(std::mt19937_64& rng, const std::shared_ptr<const Skeleton>& skeleton,
                    int frames) {
  const int J = skeleton->joint_count();
  Clip clip;
  clip.skeleton = skeleton;
  clip.frame_time = 1.0 / 120;
  clip.frames = frames;
  clip.rotations.resize(std::size_t(frames) * J * 4);
  clip.translations.resize(std::size_t(frames) * J * 3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> n(0, 0.01);
  for (int j = 0; j < J; ++j) {
    const Vec3 a{u(rng), u(rng), u(rng)},
        f{0.02 + 0.03 * std::abs(u(rng)), 0.02 + 0.03 * std::abs(u(rng)),
          0.02 + 0.03 * std::abs(u(rng))};
    for (int t = 0; t < frames; ++t) {
      const Vec3 v{a.x * std::sin(f.x * t) + n(rng), a.y * std::sin(f.y * t) + n(rng),
                   a.z * std::sin(f.z * t) + n(rng)};
      store_quat(exp(v), clip.rotation_span().at(t, j));
      store_vec3(j == 0 ? Vec3{0, 90, 0.5 * t} : skeleton->offsets[j],
                 clip.translation_span().at(t, j));
    }
  }
  make_hemisphere_continuous(clip.rotation_span());
  return clip;
}

struct ChildResult {
  int exit_code = -1;
  double seconds = 0;
  double peak_rss_mb = 0;
};

// Runs args[0] with `args`; its stdout goes to `stdout_path` (empty: /dev/null), stderr to
// /dev/null.
ChildResult run_child(const std::vector<std::string>& args, const std::string& stdout_path = {}) {
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const int devnull = open("/dev/null", O_WRONLY);
    const int out = stdout_path.empty()
                        ? devnull
                        : open(stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (devnull < 0 || out < 0) _exit(126);
    dup2(devnull, STDERR_FILENO);
    dup2(out, STDOUT_FILENO);
    execv(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  ChildResult r;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.peak_rss_mb = double(usage.ru_maxrss) / 1024.0;  // kilobytes on Linux
  return r;
}

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mocap-library-bench: end-to-end `mocap-clean filter` throughput on a synthetic library"};
  int clips = 200, frames = 1000, joints = 31, repeat = 3;
  std::string methods = "bof,nlpm,gaussian", compressions = "none,lz4,deflate", threads = "1,2";
  std::string pops = "off", paths = "filter", library_file;
  std::string cli = (fs::path(argv[0]).parent_path() / ".." / "app" / "mocap-clean").string();
  std::string workdir = (fs::temp_directory_path() / "mocap-library-bench").string();
  app.add_option("--clips", clips, "clips in the synthetic library")->capture_default_str();
  app.add_option("--frames", frames, "frames per clip")->capture_default_str();
  app.add_option("--joints", joints, "joints per clip")->capture_default_str();
  app.add_option("--methods", methods, "comma-separated methods")->capture_default_str();
  app.add_option("--compression", compressions, "comma-separated output compressions")
      ->capture_default_str();
  app.add_option("--threads", threads, "comma-separated thread counts")->capture_default_str();
  app.add_option(
         "--pops", pops,
         "comma-separated pop stages (off: the filter alone; auto: clean's default; default: no "
         "--pops, the method's own default)")
      ->capture_default_str();
  app.add_option("--repeat", repeat, "runs per configuration (the median is printed)")
      ->capture_default_str();
  app.add_option("--paths", paths,
                 "comma-separated paths: filter (HDF5 -> HDF5), clean (BVH -> BVH)")
      ->capture_default_str();
  app.add_option("--library", library_file,
                 "a library file to run on instead of the synthetic one (e.g. the replicated "
                 "CMU clips of bench/replicate_library.py)");
  app.add_option("--cli", cli, "the mocap-clean executable")->capture_default_str();
  app.add_option("--workdir", workdir, "where the library and outputs go")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  for (const std::string& path : split_list(paths))
    if (path != "filter" && path != "clean") {
      fmt::print(stderr, "mocap-library-bench: --paths: unknown path '{}' (filter, clean)\n", path);
      return 2;
    }

  fs::create_directories(workdir);
  fs::path library = fs::path(workdir) / "library.h5";
  double joint_frames = double(clips) * frames * joints;
  if (!library_file.empty()) {
    library = library_file;
    // The size of the given library, from `mocap-clean info --json`.
    const fs::path info = fs::path(workdir) / "info.json";
    if (run_child({cli, "info", library.string(), "--json"}, info.string()).exit_code != 0) {
      fmt::print(stderr, "mocap-library-bench: mocap-clean info {} failed\n", library.string());
      return 1;
    }
    std::ifstream in(info);
    const nlohmann::json summary = nlohmann::json::parse(in, nullptr, false);
    if (summary.is_discarded() || !summary.contains("joint_frames") || !summary.contains("clips")) {
      fmt::print(stderr, "mocap-library-bench: cannot read {}'s size from {}\n", library.string(),
                 info.string());
      return 1;
    }
    joint_frames = summary["joint_frames"].get<double>();
    clips =
        summary["clips"].is_number() ? summary["clips"].get<int>() : int(summary["clips"].size());
  } else {
    std::mt19937_64 rng(1);
    const auto skeleton = chain_skeleton(joints);
    std::string error;
    auto writer = io::LibraryWriter::create(library, io::Compression::none, &error);
    if (!writer) {
      fmt::print(stderr, "{}\n", error);
      return 2;
    }
    for (int c = 0; c < clips; ++c)
      if (!writer->write_clip(fmt::format("bench/{:03d}/clip{:06d}", c % 100, c),
                              synthetic_clip(rng, skeleton, frames), &error)) {
        fmt::print(stderr, "{}\n", error);
        return 2;
      }
    writer->close(nullptr);
  }
  // BVH -> BVH reads the library's BVH export.
  const fs::path bvh_in = fs::path(workdir) / "bvh-in";
  if (paths.find("clean") != std::string::npos) {
    fs::remove_all(bvh_in);
    if (run_child({cli, "export", library.string(), "-o", bvh_in.string()}).exit_code != 0) {
      fmt::print(stderr, "mocap-library-bench: mocap-clean export {} failed\n", library.string());
      return 1;
    }
  }
  for (const std::string& path : split_list(paths)) {
    for (const std::string& method : split_list(methods)) {
      for (const std::string& pop_stage : split_list(pops)) {
        // BVH output has no compression: one configuration.
        const std::vector<std::string> codecs =
            path == "clean" ? std::vector<std::string>{""} : split_list(compressions);
        for (const std::string& compression : codecs) {
          for (const std::string& t : split_list(threads)) {
            std::vector<std::pair<ChildResult, nlohmann::json>> runs;
            for (int r = 0; r < repeat; ++r) {
              const fs::path out = fs::path(workdir) / (path == "clean" ? "out-bvh" : "out.h5");
              fs::remove_all(out);
              fs::remove_all(out.string() + ".parts");
              std::vector<std::string> args = {cli, path};
              if (path == "clean")
                args.insert(args.end(), {bvh_in.string(), "-o", out.string()});
              else
                args.insert(args.end(),
                            {library.string(), "-o", out.string(), "--compression", compression});
              args.insert(args.end(),
                          {"--method", method, "--threads", t, "--no-progress", "--json"});
              if (pop_stage != "default") args.insert(args.end(), {"--pops", pop_stage});
              if (method == "nlpm") args.insert(args.end(), {"--h", "0.03"});
              const fs::path summary_path = fs::path(workdir) / "summary.json";
              const ChildResult result = run_child(args, summary_path.string());
              if (result.exit_code != 0) {
                fmt::print(stderr, "mocap-library-bench: {} {} failed with exit status {}\n", path,
                           method, result.exit_code);
                return 1;
              }
              std::ifstream in(summary_path);
              const nlohmann::json summary = nlohmann::json::parse(in, nullptr, false);
              runs.push_back({result, !summary.is_discarded() && summary.contains("stages")
                                          ? summary["stages"]
                                          : nlohmann::json(nullptr)});
            }
            std::sort(runs.begin(), runs.end(), [](const auto& a, const auto& b) {
              return a.first.seconds < b.first.seconds;
            });
            const auto& [median, stages] = runs[runs.size() / 2];
            nlohmann::json line = {{"path", path},
                                   {"method", method},
                                   {"pops", pop_stage},
                                   {"compression", path == "clean" ? nlohmann::json(nullptr)
                                                                   : nlohmann::json(compression)},
                                   {"threads", std::stoi(t)},
                                   {"clips", clips},
                                   {"joint_frames", joint_frames},
                                   {"seconds", median.seconds},
                                   {"joint_frames_per_second", joint_frames / median.seconds},
                                   {"peak_rss_mb", median.peak_rss_mb},
                                   {"runs", repeat},
                                   {"stages", stages}};
            fmt::print("{}\n", line.dump());
            std::fflush(stdout);
          }
        }
      }
    }
  }
  return 0;
}
