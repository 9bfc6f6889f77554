// The engine's promises: output identical for any thread count and shard size, failures isolated
// to their clip, and a killed run that --resume completes without losing or redoing clips.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <thread>

#include "engine/clip/filter_settings.hpp"
#include "io/library_reader.hpp"
#include "io/library_writer.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

std::shared_ptr<const Skeleton> chain_skeleton(int joints) {
  auto s = std::make_shared<Skeleton>();
  for (int j = 0; j < joints; ++j) {
    s->joint_names.push_back("j" + std::to_string(j));
    s->parents.push_back(j - 1);
    s->offsets.push_back({0, j == 0 ? 0.0 : 10.0, 0});
    std::vector<Channel> channels;
    if (j == 0) channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
    channels.insert(channels.end(), {Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    s->channels.push_back(channels);
    s->end_sites.push_back(j == joints - 1 ? std::optional<Vec3>(Vec3{0, 5, 0}) : std::nullopt);
  }
  return s;
}

// A library of `clips` noisy random motions in nested folders.
std::map<std::string, Clip> write_synthetic_library(const fs::path& path, int clips, int frames,
                                                    int joints, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.02);
  const auto skeleton = chain_skeleton(joints);
  std::map<std::string, Clip> library;
  auto writer = io::LibraryWriter::create(path, io::Compression::none, nullptr);
  for (int c = 0; c < clips; ++c) {
    Clip clip;
    clip.skeleton = skeleton;
    clip.frame_time = 1.0 / 120;
    clip.frames = frames + c % 7;
    clip.rotations = test::random_motion(rng, clip.frames, joints);
    for (std::size_t i = 0; i < clip.rotations.size(); ++i)
      clip.rotations[i] += float(noise(rng) * 0.5);
    for (std::size_t i = 0; i < clip.rotations.size(); i += 4) {
      const Quat q = normalized(load_quat(&clip.rotations[i]));
      store_quat(q, &clip.rotations[i]);
    }
    make_hemisphere_continuous(clip.rotation_span());
    clip.translations.assign(std::size_t(clip.frames) * joints * 3, 0.0f);
    for (int t = 0; t < clip.frames; ++t)
      clip.translations[std::size_t(t) * joints * 3 + 1] = float(t) * 0.1f;
    const std::string name = "set" + std::to_string(c % 3) + "/clip" + std::to_string(c);
    clip.source = name + ".bvh";
    std::string error;
    EXPECT_TRUE(writer->write_clip(name, clip, &error)) << error;
    library[name] = std::move(clip);
  }
  EXPECT_TRUE(writer->close(nullptr));
  return library;
}

// Every clip of a library file, read back.
std::map<std::string, Clip> read_library(const fs::path& path) {
  std::map<std::string, Clip> clips;
  std::string error;
  auto reader = io::LibraryReader::open(path, &error);
  EXPECT_TRUE(reader) << error;
  if (!reader) return clips;
  for (const auto& h : reader->clips()) {
    auto clip = reader->read_clip(h.path, &error);
    EXPECT_TRUE(clip) << h.path << ": " << error;
    if (clip) clips[h.path] = std::move(*clip);
  }
  return clips;
}

bool same_bits(const Clip& a, const Clip& b) {
  return a.frames == b.frames && a.rotations.size() == b.rotations.size() &&
         a.translations.size() == b.translations.size() &&
         std::memcmp(a.rotations.data(), b.rotations.data(), a.rotations.size() * sizeof(float)) ==
             0 &&
         std::memcmp(a.translations.data(), b.translations.data(),
                     a.translations.size() * sizeof(float)) == 0;
}

void expect_identical_libraries(const std::map<std::string, Clip>& expected,
                                const std::map<std::string, Clip>& actual,
                                const std::string& what) {
  ASSERT_EQ(expected.size(), actual.size()) << what;
  for (const auto& [name, clip] : expected) {
    auto it = actual.find(name);
    ASSERT_NE(it, actual.end()) << what << ": " << name;
    EXPECT_TRUE(same_bits(clip, it->second)) << what << ": " << name;
  }
}

class EngineTest : public ::testing::Test {
 protected:
  void SetUp() override { library_ = write_synthetic_library(dir_ / "lib.h5", 12, 150, 9, 7); }
  std::string lib() const { return (dir_ / "lib.h5").string(); }
  test::TempDir dir_{"engine"};
  std::map<std::string, Clip> library_;
};

TEST_F(EngineTest, OutputIsBitIdenticalForAnyThreadCountAndShardSize) {
  for (const std::string method :
       {"bof", "nlpm --h 0.03", "gaussian", "butterworth", "moving-mean"}) {
    const std::string reference = (dir_ / "ref.h5").string();
    fs::remove(reference);
    auto r = test::run_cli("filter '" + lib() + "' -o '" + reference + "' --method " + method +
                           " --threads 1 --compression none");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto expected = read_library(reference);
    ASSERT_EQ(expected.size(), library_.size());
    EXPECT_FALSE(same_bits(expected.begin()->second, library_.begin()->second))
        << method << " changed nothing";
    int run = 0;
    for (const std::string variant :
         {"--threads 2", "--threads 4 --shard-joints 1 --shard-frames 7",
          "--threads 3 --shard-joints 4 --shard-frames 64",
          "--threads 2 --shard-joints 100 --shard-frames 1000 --compression lz4"}) {
      const std::string out = (dir_ / ("out" + std::to_string(run++) + ".h5")).string();
      r = test::run_cli("filter '" + lib() + "' -o '" + out + "' --method " + method + " " +
                        variant);
      ASSERT_EQ(r.exit_code, 0) << r.err;
      expect_identical_libraries(expected, read_library(out), method + " " + variant);
    }
  }
}

// noise --position-sigma F: per-axis gaussian jitter of F body heights on the joints with
// position channels only, drawn apart from the rotations' (which stay what --sigma alone gives).
TEST_F(EngineTest, NoiseJittersThePositionChannelsInBodyHeights) {
  const std::string rotations_only = (dir_ / "r.h5").string(), both = (dir_ / "rp.h5").string();
  const std::string base = "noise '" + lib() + "' --sigma 0.02 --seed 3 -o '";
  ASSERT_EQ(test::run_cli(base + rotations_only + "'").exit_code, 0);
  const auto r = test::run_cli(base + both + "' --position-sigma 0.01");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto plain = read_library(rotations_only), jittered = read_library(both);
  ASSERT_EQ(plain.size(), library_.size());
  ASSERT_EQ(jittered.size(), library_.size());
  double sum = 0, sum2 = 0;
  int n = 0;
  for (const auto& [name, clean] : library_) {
    const Clip& a = plain.at(name);
    const Clip& b = jittered.at(name);
    EXPECT_EQ(a.rotations, b.rotations) << name;
    EXPECT_EQ(a.translations, clean.translations) << name;
    const double sigma = 0.01 * engine::body_height(*clean.skeleton);
    ASSERT_GT(sigma, 0);
    for (int t = 0; t < clean.frames; ++t)
      for (int j = 0; j < clean.joints(); ++j)
        for (int c = 0; c < 3; ++c) {
          const std::size_t i =
              (std::size_t(t) * std::size_t(clean.joints()) + std::size_t(j)) * 3 + std::size_t(c);
          const double d = double(b.translations[i]) - double(clean.translations[i]);
          if (!clean.skeleton->has_translation(j)) {
            EXPECT_EQ(d, 0.0) << name << " joint " << j;
            continue;
          }
          sum += d / sigma;
          sum2 += d * d / (sigma * sigma);
          ++n;
        }
  }
  ASSERT_GT(n, 3000);
  EXPECT_NEAR(sum / n, 0.0, 0.1);               // mean 0
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.05);  // std = F body heights
  // Out of range is a usage error.
  EXPECT_EQ(test::run_cli("noise '" + lib() + "' -o '" + (dir_ / "x.h5").string() +
                          "' --position-sigma -1")
                .exit_code,
            2);
}

