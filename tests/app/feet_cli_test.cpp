// --feet through the command line: lock by default with --method auto, off with a named method
// unless asked, the contacts in --json and the closing line, and the same bytes for any thread
// count.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "kernels/foot_lock.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

test::CommandResult clean(const test::TempDir& out, const std::string& options) {
  return test::run_cli("clean '" + test::shared_bvh_dir().string() + "' -o '" +
                       out.path().string() + "' " + options);
}

TEST(FeetCli, AutoLocksAndReportsTheContactsOfEveryClip) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir out("feet_auto");
  const auto r = clean(out, "--json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto summary = nlohmann::json::parse(r.out);
  const auto& feet = summary["feet"];
  EXPECT_EQ(feet["mode"], "lock");
  EXPECT_EQ(feet["clips"].get<std::size_t>(), test::shared_bvh_files().size());
  EXPECT_GT(feet["contacts"].get<std::size_t>(), 0u);
  EXPECT_EQ(summary["parameters"]["feet"], "lock");
  std::size_t contacts = 0;
  for (const auto& clip : feet["by_clip"]) {
    ASSERT_EQ(clip["feet"].size(), 2u) << clip.dump();  // CMU: LeftFoot and RightFoot
    if (clip["locked"].get<bool>()) {
      // The pins' smoothing, from the input feet's noise, within FootLockParams' bounds.
      const FootLockParams bounds;
      EXPECT_GT(clip["anchor_noise"].get<double>(), 0) << clip.dump();
      EXPECT_GE(clip["pin_sigma_s"].get<double>(), bounds.min_pin_sigma) << clip.dump();
      EXPECT_LE(clip["pin_sigma_s"].get<double>(), bounds.max_pin_sigma) << clip.dump();
    }
    for (const auto& foot : clip["feet"]) {
      EXPECT_EQ(foot["contacts"].get<std::size_t>(), foot["intervals"].size());
      contacts += foot["intervals"].size();
      for (const auto& interval : foot["intervals"])
        EXPECT_LT(interval[0].get<int>(), interval[1].get<int>());
    }
  }
  EXPECT_EQ(contacts, feet["contacts"].get<std::size_t>());
  // The closing line (without --json) names them.
  test::TempDir again("feet_line");
  const auto line = clean(again, "");
  ASSERT_EQ(line.exit_code, 0) << line.err;
  EXPECT_NE(line.err.find("feet: " + std::to_string(contacts) + " contacts locked"),
            std::string::npos)
      << line.err;
}

TEST(FeetCli, ANamedMethodLeavesTheFeetUnlessAsked) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir off("feet_named"), on("feet_named_lock");
  auto r = clean(off, "--method bof --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["feet"]["mode"], "off");
  r = clean(on, "--method bof --feet lock --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["feet"]["mode"], "lock");
  // Locking changed the legs of some clip.
  bool changed = false;
  for (const fs::path& file : test::shared_bvh_files())
    changed = changed || test::read_text(off / file.filename().string()) !=
                             test::read_text(on / file.filename().string());
  EXPECT_TRUE(changed);
  r = clean(on, "--feet sideways");
  EXPECT_EQ(r.exit_code, 2);
}

TEST(FeetCli, LockedOutputIsTheSameForAnyThreadCount) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir one("feet_j1"), two("feet_j2");
  auto r = clean(one, "--threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = clean(two, "--threads 2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const fs::path& file : test::shared_bvh_files())
    EXPECT_EQ(test::read_text(one / file.filename().string()),
              test::read_text(two / file.filename().string()))
        << file;
}

}  // namespace
}  // namespace mocap
