// Issue 19, "Nothing lost, ever": libraries and BVH files damaged on purpose. Each case is built
// here from a valid file (LibraryWriter, then the HDF5 C API), never checked in, and must end in
// a clear error naming the file and the clip, exit 1 or 2, never a signal, never exit 0 with a
// clip missing, never a file written that the program itself refuses.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "io/clip_validation.hpp"
#include "io/library_store.hpp"
#include "tests/test_support.hpp"

namespace mocap::io {
namespace {

namespace fs = std::filesystem;

std::shared_ptr<const Skeleton> make_skeleton(int joints, const std::string& root = "Hips") {
  auto s = std::make_shared<Skeleton>();
  for (int j = 0; j < joints; ++j) {
    s->joint_names.push_back(j == 0 ? root : "J" + std::to_string(j));
    s->parents.push_back(j - 1);
    s->offsets.push_back({0.0, 1.0 + j, 0.5});
    if (j == 0)
      s->channels.push_back({Channel::Xposition, Channel::Yposition, Channel::Zposition,
                             Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    else
      s->channels.push_back({Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    s->end_sites.push_back(j == joints - 1 ? std::optional<Vec3>(Vec3{0, 1, 0}) : std::nullopt);
  }
  return s;
}

Clip make_clip(int joints, int frames, const std::string& root = "Hips") {
  Clip clip;
  clip.skeleton = make_skeleton(joints, root);
  clip.frame_time = 1.0 / 120;
  clip.frames = frames;
  clip.source = "synthetic.bvh";
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < joints; ++j) {
      const double a = 0.01 * t + 0.1 * j;  // a small smooth rotation about z
      for (float v : {float(std::cos(a / 2)), 0.0f, 0.0f, float(std::sin(a / 2))})
        clip.rotations.push_back(v);
      for (float v : {0.0f, float(1.0 + j), 0.5f}) clip.translations.push_back(v);
    }
  return clip;
}

constexpr int kJoints = 31;
constexpr int kFrames = 200;

// A valid library of clips "a/good" and "a/victim" (the one the case damages), each with its
// own skeleton, so that damaging the victim's leaves the good clip intact.
void write_library(const fs::path& path, Compression compression = Compression::none) {
  std::string error;
  auto writer = LibraryWriter::create(path, compression, &error);
  ASSERT_TRUE(writer) << error;
  ASSERT_TRUE(writer->write_clip("a/good", make_clip(kJoints, kFrames, "Root"), &error)) << error;
  ASSERT_TRUE(writer->write_clip("a/victim", make_clip(kJoints, kFrames), &error)) << error;
  ASSERT_TRUE(writer->close(&error)) << error;
}

std::string skeleton_group() {
  return "/skeletons/" + skeleton_name(*make_skeleton(kJoints));
}

hid_t variable_string_type() {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  return type;
}

// Opens the library read-write for the damage; closes it after.
class Editor {
 public:
  explicit Editor(const fs::path& path) : file_(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT)) {
    EXPECT_GE(file_, 0) << path;
  }
  ~Editor() { H5Fclose(file_); }
  hid_t file() const { return file_; }

  void remove(const std::string& path) {
    ASSERT_GE(H5Ldelete(file_, path.c_str(), H5P_DEFAULT), 0);
  }
  // Replaces (or creates) a dataset of `dims` with `data` of `memory_type`.
  void replace(const std::string& path, hid_t file_type, hid_t memory_type,
               std::vector<hsize_t> dims, const void* data) {
    if (H5Lexists(file_, path.c_str(), H5P_DEFAULT) > 0) remove(path);
    const hid_t space = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
    const hid_t dataset =
        H5Dcreate2(file_, path.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(dataset, 0) << path;
    if (data) {
      ASSERT_GE(H5Dwrite(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0);
    }
    H5Dclose(dataset);
    H5Sclose(space);
  }
  // Fixed-length strings, as the library holds them.
  void replace_strings(const std::string& path, const std::vector<std::string>& values) {
    std::size_t size = 1;
    for (const auto& v : values) size = std::max(size, v.size());
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, size);
    H5Tset_cset(type, H5T_CSET_UTF8);
    std::vector<char> bytes(size * values.size(), '\0');
    for (std::size_t i = 0; i < values.size(); ++i)
      std::copy(values[i].begin(), values[i].end(), bytes.begin() + i * size);
    replace(path, type, type, {values.size()}, bytes.data());
    H5Tclose(type);
  }
  // Variable-length strings, which the library no longer holds nor reads (format 1 had them).
  void replace_variable_strings(const std::string& path, const std::vector<std::string>& values) {
    const hid_t type = variable_string_type();
    std::vector<const char*> pointers;
    for (const auto& v : values) pointers.push_back(v.c_str());
    replace(path, type, type, {values.size()}, pointers.data());
    H5Tclose(type);
  }
  void set_variable_string_attribute(const std::string& object, const char* name,
                                     const std::string& value) {
    const hid_t o = H5Oopen(file_, object.c_str(), H5P_DEFAULT);
    ASSERT_GE(o, 0);
    if (H5Aexists(o, name) > 0) H5Adelete(o, name);
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t type = variable_string_type();
    const hid_t a = H5Acreate2(o, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
    const char* text = value.c_str();
    ASSERT_GE(H5Awrite(a, type, &text), 0);
    H5Aclose(a);
    H5Tclose(type);
    H5Sclose(space);
    H5Oclose(o);
  }
  void set_int_attribute(const std::string& object, const char* name, int value) {
    const hid_t o = H5Oopen(file_, object.c_str(), H5P_DEFAULT);
    ASSERT_GE(o, 0);
    const hid_t a = H5Aopen(o, name, H5P_DEFAULT);
    ASSERT_GE(H5Awrite(a, H5T_NATIVE_INT, &value), 0);
    H5Aclose(a);
    H5Oclose(o);
  }
  void set_double_attribute(const std::string& object, const char* name, double value) {
    const hid_t o = H5Oopen(file_, object.c_str(), H5P_DEFAULT);
    ASSERT_GE(o, 0);
    if (H5Aexists(o, name) > 0) H5Adelete(o, name);
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate2(o, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(H5Awrite(a, H5T_NATIVE_DOUBLE, &value), 0);
    H5Aclose(a);
    H5Sclose(space);
    H5Oclose(o);
  }
  // Rewrites the victim's rotations with `values` ([frames][joints][4]).
  void rotations(const std::vector<float>& values, int frames, int joints) {
    replace("/clips/a/victim/rotations", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT,
            {hsize_t(frames), hsize_t(joints), 4}, values.data());
  }

 private:
  hid_t file_;
};

class HostileLibrary : public ::testing::Test {
 protected:
  test::TempDir dir_{"hostile"};
  fs::path lib() const { return dir_ / "lib.h5"; }
  std::string quoted(const fs::path& p) const { return "'" + p.string() + "'"; }

  void SetUp() override { write_library(lib()); }

  // `info --check` must exit 1 and name the file and the victim clip, and pass the good one.
  void expect_check_fails(const std::string& words) {
    const auto r = test::run_cli("info --check " + quoted(lib()));
    EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find(lib().string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("a/victim"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("a/good"), std::string::npos) << r.err;
  }
  // `filter` must exit 1, write the good clip, and name the victim among its failures.
  void expect_filter_fails(const std::string& words) {
    const fs::path out = dir_ / "out.h5";
    const auto r =
        test::run_cli("filter " + quoted(lib()) + " -o " + quoted(out) + " --method bof --json");
    EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
    const auto summary = nlohmann::json::parse(r.out, nullptr, false);
    ASSERT_FALSE(summary.is_discarded()) << r.out << r.err;
    ASSERT_EQ(summary["failed"].size(), 1u) << r.out;
    EXPECT_EQ(summary["failed"][0]["clip"], "a/victim");
    const std::string error = summary["failed"][0]["error"];
    EXPECT_NE(error.find(words), std::string::npos) << error;
    std::string open_error;
    const auto written = LibraryReader::open(out, &open_error);
    ASSERT_TRUE(written) << open_error;
    ASSERT_EQ(written->clips().size(), 1u);
    EXPECT_EQ(written->clips()[0].path, "a/good");
  }
  // `export` must exit 1, write the good clip, and write no file for the victim.
  void expect_export_fails(const std::string& words) {
    const fs::path out = dir_ / "bvh";
    const auto r = test::run_cli("export " + quoted(lib()) + " -o " + quoted(out) + " --json");
    EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
    EXPECT_NE((r.out + r.err).find(words), std::string::npos) << r.out << r.err;
    EXPECT_TRUE(fs::exists(out / "a/good.bvh"));
    EXPECT_FALSE(fs::exists(out / "a/victim.bvh"));
    EXPECT_FALSE(fs::exists(out / "a/victim.bvh.tmp"));
  }
};

TEST_F(HostileLibrary, TheUndamagedLibraryPassesEveryCommand) {
  const auto r = test::run_cli("info --check " + quoted(lib()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("check: 2 of 2 clips valid"), std::string::npos) << r.out;
  const auto e = test::run_cli("export " + quoted(lib()) + " -o " + quoted(dir_ / "bvh"));
  EXPECT_EQ(e.exit_code, 0) << e.err;
  const auto back = read_bvh(dir_ / "bvh" / "a/victim.bvh");
  EXPECT_TRUE(back.clip) << (back.error ? back.error->what() : "");
}

// Case 6: rotations of 30 joints against a 31-joint skeleton.
TEST_F(HostileLibrary, RotationsOfAnotherJointCount) {
  {
    Editor edit(lib());
    edit.rotations(std::vector<float>(kFrames * 30 * 4, 0.5f), kFrames, 30);
    std::vector<float> translations(kFrames * 30 * 3, 0.0f);
    edit.replace("/clips/a/victim/translations", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT,
                 {hsize_t(kFrames), 30, 3}, translations.data());
  }
  expect_check_fails("do not match skeleton");
  expect_filter_fails("do not match skeleton");
}

TEST_F(HostileLibrary, NanQuaternion) {
  Clip clip = make_clip(kJoints, kFrames);
  clip.rotations[(7 * kJoints + 3) * 4 + 2] = std::numeric_limits<float>::quiet_NaN();
  Editor(lib()).rotations(clip.rotations, kFrames, kJoints);
  // Frames count from 1, as in BVH errors (case 7).
  expect_check_fails("NaN in rotations at frame 8, joint 'J3'");
}

TEST_F(HostileLibrary, NonUnitQuaternion) {
  Clip clip = make_clip(kJoints, kFrames);
  for (int c = 0; c < 4; ++c) clip.rotations[(11 * kJoints + 5) * 4 + c] *= 1.5f;
  Editor(lib()).rotations(clip.rotations, kFrames, kJoints);
  expect_check_fails("not a unit quaternion");
  expect_export_fails("not a unit quaternion");
}

// validate_clip's vector pass accepts only norms well inside the limit; the rest, and every
// bad value, go to the exact per-sample test, which names the first one.
TEST(ClipValidation, NormsNearTheLimitAreJudgedExactly) {
  for (const auto& [scale, valid] : std::vector<std::pair<float, bool>>{{1.0f, true},
                                                                        {1.0007f, true},
                                                                        {1.0009f, true},
                                                                        {0.9991f, true},
                                                                        {1.0011f, false},
                                                                        {0.9989f, false},
                                                                        {2.0f, false}}) {
    Clip clip = make_clip(kJoints, 20);
    for (int c = 0; c < 4; ++c) clip.rotations[(13 * kJoints + 6) * 4 + c] *= scale;
    const std::string problem = validate_clip(clip);
    EXPECT_EQ(problem.empty(), valid) << scale << ": " << problem;
    if (!valid) {
      EXPECT_NE(problem.find("frame 14, joint 'J6'"), std::string::npos) << problem;
    }
  }
  Clip clip = make_clip(kJoints, 20);
  clip.translations[(19 * kJoints + 30) * 3 + 1] = -std::numeric_limits<float>::infinity();
  clip.translations[(19 * kJoints + 29) * 3 + 2] = std::numeric_limits<float>::max();
  EXPECT_EQ(validate_clip(clip), "infinity in translations at frame 20, joint 'J30'");
  clip.rotations[(2 * kJoints + 1) * 4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(validate_clip(clip), "NaN in rotations at frame 3, joint 'J1'");
}

TEST_F(HostileLibrary, ParentCycle) {
  std::vector<int> parents(kJoints);
  for (int j = 0; j < kJoints; ++j) parents[j] = j - 1;
  parents[3] = 4, parents[4] = 3;  // 3 -> 4 -> 3
  Editor(lib()).replace(skeleton_group() + "/parents", H5T_STD_I32LE, H5T_NATIVE_INT,
                        {hsize_t(kJoints)}, parents.data());
  expect_check_fails("parent that does not precede it");
}

// Case 7: filter accepted skeletons that export refused.
TEST_F(HostileLibrary, TwoRoots) {
  std::vector<int> parents(kJoints);
  for (int j = 0; j < kJoints; ++j) parents[j] = j == 10 ? -1 : j - 1;
  Editor(lib()).replace(skeleton_group() + "/parents", H5T_STD_I32LE, H5T_NATIVE_INT,
                        {hsize_t(kJoints)}, parents.data());
  expect_check_fails("second root");
  expect_filter_fails("second root");
}

TEST_F(HostileLibrary, EmptyJointName) {
  std::vector<std::string> names = make_skeleton(kJoints)->joint_names;
  names[6] = "";
  Editor(lib()).replace_strings(skeleton_group() + "/joint_names", names);
  expect_filter_fails("the name is empty");
}

// Case 5: duplicate joint names in a library.
TEST_F(HostileLibrary, DuplicateJointNames) {
  std::vector<std::string> names = make_skeleton(kJoints)->joint_names;
  names[9] = names[4];
  Editor(lib()).replace_strings(skeleton_group() + "/joint_names", names);
  expect_check_fails("must be unique");
  expect_filter_fails("must be unique");
  expect_export_fails("must be unique");
}

// Variable-length strings live in HDF5's global heap, whose decoding in libhdf5 1.10 crashes and
// hangs on damaged files (the fuzz findings in docs/reliability.md): refused before reading.
TEST_F(HostileLibrary, VariableLengthJointNamesAreRefusedUnread) {
  Editor(lib()).replace_variable_strings(skeleton_group() + "/joint_names",
                                         make_skeleton(kJoints)->joint_names);
  expect_check_fails("no readable 'joint_names' (fixed-length strings)");
  expect_filter_fails("no readable 'joint_names' (fixed-length strings)");
}

TEST_F(HostileLibrary, AVariableLengthSkeletonAttributeIsRefusedUnread) {
  Editor(lib()).set_variable_string_attribute("/clips/a/victim", "skeleton",
                                              skeleton_name(*make_skeleton(kJoints)));
  expect_check_fails("no valid 'skeleton' attribute (a fixed-length string");
  expect_filter_fails("no valid 'skeleton' attribute (a fixed-length string");
  expect_export_fails("no valid 'skeleton' attribute (a fixed-length string");
}

// Memory follows a number in the file (case 2) for strings too: a string type of 64 MB is
// refused from its size, before a byte is allocated or read (h5::kMaxStringBytes, 16 MB).
TEST_F(HostileLibrary, AStringTypeLargerThanTheLimitIsRefusedUnread) {
  {
    Editor edit(lib());
    const hid_t type = H5Tcopy(H5T_C_S1);
    ASSERT_GE(H5Tset_size(type, std::size_t(64) << 20), 0);
    edit.replace(skeleton_group() + "/joint_names", type, type, {1}, nullptr);
    H5Tclose(type);
  }
  EXPECT_LT(fs::file_size(lib()), std::uintmax_t(1) << 20) << "the test must not store 64 MB";
  expect_check_fails("no readable 'joint_names' (fixed-length strings)");
}

// A library of format 1 (variable-length strings) is refused with the way to convert it; its
// strings are not read, not even the 'format' attribute.
TEST_F(HostileLibrary, FormatVersionOneIsRefusedWithTheWayToConvertIt) {
  {
    Editor edit(lib());
    edit.set_variable_string_attribute("/", "format", "mocap-clean-library");
    edit.set_int_attribute("/", "format_version", 1);
  }
  for (const char* command : {"info --check ", "filter ", "export "}) {
    const std::string out =
        std::string(command) == "info --check " ? "" : " -o " + quoted(dir_ / "out");
    const auto r = test::run_cli(command + quoted(lib()) + out);
    EXPECT_EQ(r.exit_code, 2) << command << r.out << r.err;
    EXPECT_NE(r.err.find(lib().string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("format_version 1"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("scripts/upgrade_library.py"), std::string::npos) << r.err;
  }
  // A variable-length 'format' on a file that claims version 2 is not read either.
  Editor(lib()).set_int_attribute("/", "format_version", 2);
  const auto r = test::run_cli("info " + quoted(lib()));
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("'format' attribute is a variable-length string"), std::string::npos)
      << r.err;
}

// What a version 1 library held: the same file with variable-length strings everywhere.
void make_format_one(const fs::path& path) {
  Editor edit(path);
  for (const char* root : {"Root", "Hips"}) {
    const auto skeleton = make_skeleton(kJoints, root);
    const std::string group = "/skeletons/" + skeleton_name(*skeleton);
    edit.replace_variable_strings(group + "/joint_names", skeleton->joint_names);
    std::vector<std::string> channels(kJoints, "Zrotation Xrotation Yrotation");
    channels[0] = "Xposition Yposition Zposition Zrotation Xrotation Yrotation";
    edit.replace_variable_strings(group + "/channels", channels);
  }
  for (const auto& [clip, root] :
       {std::pair{"/clips/a/good", "Root"}, {"/clips/a/victim", "Hips"}}) {
    edit.set_variable_string_attribute(clip, "skeleton",
                                       skeleton_name(*make_skeleton(kJoints, root)));
    edit.set_variable_string_attribute(clip, "source", "synthetic.bvh");
  }
  edit.set_variable_string_attribute("/", "format", "mocap-clean-library");
  edit.set_int_attribute("/", "format_version", 1);
}

// scripts/upgrade_library.py turns a version 1 library into one this build reads, unchanged.
TEST_F(HostileLibrary, TheUpgradeScriptConvertsFormatOneLosslessly) {
  if (std::system("/usr/bin/python3 -c 'import h5py' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "h5py is not importable by /usr/bin/python3: upgrade script not tested";
  const fs::path pristine = dir_ / "pristine.h5", upgraded = dir_ / "upgraded.h5";
  write_library(pristine);
  make_format_one(lib());
  const fs::path script =
      fs::path(__FILE__).parent_path().parent_path().parent_path() / "scripts/upgrade_library.py";
  const auto run = [&](const fs::path& in, const fs::path& out) {
    return std::system(("/usr/bin/python3 '" + script.string() + "' " + quoted(in) + " " +
                        quoted(out) + " >/dev/null 2>&1")
                           .c_str());
  };
  ASSERT_EQ(run(lib(), upgraded), 0);
  EXPECT_NE(run(lib(), upgraded), 0) << "an existing output must be refused";
  EXPECT_NE(run(upgraded, dir_ / "again.h5"), 0) << "only version 1 is converted";
  EXPECT_FALSE(fs::exists(dir_ / "again.h5"));
  EXPECT_FALSE(fs::exists(dir_ / "again.h5.tmp"));
  std::string error;
  const auto before = LibraryReader::open(pristine, &error);
  ASSERT_TRUE(before) << error;
  const auto after = LibraryReader::open(upgraded, &error);
  ASSERT_TRUE(after) << error;
  ASSERT_EQ(after->clips().size(), before->clips().size());
  for (const auto& header : before->clips()) {
    const auto a = before->read_clip(header.path, &error);
    ASSERT_TRUE(a) << error;
    const auto b = after->read_clip(header.path, &error);
    ASSERT_TRUE(b) << header.path << ": " << error;
    EXPECT_EQ(b->rotations, a->rotations) << header.path;
    EXPECT_EQ(b->translations, a->translations) << header.path;
    EXPECT_EQ(b->skeleton->joint_names, a->skeleton->joint_names) << header.path;
    EXPECT_EQ(b->skeleton->channels, a->skeleton->channels) << header.path;
    EXPECT_EQ(b->source, a->source) << header.path;
    EXPECT_EQ(b->frame_time, a->frame_time) << header.path;
  }
  const auto check = test::run_cli("info --check " + quoted(upgraded));
  EXPECT_EQ(check.exit_code, 0) << check.err;
}

TEST_F(HostileLibrary, InfiniteFrameTime) {
  Editor(lib()).set_double_attribute("/clips/a/victim", "frame_time",
                                     std::numeric_limits<double>::infinity());
  expect_check_fails("frame_time");
  expect_filter_fails("frame_time");
}

// A fuzz finding (fuzz/library_reader_fuzz): a frame time of 1e300 s was valid in a library, and
// export wrote "Frame Time: 1e+300", which import refuses.
TEST_F(HostileLibrary, FrameTimeOutsideWhatBvhHolds) {
  Editor(lib()).set_double_attribute("/clips/a/victim", "frame_time", 1e300);
  expect_check_fails("frame_time");
  expect_export_fails("frame_time");
}

TEST_F(HostileLibrary, SkeletonsDeleted) {
  Editor(lib()).remove("/skeletons");
  const auto r = test::run_cli("info --check " + quoted(lib()));
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("a/victim"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("a/good"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("no skeleton"), std::string::npos) << r.err;
}

// Case 3: a clip that lost its rotations, an emptied clip group, a dataset for a clip group.
TEST_F(HostileLibrary, ClipWithoutRotationsIsReportedNotSkipped) {
  Editor(lib()).remove("/clips/a/victim/rotations");
  expect_check_fails("no 'rotations' dataset");
  expect_filter_fails("no 'rotations' dataset");
  expect_export_fails("no 'rotations' dataset");
}

TEST_F(HostileLibrary, EmptiedClipGroupIsReportedNotSkipped) {
  {
    Editor edit(lib());
    edit.remove("/clips/a/victim");
    ASSERT_GE(
        H5Gclose(H5Gcreate2(edit.file(), "/clips/a/victim", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT)),
        0);
  }
  expect_check_fails("empty group");
  expect_filter_fails("empty group");
}

TEST_F(HostileLibrary, DatasetWhereAClipGroupShouldBe) {
  {
    Editor edit(lib());
    edit.remove("/clips/a/victim");
    const float values[3] = {1, 2, 3};
    edit.replace("/clips/a/victim", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, {3}, values);
  }
  expect_filter_fails("a dataset");
  expect_export_fails("a dataset");
}

// Case 2: a shape claiming far more frames than the file stores costs no memory.
TEST_F(HostileLibrary, ClaimedFramesBeyondTheStoredDataAreRefusedBeforeAllocating) {
  {
    Editor edit(lib());
    for (const auto& [name, channels] : {std::pair{"rotations", 4}, {"translations", 3}}) {
      const std::string path = std::string("/clips/a/victim/") + name;
      edit.remove(path);
      const hsize_t dims[3] = {2'000'000, kJoints, hsize_t(channels)};
      const hsize_t chunk[3] = {64, kJoints, hsize_t(channels)};
      const hid_t space = H5Screate_simple(3, dims, nullptr);
      const hid_t properties = H5Pcreate(H5P_DATASET_CREATE);
      H5Pset_chunk(properties, 3, chunk);
      const hid_t dataset = H5Dcreate2(edit.file(), path.c_str(), H5T_IEEE_F32LE, space,
                                       H5P_DEFAULT, properties, H5P_DEFAULT);
      ASSERT_GE(dataset, 0);
      // One chunk stored; the other 31249 are only a number in the dataspace.
      const hsize_t start[3] = {0, 0, 0}, count[3] = {64, kJoints, hsize_t(channels)};
      const hid_t memory = H5Screate_simple(3, count, nullptr);
      H5Sselect_hyperslab(space, H5S_SELECT_SET, start, nullptr, count, nullptr);
      std::vector<float> values(64 * kJoints * channels, 0.0f);
      ASSERT_GE(H5Dwrite(dataset, H5T_NATIVE_FLOAT, memory, space, H5P_DEFAULT, values.data()), 0);
      H5Sclose(memory);
      H5Dclose(dataset);
      H5Pclose(properties);
      H5Sclose(space);
    }
  }
  EXPECT_LT(fs::file_size(lib()), 1u << 20);
  std::string error;
  const auto reader = LibraryReader::open(lib(), &error);
  ASSERT_TRUE(reader) << error;
  ASSERT_EQ(reader->clips().size(), 2u);
  EXPECT_NE(reader->clips()[1].error.find("stores 1 of its 31250 chunks"), std::string::npos)
      << reader->clips()[1].error;
  expect_check_fails("chunks");
  expect_filter_fails("chunks");
}

TEST_F(HostileLibrary, ClaimedFramesBeyondTheClipLimitAreRefused) {
  {
    Editor edit(lib());
    for (const auto& [name, channels] : {std::pair{"rotations", 4}, {"translations", 3}}) {
      const std::string path = std::string("/clips/a/victim/") + name;
      edit.remove(path);
      const hsize_t dims[3] = {30'000'000, kJoints, hsize_t(channels)};
      const hid_t space = H5Screate_simple(3, dims, nullptr);
      const hid_t dataset = H5Dcreate2(edit.file(), path.c_str(), H5T_IEEE_F32LE, space,
                                       H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
      ASSERT_GE(dataset, 0);
      H5Dclose(dataset);
      H5Sclose(space);
    }
  }
  // It used to end in an uncaught std::bad_alloc (exit 134).
  const auto r = test::run_cli("info --joints " + quoted(lib()));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("joint-frames"), std::string::npos) << r.err;
  expect_check_fails("joint-frames");
}

// Case 4: export never writes a file that import refuses.
TEST_F(HostileLibrary, NanOffsetsAreNotExported) {
  std::vector<double> offsets(kJoints * 3, 1.0);
  offsets[3 * 2 + 1] = std::nan("");
  Editor(lib()).replace(skeleton_group() + "/offsets", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                        {hsize_t(kJoints), 3}, offsets.data());
  expect_export_fails("offset");
}

TEST_F(HostileLibrary, FramesWithoutChannelsAreNotExported) {
  Editor(lib()).replace_strings(skeleton_group() + "/channels",
                                std::vector<std::string>(kJoints, ""));
  expect_check_fails("no channels");
  expect_export_fails("no channels");
}

// Case 8: flipped bytes in an uncompressed chunk are caught by the Fletcher-32 checksum.
TEST_F(HostileLibrary, FlippedBytesInAChunkFailTheChecksum) {
  haddr_t address = HADDR_UNDEF;
  {
    const hid_t file = H5Fopen(lib().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t dataset = H5Dopen2(file, "/clips/a/victim/translations", H5P_DEFAULT);
    hsize_t offset[3];
    unsigned mask = 0;
    hsize_t size = 0;
    const hid_t space = H5Dget_space(dataset);
    ASSERT_GE(H5Dget_chunk_info(dataset, space, 0, offset, &mask, &address, &size), 0);
    H5Sclose(space);
    EXPECT_GT(size, 400u);
    H5Dclose(dataset);
    H5Fclose(file);
  }
  {
    std::fstream f(lib(), std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(std::streamoff(address + 200));
    char bytes[64];
    f.read(bytes, 64);
    for (char& b : bytes) b = char(~b);
    f.seekp(std::streamoff(address + 200));
    f.write(bytes, 64);
    ASSERT_TRUE(f.good());
  }
  expect_check_fails("Fletcher32");
  expect_filter_fails("Fletcher32");
  expect_export_fails("Fletcher32");
}

TEST_F(HostileLibrary, NoChecksumWritesChunksWithoutTheFilter) {
  const fs::path out = dir_ / "plain.h5";
  const auto r = test::run_cli("filter " + quoted(lib()) + " -o " + quoted(out) +
                               " --method none --compression none --no-checksum");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const hid_t file = H5Fopen(out.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t dataset = H5Dopen2(file, "/clips/a/good/rotations", H5P_DEFAULT);
  const hid_t properties = H5Dget_create_plist(dataset);
  EXPECT_EQ(H5Pget_nfilters(properties), 0);
  H5Pclose(properties);
  H5Dclose(dataset);
  H5Fclose(file);
}

// ---------------------------------------------------------------------------------------------
// BVH

std::string bvh_with(const std::string& second_joint, const std::string& frame) {
  return "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition "
         "Zrotation Xrotation Yrotation\n\tJOINT Spine\n\t{\n\t\tOFFSET 0 1 0\n\t\tCHANNELS 3 "
         "Zrotation Xrotation Yrotation\n\t\tJOINT " +
         second_joint +
         "\n\t\t{\n\t\t\tOFFSET 0 1 0\n\t\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n\t\t\tEnd "
         "Site\n\t\t\t{\n\t\t\t\tOFFSET 0 1 0\n\t\t\t}\n\t\t}\n\t}\n}\nMOTION\nFrames: 2\nFrame "
         "Time: 0.0083333\n0 0 0 0 0 0 0 0 0 0 0 0\n" +
         frame + "\n";
}

TEST(HostileBvh, DuplicateJointNamesAreAnErrorNamingTheLine) {
  const auto ok = parse_bvh(bvh_with("Head", "1 2 3 4 5 6 7 8 9 10 11 12"), "ok.bvh");
  ASSERT_TRUE(ok.clip) << ok.error->what();
  const auto r = parse_bvh(bvh_with("Spine", "1 2 3 4 5 6 7 8 9 10 11 12"), "dup.bvh");
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->line, 10);
  EXPECT_NE(r.error->what().find("dup.bvh:10:"), std::string::npos) << r.error->what();
  EXPECT_NE(r.error->message.find("line 6"), std::string::npos) << r.error->message;
}

TEST(HostileBvh, APositionBeyondFloatRangeIsAnErrorNamingTheLine) {
  const auto r = parse_bvh(bvh_with("Head", "1e300 2 3 4 5 6 7 8 9 10 11 12"), "huge.bvh");
  ASSERT_TRUE(r.error) << "read as " << r.clip->translations[3];
  EXPECT_EQ(r.error->line, 25);
  EXPECT_NE(r.error->message.find("out of range"), std::string::npos) << r.error->message;
}

// The largest float's shortest text, which export writes for it, reads back as that float; the
// next value past the rounding midpoint does not (a library_reader_fuzz finding: import refused
// "3.4028235e+38" that export had written).
TEST(HostileBvh, TheLargestFloatReadsBackAndTheNextValueIsRefused) {
  const auto r = parse_bvh(bvh_with("Head", "3.4028235e+38 2 3 4 5 6 7 8 9 10 11 12"), "max.bvh");
  ASSERT_FALSE(r.error) << r.error->message;
  EXPECT_EQ(r.clip->translations[9], std::numeric_limits<float>::max());  // frame 1, Xposition
  const auto past = parse_bvh(bvh_with("Head", "3.40282357e+38 2 3 4 5 6 7 8 9 10 11 12"), "x.bvh");
  ASSERT_TRUE(past.error) << "read as " << past.clip->translations[9];
  EXPECT_NE(past.error->message.find("out of range"), std::string::npos) << past.error->message;
}

TEST(HostileBvh, ImportOfDuplicateJointNamesExitsOneNamingTheFile) {
  test::TempDir dir("hostile-bvh");
  {
    std::ofstream(dir / "good.bvh") << bvh_with("Head", "1 2 3 4 5 6 7 8 9 10 11 12");
    std::ofstream(dir / "dup.bvh") << bvh_with("Spine", "1 2 3 4 5 6 7 8 9 10 11 12");
  }
  const auto r =
      test::run_cli("import '" + (dir / "good.bvh").string() + "' '" + (dir / "dup.bvh").string() +
                    "' -o '" + (dir / "lib.h5").string() + "' --json");
  EXPECT_EQ(r.exit_code, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("dup.bvh:10:"), std::string::npos) << r.out;
}

TEST(HostileBvh, TheWriterRefusesWhatTheReaderRefuses) {
  Clip clip = make_clip(3, 2);
  auto skeleton = std::make_shared<Skeleton>(*clip.skeleton);
  skeleton->joint_names[2] = skeleton->joint_names[1];
  clip.skeleton = skeleton;
  EXPECT_NE(check_clip_for_bvh(clip).find("must be unique"), std::string::npos);
  skeleton->joint_names[2] = "J2";
  skeleton->offsets[1].y = std::nan("");
  EXPECT_NE(check_clip_for_bvh(clip).find("offset"), std::string::npos);
  skeleton->offsets[1].y = 1;
  for (auto& list : skeleton->channels) list.clear();
  EXPECT_NE(check_clip_for_bvh(clip).find("no channels"), std::string::npos);
}

}  // namespace
}  // namespace mocap::io