TEST_F(EngineTest, AClipWithNaNFailsAloneWithItsReason) {
  Clip bad = library_.begin()->second;
  bad.rotations[4 * 9 * 20 + 1] = std::nanf("");
  {
    // Rewrite the library with the poisoned clip under a new name.
    auto writer = io::LibraryWriter::create(dir_ / "poisoned.h5", io::Compression::none, nullptr);
    for (const auto& [name, clip] : library_) ASSERT_TRUE(writer->write_clip(name, clip, nullptr));
    ASSERT_TRUE(writer->write_clip("zz/poisoned", bad, nullptr));
    ASSERT_TRUE(writer->close(nullptr));
  }
  const std::string out = (dir_ / "out.h5").string();
  const auto r = test::run_cli("filter '" + (dir_ / "poisoned.h5").string() + "' -o '" + out +
                               "' --method bof --json");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  const auto summary = nlohmann::json::parse(r.out);
  ASSERT_EQ(summary["failed"].size(), 1u);
  EXPECT_EQ(summary["failed"][0]["clip"], "zz/poisoned");
  EXPECT_NE(summary["failed"][0]["error"].get<std::string>().find("NaN in rotations at frame 21"),
            std::string::npos);
  EXPECT_EQ(read_library(out).size(), library_.size());
}

