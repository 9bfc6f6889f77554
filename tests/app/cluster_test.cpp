// Cluster runs give the same library as one process: scheduler shards (--shard I/N) and MPI
// ranks, also after a killed shard is resumed with a different number of shards.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <set>
#include <thread>

#include "app/cluster.hpp"
#include "io/library_reader.hpp"
#include "io/library_writer.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// Every clip's tensors, by path.
std::map<std::string, std::pair<std::vector<float>, std::vector<float>>> tensors(
    const fs::path& path) {
  std::map<std::string, std::pair<std::vector<float>, std::vector<float>>> out;
  std::string error;
  auto reader = io::LibraryReader::open(path, &error);
  EXPECT_TRUE(reader) << error;
  if (!reader) return out;
  for (const auto& h : reader->clips()) {
    auto clip = reader->read_clip(h.path, &error);
    EXPECT_TRUE(clip) << error;
    if (clip) out[h.path] = {clip->rotations, clip->translations};
  }
  return out;
}

class ClusterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // A library of the demo's procedural clips, copied under several folders.
    const auto r = test::run_cli("demo -o '" + (dir_ / "demo").string() + "' --method none --json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    fs::create_directories(dir_ / "src");
    for (const char* copy : {"a", "b", "c"})
      fs::copy(dir_ / "demo/noisy", dir_ / "src" / copy, fs::copy_options::recursive);
    const auto i = test::run_cli("import '" + (dir_ / "src").string() + "' -o '" + lib() + "'");
    ASSERT_EQ(i.exit_code, 0) << i.err;
    const auto f = test::run_cli("filter '" + lib() + "' -o '" + (dir_ / "single.h5").string() +
                                 "' --method bof");
    ASSERT_EQ(f.exit_code, 0) << f.err;
    single_ = tensors(dir_ / "single.h5");
    ASSERT_EQ(single_.size(), 12u);
  }
  std::string lib() const { return (dir_ / "lib.h5").string(); }
  std::string filter_to(const std::string& out) const {
    return "filter '" + lib() + "' -o '" + (dir_ / out).string() + "' --method bof";
  }
  test::TempDir dir_{"cluster"};
  std::map<std::string, std::pair<std::vector<float>, std::vector<float>>> single_;
};

