// --guard through the command line (engine/clip/motion_guard.hpp): with --method auto no clip of
// the shared captures leaves `clean` with more jitter or foot skating than it came in with, the
// --json summary says what each clip kept, --guard off shows the check is not vacuous, and a
// library written by `filter` records a fallback in the clip's provenance.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/clip/motion_guard.hpp"
#include "io/library_reader.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

nlohmann::json clean_json(const test::TempDir& out, const std::string& options) {
  const auto r = test::run_cli("clean '" + test::shared_bvh_dir().string() + "' -o '" +
                               out.path().string() + "' --json " + options);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return nlohmann::json::parse(r.out, nullptr, false);
}

TEST(GuardCli, NoCaptureComesOutWithMoreJitterOrSkatingThanItWentIn) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir out("guard_on");
  const auto summary = clean_json(out, "");
  ASSERT_TRUE(summary.is_object());
  const auto& motion = summary["motion"];
  EXPECT_EQ(summary["parameters"]["guard"], "on");
  ASSERT_EQ(motion["by_clip"].size(), test::shared_bvh_files().size());
  EXPECT_EQ(motion["guard"]["clips"].get<std::size_t>(), motion["by_clip"].size());
  for (const auto& clip : motion["by_clip"]) {
    EXPECT_LE(clip["jitter_after"].get<double>(), clip["jitter_before"].get<double>()) << clip;
    // Within the measure's rounding (engine::kMeasureRounding): locked feet follow the input's.
    EXPECT_LE(clip["skating_after"].get<double>(),
              clip["skating_before"].get<double>() * (1 + engine::kMeasureRounding))
        << clip;
    EXPECT_TRUE(clip["kept"].is_string()) << clip;
  }
  EXPECT_TRUE(motion["worse"].empty());
}

TEST(GuardCli, OffTheFilterAloneRaisesSomeClipsJitter) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir on("guard_on2"), off("guard_off");
  const auto guarded = clean_json(on, "");
  const auto unguarded = clean_json(off, "--guard off");
  ASSERT_TRUE(guarded.is_object() && unguarded.is_object());
  EXPECT_FALSE(unguarded["motion"].contains("guard"));
  std::size_t raised = 0;
  for (const auto& clip : unguarded["motion"]["by_clip"])
    raised += clip["jitter_after"].get<double>() > clip["jitter_before"].get<double>() ||
              clip["skating_after"].get<double>() > clip["skating_before"].get<double>();
  EXPECT_GT(raised, 0u) << "the filter alone made no clip worse: the guard test is vacuous";
  EXPECT_EQ(guarded["motion"]["guard"]["fallbacks"].get<std::size_t>(), raised);
}

TEST(GuardCli, ALibraryRecordsAFallbackInTheClipsProvenance) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir dir("guard_library");
  const std::string lib = (dir.path() / "in.h5").string(), out = (dir.path() / "out.h5").string();
  auto r = test::run_cli("import '" + test::shared_bvh_dir().string() + "' -o '" + lib + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_cli("filter '" + lib + "' -o '" + out + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto summary = nlohmann::json::parse(r.out);
  const auto fallbacks = summary["motion"]["guard"]["fallbacks"].get<std::size_t>();
  EXPECT_GT(fallbacks, 0u);
  std::string error;
  const auto reader = io::LibraryReader::open(out, &error);
  ASSERT_TRUE(reader) << error;
  std::size_t recorded = 0;
  for (const auto& header : reader->clips()) {
    const auto clip = reader->read_encoded(header.path, &error);  // with its provenance
    ASSERT_TRUE(clip) << error;
    const auto parameters = nlohmann::json::parse(clip->provenance.parameters_json);
    recorded += parameters.contains("kept");
  }
  EXPECT_EQ(recorded, fallbacks);
}

}  // namespace
}  // namespace mocap
