// The BVH reader on well-formed input: channel orders and layouts, the textual variations of real
// files, End Sites, sign continuity, bounds on nesting and claimed frame counts, and the CMU clips.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/euler.hpp"
#include "core/quaternion.hpp"
#include "io/bvh_reader.hpp"
#include "tests/test_support.hpp"

namespace mocap::io {
namespace {

constexpr double kDeg = kPi / 180.0;
// Quaternions are stored as float: about 6e-8 per component.
constexpr double kFloatRotation = 1e-6;

Clip parse_ok(const std::string& text, const std::string& name = "test.bvh") {
  BvhReadResult result = parse_bvh(text, name);
  EXPECT_FALSE(result.error) << result.error->what();
  EXPECT_TRUE(result.clip);
  return result.clip ? std::move(*result.clip) : Clip{};
}

Quat axis_angle(int axis, double degrees) {
  Vec3 v;
  (axis == 0 ? v.x : axis == 1 ? v.y : v.z) = degrees * kDeg;
  return exp(v);
}

// The rotation a BVH channel list means, built from first principles: one rotation per channel,
// composed R_first * R_second * R_third in file order.
Quat bvh_rotation(const std::string& axes, const double degrees[3]) {
  Quat q;
  for (int i = 0; i < 3; ++i) q = q * axis_angle(axes[std::size_t(i)] - 'X', degrees[i]);
  return q;
}

std::string rotation_channels(const std::string& axes) {
  std::string out;
  for (char axis : axes) out += std::string(" ") + axis + "rotation";
  return out;
}

Quat rotation_at(const Clip& clip, int frame, int joint) {
  return load_quat(clip.rotation_view().at(frame, joint));
}

Vec3 translation_at(const Clip& clip, int frame, int joint) {
  return load_vec3(clip.translation_view().at(frame, joint));
}

const char* const kOrders[6] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};

TEST(BvhReader, EachOfTheSixOrdersComposesInFileOrder) {
  const double angles[3] = {30, -45, 60};
  for (int o = 0; o < 6; ++o) {
    const std::string axes = kOrders[o];
    const std::string text =
        "HIERARCHY\nROOT Hips\n{\n\tOFFSET 1 2 3\n\tCHANNELS 6 Xposition "
        "Yposition Zposition" +
        rotation_channels(axes) +
        "\n\tEnd Site\n\t{\n\t\tOFFSET 0 1 0\n\t}\n}\nMOTION\nFrames: 1\n"
        "Frame Time: 0.01\n4 5 6 30 -45 60\n";
    const Clip clip = parse_ok(text);
    ASSERT_EQ(clip.frames, 1);
    EXPECT_EQ(clip.skeleton->rotation_order(0), RotationOrder(o)) << axes;
    const Quat expected = bvh_rotation(axes, angles);
    EXPECT_LT(geodesic(rotation_at(clip, 0, 0), expected), kFloatRotation) << axes;
    const Quat via_kernel =
        euler_to_quat(RotationOrder(o), {angles[0] * kDeg, angles[1] * kDeg, angles[2] * kDeg});
    EXPECT_LT(geodesic(rotation_at(clip, 0, 0), via_kernel), kFloatRotation) << axes;
    const Vec3 t = translation_at(clip, 0, 0);
    EXPECT_EQ(t.x, 4);
    EXPECT_EQ(t.y, 5);
    EXPECT_EQ(t.z, 6);
  }
}

TEST(BvhReader, MixedOrdersPerJointAndInterleavedChannels) {
  // The root interleaves positions and rotations; each joint has its own order.
  const std::string text =
      "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n"
      "  CHANNELS 6 Zrotation Xposition Xrotation Yposition Yrotation Zposition\n"
      "  JOINT Spine\n  {\n    OFFSET 0 5 0\n    CHANNELS 3 Yrotation Zrotation Xrotation\n"
      "    JOINT Head\n    {\n      OFFSET 0 3 0\n      CHANNELS 3 Xrotation Zrotation Yrotation\n"
      "      End Site\n      {\n        OFFSET 0 1 0\n      }\n    }\n  }\n"
      "  JOINT Tail\n  {\n    OFFSET 0 -2 0\n    CHANNELS 0\n  }\n}\n"
      "MOTION\nFrames: 2\nFrame Time: 0.5\n"
      "10 1 20 2 30 3 40 50 60 70 80 90\n"
      "-10 -1 -20 -2 -30 -3 -40 -50 -60 -70 -80 -90\n";
  const Clip clip = parse_ok(text);
  ASSERT_EQ(clip.frames, 2);
  ASSERT_EQ(clip.joints(), 4);
  for (int t = 0; t < 2; ++t) {
    const double s = t == 0 ? 1 : -1;
    const double root[3] = {10 * s, 20 * s, 30 * s};
    const double spine[3] = {40 * s, 50 * s, 60 * s};
    const double head[3] = {70 * s, 80 * s, 90 * s};
    EXPECT_LT(geodesic(rotation_at(clip, t, 0), bvh_rotation("ZXY", root)), kFloatRotation);
    EXPECT_LT(geodesic(rotation_at(clip, t, 1), bvh_rotation("YZX", spine)), kFloatRotation);
    EXPECT_LT(geodesic(rotation_at(clip, t, 2), bvh_rotation("XZY", head)), kFloatRotation);
    EXPECT_LT(geodesic(rotation_at(clip, t, 3), Quat{}), kFloatRotation);  // no channels
    const Vec3 p = translation_at(clip, t, 0);
    EXPECT_EQ(p.x, 1 * s);
    EXPECT_EQ(p.y, 2 * s);
    EXPECT_EQ(p.z, 3 * s);
    // Joints without position channels hold their OFFSET.
    EXPECT_EQ(translation_at(clip, t, 1).y, 5);
    EXPECT_EQ(translation_at(clip, t, 3).y, -2);
  }
  EXPECT_EQ(clip.skeleton->parents, (std::vector<int>{-1, 0, 1, 0}));
  EXPECT_EQ(clip.skeleton->rotation_order(1), RotationOrder::YZX);
  EXPECT_EQ(clip.skeleton->channel_list(0),
            "Zrotation Xposition Xrotation Yposition Yrotation Zposition");
}

TEST(BvhReader, PositionChannelsOnEveryJoint) {
  const std::string text =
      "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation "
      "Xrotation Yrotation\nJOINT B\n{\nOFFSET 1 0 0\nCHANNELS 6 Xposition Yposition Zposition "
      "Zrotation Xrotation Yrotation\nJOINT C\n{\nOFFSET 0 1 0\nCHANNELS 6 Zposition Yposition "
      "Xposition Xrotation Yrotation Zrotation\nEnd Site\n{\nOFFSET 0 0 1\n}\n}\n}\n}\n"
      "MOTION\nFrames: 1\nFrame Time: 0.1\n1 2 3 0 0 0 4 5 6 0 0 90 7 8 9 0 0 0\n";
  const Clip clip = parse_ok(text);
  ASSERT_EQ(clip.joints(), 3);
  for (int j = 0; j < 3; ++j) EXPECT_TRUE(clip.skeleton->has_translation(j));
  const Vec3 a = translation_at(clip, 0, 0), b = translation_at(clip, 0, 1),
             c = translation_at(clip, 0, 2);
  EXPECT_EQ(a.x, 1);
  EXPECT_EQ(a.z, 3);
  EXPECT_EQ(b.x, 4);
  EXPECT_EQ(b.z, 6);
  EXPECT_EQ(c.x, 9);  // C lists Zposition first: 7 is z, 9 is x
  EXPECT_EQ(c.z, 7);
  const double b_angles[3] = {0, 0, 90};
  EXPECT_LT(geodesic(rotation_at(clip, 0, 1), bvh_rotation("ZXY", b_angles)), kFloatRotation);
}

const std::string kSmall =
    "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition "
    "Zrotation Yrotation Xrotation\n\tJOINT Leg\n\t{\n\t\tOFFSET 1 -2 0.5\n\t\tCHANNELS 3 "
    "Zrotation Yrotation Xrotation\n\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 -3 0\n\t\t}\n\t}\n}\n"
    "MOTION\nFrames: 3\nFrame Time: .0083333\n"
    "1 2 3 10 20 30 -5 15 25\n"
    "1.5 2.5 3.5 11 21 31 -6 16 26\n"
    "2 3 4 12 22 32 -7 17 27\n";

std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

void expect_same_clip(const Clip& a, const Clip& b) {
  ASSERT_EQ(a.frames, b.frames);
  EXPECT_EQ(*a.skeleton, *b.skeleton);
  EXPECT_EQ(a.frame_time, b.frame_time);
  EXPECT_EQ(a.rotations, b.rotations);
  EXPECT_EQ(a.translations, b.translations);
}

TEST(BvhReader, LineEndingsWhitespaceAndLayoutVariantsReadTheSame) {
  const Clip reference = parse_ok(kSmall);
  EXPECT_EQ(reference.frame_time, 0.0083333);
  // CRLF, lone CR, spaces instead of tabs, trailing blanks, blank lines, no final newline,
  // "End site", braces glued to names, lower-case keywords.
  const std::string variants[] = {
      replace_all(kSmall, "\n", "\r\n"),
      replace_all(kSmall, "\n", "\r"),
      replace_all(kSmall, "\t", "    "),
      replace_all(kSmall, "\n", " \t \n"),
      replace_all(kSmall, "\n", "\n\n"),
      kSmall.substr(0, kSmall.size() - 1),
      replace_all(kSmall, "End Site", "End site"),
      replace_all(replace_all(kSmall, "Hips\n{", "Hips {"), "Leg\n\t{", "Leg{"),
      replace_all(kSmall, "OFFSET", "offset"),
      replace_all(kSmall, " ", "\t"),
      "\xEF\xBB\xBF" + kSmall,
  };
  for (const std::string& text : variants) {
    SCOPED_TRACE(text.substr(0, 60));
    expect_same_clip(reference, parse_ok(text));
  }
}

TEST(BvhReader, NumberSpellingsOfRealFiles) {
  const std::string text = replace_all(kSmall, "1 2 3 10 20 30 -5 15 25\n",
                                       "+1e-5 1E+02 -.5 1.0e1 +20 3e1 -5. 0.15e2 +.25E2\n");
  const Clip clip = parse_ok(text);
  const Vec3 p = translation_at(clip, 0, 0);
  EXPECT_EQ(p.x, float(1e-5));
  EXPECT_EQ(p.y, 100.0f);
  EXPECT_EQ(p.z, -0.5f);
  const Clip reference = parse_ok(kSmall);
  for (int j = 0; j < 2; ++j)
    EXPECT_LT(geodesic(rotation_at(clip, 0, j), rotation_at(reference, 0, j)), 1e-7);
}

TEST(BvhReader, EndSitesAreRecordedOnTheirJoint) {
  const Clip clip = parse_ok(kSmall);
  const Skeleton& s = *clip.skeleton;
  ASSERT_EQ(s.joint_count(), 2);
  EXPECT_FALSE(s.end_sites[0]);
  ASSERT_TRUE(s.end_sites[1]);
  EXPECT_EQ(s.end_sites[1]->y, -3);
  EXPECT_EQ(s.offsets[1].x, 1);
  EXPECT_EQ(s.offsets[1].y, -2);
  EXPECT_EQ(s.offsets[1].z, 0.5);
  EXPECT_EQ(s.joint_names, (std::vector<std::string>{"Hips", "Leg"}));
  EXPECT_EQ(clip.source, "test.bvh");
  EXPECT_EQ(check_structure(s), "");
}

TEST(BvhReader, RotationsAreHemisphereContinuousAlongTime) {
  // Two full turns about Z in 10-degree steps: euler_to_quat alone flips sign every turn.
  std::string text =
      "HIERARCHY\nROOT R\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n}\n"
      "MOTION\nFrames: 73\nFrame Time: 0.1\n";
  for (int t = 0; t <= 72; ++t) text += std::to_string(t * 10) + " 5 0\n";
  const Clip clip = parse_ok(text);
  ASSERT_EQ(clip.frames, 73);
  for (int t = 0; t <= 72; ++t) {
    const double angles[3] = {t * 10.0, 5, 0};
    EXPECT_LT(geodesic(rotation_at(clip, t, 0), bvh_rotation("ZXY", angles)), kFloatRotation);
    const Quat q = rotation_at(clip, t, 0);
    EXPECT_NEAR(dot(q, q), 1.0, 1e-6);
    if (t > 0) {
      EXPECT_GE(dot(rotation_at(clip, t - 1, 0), q), 0) << "frame " << t;
    }
  }
}

// A chain of `depth` joints, each nested in the previous, with no indentation.
std::string nested_chain(int depth) {
  std::string text =
      "HIERARCHY\nROOT J0\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n";
  text.reserve(std::size_t(depth) * 40);
  for (int j = 1; j < depth; ++j)
    text += "JOINT J" + std::to_string(j) + "\n{\nOFFSET 0 1 0\nCHANNELS 0\n";
  text += "End Site\n{\nOFFSET 0 1 0\n}\n";
  for (int j = 0; j < depth; ++j) text += "}\n";
  text += "MOTION\nFrames: 1\nFrame Time: 0.1\n0 90 0\n";
  return text;
}

TEST(BvhReader, DeepNestingIsParsedWithoutRecursion) {
  const Clip clip = parse_ok(nested_chain(kMaxBvhJoints));
  ASSERT_EQ(clip.joints(), kMaxBvhJoints);
  EXPECT_EQ(clip.skeleton->parents.back(), kMaxBvhJoints - 2);
  EXPECT_TRUE(clip.skeleton->end_sites.back());
  EXPECT_EQ(translation_at(clip, 0, kMaxBvhJoints - 1).y, 1);
}

TEST(BvhReader, MoreJointsThanTheBoundIsAClearError) {
  // ROOT and 100,000 nested JOINTs: one joint too many.
  const std::string text = nested_chain(kMaxBvhJoints + 1);
  const BvhReadResult result = parse_bvh(text, "deep.bvh");
  ASSERT_TRUE(result.error);
  EXPECT_FALSE(result.clip);
  // Line of the joint that is one too many: 5 header lines, then 4 lines per joint.
  const int line = 6 + 4 * (kMaxBvhJoints - 1);
  EXPECT_EQ(result.error->line, line);
  EXPECT_EQ(result.error->what(), "deep.bvh:" + std::to_string(line) + ": more than 100000 joints");
}

TEST(BvhReader, AHugeClaimedFrameCountAllocatesOnlyForLinesPresent) {
  std::string text = replace_all(kSmall, "Frames: 3", "Frames: 100000000000");
  text = text.substr(0, text.find("2 3 4 12"));  // two frame lines remain
  const BvhReadResult result = parse_bvh(text, "claim.bvh");
  ASSERT_TRUE(result.error);
  EXPECT_EQ(result.error->what(),
            "claim.bvh:20: the file ends after 2 frame lines, but 'Frames:' (line 17) says "
            "100000000000");
}

TEST(BvhReader, ZeroFramesIsAnEmptyClip) {
  std::string text = replace_all(kSmall, "Frames: 3", "Frames: 0");
  text = text.substr(0, text.find("1 2 3 10"));
  const Clip clip = parse_ok(text);
  EXPECT_EQ(clip.frames, 0);
  EXPECT_TRUE(clip.rotations.empty());
  EXPECT_EQ(clip.joints(), 2);
}

// The frame count each clip's README gives (../shared/data/bvh/README.md).
const std::map<std::string, int> kReadmeFrames = {
    {"cmu_mb_01_01.bvh", 2752}, {"cmu_mb_02_01.bvh", 344},  {"cmu_mb_02_03.bvh", 174},
    {"cmu_mb_02_04.bvh", 484},  {"cmu_mb_02_05.bvh", 1855}, {"cmu_mb_02_10.bvh", 2646},
    {"cmu_mb_03_01.bvh", 433},  {"cmu_mb_05_02.bvh", 1124}, {"cmu_mb_06_14.bvh", 480},
};

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// Frame lines of a BVH text read the slow, obvious way, for comparison.
std::vector<std::vector<double>> naive_frames(const std::string& text) {
  std::istringstream in(text.substr(text.find("Frame Time:")));
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<double>> frames;
  while (std::getline(in, line)) {
    std::istringstream values(line);
    std::vector<double> row;
    for (double v; values >> v;) row.push_back(v);
    if (!row.empty()) frames.push_back(row);
  }
  return frames;
}

TEST(BvhReader, SharedCmuClipsMatchTheirReadmeAndAnIndependentReading) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  const auto files = test::shared_bvh_files();
  for (const auto& path : files) {
    SCOPED_TRACE(path.string());
    const BvhReadResult result = read_bvh(path);
    ASSERT_FALSE(result.error) << result.error->what();
    const Clip& clip = *result.clip;
    const auto readme = kReadmeFrames.find(path.filename().string());
    if (readme != kReadmeFrames.end()) {
      EXPECT_EQ(clip.frames, readme->second);
    }
    EXPECT_EQ(clip.joints(), 31);
    EXPECT_EQ(clip.skeleton->channel_count(), 96);
    EXPECT_EQ(clip.frame_time, 0.0083333);
    EXPECT_EQ(clip.source, path.string());
    int end_sites = 0;
    for (const auto& e : clip.skeleton->end_sites) end_sites += e.has_value();
    EXPECT_EQ(end_sites, 7);
    for (int j = 0; j < clip.joints(); ++j) {
      if (clip.skeleton->has_rotation(j)) {
        EXPECT_EQ(clip.skeleton->rotation_order(j), RotationOrder::ZYX);
      }
    }

    // Compare a few frames with the values read by iostreams, composed from first principles.
    const auto rows = naive_frames(slurp(path));
    ASSERT_EQ(int(rows.size()), clip.frames);
    for (int t : {0, 1, clip.frames / 2, clip.frames - 1}) {
      const auto& row = rows[std::size_t(t)];
      ASSERT_EQ(row.size(), 96u);
      EXPECT_EQ(translation_at(clip, t, 0).x, float(row[0]));
      EXPECT_EQ(translation_at(clip, t, 0).z, float(row[2]));
      std::size_t column = 3;
      for (int j = 0; j < clip.joints(); ++j) {
        const double angles[3] = {row[column], row[column + 1], row[column + 2]};
        column += 3;
        EXPECT_LT(geodesic(rotation_at(clip, t, j), bvh_rotation("ZYX", angles)), kFloatRotation)
            << "frame " << t << " joint " << j;
      }
    }
  }
}

// Prints the parse time of the largest clip (asserts nothing about time: CI machines vary, and
// sanitizer builds are several times slower).
TEST(BvhReader, ReportsParseTimeOfTheLargestClip) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  const auto path = test::shared_bvh_dir() / "cmu_mb_01_01.bvh";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "cmu_mb_01_01.bvh absent";
  const std::string text = slurp(path);
  double best_ms = 1e30;
  for (int run = 0; run < 5; ++run) {
    const auto start = std::chrono::steady_clock::now();
    const BvhReadResult result = parse_bvh(text, path.string());
    const auto stop = std::chrono::steady_clock::now();
    ASSERT_TRUE(result.clip);
    best_ms = std::min(best_ms, std::chrono::duration<double, std::milli>(stop - start).count());
  }
  std::printf("parse_bvh(cmu_mb_01_01.bvh, %zu bytes): %.2f ms (best of 5)\n", text.size(),
              best_ms);
}

}  // namespace
}  // namespace mocap::io