TEST_F(EngineTest, AnExistingPartsFolderNeedsResume) {
  const std::string out = (dir_ / "out.h5").string();
  fs::create_directories(out + ".parts");
  const auto r = test::run_cli("filter '" + lib() + "' -o '" + out + "' --method gaussian");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--resume"), std::string::npos) << r.err;
}

TEST_F(EngineTest, ResumingAFinishedOutputRedoesNothingUnlessSomethingChanged) {
  const std::string out = (dir_ / "out.h5").string();
  const std::string run = "filter '" + lib() + "' -o '" + out + "' --method gaussian";
  ASSERT_EQ(test::run_cli(run).exit_code, 0);
  // Back-date the output, so that a rewrite would show in its time stamp.
  const auto written = fs::last_write_time(lib()) + std::chrono::seconds(5);
  fs::last_write_time(out, written);

  auto r = test::run_cli(run + " --resume");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("already complete"), std::string::npos) << r.err;
  EXPECT_EQ(fs::last_write_time(out), written) << "the output was written again";
  r = test::run_cli(run + " --resume --shard 1/2 --json");  // a job array run again
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(nlohmann::json::parse(r.out)["already_complete"].get<bool>()) << r.out;
  EXPECT_FALSE(fs::exists(out + ".parts"));
  EXPECT_EQ(fs::last_write_time(out), written);

  // Other parameters: redone (and recorded, so the same command is complete again).
  r = test::run_cli(run + " --sigma-t 2 --resume");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("already complete"), std::string::npos) << r.err;
  EXPECT_NE(fs::last_write_time(out), written);
  r = test::run_cli(run + " --sigma-t 2 --resume");
  EXPECT_NE(r.err.find("already complete"), std::string::npos) << r.err;
  // An input changed since the output was written: redone.
  fs::last_write_time(lib(), fs::last_write_time(out) + std::chrono::seconds(5));
  r = test::run_cli(run + " --sigma-t 2 --resume");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("already complete"), std::string::npos) << r.err;
}

// Starts mocap-clean with `arguments` (no shell), returning its pid.
pid_t spawn_cli(const std::vector<std::string>& arguments) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    const std::string cli = test::cli_path().string();
    argv.push_back(const_cast<char*>(cli.c_str()));
    for (const auto& a : arguments) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const int devnull = ::open("/dev/null", O_WRONLY);
    dup2(devnull, STDOUT_FILENO);
    dup2(devnull, STDERR_FILENO);
    execv(cli.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

TEST(EngineResume, KilledRunsLeaveValidOutputAndResumeCompletesIt) {
  test::TempDir dir("resume");
  const fs::path lib = dir / "lib.h5";
  write_synthetic_library(lib, 160, 300, 16, 11);
  const std::vector<std::string> base = {
      "filter",    lib.string(), "--method",         "nlpm", "--h",          "0.03",
      "--threads", "1",          "--clips-per-part", "6",    "--no-progress"};
  auto with = [&](const std::string& out, std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.push_back("-o");
    args.push_back(out);
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const std::string reference = (dir / "reference.h5").string();
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(wait_exit(spawn_cli(with(reference, {}))), 0);
  const double full_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const auto expected = read_library(reference);
  ASSERT_EQ(expected.size(), 160u);

  const std::string out = (dir / "out.h5").string();
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> when(0.05, 0.9);
  int kills = 0;
  for (int attempt = 0; attempt < 8; ++attempt) {
    const pid_t pid = spawn_cli(with(out, {"--resume"}));
    std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(when(rng) * full_ms));
    const int signal = attempt % 4 == 3 ? SIGINT : SIGKILL;  // Ctrl-C finishes the clips in flight
    if (kill(pid, signal) == 0) ++kills;
    wait_exit(pid);
    // An interrupted run removes its joined copy (PartedOutput); a killed one leaves it to the
    // next run, which starts from the parts.
    if (signal == SIGINT) {
      EXPECT_FALSE(fs::exists(out + ".parts/joined.h5.tmp")) << attempt;
    }
    // Whatever moment it died at, OUT is absent or a valid library of complete clips.
    if (fs::exists(out)) {
      for (const auto& [name, clip] : read_library(out)) {
        ASSERT_TRUE(expected.count(name)) << name;
        EXPECT_TRUE(same_bits(expected.at(name), clip)) << "after kill " << attempt << ": " << name;
      }
    }
  }
  EXPECT_GT(kills, 0);
  ASSERT_EQ(wait_exit(spawn_cli(with(out, {"--resume"}))), 0);
  EXPECT_FALSE(fs::exists(out + ".parts"));
  expect_identical_libraries(expected, read_library(out), "after resume");
}

}  // namespace
}  // namespace mocap
