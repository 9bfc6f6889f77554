// Forward kinematics (kernels/forward_kinematics.hpp) of chains whose positions are known.
#include "kernels/forward_kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "io/bvh_reader.hpp"
#include "tests/test_support.hpp"

namespace mocap {
namespace {

Quat about_z(double angle) {
  return exp(Vec3{0, 0, angle});
}

void expect_near(const float* p, Vec3 expected, double tolerance, const std::string& what) {
  EXPECT_NEAR(p[0], expected.x, tolerance) << what;
  EXPECT_NEAR(p[1], expected.y, tolerance) << what;
  EXPECT_NEAR(p[2], expected.z, tolerance) << what;
}

// A planar three-link arm: root at a moving translation, links of length 1 along x, each joint
// turning about z; the positions are the familiar sums of cosines and sines.
TEST(ForwardKinematics, PlanarArmMatchesTheClosedForm) {
  const std::vector<int> parents{-1, 0, 1};
  const std::vector<Vec3> offsets{{0, 0, 0}, {1, 0, 0}, {1, 0, 0}};
  const std::vector<JointSite> sites{{2, {1, 0, 0}}};  // the End Site of the last link
  const int frames = 5, joints = 3;
  std::vector<float> rotations(std::size_t(frames) * joints * 4);
  std::vector<float> translations(std::size_t(frames) * joints * 3, 0.0f);
  std::vector<float> positions(std::size_t(frames) * joints * 3), site_positions(frames * 3);
  std::vector<double> a0(frames), a1(frames), a2(frames);
  for (int t = 0; t < frames; ++t) {
    a0[t] = 0.3 * t;
    a1[t] = -0.5 + 0.2 * t;
    a2[t] = 1.1 - 0.4 * t;
    store_quat(about_z(a0[t]), &rotations[(t * joints + 0) * 4]);
    store_quat(about_z(a1[t]), &rotations[(t * joints + 1) * 4]);
    store_quat(about_z(a2[t]), &rotations[(t * joints + 2) * 4]);
    store_vec3({2.0 * t, 5.0, -1.0}, &translations[(t * joints + 0) * 3]);
  }
  const std::vector<std::uint8_t> translated{1, 0, 0};
  ForwardKinematicsJob fk;
  fk.parents = parents;
  fk.offsets = offsets;
  fk.rotations = {rotations.data(), frames, joints};
  fk.translations = {translations.data(), frames, joints};
  fk.translated_joints = translated;
  fk.sites = sites;
  fk.positions = {positions.data(), frames, joints};
  fk.site_positions = {site_positions.data(), frames, 1};
  ASSERT_TRUE(fk.run().ok());
  for (int t = 0; t < frames; ++t) {
    const Vec3 root{2.0 * t, 5.0, -1.0};
    const double s1 = a0[t], s2 = a0[t] + a1[t], s3 = s2 + a2[t];
    const Vec3 p1 = root + Vec3{std::cos(s1), std::sin(s1), 0};
    const Vec3 p2 = p1 + Vec3{std::cos(s2), std::sin(s2), 0};
    const Vec3 tip = p2 + Vec3{std::cos(s3), std::sin(s3), 0};
    const std::string frame = "frame " + std::to_string(t);
    expect_near(&positions[(t * joints + 0) * 3], root, 1e-5, frame + " root");
    expect_near(&positions[(t * joints + 1) * 3], p1, 1e-5, frame + " joint 1");
    expect_near(&positions[(t * joints + 2) * 3], p2, 1e-5, frame + " joint 2");
    expect_near(&site_positions[t * 3], tip, 1e-5, frame + " end site");
  }
}

// Moving the whole skeleton: a constant rotation a of the root rotates every position about the
// root, a constant translation shifts them all (property, random skeleton and poses).
TEST(ForwardKinematics, IsEquivariantUnderARigidMotionOfTheRoot) {
  std::mt19937_64 rng(11);
  const int frames = 4, joints = 9;
  std::vector<int> parents{-1};
  std::vector<Vec3> offsets{{0, 0, 0}};
  std::uniform_real_distribution<double> u(-1, 1);
  for (int j = 1; j < joints; ++j) {
    parents.push_back(int(rng() % std::uint64_t(j)));
    offsets.push_back({u(rng), u(rng), u(rng)});
  }
  std::vector<float> rotations(std::size_t(frames) * joints * 4), moved(rotations.size());
  for (int i = 0; i < frames * joints; ++i)
    store_quat(test::random_rotation(rng), &rotations[i * 4]);
  const Quat a = test::random_rotation(rng);
  const Vec3 shift{3, -2, 7};
  moved = rotations;
  std::vector<float> translations(std::size_t(frames) * joints * 3, 0.0f);
  for (int t = 0; t < frames; ++t) {
    store_quat(a * load_quat(&rotations[(t * joints) * 4]), &moved[(t * joints) * 4]);
    store_vec3(shift, &translations[(t * joints) * 3]);
  }
  std::vector<std::uint8_t> root_only(joints, 0);
  root_only[0] = 1;
  std::vector<float> before(std::size_t(frames) * joints * 3), after(before.size());
  ForwardKinematicsJob fk;
  fk.parents = parents;
  fk.offsets = offsets;
  fk.rotations = {rotations.data(), frames, joints};
  fk.positions = {before.data(), frames, joints};
  ASSERT_TRUE(fk.run().ok());
  fk.rotations = {moved.data(), frames, joints};
  fk.translations = {translations.data(), frames, joints};
  fk.translated_joints = root_only;
  fk.positions = {after.data(), frames, joints};
  ASSERT_TRUE(fk.run().ok());
  for (int i = 0; i < frames * joints; ++i)
    expect_near(&after[i * 3], shift + rotate(a, load_vec3(&before[i * 3])), 1e-5,
                "sample " + std::to_string(i));
}

// output_joints computes only the chains above the wanted joints, with the same arithmetic:
// their positions are the full run's bit for bit, in the order asked, with translated joints.
TEST(ForwardKinematics, OutputJointsAreTheFullRunsBitForBit) {
  std::mt19937_64 rng(5);
  const int frames = 6, joints = 14;
  std::vector<int> parents{-1};
  std::vector<Vec3> offsets{{0, 0, 0}};
  std::uniform_real_distribution<double> u(-1, 1);
  for (int j = 1; j < joints; ++j) {
    parents.push_back(int(rng() % std::uint64_t(j)));
    offsets.push_back({u(rng), u(rng), u(rng)});
  }
  std::vector<float> rotations(std::size_t(frames) * joints * 4);
  std::vector<float> translations(std::size_t(frames) * joints * 3);
  for (int i = 0; i < frames * joints; ++i) {
    store_quat(test::random_rotation(rng), &rotations[std::size_t(i) * 4]);
    store_vec3({u(rng), u(rng), u(rng)}, &translations[std::size_t(i) * 3]);
  }
  std::vector<std::uint8_t> translated(joints, 0);
  translated[0] = translated[3] = 1;
  std::vector<float> all(std::size_t(frames) * joints * 3);
  ForwardKinematicsJob fk;
  fk.parents = parents;
  fk.offsets = offsets;
  fk.rotations = {rotations.data(), frames, joints};
  fk.translations = {translations.data(), frames, joints};
  fk.translated_joints = translated;
  fk.positions = {all.data(), frames, joints};
  ASSERT_TRUE(fk.run().ok());
  const std::vector<int> wanted{13, 4, 0, 9};
  std::vector<float> some(std::size_t(frames) * wanted.size() * 3, -7.0f);
  fk.output_joints = wanted;
  fk.positions = {some.data(), frames, int(wanted.size())};
  ASSERT_TRUE(fk.run().ok());
  for (int t = 0; t < frames; ++t)
    for (std::size_t k = 0; k < wanted.size(); ++k)
      for (int axis = 0; axis < 3; ++axis)
        EXPECT_EQ(some[(std::size_t(t) * wanted.size() + k) * 3 + std::size_t(axis)],
                  all[(std::size_t(t) * joints + std::size_t(wanted[k])) * 3 + std::size_t(axis)])
            << "frame " << t << ", joint " << wanted[k];

  // A position array of the whole skeleton is not one of the wanted joints'.
  fk.positions = {all.data(), frames, joints};
  EXPECT_FALSE(fk.validate().ok());
  const std::vector<int> outside{joints};
  fk.output_joints = outside;
  fk.positions = {some.data(), frames, 1};
  EXPECT_NE(fk.validate().message().find("output joint 14"), std::string::npos);
}

// Runs both implementations of `fk` (its outputs replaced) and counts the floats that differ in
// any bit, positions and sites; each output starts from a different fill, so a value either path
// fails to write shows up too.
long differing_bits(ForwardKinematicsJob fk) {
  const std::size_t frames = std::size_t(fk.rotations.frames);
  const std::size_t outputs =
      fk.output_joints.empty() ? fk.parents.size() : fk.output_joints.size();
  std::vector<float> positions[2], sites[2];
  for (int k = 0; k < 2; ++k) {
    positions[k].assign(frames * outputs * 3, k == 0 ? -1.0f : 2.0f);
    sites[k].assign(frames * fk.sites.size() * 3, k == 0 ? -1.0f : 2.0f);
    fk.implementation = k == 0 ? Implementation::reference : Implementation::fast;
    fk.positions = {positions[k].data(), int(frames), int(outputs)};
    fk.site_positions = {sites[k].data(), int(frames), int(fk.sites.size())};
    if (!fk.run().ok()) return -1;
  }
  long differ = 0;
  for (int part = 0; part < 2; ++part) {
    const std::vector<float>(&values)[2] = part == 0 ? positions : sites;
    for (std::size_t i = 0; i < values[0].size(); ++i)
      differ += std::memcmp(&values[0][i], &values[1][i], sizeof(float)) != 0;
  }
  return differ;
}

// The fast path does the reference's operations in its order (kernels/simd/
// forward_kinematics_simd.hpp): the same bits for random skeletons, clip lengths around the
// chunk and vector sizes, translated joints (a root and an inner joint), sites, output joints,
// and offsets with zero components (the zero products decide a zero's sign).
TEST(ForwardKinematics, FastPathIsTheReferenceBitForBit) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const int frames : {1, 7, 8, 63, 64, 65, 200}) {
    const int joints = 3 + int(rng() % 30);
    std::vector<int> parents{-1};
    std::vector<Vec3> offsets{{0, 0, 0}};
    for (int j = 1; j < joints; ++j) {
      parents.push_back(j % 5 == 0 ? -1 : int(rng() % std::uint64_t(j)));  // several roots
      offsets.push_back(j % 3 == 0 ? Vec3{0, u(rng), -0.0} : Vec3{u(rng), u(rng), u(rng)});
    }
    std::vector<float> rotations(std::size_t(frames) * std::size_t(joints) * 4);
    std::vector<float> translations(std::size_t(frames) * std::size_t(joints) * 3);
    for (int i = 0; i < frames * joints; ++i) {
      store_quat(i % 11 == 0 ? Quat{} : test::random_rotation(rng), &rotations[std::size_t(i) * 4]);
      store_vec3({40 * u(rng), 40 * u(rng), 40 * u(rng)}, &translations[std::size_t(i) * 3]);
    }
    std::vector<std::uint8_t> translated(std::size_t(joints), 0);
    translated[0] = translated[std::size_t(joints) / 2] = 1;
    const std::vector<JointSite> sites{{joints - 1, {0.5, 0, -2}}, {0, {1, 1, 1}}};
    ForwardKinematicsJob fk;
    fk.parents = parents;
    fk.offsets = offsets;
    fk.rotations = {rotations.data(), frames, joints};
    fk.translations = {translations.data(), frames, joints};
    const std::string what =
        std::to_string(frames) + " frames, " + std::to_string(joints) + " joints";
    EXPECT_EQ(differing_bits(fk), 0) << what << ", offsets only";
    fk.translated_joints = translated;
    fk.sites = sites;
    EXPECT_EQ(differing_bits(fk), 0) << what << ", translated joints and sites";
    fk.sites = {};
    const std::vector<int> wanted{joints - 1, 0, joints / 2};
    fk.output_joints = wanted;
    EXPECT_EQ(differing_bits(fk), 0) << what << ", output joints";
  }
}

