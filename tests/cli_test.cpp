// End-to-end tests of the mocap-clean command line: files in, files out, errors and exit codes.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>

#include "engine/demo_library.hpp"
#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

TEST(Cli, CleanWithMethodNoneReproducesEverySharedClip) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir out("clean-none");
  const auto r = test::run_cli("clean '" + test::shared_bvh_dir().string() + "' -o '" +
                               out.path().string() + "' --method none --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary["clips"].get<int>(), int(test::shared_bvh_files().size()));
  EXPECT_TRUE(summary["failed"].empty());
  for (const fs::path& file : test::shared_bvh_files()) {
    const auto original = io::read_bvh(file);
    const auto written = io::read_bvh(out / file.filename().string());
    ASSERT_TRUE(original.clip && written.clip) << file;
    const io::Clip& a = *original.clip;
    const io::Clip& b = *written.clip;
    ASSERT_EQ(a.frames, b.frames);
    EXPECT_EQ(a.frame_time, b.frame_time);
    EXPECT_TRUE(*a.skeleton == *b.skeleton);
    const auto errors = test::rotation_errors(a.rotation_view(), b.rotation_view());
    EXPECT_LT(errors.max, 1e-6) << file;
    for (std::size_t i = 0; i < a.translations.size(); ++i)
      ASSERT_NEAR(a.translations[i], b.translations[i], 1e-6) << file;
  }
}

TEST(Cli, AFailingFileIsNamedAndTheOthersAreWritten) {
  test::TempDir in("clean-fail-in"), out("clean-fail-out");
  const auto demo = engine::make_demo_library();
  fs::create_directories(in / "good");
  std::string error;
  ASSERT_TRUE(io::write_bvh(demo[0].clip, in / "good/walk.bvh", &error)) << error;
  ASSERT_TRUE(io::write_bvh(demo[2].clip, in / "good/wave.bvh", &error)) << error;
  std::string text = io::format_bvh(demo[0].clip);
  text.insert(text.rfind('\n', text.size() - 2) + 1, "1 2 3\n");  // a short frame line
  std::ofstream(in / "broken.bvh") << text;

  const auto r = test::run_cli("clean '" + in.path().string() + "' -o '" + out.path().string() +
                               "' --method gaussian --json");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("broken.bvh:"), std::string::npos) << r.err;  // file and line named
  EXPECT_TRUE(fs::exists(out / "good/walk.bvh"));
  EXPECT_TRUE(fs::exists(out / "good/wave.bvh"));
  EXPECT_FALSE(fs::exists(out / "broken.bvh"));
  const auto summary = nlohmann::json::parse(r.out);
  ASSERT_EQ(summary["failed"].size(), 1u);
  EXPECT_EQ(summary["failed"][0]["clip"], "broken.bvh");
  EXPECT_NE(summary["failed"][0]["error"].get<std::string>().find("values"), std::string::npos);
  EXPECT_EQ(summary["clips"], 2);
}

TEST(Cli, AFileThatFailsAloneExitsWithOneAndNamesItsLineOnce) {
  test::TempDir in("clean-fail-alone"), out("clean-fail-alone-out");
  std::string text = io::format_bvh(engine::make_demo_library()[0].clip);
  text.replace(text.find("Frame Time:"), std::string("Frame Time:").size(), "Frame Time: -");
  std::ofstream(in / "broken.bvh") << text;
  const auto r = test::run_cli("clean '" + (in / "broken.bvh").string() + "' -o '" +
                               out.path().string() + "' --method none");
  EXPECT_EQ(r.exit_code, 1) << "a malformed file is not a usage error";
  const std::string where = (in / "broken.bvh").string() + ":";
  const auto first = r.err.find(where);
  ASSERT_NE(first, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("broken.bvh", first + where.size()), std::string::npos)
      << "the file is named once: " << r.err;
  EXPECT_FALSE(fs::exists(out / "broken.bvh"));
}

