// mocap-library-bench: the end-to-end driver. Generates a synthetic library of a given size
// (random smooth motions with noise, fixed seed), then runs `mocap-clean filter` on it for each
// method x pop stage x compression x thread count as a child process and prints one JSON line per
// run:
// {"method", "pops", "compression", "threads", "clips", "joint_frames", "seconds",
//  "joint_frames_per_second", "peak_rss_mb"} (wall time and peak RSS of the child).
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

ChildResult run_child(const std::vector<std::string>& args) {
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const int devnull = open("/dev/null", O_WRONLY);
    dup2(devnull, STDERR_FILENO);
    dup2(devnull, STDOUT_FILENO);
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
  std::string pops = "off";
  std::string cli = (fs::path(argv[0]).parent_path() / ".." / "app" / "mocap-clean").string();
  std::string workdir = (fs::temp_directory_path() / "mocap-library-bench").string();
  app.add_option("--clips", clips, "clips in the synthetic library")->capture_default_str();
  app.add_option("--frames", frames, "frames per clip")->capture_default_str();
  app.add_option("--joints", joints, "joints per clip")->capture_default_str();
  app.add_option("--methods", methods, "comma-separated methods")->capture_default_str();
  app.add_option("--compression", compressions, "comma-separated output compressions")
      ->capture_default_str();
  app.add_option("--threads", threads, "comma-separated thread counts")->capture_default_str();
  app.add_option("--pops", pops,
                 "comma-separated pop stages (off: the filter alone; auto: clean's default)")
      ->capture_default_str();
  app.add_option("--repeat", repeat, "runs per configuration (the median is printed)")
      ->capture_default_str();
  app.add_option("--cli", cli, "the mocap-clean executable")->capture_default_str();
  app.add_option("--workdir", workdir, "where the library and outputs go")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  fs::create_directories(workdir);
  const fs::path library = fs::path(workdir) / "library.h5";
  {
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
  const double joint_frames = double(clips) * frames * joints;
  for (const std::string& method : split_list(methods)) {
    for (const std::string& pop_stage : split_list(pops)) {
      for (const std::string& compression : split_list(compressions)) {
        for (const std::string& t : split_list(threads)) {
          std::vector<ChildResult> runs;
          for (int r = 0; r < repeat; ++r) {
            const fs::path out = fs::path(workdir) / "out.h5";
            fs::remove(out);
            fs::remove_all(out.string() + ".parts");
            std::vector<std::string> args = {
                cli,        "filter",        library.string(), "-o",        out.string(),
                "--method", method,          "--compression",  compression, "--threads",
                t,          "--no-progress", "--pops",         pop_stage};
            if (method == "nlpm") args.insert(args.end(), {"--h", "0.03"});
            runs.push_back(run_child(args));
            if (runs.back().exit_code != 0) {
              fmt::print(stderr, "mocap-library-bench: {} failed with exit status {}\n", method,
                         runs.back().exit_code);
              return 1;
            }
          }
          std::sort(runs.begin(), runs.end(),
                    [](const auto& a, const auto& b) { return a.seconds < b.seconds; });
          const ChildResult& median = runs[runs.size() / 2];
          nlohmann::json line = {{"method", method},
                                 {"pops", pop_stage},
                                 {"compression", compression},
                                 {"threads", std::stoi(t)},
                                 {"clips", clips},
                                 {"joint_frames", joint_frames},
                                 {"seconds", median.seconds},
                                 {"joint_frames_per_second", joint_frames / median.seconds},
                                 {"peak_rss_mb", median.peak_rss_mb},
                                 {"runs", repeat}};
          fmt::print("{}\n", line.dump());
          std::fflush(stdout);
        }
      }
    }
  }
  return 0;
}