// The same on the shared captures (31 joints, a translated root, thousands of frames).
TEST(ForwardKinematics, FastPathIsTheReferenceBitForBitOnRealClips) {
  MOCAP_REQUIRE_SHARED_CLIPS();
  for (const auto& path : test::shared_bvh_files()) {
    const io::BvhReadResult r = io::read_bvh(path);
    ASSERT_TRUE(r.clip) << path;
    const Clip& clip = *r.clip;
    const std::vector<std::uint8_t> translated = clip.skeleton->translated_mask();
    ForwardKinematicsJob fk;
    fk.parents = clip.skeleton->parents;
    fk.offsets = clip.skeleton->offsets;
    fk.rotations = clip.rotation_view();
    fk.translations = clip.translation_view();
    fk.translated_joints = translated;
    EXPECT_EQ(differing_bits(fk), 0) << path;
  }
}

TEST(ForwardKinematics, ValidateNamesWhatIsWrong) {
  const std::vector<int> parents{-1, 2, 0};  // joint 1's parent comes after it
  const std::vector<Vec3> offsets(3);
  std::vector<float> rotations(3 * 4, 0.0f), positions(3 * 3);
  ForwardKinematicsJob fk;
  fk.parents = parents;
  fk.offsets = offsets;
  fk.rotations = {rotations.data(), 1, 3};
  fk.positions = {positions.data(), 1, 3};
  const Status s = fk.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("joint 1"), std::string::npos) << s.message();

  const std::vector<int> good{-1, 0, 1};
  fk.parents = good;
  EXPECT_TRUE(fk.validate().ok());
  const std::vector<JointSite> sites{{5, {}}};
  fk.sites = sites;
  EXPECT_FALSE(fk.validate().ok());
  // A site on a real joint still needs somewhere to write its positions.
  const std::vector<JointSite> real_site{{2, {}}};
  fk.sites = real_site;
  EXPECT_NE(fk.validate().message().find("site_positions"), std::string::npos);
}

}  // namespace
}  // namespace mocap