TEST(Cli, NoInputIsLostOrReadTwice) {
  test::TempDir dir("clean-layout");
  const auto demo = engine::make_demo_library();
  std::string error;
  fs::create_directories(dir / "src/sub");
  fs::create_directories(dir / "other/sub");
  ASSERT_TRUE(io::write_bvh(demo[0].clip, dir / "src/walk.bvh", &error)) << error;
  ASSERT_TRUE(io::write_bvh(demo[1].clip, dir / "src/sub/run.bvh", &error)) << error;
  ASSERT_TRUE(io::write_bvh(demo[2].clip, dir / "other/sub/run.bvh", &error)) << error;
  const std::string src = (dir / "src").string();
  const std::string original = test::read_text(dir / "src/walk.bvh");

  // An output folder inside the source folder: a second run does not clean the first's output.
  for (int run = 0; run < 2; ++run) {
    const auto r = test::run_cli("clean '" + src + "' -o '" + src + "/cleaned' --json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["clips"], 2) << "run " << run;
  }
  EXPECT_FALSE(fs::exists(dir / "src/cleaned/cleaned"));

  // Output over the input: refused, the capture untouched.
  auto r = test::run_cli("clean '" + src + "' -o '" + src + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("would overwrite this input"), std::string::npos) << r.err;
  EXPECT_EQ(test::read_text(dir / "src/walk.bvh"), original);

  // Two different files that would land on the same output path: refused, naming both.
  r = test::run_cli("clean '" + src + "' '" + (dir / "other").string() + "' -o '" +
                    (dir / "out").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("would both be written as sub/run.bvh"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
  // The same file reached twice is one clip.
  r = test::run_cli("clean '" + src + "' '" + src + "/' -o '" + (dir / "out").string() +
                    "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["clips"], 4) << "src and src/cleaned (not skipped here)";
}

TEST(Cli, UsageErrorsExitWithTwoAndSayWhy) {
  test::TempDir out("usage");
  const std::string o = " -o '" + out.path().string() + "'";
  auto r = test::run_cli("clean /nonexistent/folder" + o);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("/nonexistent/folder"), std::string::npos);
  r = test::run_cli("clean x.bvh" + o + " --method blur");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("blur"), std::string::npos);
  r = test::run_cli("clean x.bvh");  // no -o
  EXPECT_EQ(r.exit_code, 2);
  r = test::run_cli("clean x.bvh" + o + " --sigma-t -1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--sigma-t: must be a number >= 0, got '-1'"), std::string::npos) << r.err;
  r = test::run_cli("clean x.bvh" + o + " --iterations 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--iterations: must be a number > 0, got '0'"), std::string::npos) << r.err;
  EXPECT_LT(r.err.size(), 200u) << "a message to read, not a range up to DBL_MAX: " << r.err;
  r = test::run_cli("frobnicate");
  EXPECT_EQ(r.exit_code, 2);
}

TEST(Cli, HelpTeachesEveryCommand) {
  const auto r = test::run_cli("--help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* word :
       {"clean", "demo", "import", "filter", "export", "noise", "info", "Examples"})
    EXPECT_NE(r.out.find(word), std::string::npos) << word;
  const auto clean = test::run_cli("clean --help");
  for (const char* word : {"--sigma-g", "--search-radius", "--cutoff", "--boundary",
                           "--translations", "--threads", "--json"})
    EXPECT_NE(clean.out.find(word), std::string::npos) << word;
}

TEST(Cli, DemoCleansTheBuiltInLibraryAndGainsOverTheNoise) {
  test::TempDir out("demo");
  const auto r = test::run_cli("demo -o '" + out.path().string() + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto summary = nlohmann::json::parse(r.out);
  ASSERT_EQ(summary["scores"].size(), 4u);
  for (const auto& s : summary["scores"])
    EXPECT_GT(s["cleaned_psnr_db"].get<double>(), s["noisy_psnr_db"].get<double>() + 3.0)
        << s.dump();
}

TEST(Cli, LibraryRoundTripImportFilterExport) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir dir("library");
  const std::string lib = (dir / "lib.h5").string(), out = (dir / "out.h5").string();
  auto r =
      test::run_cli("import '" + test::shared_bvh_dir().string() + "' -o '" + lib + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_cli("filter '" + lib + "' -o '" + out + "' --method none --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(out + ".parts"));  // joined and cleaned up
  r = test::run_cli("info '" + out + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["clips"].get<int>(), int(test::shared_bvh_files().size()));
  EXPECT_EQ(info["provenance"]["method"], "none");
  EXPECT_EQ(info["provenance"]["input_file"], lib);
  r = test::run_cli("export '" + out + "' -o '" + (dir / "bvh").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const fs::path& file : test::shared_bvh_files()) {
    const auto a = io::read_bvh(file), b = io::read_bvh(dir / "bvh" / file.filename().string());
    ASSERT_TRUE(a.clip && b.clip) << file;
    EXPECT_LT(test::rotation_errors(a.clip->rotation_view(), b.clip->rotation_view()).max, 1e-6);
  }
}

}  // namespace
}  // namespace mocap