TEST_F(ClusterTest, TwoShardsJoinIntoTheSingleProcessLibrary) {
  auto r = test::run_cli(filter_to("sharded.h5") + " --shard 1/2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "sharded.h5"));  // waits for the other shard
  r = test::run_cli(filter_to("sharded.h5") + " --shard 0/2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "sharded.h5.parts"));
  EXPECT_EQ(tensors(dir_ / "sharded.h5"), single_);
}

TEST_F(ClusterTest, ShardsSplitByCostAndAgreeOnTheSplit) {
  // Three shards each take some clips, none twice, all together every clip.
  std::set<std::string> seen;
  for (int i = 0; i < 3; ++i) {
    const auto r =
        test::run_cli(filter_to("three.h5") + " --shard " + std::to_string(i) + "/3 --json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto summary = nlohmann::json::parse(r.out);
    EXPECT_GE(summary["clips"].get<int>(), 3) << "unbalanced shard " << i;
    EXPECT_LE(summary["clips"].get<int>(), 5) << "unbalanced shard " << i;
  }
  EXPECT_EQ(tensors(dir_ / "three.h5"), single_);
}

TEST_F(ClusterTest, AKilledShardResumesWithAnotherShardCount) {
  auto r = test::run_cli(filter_to("resumed.h5") + " --shard 0/2 --clips-per-part 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Shard 1/2 dies before it finishes: simulate with a run interrupted right after start.
  const std::string cmd = "'" + test::cli_path().string() + "' " + filter_to("resumed.h5") +
                          " --shard 1/2 --clips-per-part 1 --threads 1 >/dev/null 2>&1 & pid=$!; "
                          "sleep 0.05; kill -9 $pid; wait $pid 2>/dev/null";
  std::system(cmd.c_str());
  // Resume the rest with three shards.
  for (int i = 0; i < 3; ++i) {
    r = test::run_cli(filter_to("resumed.h5") + " --resume --shard " + std::to_string(i) + "/3");
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  EXPECT_EQ(tensors(dir_ / "resumed.h5"), single_);
}

TEST_F(ClusterTest, AJoinerKilledMidJoinDoesNotBlockTheNextJoin) {
  // A joiner killed while joining leaves its lock file and a half-written OUT.tmp behind; the
  // lock is an flock, gone with its process, so the next shard to finish joins.
  auto r = test::run_cli(filter_to("killed_join.h5") + " --shard 0/2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const fs::path parts = dir_ / "killed_join.h5.parts";
  for (const fs::path& left : {parts / "join.lock", dir_ / "killed_join.h5.tmp"}) {
    std::FILE* f = std::fopen(left.c_str(), "a");
    ASSERT_NE(f, nullptr) << left;
    std::fputs("left by a killed joiner", f);
    std::fclose(f);
  }
  r = test::run_cli(filter_to("killed_join.h5") + " --shard 1/2 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(nlohmann::json::parse(r.out)["joined"].get<bool>()) << r.out;
  EXPECT_FALSE(fs::exists(parts));
  EXPECT_EQ(tensors(dir_ / "killed_join.h5"), single_);
}

TEST_F(ClusterTest, AShardThatComesLateDoesNotJoinAgain) {
  for (int i = 0; i < 2; ++i) {
    const auto r = test::run_cli(filter_to("late.h5") + " --shard " + std::to_string(i) + "/2");
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  const auto joined_at = fs::last_write_time(dir_ / "late.h5");
  // Shard 1/2 again (a scheduler retry): nothing left to do, OUT stays as it is.
  const auto r = test::run_cli(filter_to("late.h5") + " --shard 1/2 --resume --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(fs::last_write_time(dir_ / "late.h5"), joined_at);
  EXPECT_EQ(tensors(dir_ / "late.h5"), single_);
}

TEST_F(ClusterTest, MpiTwoRanksGiveTheSingleProcessLibrary) {
  if (!engine::built_with_mpi()) GTEST_SKIP() << "built without MPI (libopenmpi-dev not found)";
#ifdef MOCAP_SANITIZED
  // OpenMPI patches malloc with its own memory hooks, which clash with the sanitizers' runtime;
  // the plain build of CI runs this test.
  GTEST_SKIP() << "MPI is not run under sanitizers (" MOCAP_SANITIZED "): OpenMPI's memory hooks";
#endif
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0) GTEST_SKIP() << "mpirun not installed";
  const std::string out = (dir_ / "mpi.h5").string();
  const std::string cmd = "mpirun -np 2 --oversubscribe --allow-run-as-root '" +
                          test::cli_path().string() + "' filter '" + lib() + "' -o '" + out +
                          "' --method bof --json > '" + (dir_ / "mpi.json").string() + "' 2> '" +
                          (dir_ / "mpi.err").string() + "'";
  const int status = std::system(cmd.c_str());
  ASSERT_EQ(status, 0) << test::read_text(dir_ / "mpi.err");
  EXPECT_EQ(tensors(out), single_);
  // Only rank 0 reports: one JSON line with totals and per-rank throughput.
  const std::string text = test::read_text(dir_ / "mpi.json");
  ASSERT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
  const auto summary = nlohmann::json::parse(text);
  EXPECT_EQ(summary["clips"], 12);
  EXPECT_EQ(summary["ranks"].size(), 2u);
}

TEST_F(ClusterTest, MpiSummaryCountsThePopsAndChoicesOfEveryRank) {
  if (!engine::built_with_mpi()) GTEST_SKIP() << "built without MPI (libopenmpi-dev not found)";
#ifdef MOCAP_SANITIZED
  GTEST_SKIP() << "MPI is not run under sanitizers (" MOCAP_SANITIZED "): OpenMPI's memory hooks";
#endif
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0) GTEST_SKIP() << "mpirun not installed";
  const std::string popped = (dir_ / "popped.h5").string();
  ASSERT_EQ(test::run_cli("noise '" + lib() + "' -o '" + popped + "' --model impulse").exit_code,
            0);
  const std::string run = "filter '" + popped + "' --method auto --json -o '";
  const auto single = test::run_cli(run + (dir_ / "single-auto.h5").string() + "'");
  ASSERT_EQ(single.exit_code, 0) << single.err;
  const std::string cmd = "mpirun -np 2 --oversubscribe --allow-run-as-root '" +
                          test::cli_path().string() + "' " + run + (dir_ / "mpi-auto.h5").string() +
                          "' > '" + (dir_ / "mpi.json").string() + "' 2> '" +
                          (dir_ / "mpi.err").string() + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << test::read_text(dir_ / "mpi.err");
  const auto expected = nlohmann::json::parse(single.out);
  const auto summary = nlohmann::json::parse(test::read_text(dir_ / "mpi.json"));
  ASSERT_GT(expected["pops"]["samples"].get<int>(), 0) << "no pops to count";
  for (const char* key : {"samples", "repaired", "clips", "by_joint"})
    EXPECT_EQ(summary["pops"][key], expected["pops"][key]) << key;
  EXPECT_EQ(summary["automatic"]["clips"], 12);
  EXPECT_EQ(summary["automatic"]["methods"], expected["automatic"]["methods"]);
  EXPECT_EQ(summary["automatic"]["noise_sigma"], expected["automatic"]["noise_sigma"]);
  // The same choice for each clip, whichever rank filtered it.
  const auto by_clip = [](const nlohmann::json& j) {
    std::map<std::string, nlohmann::json> m;
    for (const auto& c : j["automatic"]["by_clip"]) m[c["clip"].get<std::string>()] = c;
    return m;
  };
  EXPECT_EQ(by_clip(summary), by_clip(expected));
}

TEST_F(ClusterTest, CommandsThatDoNotSplitRunOnRankZeroOnly) {
  if (!engine::built_with_mpi()) GTEST_SKIP() << "built without MPI (libopenmpi-dev not found)";
#ifdef MOCAP_SANITIZED
  GTEST_SKIP() << "MPI is not run under sanitizers (" MOCAP_SANITIZED "): OpenMPI's memory hooks";
#endif
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0) GTEST_SKIP() << "mpirun not installed";
  // eval under two ranks: one report, one summary, a note that rank 1 had nothing to do.
  const std::string cmd =
      "mpirun -np 2 --oversubscribe --allow-run-as-root '" + test::cli_path().string() +
      "' eval '" + (dir_ / "src/a").string() + "' -o '" + (dir_ / "report").string() +
      "' --noise gaussian:0.03 --methods bof --pops off --no-plots --json > '" +
      (dir_ / "eval.json").string() + "' 2> '" + (dir_ / "eval.err").string() + "'";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << test::read_text(dir_ / "eval.err");
  const std::string out = test::read_text(dir_ / "eval.json");
  ASSERT_EQ(std::count(out.begin(), out.end(), '\n'), 1) << out;
  EXPECT_EQ(nlohmann::json::parse(out)["clips"], 4);
  EXPECT_NE(test::read_text(dir_ / "eval.err").find("rank 0 only"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir_ / "report/report.json"));
}

}  // namespace
}  // namespace mocap
