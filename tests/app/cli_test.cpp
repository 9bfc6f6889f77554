// End-to-end tests of the mocap-clean command line: files in, files out, errors and exit codes.
#include <fmt/core.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <sstream>

#include "engine/clip/filter_settings.hpp"
#include "engine/library/demo_library.hpp"
#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// The values of a BVH file's frame lines, as written (degrees and file units), one row a frame.
std::vector<std::vector<double>> motion_values(const fs::path& file) {
  std::istringstream text(test::read_text(file));
  std::string line;
  while (std::getline(text, line) && line.find("Frame Time") == std::string::npos) {
  }
  std::vector<std::vector<double>> rows;
  while (std::getline(text, line)) {
    std::istringstream numbers(line);
    std::vector<double> row;
    for (double v; numbers >> v;) row.push_back(v);
    if (!row.empty()) rows.push_back(std::move(row));
  }
  return rows;
}

// The columns of a clip's frame lines that hold rotation channels.
std::vector<std::size_t> rotation_columns(const Skeleton& skeleton) {
  std::vector<std::size_t> columns;
  std::size_t column = 0;
  for (const auto& channels : skeleton.channels)
    for (Channel c : channels) {
      if (is_rotation(c)) columns.push_back(column);
      ++column;
    }
  return columns;
}

// Writes the first `count` demo clips as BVH files into `folder`; returns their names.
std::vector<std::string> write_demo_files(const fs::path& folder, std::size_t count) {
  const auto demo = engine::make_demo_library();
  std::vector<std::string> names;
  for (std::size_t i = 0; i < count; ++i) {
    const std::string name = "clip" + std::to_string(i) + ".bvh";
    std::string error;
    EXPECT_TRUE(io::write_bvh(demo[i].clip, folder / name, &error)) << error;
    names.push_back(name);
  }
  return names;
}

fs::path repository_root() {
  return fs::path(__FILE__).parent_path().parent_path().parent_path();
}
fs::path readme_path() {
  return repository_root() / "README.md";
}

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
    const Clip& a = *original.clip;
    const Clip& b = *written.clip;
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

// Issue 15: BVH files are read as bytes by the serial reader and parsed in parallel tasks; the
// output is the same bytes for any thread count, and --json's stages time the parsing apart.
TEST(Cli, CleanParsesInParallelWithTheSameBytesForAnyThreadCount) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir one("clean-parallel-1"), two("clean-parallel-2");
  std::map<int, nlohmann::json> stages;
  for (const auto& [threads, out] : {std::pair{1, &one}, std::pair{2, &two}}) {
    const auto r =
        test::run_cli(fmt::format("clean '{}' -o '{}' --threads {} --json --overwrite",
                                  test::shared_bvh_dir().string(), out->path().string(), threads));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    stages[threads] = nlohmann::json::parse(r.out)["stages"];
  }
  std::size_t files = 0;
  for (const auto& path : test::shared_bvh_files()) {
    const auto slurp = [](const fs::path& file) {
      std::ifstream in(file, std::ios::binary);
      return std::string(std::istreambuf_iterator<char>(in), {});
    };
    const std::string a = slurp(one / path.filename().string()),
                      b = slurp(two / path.filename().string());
    EXPECT_FALSE(a.empty()) << path;
    EXPECT_EQ(a, b) << path;
    ++files;
  }
  EXPECT_EQ(files, 9u);
  for (const auto& [threads, s] : stages) {
    EXPECT_GT(s["parse"].get<double>(), 0) << threads;
    EXPECT_GT(s["read"].get<double>(), 0) << threads;
  }
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
    const auto r = test::run_cli("clean '" + src + "' -o '" + src + "/cleaned' --json --overwrite");
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
  for (const auto& s : summary["scores"]) {
    EXPECT_GT(s["cleaned_psnr_db"].get<double>(), s["noisy_psnr_db"].get<double>() + 3.0)
        << s.dump();
    // What a viewer sees: the joint positions (issue "positions": <= 0.6x the noisy input's).
    EXPECT_LE(s["cleaned_mpjpe_mm"].get<double>(), 0.6 * s["noisy_mpjpe_mm"].get<double>())
        << s.dump();
  }
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

