// Issue 19, case 1: a full disk during `filter` and `import`. The output goes to a 30 MB tmpfs
// (skipped, with a message, where mount is not permitted): the run must end with exit 1 naming
// what was not written, never a signal, leave no temporary file behind, keep OUT valid, and
// complete with --resume once there is space.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "io/library_store.hpp"
#include "tests/test_support.hpp"

namespace mocap::io {
namespace {

namespace fs = std::filesystem;

constexpr int kJoints = 31;
constexpr int kFrames = 1000;  // 868 KB of tensors a clip

Clip make_clip(int seed) {
  auto s = std::make_shared<Skeleton>();
  for (int j = 0; j < kJoints; ++j) {
    s->joint_names.push_back(j == 0 ? "Hips" : "J" + std::to_string(j));
    s->parents.push_back(j - 1);
    s->offsets.push_back({0.0, 1.0, 0.0});
    if (j == 0)
      s->channels.push_back({Channel::Xposition, Channel::Yposition, Channel::Zposition,
                             Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    else
      s->channels.push_back({Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    s->end_sites.push_back(std::nullopt);
  }
  Clip clip;
  clip.skeleton = s;
  clip.frame_time = 1.0 / 120;
  clip.frames = kFrames;
  for (int t = 0; t < kFrames; ++t)
    for (int j = 0; j < kJoints; ++j) {
      const double a = 0.001 * t * (j + 1) + 0.37 * seed;
      const double c = std::cos(a / 2), s2 = std::sin(a / 2);
      for (double v : {c, s2 * 0.6, s2 * 0.8, 0.0}) clip.rotations.push_back(float(v));
      for (double v : {std::sin(a) * 10, 1.0 + j, 0.001 * t})
        clip.translations.push_back(j == 0 ? float(v) : (v == 1.0 + j ? 1.0f : 0.0f));
    }
  // Joints without position channels hold their offset.
  for (int t = 0; t < kFrames; ++t)
    for (int j = 1; j < kJoints; ++j) {
      float* p = clip.translations.data() + (std::size_t(t) * kJoints + j) * 3;
      p[0] = 0, p[1] = 1, p[2] = 0;
    }
  return clip;
}

class DiskFull : public ::testing::Test {
 protected:
  test::TempDir dir_{"disk-full"};
  fs::path mnt_ = dir_ / "mnt";
  bool mounted_ = false;

  void SetUp() override {
    fs::create_directories(mnt_);
    if (::mount("tmpfs", mnt_.c_str(), "tmpfs", 0, "size=30m") != 0)
      GTEST_SKIP() << "cannot mount a 30 MB tmpfs here (" << std::strerror(errno)
                   << "): the disk-full test needs root and mount permission";
    mounted_ = true;
  }
  void TearDown() override {
    if (mounted_) ::umount2(mnt_.c_str(), MNT_DETACH);
  }
  void grow() {
    ASSERT_EQ(::mount("tmpfs", mnt_.c_str(), "tmpfs", MS_REMOUNT, "size=200m"), 0)
        << std::strerror(errno);
  }
  std::string q(const fs::path& p) const { return "'" + p.string() + "'"; }

  // No temporary file anywhere below the mount.
  void expect_no_temporaries() {
    for (const auto& entry : fs::recursive_directory_iterator(mnt_))
      EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
  }

  // The failed run: exit 1 (not a signal, not 2), naming the disk's error; OUT, if present, is
  // a valid library; then --resume with space completes it with every clip, equal to `want`.
  void expect_fails_then_resumes(const std::string& command, const fs::path& out,
                                 const std::map<std::string, Clip>& want) {
    const auto r = test::run_cli(command + " --json");
    EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
    EXPECT_NE(r.out.find("No space left on device"), std::string::npos) << r.out << r.err;
    expect_no_temporaries();
    if (fs::exists(out)) {
      std::string error;
      EXPECT_TRUE(LibraryReader::open(out, &error)) << error;
    }
    grow();
    const auto resumed = test::run_cli(command + " --resume --json");
    ASSERT_EQ(resumed.exit_code, 0) << resumed.out << resumed.err;
    expect_no_temporaries();
    EXPECT_FALSE(fs::exists(out.string() + ".parts"));
    std::string error;
    const auto reader = LibraryReader::open(out, &error);
    ASSERT_TRUE(reader) << error;
    ASSERT_EQ(reader->clips().size(), want.size());
    for (const auto& [path, clip] : want) {
      const auto back = reader->read_clip(path, &error);
      ASSERT_TRUE(back) << error;
      EXPECT_EQ(back->rotations, clip.rotations) << path;
      EXPECT_EQ(back->translations, clip.translations) << path;
    }
  }
};

std::map<std::string, Clip> write_input(const fs::path& path, int clips) {
  std::map<std::string, Clip> library;
  std::string error;
  auto writer = LibraryWriter::create(path, Compression::none, &error);
  EXPECT_TRUE(writer) << error;
  for (int i = 0; i < clips; ++i) {
    const std::string name = "set/clip" + std::to_string(100 + i);
    library[name] = make_clip(i);
    EXPECT_TRUE(writer->write_clip(name, library[name], &error)) << error;
  }
  EXPECT_TRUE(writer->close(&error)) << error;
  return library;
}

// 20 clips, 17 MB: the parts fit, the join beside them does not.
TEST_F(DiskFull, FilterWhoseJoinDoesNotFit) {
  const auto input = write_input(dir_ / "in.h5", 20);
  const fs::path out = mnt_ / "out.h5";
  expect_fails_then_resumes("filter " + q(dir_ / "in.h5") + " -o " + q(out) +
                                " --method none --compression none --clips-per-part 4",
                            out, input);
}

// 45 clips, 39 MB: the parts themselves run out of space.
TEST_F(DiskFull, FilterWhosePartsDoNotFit) {
  const auto input = write_input(dir_ / "in.h5", 45);
  const fs::path out = mnt_ / "out.h5";
  expect_fails_then_resumes("filter " + q(dir_ / "in.h5") + " -o " + q(out) +
                                " --method none --compression none --clips-per-part 4",
                            out, input);
}

TEST_F(DiskFull, ImportWhosePartsDoNotFit) {
  std::map<std::string, Clip> want;
  fs::create_directories(dir_ / "bvh");
  for (int i = 0; i < 40; ++i) {
    Clip clip = make_clip(i);
    std::string error;
    const std::string name = "clip" + std::to_string(100 + i);
    ASSERT_TRUE(write_bvh(clip, dir_ / "bvh" / (name + ".bvh"), &error)) << error;
    // What import stores is what it reads back from the text.
    want[name] = std::move(*read_bvh(dir_ / "bvh" / (name + ".bvh")).clip);
  }
  const fs::path out = mnt_ / "out.h5";
  expect_fails_then_resumes(
      "import " + q(dir_ / "bvh") + " -o " + q(out) + " --compression none --clips-per-part 4", out,
      want);
}

}  // namespace
}  // namespace mocap::io
