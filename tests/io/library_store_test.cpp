// The HDF5 library store (../shared/spec/architecture.md, "The HDF5 library file"): files written
// by LibraryWriter are inspected through the HDF5 C API itself, read back through LibraryReader,
// and checked by h5py; the encoded (H5Dwrite_chunk) path must store the very same bytes.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <thread>
#include <tuple>

#include "io/chunk_codec.hpp"
#include "io/library_store.hpp"
#include "tests/test_support.hpp"

namespace mocap::io {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Synthetic skeletons and clips

std::shared_ptr<const Skeleton> make_skeleton(const std::string& root, int joints) {
  auto s = std::make_shared<Skeleton>();
  const std::vector<Channel> rotation = {Channel::Zrotation, Channel::Xrotation,
                                         Channel::Yrotation};
  for (int j = 0; j < joints; ++j) {
    s->joint_names.push_back(j == 0 ? root : root + "_joint" + std::to_string(j));
    s->parents.push_back(j == 0 ? -1 : (j - 1) / 2);
    s->offsets.push_back({0.5 * j, -1.25 + j, 0.1 / (j + 1)});
    if (j == 0)
      s->channels.push_back({Channel::Xposition, Channel::Yposition, Channel::Zposition,
                             Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    else if (j == joints - 1)
      s->channels.push_back({});  // a joint without channels
    else
      s->channels.push_back(rotation);
    if (j % 3 == 2)
      s->end_sites.push_back(Vec3{0.0, 1.0 / (j + 1), -2.0});
    else
      s->end_sites.push_back(std::nullopt);
  }
  EXPECT_EQ(check_structure(*s), "");
  return s;
}

Clip make_clip(std::shared_ptr<const Skeleton> skeleton, int frames, std::uint64_t seed,
               const std::string& source) {
  std::mt19937_64 rng(seed);
  Clip clip;
  clip.skeleton = std::move(skeleton);
  clip.frame_time = 1.0 / 120.0;
  clip.frames = frames;
  clip.source = source;
  clip.rotations = test::random_motion(rng, frames, clip.joints(), 1.0);
  std::normal_distribution<float> n(0.0f, 10.0f);
  clip.translations.resize(std::size_t(frames) * clip.joints() * 3);
  for (float& t : clip.translations) t = n(rng);
  return clip;
}

// `text` fits `pattern`, where 'd' stands for a decimal digit, 'x' for a lower-case hex digit,
// and any other character for itself. (std::regex trips GCC 12's warnings under sanitizers.)
bool matches(const std::string& text, const std::string& pattern) {
  if (text.size() != pattern.size()) return false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const bool digit = c >= '0' && c <= '9';
    if (pattern[i] == 'd'   ? !digit
        : pattern[i] == 'x' ? !(digit || (c >= 'a' && c <= 'f'))
                            : c != pattern[i])
      return false;
  }
  return true;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// A folder of its own for each test, removed afterwards.
class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info->test_suite_name()) + "_" + info->name();
    for (char& c : name)
      if (c == '/') c = '_';
    dir_ = fs::temp_directory_path() / ("mocap_store_" + std::to_string(::getpid()) + "_" + name);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path file(const std::string& name) const { return dir_ / name; }

  fs::path dir_;
};

// ---------------------------------------------------------------------------------------------
// Direct HDF5 C API inspection (independent of the store's own helpers)

struct Closer {
  hid_t id;
  herr_t (*close)(hid_t);
  ~Closer() {
    if (id >= 0) close(id);
  }
};

// The bytes of a fixed-length, NUL-padded UTF-8 string type of `size` bytes, cut at the first
// NUL: what h5py reads as bytes and `.decode()`s. Anything else fails the test.
std::vector<std::string> fixed_utf8_strings(hid_t type, hid_t space, const char* name,
                                            const std::function<herr_t(void*)>& read) {
  EXPECT_EQ(H5Tget_class(type), H5T_STRING) << name;
  EXPECT_EQ(H5Tis_variable_str(type), 0) << name;
  EXPECT_EQ(H5Tget_cset(type), H5T_CSET_UTF8) << name;
  EXPECT_EQ(H5Tget_strpad(type), H5T_STR_NULLPAD) << name;
  const std::size_t size = H5Tget_size(type);
  const auto count = std::size_t(H5Sget_simple_extent_npoints(space));
  std::vector<char> bytes(size * count);
  EXPECT_GE(read(bytes.data()), 0) << name;
  std::vector<std::string> out;
  for (std::size_t i = 0; i < count; ++i) {
    const char* text = bytes.data() + i * size;
    out.emplace_back(text, std::find(text, text + size, '\0'));
  }
  return out;
}

std::string fixed_utf8_attribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) return "<missing>";
  const Closer attribute{H5Aopen(object, name, H5P_DEFAULT), H5Aclose};
  const Closer type{H5Aget_type(attribute.id), H5Tclose};
  const Closer space{H5Aget_space(attribute.id), H5Sclose};
  const auto strings = fixed_utf8_strings(type.id, space.id, name, [&](void* buffer) {
    return H5Aread(attribute.id, type.id, buffer);
  });
  return strings.size() == 1 ? strings.front() : "<not one string>";
}

std::vector<std::string> fixed_utf8_dataset(hid_t group, const char* name) {
  const Closer dataset{H5Dopen2(group, name, H5P_DEFAULT), H5Dclose};
  const Closer type{H5Dget_type(dataset.id), H5Tclose};
  const Closer space{H5Dget_space(dataset.id), H5Sclose};
  EXPECT_EQ(H5Sget_simple_extent_ndims(space.id), 1) << name;
  return fixed_utf8_strings(type.id, space.id, name, [&](void* buffer) {
    return H5Dread(dataset.id, type.id, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
  });
}

std::vector<hsize_t> dims_of(hid_t dataset) {
  const Closer space{H5Dget_space(dataset), H5Sclose};
  std::vector<hsize_t> dims(std::size_t(H5Sget_simple_extent_ndims(space.id)));
  H5Sget_simple_extent_dims(space.id, dims.data(), nullptr);
  return dims;
}

template <class T>
std::vector<T> read_all(hid_t group, const char* name, hid_t memory_type) {
  const Closer dataset{H5Dopen2(group, name, H5P_DEFAULT), H5Dclose};
  const Closer space{H5Dget_space(dataset.id), H5Sclose};
  std::vector<T> out(std::size_t(H5Sget_simple_extent_npoints(space.id)));
  if (!out.empty()) {
    EXPECT_GE(H5Dread(dataset.id, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), 0);
  }
  return out;
}

std::vector<std::string> link_names(hid_t group) {
  std::vector<std::string> names;
  H5Literate(
      group, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
      },
      &names);
  return names;
}

