// --report DIR (engine/run/review_report.hpp): the data the review page shows, read back the way
// the page reads it (base64, inflate, byte planes, int16 steps), against forward kinematics of the
// clip as read and as written. The page itself is tested in chromium (tests/review_page).
#include <gtest/gtest.h>
#include <zlib.h>

#include <fmt/format.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "engine/clip/filter_settings.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/run/review_report.hpp"
#include "io/bvh_reader.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

std::vector<unsigned char> from_base64(const std::string& text) {
  std::vector<unsigned char> out;
  unsigned value = 0;
  int bits = 0;
  for (char ch : text) {
    int v = -1;
    if (ch >= 'A' && ch <= 'Z') v = ch - 'A';
    if (ch >= 'a' && ch <= 'z') v = ch - 'a' + 26;
    if (ch >= '0' && ch <= '9') v = ch - '0' + 52;
    if (ch == '+') v = 62;
    if (ch == '/') v = 63;
    if (v < 0) continue;  // '=' padding
    value = value << 6 | unsigned(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<unsigned char>(value >> bits & 0xff));
    }
  }
  return out;
}

struct PageClip {
  nlohmann::json meta;
  std::vector<float> positions[2], angles[2];  // before, after: [S][J][3] cm, degrees
};

// What review.js decode() does.
PageClip read_page_clip(const fs::path& file) {
  const std::string text = test::read_text(file);
  const std::size_t open = text.find(','), data = text.rfind(",\"");
  EXPECT_EQ(text.rfind("mocapReviewClip(", 0), 0u) << file;
  PageClip clip;
  clip.meta = nlohmann::json::parse(text.substr(open + 1, data - open - 1));
  const std::vector<unsigned char> packed =
      from_base64(text.substr(data + 2, text.rfind('"') - data - 2));
  const std::size_t row = clip.meta["joints"].size() * 3,
                    n = std::size_t(clip.meta["count"].get<int>()) * row;
  std::vector<unsigned char> planes(n * 8);
  uLongf size = uLongf(planes.size());
  EXPECT_EQ(uncompress(planes.data(), &size, packed.data(), uLong(packed.size())), Z_OK);
  EXPECT_EQ(size, planes.size());
  std::vector<std::int16_t> q(n * 4);
  for (std::size_t k = 0; k < q.size(); ++k)
    q[k] = std::int16_t(std::uint16_t(planes[k] | planes[q.size() + k] << 8) +
                        (k >= row ? std::uint16_t(q[k - row]) : 0));
  const double ps = clip.meta["position_scale"], as = clip.meta["angle_scale"];
  for (int v = 0; v < 2; ++v) {
    for (std::size_t k = 0; k < n; ++k) {
      clip.positions[v].push_back(float(q[std::size_t(v) * n + k] * ps));
      clip.angles[v].push_back(float(q[(2 + std::size_t(v)) * n + k] * as));
    }
  }
  return clip;
}

Clip read_clip(const fs::path& path) {
  io::BvhReadResult r = io::read_bvh(path);
  EXPECT_TRUE(r.clip) << path;
  return std::move(*r.clip);
}

TEST(ReviewReport, GuessesTheFileUnitFromTheBodyHeight) {
  std::string name;
  EXPECT_EQ(engine::guess_cm_per_unit(172, &name), 1.0);
  EXPECT_EQ(name, "cm");
  EXPECT_EQ(engine::guess_cm_per_unit(1.72, &name), 100.0);
  EXPECT_EQ(name, "m");
  EXPECT_EQ(engine::guess_cm_per_unit(68, &name), 2.54);
  EXPECT_EQ(name, "inch");
  EXPECT_NEAR(engine::guess_cm_per_unit(30, &name), 2.54 / 0.45, 1e-12);  // CMU's conversions
  EXPECT_NE(name.find("CMU"), std::string::npos);
  EXPECT_NEAR(engine::guess_cm_per_unit(5, &name), 34.0, 1e-12);  // nothing fits: 170 cm tall
  EXPECT_NE(name.find("unknown"), std::string::npos);
}

