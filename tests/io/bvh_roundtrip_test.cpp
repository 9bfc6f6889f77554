// Read, write, read again: the BVH writer keeps the hierarchy, frame count and frame time, every
// rotation within 1e-6 rad and translation within 1e-6, and writes Euler curves without wraps.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/euler.hpp"
#include "core/quaternion.hpp"
#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "tests/test_support.hpp"

namespace mocap::io {
namespace {

constexpr double kDeg = kPi / 180.0;
constexpr double kRotationTolerance = 1e-6;     // rad, geodesic
constexpr double kTranslationTolerance = 1e-6;  // file units, absolute

// A scratch directory removed at the end of the test.
struct ScratchDir {
  std::filesystem::path path;
  ScratchDir() {
    path = std::filesystem::temp_directory_path() /
           ("bvh_roundtrip_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
};

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

Clip parse_ok(const std::string& text, const std::string& name) {
  BvhReadResult result = parse_bvh(text, name);
  EXPECT_FALSE(result.error) << result.error->what();
  return result.clip ? std::move(*result.clip) : Clip{};
}

struct RoundTripErrors {
  double rotation = 0, translation = 0;
};

RoundTripErrors expect_same_motion(const Clip& a, const Clip& b) {
  RoundTripErrors errors;
  EXPECT_EQ(a.frames, b.frames);
  EXPECT_EQ(a.frame_time, b.frame_time);
  EXPECT_TRUE(*a.skeleton == *b.skeleton);
  if (a.frames != b.frames || a.joints() != b.joints()) return errors;
  errors.rotation = test::rotation_errors(a.rotation_view(), b.rotation_view()).max;
  for (std::size_t i = 0; i < a.translations.size(); ++i)
    errors.translation =
        std::max(errors.translation, double(std::abs(a.translations[i] - b.translations[i])));
  EXPECT_LE(errors.rotation, kRotationTolerance);
  EXPECT_LE(errors.translation, kTranslationTolerance);
  return errors;
}

// The channel values of the frame lines of a BVH text, read the slow, obvious way.
std::vector<std::vector<double>> frame_values(const std::string& text) {
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

// In the written text, no rotation channel jumps by 180 degrees or more between two frames
// unless the rotation itself turns by 90 degrees or more there. Returns the largest jump (deg)
// seen across a step of less than 90 degrees.
double expect_continuous_euler(const Clip& clip, const std::string& text) {
  const auto rows = frame_values(text);
  EXPECT_EQ(int(rows.size()), clip.frames);
  const Skeleton& s = *clip.skeleton;
  double largest = 0;
  for (int t = 1; t < int(rows.size()); ++t) {
    std::size_t column = 0;
    for (int j = 0; j < s.joint_count(); ++j) {
      const double step = geodesic(load_quat(clip.rotation_view().at(t - 1, j)),
                                   load_quat(clip.rotation_view().at(t, j)));
      for (Channel c : s.channels[std::size_t(j)]) {
        if (is_rotation(c) && step < 90 * kDeg) {
          const double jump =
              std::abs(rows[std::size_t(t)][column] - rows[std::size_t(t - 1)][column]);
          largest = std::max(largest, jump);
          EXPECT_LT(jump, 180) << "frame " << t << " joint " << s.joint_names[std::size_t(j)]
                               << " channel " << to_string(c) << ", rotation step " << step / kDeg
                               << " deg";
        }
        ++column;
      }
    }
  }
  return largest;
}

TEST(BvhRoundTrip, SharedCmuClipsSurviveWriteAndRead) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  ScratchDir scratch;
  for (const auto& path : test::shared_bvh_files()) {
    SCOPED_TRACE(path.string());
    const BvhReadResult first = read_bvh(path);
    ASSERT_FALSE(first.error) << first.error->what();
    const auto written = scratch.path / path.filename();
    std::string error;
    ASSERT_TRUE(write_bvh(*first.clip, written, &error)) << error;
    EXPECT_FALSE(std::filesystem::exists(written.string() + ".tmp"));
    const BvhReadResult second = read_bvh(written);
    ASSERT_FALSE(second.error) << second.error->what();
    const RoundTripErrors errors = expect_same_motion(*first.clip, *second.clip);
    const double jump = expect_continuous_euler(*first.clip, slurp(written));
    std::printf(
        "%s: max rotation error %.3g rad, max translation error %.3g, largest Euler "
        "step %.1f deg\n",
        path.filename().c_str(), errors.rotation, errors.translation, jump);
  }
}

TEST(BvhRoundTrip, FormatIsTheTextWriteBvhWrites) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  ScratchDir scratch;
  const BvhReadResult clip = read_bvh(test::shared_bvh_files().front());
  ASSERT_TRUE(clip.clip);
  const auto written = scratch.path / "out.bvh";
  ASSERT_TRUE(write_bvh(*clip.clip, written, nullptr));
  const std::string text = format_bvh(*clip.clip);
  EXPECT_EQ(slurp(written), text);
  EXPECT_EQ(text.find('\r'), std::string::npos);          // LF line endings
  EXPECT_NE(text.find("\n\tJOINT "), std::string::npos);  // tab indentation
}

// A root with positions and rotations and a child, both in `order`, with an End Site.
std::shared_ptr<Skeleton> two_joint_skeleton(RotationOrder order) {
  auto s = std::make_shared<Skeleton>();
  std::vector<Channel> rotations;
  for (int i = 0; i < 3; ++i) rotations.push_back(Channel(3 + order_axis(order, i)));
  s->joint_names = {"Root", "Child"};
  s->parents = {-1, 0};
  s->offsets = {{0, 0, 0}, {0.5, 1.25, -3}};
  s->channels = {{Channel::Xposition, Channel::Yposition, Channel::Zposition}, rotations};
  s->channels[0].insert(s->channels[0].end(), rotations.begin(), rotations.end());
  s->end_sites = {std::nullopt, Vec3{0, 2, 0}};
  return s;
}

Clip clip_of(std::shared_ptr<Skeleton> skeleton, const std::vector<Quat>& root,
             const std::vector<Quat>& child) {
  Clip clip;
  clip.skeleton = skeleton;
  clip.frame_time = 1.0 / 120;
  clip.frames = int(root.size());
  for (std::size_t t = 0; t < root.size(); ++t) {
    for (const Quat& q : {root[t], child[t]})
      for (double v : {q.w, q.x, q.y, q.z}) clip.rotations.push_back(float(v));
    for (double v : {0.1 * double(t), 17.8693, -123.456789}) clip.translations.push_back(float(v));
    for (double v : {0.5, 1.25, -3.0}) clip.translations.push_back(float(v));
  }
  make_hemisphere_continuous(clip.rotation_span());
  return clip;
}

TEST(BvhRoundTrip, SyntheticClipsOfAllSixOrdersIncludingGimbalLock) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (int o = 0; o < 6; ++o) {
    const RotationOrder order = RotationOrder(o);
    SCOPED_TRACE(std::string(to_string(order)));
    std::vector<Quat> root, child;
    // Exact gimbal lock, and near it from both sides.
    for (double b :
         {kPi / 2, -kPi / 2, kPi / 2 - 1e-9, kPi / 2 + 1e-7, -kPi / 2 + 1e-5, kPi / 2 - 1e-3})
      for (int k = 0; k < 8; ++k) {
        root.push_back(euler_to_quat(order, {u(rng), b, u(rng)}));
        child.push_back(euler_to_quat(order, {u(rng), -b, u(rng)}));
      }
    // A smooth path through gimbal lock.
    for (int t = 0; t <= 100; ++t) {
      const double s = t / 100.0;
      root.push_back(euler_to_quat(order, {0.3 + s, -0.2 + 3 * s, 1 - 2 * s}));
      child.push_back(euler_to_quat(order, {2 * s, kPi / 2 * (1 - s) + 0.01, -s}));
    }
    // Arbitrary rotations.
    for (int k = 0; k < 50; ++k) {
      root.push_back(test::random_rotation(rng));
      child.push_back(test::random_rotation(rng));
    }
    const Clip original = clip_of(two_joint_skeleton(order), root, child);
    ASSERT_EQ(check_clip_for_bvh(original), "");
    const std::string text = format_bvh(original);
    const Clip reread = parse_ok(text, "synthetic.bvh");
    expect_same_motion(original, reread);
  }
}

TEST(BvhRoundTrip, SmoothSyntheticMotionIsWrittenWithContinuousAngles) {
  std::mt19937_64 rng(9);
  for (int o = 0; o < 6; ++o) {
    const RotationOrder order = RotationOrder(o);
    SCOPED_TRACE(std::string(to_string(order)));
    const int frames = 400;
    // Large amplitudes so that angles cross +-180 degrees and wrap if the writer lets them.
    const std::vector<float> motion = test::random_motion(rng, frames, 2, 3.0);
    std::vector<Quat> root, child;
    for (int t = 0; t < frames; ++t) {
      root.push_back(load_quat(&motion[std::size_t(t) * 8]));
      child.push_back(load_quat(&motion[std::size_t(t) * 8 + 4]));
    }
    const Clip original = clip_of(two_joint_skeleton(order), root, child);
    const std::string text = format_bvh(original);
    expect_same_motion(original, parse_ok(text, "smooth.bvh"));
    expect_continuous_euler(original, text);
  }
}

TEST(BvhRoundTrip, ContinuousAnglesLeaveThePlusMinus180Range) {
  // A steady spin about the first axis: the written angle keeps growing instead of wrapping.
  const auto skeleton = two_joint_skeleton(RotationOrder::ZXY);
  std::vector<Quat> spin, still;
  for (int t = 0; t < 100; ++t) {
    spin.push_back(euler_to_quat(RotationOrder::ZXY, {t * 10 * kDeg, 0.2, 0}));
    still.push_back(Quat{});
  }
  const Clip clip = clip_of(skeleton, spin, still);
  const auto rows = frame_values(format_bvh(clip));
  ASSERT_EQ(rows.size(), 100u);
  EXPECT_NEAR(rows.back()[3], 990, 1e-5);  // column 3: the root's Zrotation
}

// The frame lines' number forms, each written straight into the line: degrees with six
// decimals and trailing zeros dropped ("12.5", "-0.000123"), no "-0", fixed notation with six
// decimals past 9e12 degrees (a source whose own branch lies that far), the translations'
// shortest float form.
TEST(BvhRoundTrip, FrameValuesAreWrittenInTheirShortForms) {
  const auto skeleton = two_joint_skeleton(RotationOrder::ZXY);
  const std::vector<Quat> root = {euler_to_quat(RotationOrder::ZXY, {12.5 * kDeg, 0, 0}),
                                  euler_to_quat(RotationOrder::ZXY, {-0.000123 * kDeg, 0, 0}),
                                  euler_to_quat(RotationOrder::ZXY, {-1e-9 * kDeg, 0, 0}), Quat{}};
  Clip clip = clip_of(skeleton, root, std::vector<Quat>(4, Quat{}));
  clip.source_angles.assign(4 * 2 * 3, 0.0f);
  clip.source_angles[3 * 2 * 3] = 2e11f;  // frame 3's root, first angle: its own far branch
  const std::string text = format_bvh(clip);
  std::istringstream in(text.substr(text.find("Frame Time:")));
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<std::string>> rows;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    rows.emplace_back();
    for (std::string w; words >> w;) rows.back().push_back(w);
  }
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[0][3], "12.5");
  EXPECT_EQ(rows[1][3], "-0.000123");
  EXPECT_EQ(rows[2][3], "0");
  EXPECT_EQ(rows[0][1], "17.8693");  // the translation's float, shortest
  EXPECT_EQ(rows[0][2], "-123.45679");
  const std::string& far = rows[3][3];
  ASSERT_NE(far.find('.'), std::string::npos) << far;
  EXPECT_EQ(far.size() - far.find('.'), 7u) << far;
  EXPECT_NEAR(std::stod(far) / (2e11 / kDeg), 1.0, 1e-6) << far;
}