// The filters of a dataset's creation properties, in pipeline order, with their first value.
std::vector<std::pair<H5Z_filter_t, unsigned>> filters_of(hid_t dataset) {
  const Closer properties{H5Dget_create_plist(dataset), H5Pclose};
  std::vector<std::pair<H5Z_filter_t, unsigned>> out;
  for (int i = 0; i < H5Pget_nfilters(properties.id); ++i) {
    unsigned flags = 0, values[4] = {0, 0, 0, 0};
    std::size_t count = 4;
    const H5Z_filter_t id =
        H5Pget_filter2(properties.id, unsigned(i), &flags, &count, values, 0, nullptr, nullptr);
    out.emplace_back(id, count > 0 ? values[0] : 0u);
  }
  return out;
}

// Checks a skeleton group against the skeleton written.
void expect_skeleton_group(hid_t file, const std::string& name, const Skeleton& s) {
  SCOPED_TRACE("skeleton " + name);
  const Closer group{H5Gopen2(file, ("/skeletons/" + name).c_str(), H5P_DEFAULT), H5Gclose};
  ASSERT_GE(group.id, 0);
  const int n = s.joint_count();
  EXPECT_EQ(fixed_utf8_dataset(group.id, "joint_names"), s.joint_names);
  std::vector<std::string> channels;
  for (int j = 0; j < n; ++j) channels.push_back(s.channel_list(j));
  EXPECT_EQ(fixed_utf8_dataset(group.id, "channels"), channels);
  EXPECT_EQ(channels.back(), "");  // a joint without channels is stored as ""
  {
    const Closer parents{H5Dopen2(group.id, "parents", H5P_DEFAULT), H5Dclose};
    const Closer type{H5Dget_type(parents.id), H5Tclose};
    EXPECT_GT(H5Tequal(type.id, H5T_STD_I32LE), 0);
    EXPECT_EQ(dims_of(parents.id), (std::vector<hsize_t>{hsize_t(n)}));
  }
  EXPECT_EQ(read_all<int>(group.id, "parents", H5T_NATIVE_INT), s.parents);
  for (const char* rows : {"offsets", "end_sites"}) {
    const Closer dataset{H5Dopen2(group.id, rows, H5P_DEFAULT), H5Dclose};
    const Closer type{H5Dget_type(dataset.id), H5Tclose};
    EXPECT_GT(H5Tequal(type.id, H5T_IEEE_F64LE), 0) << rows;
    EXPECT_EQ(dims_of(dataset.id), (std::vector<hsize_t>{hsize_t(n), 3})) << rows;
  }
  const auto offsets = read_all<double>(group.id, "offsets", H5T_NATIVE_DOUBLE);
  const auto end_sites = read_all<double>(group.id, "end_sites", H5T_NATIVE_DOUBLE);
  const auto has_end_site = read_all<std::uint8_t>(group.id, "has_end_site", H5T_NATIVE_UINT8);
  ASSERT_EQ(has_end_site.size(), std::size_t(n));
  for (int j = 0; j < n; ++j) {
    EXPECT_EQ(offsets[3 * j], s.offsets[j].x);
    EXPECT_EQ(offsets[3 * j + 1], s.offsets[j].y);
    EXPECT_EQ(offsets[3 * j + 2], s.offsets[j].z);
    EXPECT_EQ(has_end_site[j] != 0, s.end_sites[j].has_value()) << j;
    if (s.end_sites[j]) {
      EXPECT_EQ(end_sites[3 * j], s.end_sites[j]->x);
      EXPECT_EQ(end_sites[3 * j + 1], s.end_sites[j]->y);
      EXPECT_EQ(end_sites[3 * j + 2], s.end_sites[j]->z);
    }
  }
}

// Checks a clip group: attributes, both datasets' type, shape, chunking, filters and values.
void expect_clip_group(hid_t file, const std::string& path, const Clip& clip,
                       Compression compression) {
  SCOPED_TRACE("clip " + path);
  const Closer group{H5Gopen2(file, ("/clips/" + path).c_str(), H5P_DEFAULT), H5Gclose};
  ASSERT_GE(group.id, 0);
  EXPECT_EQ(fixed_utf8_attribute(group.id, "skeleton"), skeleton_name(*clip.skeleton));
  EXPECT_EQ(fixed_utf8_attribute(group.id, "source"), clip.source);
  {
    const Closer attribute{H5Aopen(group.id, "frame_time", H5P_DEFAULT), H5Aclose};
    const Closer type{H5Aget_type(attribute.id), H5Tclose};
    EXPECT_GT(H5Tequal(type.id, H5T_IEEE_F64LE), 0);
    double frame_time = 0;
    H5Aread(attribute.id, H5T_NATIVE_DOUBLE, &frame_time);
    EXPECT_EQ(frame_time, clip.frame_time);
  }
  const int joints = clip.joints();
  for (const auto& [name, channels, values] : {std::tuple{"rotations", 4, &clip.rotations},
                                               std::tuple{"translations", 3, &clip.translations}}) {
    SCOPED_TRACE(name);
    const Closer dataset{H5Dopen2(group.id, name, H5P_DEFAULT), H5Dclose};
    ASSERT_GE(dataset.id, 0);
    const Closer type{H5Dget_type(dataset.id), H5Tclose};
    EXPECT_GT(H5Tequal(type.id, H5T_NATIVE_FLOAT), 0);
    EXPECT_EQ(dims_of(dataset.id),
              (std::vector<hsize_t>{hsize_t(clip.frames), hsize_t(joints), hsize_t(channels)}));
    const Closer properties{H5Dget_create_plist(dataset.id), H5Pclose};
    ASSERT_EQ(H5Pget_layout(properties.id), H5D_CHUNKED);
    hsize_t chunk[3] = {0, 0, 0};
    ASSERT_EQ(H5Pget_chunk(properties.id, 3, chunk), 3);
    EXPECT_EQ(chunk[1], hsize_t(joints));
    EXPECT_EQ(chunk[2], hsize_t(channels));
    EXPECT_GE(chunk[0], 1u);
    EXPECT_LE(chunk[0], hsize_t(std::max(clip.frames, 1)));
    const std::size_t chunk_bytes = chunk[0] * chunk[1] * chunk[2] * sizeof(float);
    EXPECT_LE(chunk_bytes, 256u * 1024u);
    if (chunk[0] < hsize_t(clip.frames)) {
      EXPECT_GE(chunk_bytes, 64u * 1024u);
    }
    // The pipeline ends with Fletcher-32, the writer's default (issue 19).
    auto filters = filters_of(dataset.id);
    ASSERT_FALSE(filters.empty());
    EXPECT_EQ(filters.back().first, H5Z_FILTER_FLETCHER32);
    filters.pop_back();
    switch (compression) {
      case Compression::none:
        EXPECT_TRUE(filters.empty());
        break;
      case Compression::lz4:
        ASSERT_EQ(filters.size(), 2u);
        EXPECT_EQ(filters[0].first, H5Z_FILTER_SHUFFLE);
        EXPECT_EQ(filters[1].first, H5Z_filter_t(kLz4FilterId));
        break;
      case Compression::deflate:
        ASSERT_EQ(filters.size(), 2u);
        EXPECT_EQ(filters[0].first, H5Z_FILTER_SHUFFLE);
        EXPECT_EQ(filters[1].first, H5Z_FILTER_DEFLATE);
        EXPECT_EQ(filters[1].second, unsigned(kDeflateLevel));
        break;
    }
    EXPECT_TRUE(same_bits(read_all<float>(group.id, name, H5T_NATIVE_FLOAT), *values));
  }
}