// The clip's data on the page is its forward kinematics, as read and as written, within the
// int16 step; every frame with a pop is sampled; the list row names the clip and its pops.
TEST(ReviewReport, ThePageHoldsTheMotionBeforeAndAfterAndEveryPopFrame) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  const fs::path input = test::shared_bvh_dir() / "cmu_mb_02_03.bvh";
  test::TempDir dir("review");
  const auto run = test::run_cli("clean '" + input.string() + "' -o '" + (dir / "out").string() +
                                 "' --report '" + (dir / "review").string() + "' --no-progress");
  if (run.exit_code == 2 && run.err.find("three.js") != std::string::npos)
    GTEST_SKIP() << "built without three.js: " << run.err;
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("review page:"), std::string::npos) << run.err;

  const std::string page = test::read_text(dir / "review" / "index.html");
  const std::string open = R"(<script type="application/json" id="clips-data">)";
  const std::size_t begin = page.find(open);
  ASSERT_NE(begin, std::string::npos);
  const std::size_t end = page.find("</script>", begin);
  const nlohmann::json rows =
      nlohmann::json::parse(page.substr(begin + open.size(), end - begin - open.size()));
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0]["name"], "cmu_mb_02_03.bvh");
  EXPECT_EQ(rows[0]["frames"], 174);
  EXPECT_EQ(page.find("@THREE_JS@"), std::string::npos);  // every marker filled
  EXPECT_NE(page.find("REVISION"), std::string::npos);    // three.js inside

  const PageClip clip = read_page_clip(dir / "review" / rows[0]["file"].get<std::string>());
  const Clip before = read_clip(input), after = read_clip(dir / "out" / "cmu_mb_02_03.bvh");
  const double cm = engine::guess_cm_per_unit(engine::body_height(*before.skeleton), nullptr);
  const std::vector<float> fk[2] = {engine::joint_positions(before),
                                    engine::joint_positions(after)};
  const std::vector<int> frames = clip.meta["sample_frames"];
  const std::size_t J = std::size_t(before.joints());
  ASSERT_EQ(frames.size(), std::size_t(clip.meta["count"].get<int>()));
  EXPECT_EQ(clip.meta["stride"], 2);  // 120 Hz, shown at 60
  const double step = clip.meta["position_scale"];
  for (int v = 0; v < 2; ++v) {
    double worst = 0;
    for (std::size_t s = 0; s < frames.size(); ++s)
      for (std::size_t k = 0; k < J * 3; ++k)
        worst = std::max(worst, std::abs(clip.positions[v][s * J * 3 + k] -
                                         fk[v][std::size_t(frames[s]) * J * 3 + k] * cm));
    // Half a step of quantization; after: also the BVH text's rounding of the written angles.
    EXPECT_LT(worst, step * 0.5 + (v == 0 ? 1e-4 : 1e-3)) << (v == 0 ? "before" : "after");
  }
  // Pops: each one's frame is sampled, and the row counts them.
  const nlohmann::json& pops = clip.meta["pops"];
  EXPECT_EQ(rows[0]["pops"], pops.size());
  ASSERT_GT(pops.size(), 0u);  // 02_03 has two (LeftToeBase)
  for (const auto& p : pops)
    EXPECT_TRUE(std::binary_search(frames.begin(), frames.end(), p[0].get<int>())) << p;
  // A joint's angle curve: the rotation vector of the clip as read, in degrees.
  const int t = frames[frames.size() / 2], j = 5;
  const Vec3 r = log(load_quat(before.rotation_view().at(t, j)));
  const std::size_t at = (frames.size() / 2 * J + std::size_t(j)) * 3;
  EXPECT_NEAR(clip.angles[0][at], r.x * 180 / 3.14159265358979323846,
              clip.meta["angle_scale"].get<double>());
}

TEST(ReviewReport, AReportFolderThatCannotBeMadeIsAUsageErrorNamingIt) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir dir("review-bad");
  {
    std::ofstream blocker(dir / "file");
    blocker << "x";
  }
  const auto run = test::run_cli(
      "clean '" + (test::shared_bvh_dir() / "cmu_mb_02_03.bvh").string() + "' -o '" +
      (dir / "out").string() + "' --report '" + (dir / "file" / "review").string() + "'");
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find((dir / "file" / "review").string()), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir / "out"));  // refused before cleaning anything
}

// filter --report: the same page from a library.
TEST(ReviewReport, FilterWritesThePageForALibrary) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  test::TempDir dir("review-lib");
  const std::string lib = (dir / "lib.h5").string();
  ASSERT_EQ(
      test::run_cli("import '" + test::shared_bvh_dir().string() + "' -o '" + lib + "'").exit_code,
      0);
  const auto run = test::run_cli("filter '" + lib + "' -o '" + (dir / "clean.h5").string() +
                                 "' --report '" + (dir / "review").string() + "' --no-progress");
  if (run.exit_code == 2 && run.err.find("three.js") != std::string::npos)
    GTEST_SKIP() << "built without three.js: " << run.err;
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string page = test::read_text(dir / "review" / "index.html");
  EXPECT_NE(page.find("\"command\":\"filter\""), std::string::npos);
  const std::size_t clips = test::shared_bvh_files().size();
  for (std::size_t i = 0; i < clips; ++i)
    EXPECT_TRUE(fs::exists(dir / "review" / "clips" / fmt::format("{:05}.js", i))) << i;
}

}  // namespace
}  // namespace mocap