TEST(Cli, CleanRefusesAFolderThatHoldsFilesAndResumesAnInterruptedRun) {
  test::TempDir in("resume-in"), out("resume-out");
  const auto names = write_demo_files(in.path(), 3);
  const std::string base = "clean '" + in.path().string() + "' -o '" + out.path().string() + "'";
  auto r = test::run_cli(base + " --method gaussian --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["clips"], 3);

  // Again without --resume or --overwrite: refused, nothing touched.
  const auto written_at = fs::last_write_time(out / names[0]);
  r = test::run_cli(base + " --method gaussian");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err.rfind("mocap-clean: clean: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("is not empty"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--resume"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
  EXPECT_EQ(fs::last_write_time(out / names[0]), written_at);

  // An interrupted run: one output missing, one left half-written as .tmp, and one written but
  // killed before its record (the file exists, the manifest does not name it).
  fs::remove(out / names[1]);
  std::ofstream(out / (names[1] + ".tmp")) << "HIERARCHY\nROOT Hips\n";
  const fs::path manifest = out / ".mocap-clean.jsonl";
  std::string records = test::read_text(manifest);
  const std::string last = names[2];
  const auto at = records.find("\"file\":\"" + last + "\"");
  ASSERT_NE(at, std::string::npos) << records;
  const auto line_start = records.rfind('\n', at);
  records.resize(line_start == std::string::npos ? 0 : line_start + 1);
  records += "{\"engine_version\":\"0.1.0\",\"fi";  // a line cut short by the kill
  std::ofstream(manifest, std::ios::trunc) << records;
  r = test::run_cli(base + " --method gaussian --resume --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary["clips"], 2) << "the missing and the unrecorded output are redone";
  EXPECT_EQ(summary["kept"], 1);
  EXPECT_EQ(fs::last_write_time(out / names[0]), written_at) << "a complete output is kept";
  ASSERT_TRUE(io::read_bvh(out / names[1]).clip);

  // Everything complete: nothing to do.
  r = test::run_cli(base + " --method gaussian --resume --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary["clips"], 0);
  EXPECT_EQ(summary["kept"], 3);

  // An input edited after its output was written is cleaned again.
  fs::last_write_time(in / names[0], fs::last_write_time(out / names[0]) + std::chrono::seconds(5));
  r = test::run_cli(base + " --method gaussian --resume --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["clips"], 1);

  // Other parameters: no output counts as complete.
  r = test::run_cli(base + " --method gaussian --sigma-t 2 --resume --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["clips"], 3);

  // --overwrite redoes everything; --resume and --overwrite together are a usage error.
  r = test::run_cli(base + " --method gaussian --overwrite --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["clips"], 3);
  r = test::run_cli(base + " --resume --overwrite");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err.rfind("mocap-clean: ", 0), 0u) << r.err;
}

TEST(Cli, CleanOneFileWritesThatFile) {
  test::TempDir dir("one-file");
  const auto names = write_demo_files(dir.path(), 2);
  const fs::path a = dir / names[0], target = dir / "sub/a-clean.bvh";
  auto r = test::run_cli("clean '" + a.string() + "' -o '" + target.string() + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(fs::is_regular_file(target)) << "a file, not a folder named a-clean.bvh";
  const auto written = io::read_bvh(target);
  ASSERT_TRUE(written.clip) << written.error->what();
  EXPECT_EQ(written.clip->frames, io::read_bvh(a).clip->frames);
  // It exists now: replaced only when asked.
  r = test::run_cli("clean '" + a.string() + "' -o '" + target.string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--overwrite"), std::string::npos) << r.err;
  r = test::run_cli("clean '" + a.string() + "' -o '" + target.string() + "' --overwrite");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  // Over its own input, or two sources into one file: refused.
  r = test::run_cli("clean '" + a.string() + "' -o '" + a.string() + "' --overwrite");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("would overwrite this input"), std::string::npos) << r.err;
  r = test::run_cli("clean '" + a.string() + "' '" + (dir / names[1]).string() + "' -o '" +
                    (dir / "both.bvh").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("names one BVH file"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "both.bvh"));
}

TEST(Cli, InfoReadsABvhFile) {
  test::TempDir dir("info-bvh");
  const auto demo = engine::make_demo_library();
  std::string error;
  ASSERT_TRUE(io::write_bvh(demo[0].clip, dir / "walk.bvh", &error)) << error;
  auto r = test::run_cli("info '" + (dir / "walk.bvh").string() + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["format"], "bvh");
  EXPECT_EQ(info["frames"], demo[0].clip.frames);
  EXPECT_EQ(info["joints"], demo[0].clip.joints());
  EXPECT_NEAR(info["frame_rate"].get<double>(), 1.0 / demo[0].clip.frame_time, 1e-9);
  EXPECT_EQ(info["rotation_orders"]["ZYX"], demo[0].clip.joints()) << info.dump();
  EXPECT_EQ(info["joint_list"][0]["parent"], nullptr);
  r = test::run_cli("info '" + (dir / "walk.bvh").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ZYX"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("garbage joints:"), std::string::npos) << r.out;

  std::ofstream(dir / "broken.bvh") << "HIERARCHY\nROOT Hips\n{\n";
  r = test::run_cli("info '" + (dir / "broken.bvh").string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("broken.bvh:"), std::string::npos) << r.err;

  if (test::shared_bvh_files().empty()) return;
  const fs::path clip = test::shared_bvh_dir() / "cmu_mb_06_14.bvh";
  if (!fs::exists(clip)) return;
  r = test::run_cli("info '" + clip.string() + "' --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  bool flipping_thumb = false;
  const auto bvh_info = nlohmann::json::parse(r.out);
  for (const auto& g : bvh_info["garbage_joints"])
    flipping_thumb |= g["joint"] == "LThumb" && g["class"] == "flipping";
  EXPECT_TRUE(flipping_thumb) << r.out;
}

TEST(Cli, CleanKeepsTheSourcesEulerCurves) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir none("euler-none"), cleaned("euler-auto");
  const std::string src = test::shared_bvh_dir().string();
  auto r = test::run_cli("clean '" + src + "' -o '" + none.path().string() + "' --method none");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_cli("clean '" + src + "' -o '" + cleaned.path().string() + "'");  // auto
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::size_t flips = 0, source_steps = 0;
  for (const fs::path& file : test::shared_bvh_files()) {
    const auto source = motion_values(file);
    const auto copy = motion_values(none / file.filename());
    ASSERT_EQ(source.size(), copy.size()) << file;
    for (std::size_t t = 0; t < source.size(); ++t) {
      ASSERT_EQ(source[t].size(), copy[t].size());
      for (std::size_t c = 0; c < source[t].size(); ++c)
        ASSERT_NEAR(copy[t][c], source[t][c], 1e-3) << file << " frame " << t << " value " << c;
    }
    // After the filter: no 180 or 360 degree jump against the source where it has none.
    const auto filtered = motion_values(cleaned / file.filename());
    const auto columns = rotation_columns(*io::read_bvh(file).clip->skeleton);
    for (std::size_t t = 1; t < source.size(); ++t)
      for (std::size_t c : columns) {
        if (std::abs(source[t][c] - source[t - 1][c]) > 90) {
          ++source_steps;
          continue;
        }
        const double before = filtered[t - 1][c] - source[t - 1][c];
        const double now = filtered[t][c] - source[t][c];
        if (std::abs(now - before) > 90) ++flips;
      }
    // CMU's synthetic T-pose frame 0 is left as it came (--split-impossible is on with auto).
    for (std::size_t c = 0; c < source[0].size(); ++c)
      EXPECT_NEAR(filtered[0][c], source[0][c], 1e-3) << file << " frame 0 value " << c;
  }
  EXPECT_EQ(flips, 0u) << "(the sources' own jumps, not counted: " << source_steps << ")";
}

TEST(Cli, FilterRecordsWhatItDidToEachClip) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  if (std::system("/usr/bin/python3 -c 'import h5py' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "h5py is not importable by /usr/bin/python3: h5py check skipped";
  test::TempDir dir("clip-provenance");
  const std::string lib = (dir / "lib.h5").string(), out = (dir / "out.h5").string();
  auto r = test::run_cli("import '" + test::shared_bvh_dir().string() + "' -o '" + lib +
                         "' --compression deflate");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = test::run_cli("filter '" + lib + "' -o '" + out + "' --compression deflate --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto summary = nlohmann::json::parse(r.out);
  // Written by h5py-reading Python: clip, method, parameters, noise_sigma, pops, repaired.
  const fs::path script = dir / "read.py";
  std::ofstream(script) << R"(import h5py, json, sys
f = h5py.File(sys.argv[1], "r")
rows = []
def visit(name, obj):
    if isinstance(obj, h5py.Group) and "rotations" in obj:
        a = obj.attrs
        pops = obj["pops"][()] if "pops" in obj else None
        rows.append({"clip": name[len("clips/"):], "method": a["method"].decode(),
                     "parameters": json.loads(a["parameters"].decode()),
                     "noise_sigma": float(a["noise_sigma"]) if "noise_sigma" in a else None,
                     "pops": pops.tolist() if pops is not None else None,
                     "pops_shape": list(pops.shape) if pops is not None else None,
                     "repaired": int(obj["pops"].attrs["repaired"]) if pops is not None else None,
                     "contacts_shape": list(obj["contacts"].shape) if "contacts" in obj else None})
f.visititems(visit)
print(json.dumps(rows))
)";
  const std::string command = "/usr/bin/python3 '" + script.string() + "' '" + out + "'";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string text;
  char buffer[4096];
  for (std::size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;) text.append(buffer, n);
  ASSERT_EQ(pclose(pipe), 0) << text;
  const auto rows = nlohmann::json::parse(text);
  ASSERT_EQ(rows.size(), test::shared_bvh_files().size());
  std::map<std::string, nlohmann::json> automatic;
  for (const auto& c : summary["automatic"]["by_clip"]) automatic[c["clip"]] = c;
  std::size_t pops = 0, contacts = 0;
  for (const auto& row : rows) {
    const std::string clip = row["clip"];
    ASSERT_TRUE(automatic.count(clip)) << clip;
    const auto& chosen = automatic[clip];
    EXPECT_EQ(row["method"], chosen["method"]) << clip;
    EXPECT_NEAR(row["noise_sigma"].get<double>(), chosen["noise_sigma"].get<double>(), 1e-12);
    for (const auto& [key, value] : chosen["parameters"].items())
      EXPECT_EQ(row["parameters"][key], value) << clip << " " << key;
    ASSERT_FALSE(row["pops"].is_null()) << clip;
    EXPECT_EQ(row["pops_shape"][1], 2);
    EXPECT_EQ(row["repaired"], 1) << "120 fps: auto repairs";
    for (const auto& p : row["pops"]) {
      EXPECT_GE(p[0].get<int>(), 0);
      EXPECT_GE(p[1].get<int>(), 0);
    }
    pops += row["pops"].size();
    // The feet locked by default with auto: their contacts, [N, 3].
    ASSERT_FALSE(row["contacts_shape"].is_null()) << clip;
    if (row["contacts_shape"][0].get<int>() > 0) {
      EXPECT_EQ(row["contacts_shape"][1], 3) << clip;
    }
    contacts += row["contacts_shape"][0].get<std::size_t>();
  }
  EXPECT_EQ(pops, summary["pops"]["samples"].get<std::size_t>()) << "every pop, once";
  EXPECT_EQ(contacts, summary["feet"]["contacts"].get<std::size_t>()) << "every contact, once";
  EXPECT_GT(contacts, 0u);
}

TEST(Cli, AnglesTakeDegreesImplausibleValuesWarnAndMethodNamesIgnoreCase) {
  test::TempDir in("angles-in"), out("angles-out");
  write_demo_files(in.path(), 1);
  const std::string base = "clean '" + in.path().string() + "' -o '" + out.path().string() + "'";
  auto r = test::run_cli(base + " --method bof --sigma-g 10deg --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NEAR(nlohmann::json::parse(r.out)["parameters"]["sigma_g"].get<double>(), 10 * kPi / 180,
              1e-12);
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  r = test::run_cli(base + " --overwrite --method bof --sigma-g 10 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("mocap-clean: clean: warning: --sigma-g 10 rad"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("10deg"), std::string::npos) << r.err;
  r = test::run_cli(base + " --overwrite --method Butterworth --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["method"], "butterworth");
  r = test::run_cli(base + " --overwrite --method bof --sigma-g -3deg");
  EXPECT_EQ(r.exit_code, 2);
  r = test::run_cli(base + " --overwrite --method bof --sigma-g tendeg");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("tendeg"), std::string::npos) << r.err;

  // noise's angles too: 40deg (0.70 rad) exceeds a 0.5 rad maximum, 20deg (0.35 rad) does not.
  const std::string lib = (out / "lib.h5").string();
  r = test::run_cli("import '" + in.path().string() + "' -o '" + lib + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string noise = "noise '" + lib + "' -o '" + (out / "n.h5").string() +
                            "' --model impulse --max-angle 0.5 --min-angle ";
  r = test::run_cli(noise + "40deg");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--min-angle must not exceed --max-angle"), std::string::npos) << r.err;
  r = test::run_cli(noise + "20deg");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

TEST(Cli, HelpStandsOnItsOwnAndEveryErrorIsPrefixed) {
  for (const char* command : {"", "clean ", "demo ", "import ", "filter ", "export ", "noise ",
                              "join ", "info ", "eval "}) {
    const auto r = test::run_cli(std::string(command) + "--help");
    EXPECT_EQ(r.exit_code, 0) << command;
    EXPECT_EQ(r.out.find("../shared"), std::string::npos) << command << r.out;
    EXPECT_NE(r.out.find("Examples:"), std::string::npos) << command;
    if (*command) {
      // Its own examples, not the whole program's list.
      EXPECT_NE(r.out.find("mocap-clean " + std::string(command)), std::string::npos) << command;
      EXPECT_EQ(r.out.find("Run `mocap-clean <command> --help`"), std::string::npos) << command;
    }
  }
  for (const char* bad : {"clean x.bvh -o out --resume2", "clean", "frobnicate",
                          "clean x.bvh -o out --method blur", "info"}) {
    const auto r = test::run_cli(bad);
    EXPECT_EQ(r.exit_code, 2) << bad;
    EXPECT_EQ(r.err.rfind("mocap-clean: ", 0), 0u) << bad << ": " << r.err;
  }
}

TEST(Cli, TheDocsAgreeWithTheCode) {
  const std::string readme = test::read_text(readme_path());
  ASSERT_FALSE(readme.empty()) << readme_path();
  const fs::path automatic_path = repository_root() / "docs/automatic-parameters.md";
  const std::string automatic = test::read_text(automatic_path);
  ASSERT_FALSE(automatic.empty()) << automatic_path;
  // The method table has a row for every method --method takes, and names no other.
  for (const char* name :
       {"bof", "nlpm", "gaussian", "butterworth", "moving-mean", "kalman", "auto", "none"}) {
    EXPECT_TRUE(engine::parse_method(name)) << name;
    EXPECT_NE(readme.find(std::string("\n| `") + name + "` |"), std::string::npos) << name;
  }
  // The automatic parameters, with the code's constants (line breaks read as spaces).
  std::string flat;
  for (char c : automatic) {
    const bool space = c == '\n' || c == ' ';
    if (!(space && !flat.empty() && flat.back() == ' ')) flat += space ? ' ' : c;
  }
  auto expect = [&](const std::string& formula) {
    EXPECT_NE(flat.find(formula), std::string::npos) << automatic_path << " lacks: " << formula;
  };
  expect(fmt::format("`sigma_g = {:g} sigma_hat`", engine::kBofAutoSigmaGFactor));
  expect(fmt::format("`sigma_t = max(1, {:g} sqrt(sigma_hat) (fps / 120)^0.75)`",
                     engine::kBofAutoSigmaTFactor));
  expect(fmt::format("`h = {:g} sigma_hat`", engine::kNlpmAutoFactor));
  expect(fmt::format("range width of `{:g} sigma_hat`", engine::kNlpmAutoRangeFactor));
  expect(fmt::format("`sigma_hat` < {:g} rad", engine::kAutoCleanBelow));
  expect(fmt::format("`n = clamp(round(sigma_hat / {:g}), 1, 5)`", engine::kAutoNoisePerIteration));
  expect(fmt::format("`sigma_g = {:g} sigma_hat / sqrt(n)`", engine::kAutoSigmaGFactor));
  expect(fmt::format("`sigma_t = max(1, {:g} sqrt(sigma_hat) (fps / 120)^0.5 / sqrt(n))`",
                     engine::kAutoSigmaTFactor));
  // bof's sigma_t does scale with the frame rate as the page says: 30 fps against 120 fps.
  BilateralParams p;
  p.sigma_g = 0;
  p.sigma_t = 0;
  const double at120 = engine::automatic_bilateral(p, 0.04, 1.0 / 120).sigma_t;
  const double at30 = engine::automatic_bilateral(p, 0.04, 1.0 / 30).sigma_t;
  EXPECT_NEAR(at120, std::max(1.0, engine::kBofAutoSigmaTFactor * std::sqrt(0.04)), 1e-12);
  EXPECT_NEAR(
      at30,
      std::max(1.0, engine::kBofAutoSigmaTFactor * std::sqrt(0.04) * std::pow(30.0 / 120.0, 0.75)),
      1e-12);
  // No command of the README points outside the clone without saying so.
  EXPECT_NE(readme.find("cmake --install build"), std::string::npos);
}

// The README and the pages of docs/ link to each other and to figures by relative paths, and the
// sources cite the pages (docs/feet.md, ...): each of those must lead to a file of the clone.
TEST(Cli, EveryLinkOfTheDocsLeadsToAFile) {
  const fs::path root = repository_root();
  std::vector<fs::path> pages{root / "README.md"};
  for (const auto& entry : fs::directory_iterator(root / "docs"))
    if (entry.path().extension() == ".md") pages.push_back(entry.path());
  ASSERT_GE(pages.size(), 2u) << "no page in " << root / "docs";
  const std::regex link(R"(\]\(([^)#\s]+)(#[^)]*)?\))");
  int links = 0;
  for (const fs::path& page : pages) {
    const std::string text = test::read_text(page);
    ASSERT_FALSE(text.empty()) << page;
    for (std::sregex_iterator it(text.begin(), text.end(), link), end; it != end; ++it) {
      const std::string target = (*it)[1];
      if (target.find("://") != std::string::npos) continue;
      ++links;
      EXPECT_TRUE(fs::exists(page.parent_path() / target)) << page << " links to " << target;
    }
  }
  EXPECT_GT(links, 10);
  // The sources' citations of a page: "docs/NAME.md" in any file of the layers and tests.
  const std::regex cited(R"(docs/([a-z-]+\.md))");
  int citations = 0;
  for (const char* layer : {"app", "core", "engine", "io", "kernels", "python", "bench", "tests"})
    for (const auto& entry : fs::recursive_directory_iterator(root / layer)) {
      if (!entry.is_regular_file()) continue;
      const std::string text = test::read_text(entry.path());
      for (std::sregex_iterator it(text.begin(), text.end(), cited), end; it != end; ++it) {
        ++citations;
        EXPECT_TRUE(fs::exists(root / "docs" / std::string((*it)[1])))
            << entry.path() << " cites docs/" << (*it)[1];
      }
    }
  EXPECT_GT(citations, 10);
}

TEST(Cli, InstallPutsTheBinaryOnAPrefix) {
  const fs::path build = test::cli_path().parent_path().parent_path();
  if (!fs::exists(build / "cmake_install.cmake")) GTEST_SKIP() << "no cmake_install.cmake";
  test::TempDir prefix("install");
  const std::string command = "cmake --install '" + build.string() + "' --prefix '" +
                              prefix.path().string() + "' >/dev/null 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const fs::path installed = prefix / "bin/mocap-clean";
  ASSERT_TRUE(fs::exists(installed));
  FILE* pipe = popen(("'" + installed.string() + "' --version").c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char buffer[64] = {};
  const std::size_t n = fread(buffer, 1, sizeof buffer - 1, pipe);
  EXPECT_EQ(pclose(pipe), 0);
  EXPECT_NE(std::string(buffer, n).find("0."), std::string::npos) << buffer;
}

TEST(Cli, EvalNamesEachInvalidGridPointOnceFlagsGridEdgesAndGivesTheSpread) {
  test::TempDir in("eval-in"), out("eval-out"), single("eval-single");
  write_demo_files(in.path(), 2);  // 120 fps; --frame-step 4 makes them 30 fps (Nyquist 15 Hz)
  const std::string base = "eval '" + in.path().string() + "' --methods butterworth --noise " +
                           "gaussian:0.03 --pops off --frame-step 4 --no-plots --no-progress";
  auto r = test::run_cli(base + " -o '" + out.path().string() +
                         "' --grid butterworth.cutoff=3,6,15 --grid butterworth.order=2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::size_t lines = 0;
  for (std::size_t at = 0; (at = r.err.find("cutoff=15", at)) != std::string::npos; ++at) ++lines;
  EXPECT_EQ(lines, 1u) << r.err;
  EXPECT_NE(r.err.find("failed on 2 of 2 runs"), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(test::read_text(out / "report.json"));
  const auto& method = report["methods"][0];
  const int best = method["best_point"][0].get<int>();
  ASSERT_GE(best, 0);
  const double cutoff = method["grid"][std::size_t(best)]["params"]["cutoff"].get<double>();
  // 3 Hz is the grid's low edge; 6 its middle (15 failed, but is still the axis' top).
  EXPECT_EQ(method["best_point_edge_parameters"][0].size(), cutoff == 3 ? 1u : 0u)
      << method["best_point_edge_parameters"].dump();
  EXPECT_EQ(r.out.find("* / ") != std::string::npos, cutoff == 3) << r.out;
  const auto& spread = method["grid"][std::size_t(best)]["results"][0]["psnr_db_per_clip"];
  EXPECT_LE(spread["min"].get<double>(), spread["median"].get<double>());
  EXPECT_LE(spread["median"].get<double>(), spread["max"].get<double>());
  EXPECT_LT(spread["min"].get<double>(), spread["max"].get<double>()) << "two different clips";
  EXPECT_NE(test::read_text(out / "index.html").find("min / median / max"), std::string::npos);

  // A grid of two points: the best is on an edge, flagged in the table.
  r = test::run_cli(base + " -o '" + single.path().string() +
                    "' --grid butterworth.cutoff=2,3 --grid butterworth.order=2");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("* / "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("edge of its grid"), std::string::npos) << r.out;
}

TEST(Cli, TheDemoSaysWhatToTryNext) {
  test::TempDir out("demo-next");
  const auto r = test::run_cli("demo -o '" + out.path().string() + "' --no-progress");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("Next, on your own files:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("mocap-clean clean a.bvh -o a-clean.bvh"), std::string::npos);
}

}  // namespace
}  // namespace mocap