// ---------------------------------------------------------------------------------------------
// Names, paths and chunk sizes

TEST(LibraryFormat, ClipPathFromSource) {
  EXPECT_EQ(clip_path_from_source("cmu/01/01_01.bvh"), "cmu/01/01_01");
  EXPECT_EQ(clip_path_from_source("./cmu\\01\\01_01.bvh"), "cmu/01/01_01");
  EXPECT_EQ(clip_path_from_source("././a//b/./c.d.bvh"), "a/b/c.d");
  EXPECT_EQ(clip_path_from_source("v1.2/take"), "v1.2/take");  // a dot in a folder stays
  EXPECT_EQ(clip_path_from_source("walk.bvh"), "walk");
  EXPECT_EQ(clip_path_from_source("../walk.bvh"), "");
  EXPECT_EQ(clip_path_from_source("a/../../walk.bvh"), "");
  EXPECT_EQ(clip_path_from_source("/abs/walk.bvh"), "");
  EXPECT_EQ(clip_path_from_source("./"), "");
  EXPECT_EQ(clip_path_from_source(""), "");
}

TEST(LibraryFormat, CheckClipPath) {
  EXPECT_EQ(check_clip_path("cmu/01/01_01"), "");
  EXPECT_NE(check_clip_path(""), "");
  EXPECT_NE(check_clip_path("/cmu/01"), "");
  EXPECT_NE(check_clip_path("cmu//01"), "");
  EXPECT_NE(check_clip_path("cmu/../01"), "");
  EXPECT_NE(check_clip_path("cmu/01/"), "");
}

TEST(LibraryFormat, SkeletonNameIsDeterministicAndFollowsContent) {
  const auto a = make_skeleton("Hips", 31);
  const Skeleton copy = *a;
  const std::string name = skeleton_name(*a);
  EXPECT_TRUE(matches(name, "Hips-31j-xxxxxxxx")) << name;
  EXPECT_EQ(skeleton_name(copy), name);
  Skeleton moved = *a;
  moved.offsets[5].y += 1e-9;
  EXPECT_NE(skeleton_name(moved), name);
  Skeleton end_site = *a;
  end_site.end_sites[4] = Vec3{};
  EXPECT_NE(skeleton_name(end_site), name);
  Skeleton reordered = *a;
  reordered.channels[1] = {Channel::Xrotation, Channel::Yrotation, Channel::Zrotation};
  EXPECT_NE(skeleton_name(reordered), name);
  Skeleton odd = *a;
  odd.joint_names[0] = "root/with space";
  EXPECT_EQ(skeleton_name(odd).rfind("root_with_space-31j-", 0), 0u) << skeleton_name(odd);
}

TEST(LibraryFormat, CompressionNames) {
  for (Compression c : {Compression::none, Compression::lz4, Compression::deflate})
    EXPECT_EQ(parse_compression(to_string(c)), c);
  EXPECT_FALSE(parse_compression("zstd"));
  EXPECT_FALSE(parse_compression(""));
}