TEST(BvhRoundTrip, WriteReplacesAtomicallyAndRefusesBadClips) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  ScratchDir scratch;
  const BvhReadResult read = read_bvh(test::shared_bvh_files().front());
  ASSERT_TRUE(read.clip);
  const auto target = scratch.path / "clip.bvh";
  std::string error;
  ASSERT_TRUE(write_bvh(*read.clip, target, &error)) << error;
  const std::string before = slurp(target);

  // A clip with a NaN is refused before anything is written: the old file stays whole.
  Clip broken = *read.clip;
  broken.rotations[5] = std::nanf("");
  EXPECT_FALSE(write_bvh(broken, target, &error));
  EXPECT_EQ(error, target.string() + ": the clip holds non-finite values");
  EXPECT_EQ(slurp(target), before);
  EXPECT_FALSE(std::filesystem::exists(target.string() + ".tmp"));

  Clip wrong_size = *read.clip;
  wrong_size.translations.pop_back();
  EXPECT_FALSE(write_bvh(wrong_size, target, &error));
  EXPECT_NE(error.find("the tensors do not match"), std::string::npos) << error;

  Clip no_time = *read.clip;
  no_time.frame_time = 0;
  EXPECT_FALSE(write_bvh(no_time, target, nullptr));

  // An unwritable place leaves nothing behind and says why.
  const auto nowhere = scratch.path / "missing-dir" / "clip.bvh";
  EXPECT_FALSE(write_bvh(*read.clip, nowhere, &error));
  EXPECT_NE(error.find("cannot create"), std::string::npos) << error;
  EXPECT_FALSE(std::filesystem::exists(nowhere.parent_path()));
  EXPECT_EQ(slurp(target), before);
}

TEST(BvhRoundTrip, SkeletonsBvhCannotHoldAreRefused) {
  Clip clip = clip_of(two_joint_skeleton(RotationOrder::XYZ), {Quat{}}, {Quat{}});
  auto two_roots = std::make_shared<Skeleton>(*clip.skeleton);
  two_roots->parents[1] = -1;
  clip.skeleton = two_roots;
  // The shared skeleton check (core/skeleton.hpp) refuses it for every format.
  EXPECT_EQ(check_clip_for_bvh(clip), "joint 'Child' is a second root; a skeleton has exactly one");
  auto bad_name = std::make_shared<Skeleton>(*two_joint_skeleton(RotationOrder::XYZ));
  bad_name->joint_names[1] = "Left{Arm";
  clip.skeleton = bad_name;
  EXPECT_NE(check_clip_for_bvh(clip).find("Left{Arm"), std::string::npos);
}

}  // namespace
}  // namespace mocap::io