TEST(LibraryFormat, ChunkFramesKeepChunksNear128KiB) {
  for (int joints : {1, 2, 17, 31, 64, 500, 4096}) {
    for (int channels : {3, 4}) {
      const std::size_t frame_bytes = std::size_t(joints) * channels * sizeof(float);
      for (int frames : {0, 1, 7, 100, 5000, 1000000}) {
        const int c = chunk_frames(frames, frame_bytes);
        EXPECT_GE(c, 1);
        EXPECT_LE(c, std::max(frames, 1));
        EXPECT_LE(c * frame_bytes, std::max<std::size_t>(128 * 1024, frame_bytes));
        if (c < frames) {
          EXPECT_GE(c * frame_bytes, 64u * 1024u) << joints << " " << frames;
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Chunk codec

TEST(ChunkCodec, ShuffleGroupsBytesOfEachElement) {
  std::vector<std::uint8_t> in(4 * 5 + 3), out(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) in[i] = std::uint8_t(i * 7 + 1);
  shuffle_bytes(in, 4, out);
  for (std::size_t e = 0; e < 5; ++e)
    for (std::size_t b = 0; b < 4; ++b) EXPECT_EQ(out[b * 5 + e], in[e * 4 + b]);
  for (std::size_t i = 20; i < in.size(); ++i) EXPECT_EQ(out[i], in[i]);  // leftover bytes
}

TEST(ChunkCodec, Lz4FilterFormatRoundTripsAndStoresIncompressibleBlocksRaw) {
  std::mt19937_64 rng(5);
  std::vector<std::uint8_t> noise(10000), smooth(10000);
  for (auto& b : noise) b = std::uint8_t(rng());
  for (std::size_t i = 0; i < smooth.size(); ++i) smooth[i] = std::uint8_t(i / 100);
  for (const auto* input : {&noise, &smooth}) {
    std::vector<std::uint8_t> encoded, decoded;
    ASSERT_TRUE(lz4_filter_encode(*input, encoded));
    ASSERT_GE(encoded.size(), 16u);
    std::uint64_t total = 0;
    for (int i = 0; i < 8; ++i) total = (total << 8) | encoded[i];
    std::uint32_t block = 0, stored = 0;
    for (int i = 8; i < 12; ++i) block = (block << 8) | encoded[i];
    for (int i = 12; i < 16; ++i) stored = (stored << 8) | encoded[i];
    EXPECT_EQ(total, input->size());
    EXPECT_EQ(block, input->size());  // one block: the default block size exceeds any chunk
    EXPECT_EQ(encoded.size(), 16u + stored);
    if (input == &noise) {
      EXPECT_EQ(stored, input->size());  // stored raw
      EXPECT_EQ(std::memcmp(encoded.data() + 16, input->data(), input->size()), 0);
    } else {
      EXPECT_LT(stored, input->size() / 10);
    }
    ASSERT_TRUE(lz4_filter_decode(encoded, decoded));
    EXPECT_EQ(decoded, *input);
    encoded.resize(encoded.size() - 1);
    EXPECT_FALSE(lz4_filter_decode(encoded, decoded));
  }
}

// ---------------------------------------------------------------------------------------------
// Writing, inspected through the C API

struct Library {
  std::shared_ptr<const Skeleton> a = make_skeleton("Hips", 31), b = make_skeleton("root", 5);
  std::vector<std::pair<std::string, Clip>> clips;
  Library() {
    // Short (one chunk), long (several chunks and a partial one), nested, and a lone one.
    clips.emplace_back("cmu/01/01_01", make_clip(a, 120, 1, "cmu/01/01_01.bvh"));
    clips.emplace_back("cmu/01/01_02", make_clip(a, 700, 2, "cmu/01/01_02.bvh"));
    clips.emplace_back("other/deep/nested/take", make_clip(b, 3000, 3, "other/deep/take.bvh"));
    clips.emplace_back("lone", make_clip(b, 2, 4, "lone.bvh"));
  }
};

bool write_library(const fs::path& path, Compression compression, const Library& library,
                   bool encoded) {
  std::string error;
  auto writer = LibraryWriter::create(path, compression, &error);
  EXPECT_TRUE(writer) << error;
  if (!writer) return false;
  for (const auto& [clip_path, clip] : library.clips) {
    if (encoded) {
      auto encoded_clip = encode_clip(clip, compression, &error);
      EXPECT_TRUE(encoded_clip) << error;
      if (!encoded_clip) return false;
      EXPECT_TRUE(writer->write_encoded(clip_path, *encoded_clip, &error)) << error;
    } else {
      EXPECT_TRUE(writer->write_clip(clip_path, clip, &error)) << error;
    }
  }
  EXPECT_TRUE(writer->close(&error)) << error;
  return true;
}

class StoreByCompression : public StoreTest, public ::testing::WithParamInterface<Compression> {};

TEST_P(StoreByCompression, LayoutSeenThroughTheHdf5CApi) {
  const Compression compression = GetParam();
  ASSERT_TRUE(compression_available(compression)) << compression_unavailable_reason(compression);
  const Library library;
  const fs::path path = file("library.h5");
  ASSERT_TRUE(write_library(path, compression, library, false));

  const Closer h5file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
  ASSERT_GE(h5file.id, 0);
  EXPECT_EQ(fixed_utf8_attribute(h5file.id, "format"), "mocap-clean-library");
  {
    const Closer version{H5Aopen(h5file.id, "format_version", H5P_DEFAULT), H5Aclose};
    const Closer type{H5Aget_type(version.id), H5Tclose};
    EXPECT_EQ(H5Tget_class(type.id), H5T_INTEGER);
    int value = 0;
    H5Aread(version.id, H5T_NATIVE_INT, &value);
    EXPECT_EQ(value, 2);
  }
  // Two skeletons for four clips: each stored once, under its content-derived name.
  const Closer skeletons{H5Gopen2(h5file.id, "/skeletons", H5P_DEFAULT), H5Gclose};
  std::vector<std::string> expected = {skeleton_name(*library.a), skeleton_name(*library.b)};
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(link_names(skeletons.id), expected);
  expect_skeleton_group(h5file.id, skeleton_name(*library.a), *library.a);
  expect_skeleton_group(h5file.id, skeleton_name(*library.b), *library.b);
  const Closer clips{H5Gopen2(h5file.id, "/clips", H5P_DEFAULT), H5Gclose};
  EXPECT_EQ(link_names(clips.id), (std::vector<std::string>{"cmu", "lone", "other"}));
  for (const auto& [clip_path, clip] : library.clips)
    expect_clip_group(h5file.id, clip_path, clip, compression);
  EXPECT_EQ(H5Aexists(h5file.id, "provenance"), 0);
  EXPECT_LE(H5Lexists(h5file.id, "provenance", H5P_DEFAULT), 0);  // only on filter outputs
}

TEST_P(StoreByCompression, ReaderRoundTripsBitExactAndSharesSkeletons) {
  const Compression compression = GetParam();
  const Library library;
  const fs::path path = file("library.h5");
  ASSERT_TRUE(write_library(path, compression, library, false));
  std::string error;
  const auto reader = LibraryReader::open(path, &error);
  ASSERT_TRUE(reader) << error;
  const auto& headers = reader->clips();
  ASSERT_EQ(headers.size(), library.clips.size());
  for (std::size_t i = 1; i < headers.size(); ++i) EXPECT_LT(headers[i - 1].path, headers[i].path);
  std::map<std::string, std::shared_ptr<const Skeleton>> seen;
  for (const auto& [clip_path, clip] : library.clips) {
    SCOPED_TRACE(clip_path);
    const auto header = std::find_if(headers.begin(), headers.end(),
                                     [&](const ClipHeader& h) { return h.path == clip_path; });
    ASSERT_NE(header, headers.end());
    EXPECT_EQ(header->error, "");
    EXPECT_EQ(header->skeleton, skeleton_name(*clip.skeleton));
    EXPECT_EQ(header->frames, clip.frames);
    EXPECT_EQ(header->joints, clip.joints());
    EXPECT_EQ(header->frame_time, clip.frame_time);
    EXPECT_EQ(header->source, clip.source);
    const auto back = reader->read_clip(clip_path, &error);
    ASSERT_TRUE(back) << error;
    EXPECT_EQ(*back->skeleton, *clip.skeleton);
    EXPECT_EQ(back->frames, clip.frames);
    EXPECT_EQ(back->frame_time, clip.frame_time);
    EXPECT_EQ(back->source, clip.source);
    EXPECT_TRUE(same_bits(back->rotations, clip.rotations));
    EXPECT_TRUE(same_bits(back->translations, clip.translations));
    auto [it, fresh] = seen.emplace(header->skeleton, back->skeleton);
    if (!fresh) {
      EXPECT_EQ(it->second.get(), back->skeleton.get());  // read once, shared
    }
  }
  EXPECT_EQ(reader->skeleton(skeleton_name(*library.a), &error).get(),
            seen[skeleton_name(*library.a)].get());
  EXPECT_FALSE(reader->provenance());
}

// The encoded path hands HDF5 the chunks as the filters would have made them: the stored chunk
// bytes equal those of write_clip(), and HDF5's own filters (the plugin, for lz4) decode them.
TEST_P(StoreByCompression, EncodedWriteStoresTheSameChunkBytes) {
  const Compression compression = GetParam();
  const Library library;
  const fs::path plain = file("plain.h5"), encoded = file("encoded.h5");
  ASSERT_TRUE(write_library(plain, compression, library, false));
  ASSERT_TRUE(write_library(encoded, compression, library, true));
  const Closer a{H5Fopen(plain.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
  const Closer b{H5Fopen(encoded.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
  for (const auto& [clip_path, clip] : library.clips) {
    expect_clip_group(b.id, clip_path, clip, compression);
    for (const char* name : {"rotations", "translations"}) {
      SCOPED_TRACE(clip_path + "/" + name);
      const std::string dataset_path = "/clips/" + clip_path + "/" + name;
      const Closer da{H5Dopen2(a.id, dataset_path.c_str(), H5P_DEFAULT), H5Dclose};
      const Closer db{H5Dopen2(b.id, dataset_path.c_str(), H5P_DEFAULT), H5Dclose};
      const Closer pa{H5Dget_create_plist(da.id), H5Pclose};
      hsize_t chunk[3];
      H5Pget_chunk(pa.id, 3, chunk);
      const hsize_t frames = dims_of(da.id)[0];
      int chunks = 0;
      for (hsize_t start = 0; start < frames; start += chunk[0], ++chunks) {
        const hsize_t offset[3] = {start, 0, 0};
        hsize_t size_a = 0, size_b = 0;
        ASSERT_GE(H5Dget_chunk_storage_size(da.id, offset, &size_a), 0);
        ASSERT_GE(H5Dget_chunk_storage_size(db.id, offset, &size_b), 0);
        ASSERT_EQ(size_a, size_b) << "chunk at frame " << start;
        std::vector<std::uint8_t> bytes_a(size_a), bytes_b(size_b);
        std::uint32_t mask_a = 99, mask_b = 99;
        ASSERT_GE(H5Dread_chunk(da.id, H5P_DEFAULT, offset, &mask_a, bytes_a.data()), 0);
        ASSERT_GE(H5Dread_chunk(db.id, H5P_DEFAULT, offset, &mask_b, bytes_b.data()), 0);
        EXPECT_EQ(mask_a, 0u);
        EXPECT_EQ(mask_b, 0u);
        EXPECT_EQ(bytes_a, bytes_b) << "chunk at frame " << start;
      }
      if (clip.frames > int(chunk[0])) {
        EXPECT_GT(chunks, 1);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Compressions, StoreByCompression,
                         ::testing::Values(Compression::none, Compression::lz4,
                                           Compression::deflate),
                         [](const auto& param_info) {
                           return std::string(to_string(param_info.param));
                         });

// ---------------------------------------------------------------------------------------------
// Provenance, empty clips, links between files

// One h5py run over a file of each compression (h5py's start-up is most of the cost): plain
// h5py must see the layout, UTF-8 strings (as bytes), and decode lz4 through the plugin.
TEST_F(StoreTest, H5pyReadsTheLayout) {
  if (std::system("/usr/bin/python3 -c 'import h5py' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "h5py is not importable by /usr/bin/python3: h5py check skipped";
  const Library library;
  std::string files;
  for (Compression compression : {Compression::none, Compression::lz4, Compression::deflate}) {
    const fs::path path = file(std::string(to_string(compression)) + ".h5");
    ASSERT_TRUE(write_library(path, compression, library, compression == Compression::lz4));
    files += " '" + path.string() + "'";
  }
  {
    std::string error;
    auto writer = LibraryWriter::create(file("provenance.h5"), Compression::lz4, &error);
    ASSERT_TRUE(writer) << error;
    for (const auto& [clip_path, clip] : library.clips)
      ASSERT_TRUE(writer->write_clip(clip_path, clip, &error)) << error;
    ASSERT_TRUE(
        writer->write_provenance({"bof", R"({"sigma_t": 1.0})", "0.1.0", "in.h5", ""}, &error))
        << error;
  }
  const fs::path script = fs::path(__FILE__).parent_path() / "library_h5py_check.py";
  std::string clips;
  for (const auto& entry : library.clips) clips += (clips.empty() ? "" : ",") + entry.first;
  const std::string run =
      "/usr/bin/python3 '" + script.string() + "' --clips " + clips + " --skeletons 2";
  EXPECT_EQ(std::system((run + files).c_str()), 0) << run + files;
  const std::string with_provenance =
      run + " --provenance '" + file("provenance.h5").string() + "'";
  EXPECT_EQ(std::system(with_provenance.c_str()), 0) << with_provenance;
}

TEST_F(StoreTest, ProvenanceAttributes) {
  const fs::path path = file("out.h5");
  std::string error;
  {
    auto writer = LibraryWriter::create(path, Compression::none, &error);
    ASSERT_TRUE(writer) << error;
    ASSERT_TRUE(writer->write_provenance({"old", "{}", "0", "x", ""}, &error)) << error;
    const Provenance p{"nlpm", R"({"K": 5, "h": 0.1})", "0.1.0", "lib.h5", "2024-05-01T12:00:00Z"};
    ASSERT_TRUE(writer->write_provenance(p, &error)) << error;  // replaces the first
    ASSERT_TRUE(writer->close(&error)) << error;
    EXPECT_FALSE(writer->write_provenance(p, &error));
    EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  }
  {
    const Closer h5file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
    const Closer group{H5Gopen2(h5file.id, "/provenance", H5P_DEFAULT), H5Gclose};
    ASSERT_GE(group.id, 0);
    EXPECT_EQ(fixed_utf8_attribute(group.id, "method"), "nlpm");
    EXPECT_EQ(fixed_utf8_attribute(group.id, "parameters"), R"({"K": 5, "h": 0.1})");
    EXPECT_EQ(fixed_utf8_attribute(group.id, "engine_version"), "0.1.0");
    EXPECT_EQ(fixed_utf8_attribute(group.id, "input_file"), "lib.h5");
    EXPECT_EQ(fixed_utf8_attribute(group.id, "created"), "2024-05-01T12:00:00Z");
  }
  const auto reader = LibraryReader::open(path, &error);
  ASSERT_TRUE(reader) << error;
  const auto p = reader->provenance();
  ASSERT_TRUE(p);
  EXPECT_EQ(p->method, "nlpm");
  EXPECT_EQ(p->parameters_json, R"({"K": 5, "h": 0.1})");
  EXPECT_EQ(p->created, "2024-05-01T12:00:00Z");
  EXPECT_TRUE(reader->clips().empty());
}

TEST_F(StoreTest, ProvenanceCreatedDefaultsToNowInUtc) {
  const fs::path path = file("out.h5");
  std::string error;
  {
    auto writer = LibraryWriter::create(path, Compression::deflate, &error);
    ASSERT_TRUE(writer) << error;
    ASSERT_TRUE(writer->write_provenance({"bof", "{}", "0.1.0", "lib.h5", ""}, &error));
  }  // the destructor closes
  const auto reader = LibraryReader::open(path, &error);
  ASSERT_TRUE(reader) << error;
  const auto p = reader->provenance();
  ASSERT_TRUE(p);
  EXPECT_TRUE(matches(p->created, "dddd-dd-ddTdd:dd:ddZ")) << p->created;
  EXPECT_GE(p->created.substr(0, 4), "2024");
}

TEST_F(StoreTest, EmptyClipRoundTrips) {
  const fs::path path = file("empty.h5");
  const Clip clip = make_clip(make_skeleton("Hips", 4), 0, 9, "empty.bvh");
  std::string error;
  for (bool encoded : {false, true}) {
    auto writer = LibraryWriter::create(path, Compression::lz4, &error);
    ASSERT_TRUE(writer) << error;
    if (encoded)
      ASSERT_TRUE(writer->write_encoded("e", *encode_clip(clip, Compression::lz4, &error), &error))
          << error;
    else
      ASSERT_TRUE(writer->write_clip("e", clip, &error)) << error;
    ASSERT_TRUE(writer->close(&error)) << error;
    const auto reader = LibraryReader::open(path, &error);
    ASSERT_TRUE(reader) << error;
    ASSERT_EQ(reader->clips().size(), 1u);
    EXPECT_EQ(reader->clips()[0].frames, 0);
    EXPECT_EQ(reader->clips()[0].joints, 4);
    const auto back = reader->read_clip("e", &error);
    ASSERT_TRUE(back) << error;
    EXPECT_EQ(back->frames, 0);
    EXPECT_TRUE(back->rotations.empty());
  }
}

// Parts written by separate processes join through external links; the skeletons stay in the
// parts, where the reader finds them.
TEST_F(StoreTest, ReaderFollowsExternalAndSoftLinks) {
  const Library library;
  std::string error;
  for (const auto& [part, prefix] :
       {std::pair{"part1.h5", "cmu"}, std::pair{"part2.h5", "other"}}) {
    auto writer = LibraryWriter::create(file(part), Compression::lz4, &error);
    ASSERT_TRUE(writer) << error;
    for (const auto& [clip_path, clip] : library.clips)
      if (clip_path.rfind(prefix, 0) == 0) {
        ASSERT_TRUE(writer->write_clip(clip_path, clip, &error)) << error;
      }
  }
  ASSERT_TRUE(LibraryWriter::create(file("main.h5"), Compression::lz4, &error)) << error;
  {
    const Closer h5file{H5Fopen(file("main.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose};
    ASSERT_GE(H5Lcreate_external("part1.h5", "/clips/cmu", h5file.id, "/clips/cmu", H5P_DEFAULT,
                                 H5P_DEFAULT),
              0);
    ASSERT_GE(H5Lcreate_external("part2.h5", "/clips/other", h5file.id, "/clips/other", H5P_DEFAULT,
                                 H5P_DEFAULT),
              0);
    ASSERT_GE(H5Lcreate_soft("/clips/cmu/01", h5file.id, "/clips/alias", H5P_DEFAULT, H5P_DEFAULT),
              0);
    ASSERT_GE(H5Lcreate_external("missing.h5", "/clips/x", h5file.id, "/clips/zz_missing",
                                 H5P_DEFAULT, H5P_DEFAULT),
              0);
  }
  // Resolve the links relative to the main file, not to the working directory.
  const fs::path cwd = fs::current_path();
  fs::current_path(fs::temp_directory_path());
  const auto reader = LibraryReader::open(file("main.h5"), &error);
  fs::current_path(cwd);
  ASSERT_TRUE(reader) << error;
  std::vector<std::string> paths;
  for (const auto& h : reader->clips()) paths.push_back(h.path);
  // The soft link is an alias: its clips are listed under both paths.
  EXPECT_EQ(paths,
            (std::vector<std::string>{"alias/01_01", "alias/01_02", "cmu/01/01_01", "cmu/01/01_02",
                                      "other/deep/nested/take", "zz_missing"}))
      << ::testing::PrintToString(paths);
  ASSERT_EQ(reader->clips().size(), 6u);
  const ClipHeader& missing = reader->clips().back();
  EXPECT_NE(missing.error.find("missing.h5"), std::string::npos) << missing.error;
  EXPECT_NE(missing.error.find(file("main.h5").string()), std::string::npos) << missing.error;
  for (const auto& [clip_path, clip] : library.clips) {
    if (clip_path == "lone") continue;
    const auto back = reader->read_clip(clip_path, &error);
    ASSERT_TRUE(back) << error;
    EXPECT_TRUE(same_bits(back->rotations, clip.rotations));
    EXPECT_EQ(*back->skeleton, *clip.skeleton);
  }
  const auto alias = reader->read_clip("alias/01_02", &error);
  ASSERT_TRUE(alias) << error;
  EXPECT_TRUE(same_bits(alias->translations, library.clips[1].second.translations));
  EXPECT_FALSE(reader->read_clip("zz_missing", &error));
}

TEST_F(StoreTest, ReaderSurvivesLinkLoops) {
  const Library library;
  std::string error;
  {
    auto writer = LibraryWriter::create(file("loop.h5"), Compression::none, &error);
    ASSERT_TRUE(writer) << error;
    ASSERT_TRUE(writer->write_clip("a/b/take", library.clips[0].second, &error)) << error;
  }
  {
    const Closer h5file{H5Fopen(file("loop.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose};
    ASSERT_GE(H5Lcreate_soft("/clips/a", h5file.id, "/clips/a/b/up", H5P_DEFAULT, H5P_DEFAULT), 0);
    ASSERT_GE(
        H5Lcreate_hard(h5file.id, "/clips", h5file.id, "/clips/a/root", H5P_DEFAULT, H5P_DEFAULT),
        0);
  }
  const auto reader = LibraryReader::open(file("loop.h5"), &error);
  ASSERT_TRUE(reader) << error;
  ASSERT_EQ(reader->clips().size(), 1u);
  EXPECT_EQ(reader->clips()[0].path, "a/b/take");
}

// ---------------------------------------------------------------------------------------------
// Errors, each naming the file

void expect_names_file(const std::string& error, const fs::path& path, const std::string& what) {
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find(what), std::string::npos) << error;
}

TEST_F(StoreTest, OpenRejectsMissingNonHdf5AndForeignFiles) {
  std::string error;
  EXPECT_FALSE(LibraryReader::open(file("nope.h5"), &error));
  expect_names_file(error, file("nope.h5"), "no such file");

  std::ofstream(file("text.h5")) << "just text, not HDF5\n";
  EXPECT_FALSE(LibraryReader::open(file("text.h5"), &error));
  expect_names_file(error, file("text.h5"), "not an HDF5 file");

  {
    const Closer h5file{
        H5Fcreate(file("foreign.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose};
    const Closer group{H5Gcreate2(h5file.id, "clips", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                       H5Gclose};
  }
  EXPECT_FALSE(LibraryReader::open(file("foreign.h5"), &error));
  expect_names_file(error, file("foreign.h5"), "not a mocap-clean library");
  expect_names_file(error, file("foreign.h5"), "'format'");

  ASSERT_TRUE(LibraryWriter::create(file("v3.h5"), Compression::none, &error)) << error;
  {
    const Closer h5file{H5Fopen(file("v3.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose};
    const Closer attribute{H5Aopen(h5file.id, "format_version", H5P_DEFAULT), H5Aclose};
    const int three = 3;
    ASSERT_GE(H5Awrite(attribute.id, H5T_NATIVE_INT, &three), 0);
  }
  EXPECT_FALSE(LibraryReader::open(file("v3.h5"), &error));
  expect_names_file(error, file("v3.h5"), "format_version 3 is not supported");

  EXPECT_FALSE(LibraryWriter::create(file("no/such/folder/x.h5"), Compression::none, &error));
  expect_names_file(error, file("no/such/folder/x.h5"), "cannot create");
}

TEST_F(StoreTest, ReadClipRejectsShapesThatDisagreeWithTheSkeleton) {
  const fs::path path = file("bad.h5");
  const Library library;
  std::string error;
  {
    auto writer = LibraryWriter::create(path, Compression::none, &error);
    ASSERT_TRUE(writer) << error;
    ASSERT_TRUE(writer->write_clip("good", library.clips[0].second, &error)) << error;
  }
  {  // Copy "good" by hand, then give its rotations one joint fewer than the skeleton has.
    const Closer h5file{H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose};
    ASSERT_GE(H5Ocopy(h5file.id, "/clips/good", h5file.id, "/clips/bad", H5P_DEFAULT, H5P_DEFAULT),
              0);
    ASSERT_GE(H5Ldelete(h5file.id, "/clips/bad/rotations", H5P_DEFAULT), 0);
    const hsize_t dims[3] = {120, 30, 4};
    const Closer space{H5Screate_simple(3, dims, nullptr), H5Sclose};
    const Closer dataset{H5Dcreate2(h5file.id, "/clips/bad/rotations", H5T_NATIVE_FLOAT, space.id,
                                    H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                         H5Dclose};
    ASSERT_GE(dataset.id, 0);
    // Stored in full: a dataset with unstored bytes is refused before its shape is compared.
    const std::vector<float> values(120 * 30 * 4, 0.5f);
    ASSERT_GE(H5Dwrite(dataset.id, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()),
              0);
  }
  const auto reader = LibraryReader::open(path, &error);
  ASSERT_TRUE(reader) << error;
  ASSERT_EQ(reader->clips().size(), 2u);
  EXPECT_TRUE(reader->read_clip("good", &error)) << error;
  EXPECT_FALSE(reader->read_clip("bad", &error));
  expect_names_file(error, path, "clip 'bad'");
  expect_names_file(error, path, "[120, 30, 4]");
  expect_names_file(error, path, "[F, 31, 4]");
  EXPECT_FALSE(reader->read_clip("absent/clip", &error));
  expect_names_file(error, path, "no clip 'absent/clip'");
  EXPECT_FALSE(reader->skeleton("nobody-1j-00000000", &error));
  expect_names_file(error, path, "no skeleton 'nobody-1j-00000000'");
}

TEST_F(StoreTest, WriteClipRefusesBadClipsAndPaths) {
  const fs::path path = file("lib.h5");
  const Library library;
  const Clip& good = library.clips[0].second;
  std::string error;
  auto writer = LibraryWriter::create(path, Compression::deflate, &error);
  ASSERT_TRUE(writer) << error;
  Clip short_rotations = good;
  short_rotations.rotations.pop_back();
  EXPECT_FALSE(writer->write_clip("a/short", short_rotations, &error));
  expect_names_file(error, path, "rotations hold");
  Clip bad_time = good;
  bad_time.frame_time = 0;
  EXPECT_FALSE(writer->write_clip("a/time", bad_time, &error));
  expect_names_file(error, path, "frame_time");
  EXPECT_FALSE(writer->write_clip("../up", good, &error));
  expect_names_file(error, path, "'..'");
  ASSERT_TRUE(writer->write_clip("a/b", good, &error)) << error;
  EXPECT_FALSE(writer->write_clip("a/b", good, &error));
  expect_names_file(error, path, "exists already");
  EXPECT_FALSE(writer->write_clip("a/b/c", good, &error));
  expect_names_file(error, path, "clips cannot nest");
  ASSERT_TRUE(writer->close(&error)) << error;

  const Closer h5file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
  const Closer clips{H5Gopen2(h5file.id, "/clips", H5P_DEFAULT), H5Gclose};
  EXPECT_EQ(link_names(clips.id), std::vector<std::string>{"a"});
  const Closer a{H5Gopen2(h5file.id, "/clips/a", H5P_DEFAULT), H5Gclose};
  EXPECT_EQ(link_names(a.id), std::vector<std::string>{"b"});
}

// A failure after the rotations are written (here: translations encoded for another shape)
// leaves nothing behind: no clip group, no new parent groups, no new skeleton.
TEST_F(StoreTest, FailedWriteLeavesNoTrace) {
  const fs::path path = file("lib.h5");
  const Library library;
  std::string error;
  auto writer = LibraryWriter::create(path, Compression::lz4, &error);
  ASSERT_TRUE(writer) << error;
  ASSERT_TRUE(writer->write_clip("kept/one", library.clips[0].second, &error)) << error;
  auto broken = encode_clip(library.clips[2].second, Compression::lz4, &error);
  ASSERT_TRUE(broken) << error;
  broken->translations.chunk_ends.pop_back();
  EXPECT_FALSE(writer->write_encoded("kept/new/deeper/two", *broken, &error));
  expect_names_file(error, path, "translations");
  EXPECT_FALSE(writer->write_encoded("fresh/two", *broken, &error));
  auto deflated = encode_clip(library.clips[2].second, Compression::deflate, &error);
  EXPECT_FALSE(writer->write_encoded("fresh/three", *deflated, &error));
  expect_names_file(error, path, "encoded with deflate");
  ASSERT_TRUE(writer->close(&error)) << error;

  const Closer h5file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
  const Closer clips{H5Gopen2(h5file.id, "/clips", H5P_DEFAULT), H5Gclose};
  EXPECT_EQ(link_names(clips.id), std::vector<std::string>{"kept"});
  const Closer kept{H5Gopen2(h5file.id, "/clips/kept", H5P_DEFAULT), H5Gclose};
  EXPECT_EQ(link_names(kept.id), std::vector<std::string>{"one"});
  const Closer skeletons{H5Gopen2(h5file.id, "/skeletons", H5P_DEFAULT), H5Gclose};
  EXPECT_EQ(link_names(skeletons.id),
            std::vector<std::string>{skeleton_name(*library.clips[0].second.skeleton)});
}

TEST_F(StoreTest, Lz4WithoutItsPluginIsAClearError) {
  ASSERT_TRUE(compression_available(Compression::lz4));
  // Forget the plugin and forbid loading it again: as on a machine without it.
  ASSERT_GE(H5Zunregister(H5Z_filter_t(kLz4FilterId)), 0);
  ASSERT_GE(H5PLset_loading_state(0), 0);
  std::string error;
  EXPECT_FALSE(compression_available(Compression::lz4));
  EXPECT_FALSE(LibraryWriter::create(file("lz4.h5"), Compression::lz4, &error));
  expect_names_file(error, file("lz4.h5"), "hdf5-filter-plugin");
  expect_names_file(error, file("lz4.h5"), "HDF5_PLUGIN_PATH");
  EXPECT_TRUE(LibraryWriter::create(file("deflate.h5"), Compression::deflate, &error)) << error;
  ASSERT_GE(H5PLset_loading_state(H5PL_ALL_PLUGIN), 0);
  EXPECT_TRUE(compression_available(Compression::lz4));
}

// ---------------------------------------------------------------------------------------------
// Throughput (prints, asserts nothing about time). Run by hand:
//   library_store_test --gtest_also_run_disabled_tests --gtest_filter='*Throughput*'

TEST_F(StoreTest, DISABLED_Throughput) {
  constexpr int kClips = 80, kFrames = 2000, kJoints = 31, kDistinct = 8;
  const auto skeleton = make_skeleton("Hips", kJoints);
  std::vector<Clip> clips;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 0.01);  // rad, per axis
  for (int i = 0; i < kDistinct; ++i) {
    Clip clip = make_clip(skeleton, kFrames, 100 + i, "take.bvh");
    for (std::size_t k = 0; k < clip.rotations.size(); k += 4) {
      const Quat q =
          load_quat(clip.rotations.data() + k) * exp(Vec3{noise(rng), noise(rng), noise(rng)});
      store_quat(q, clip.rotations.data() + k);
    }
    clips.push_back(std::move(clip));
  }
  const double joint_frames = double(kClips) * kFrames * kJoints;
  const double raw_mb = joint_frames * 7 * sizeof(float) / 1e6;
  // Wall time, and the process's CPU time: on a shared, loaded machine the latter tells what one
  // free core would do.
  struct Lap {
    double wall, cpu;
  };
  auto now = [] {
    timespec cpu{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &cpu);
    return Lap{
        std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(),
        double(cpu.tv_sec) + 1e-9 * double(cpu.tv_nsec)};
  };
  auto rate = [&](Lap start) {  // M joint-frames/s, wall and CPU
    const Lap end = now();
    return Lap{joint_frames / (end.wall - start.wall) / 1e6,
               joint_frames / (end.cpu - start.cpu) / 1e6};
  };
  std::printf("%d clips x %d frames x %d joints: %.1f M joint-frames, %.1f MB raw\n", kClips,
              kFrames, kJoints, joint_frames / 1e6, raw_mb);
  std::printf("M joint-frames/s as wall (cpu); 'encode x2' runs on 2 threads (cpu = both)\n");
  for (Compression compression : {Compression::none, Compression::lz4, Compression::deflate}) {
    const fs::path path = file(std::string(to_string(compression)) + ".h5");
    std::string error;
    Lap start = now();
    {
      auto writer = LibraryWriter::create(path, compression, &error);
      ASSERT_TRUE(writer) << error;
      for (int i = 0; i < kClips; ++i)
        ASSERT_TRUE(writer->write_clip("c/" + std::to_string(i), clips[i % kDistinct], &error));
      ASSERT_TRUE(writer->close(&error));
    }
    const Lap plain = rate(start);
    const double size_mb = double(fs::file_size(path)) / 1e6;

    std::vector<std::optional<EncodedClip>> encoded(kClips);
    start = now();
    for (int i = 0; i < kClips; ++i)
      encoded[i] = encode_clip(clips[i % kDistinct], compression, &error);
    const Lap encode_one = rate(start);
    start = now();
    std::vector<std::thread> workers;
    for (int w = 0; w < 2; ++w)
      workers.emplace_back([&, w] {
        std::string e;
        for (int i = w; i < kClips; i += 2)
          encoded[i] = encode_clip(clips[i % kDistinct], compression, &e);
      });
    for (auto& w : workers) w.join();
    const Lap encode_two = rate(start);
    start = now();
    {
      auto writer = LibraryWriter::create(file("encoded.h5"), compression, &error);
      ASSERT_TRUE(writer) << error;
      for (int i = 0; i < kClips; ++i)
        ASSERT_TRUE(writer->write_encoded("c/" + std::to_string(i), *encoded[i], &error));
      ASSERT_TRUE(writer->close(&error));
    }
    const Lap write_encoded = rate(start);
    std::printf(
        "%-7s %6.1f MB (%.2fx) | write_clip %5.1f (%5.1f) | encode %5.1f (%5.1f), x2 %5.1f "
        "(%5.1f) | write_encoded %5.1f (%5.1f)\n",
        std::string(to_string(compression)).c_str(), size_mb, raw_mb / size_mb, plain.wall,
        plain.cpu, encode_one.wall, encode_one.cpu, encode_two.wall, encode_two.cpu,
        write_encoded.wall, write_encoded.cpu);
  }
}

}  // namespace
}  // namespace mocap::io
