// Issue 19, item 2, at the level of chunks: numbers in a library file that HDF5 (or its LZ4
// plugin) would allocate or trust before reading. Each case is made here from a library the
// store writes, then damaged with the HDF5 C API or a byte patch; the reader must refuse the
// clip with an error naming the file, the clip and what is wrong, before HDF5 decodes it.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <vector>

#include "io/chunk_codec.hpp"
#include "io/library_store.hpp"
#include "tests/test_support.hpp"

namespace mocap::io {
namespace {

namespace fs = std::filesystem;

constexpr int kJoints = 3;
constexpr int kFrames = 2;

Clip make_clip() {
  auto s = std::make_shared<Skeleton>();
  for (int j = 0; j < kJoints; ++j) {
    s->joint_names.push_back(j == 0 ? "Hips" : "J" + std::to_string(j));
    s->parents.push_back(j - 1);
    s->offsets.push_back({0.0, 1.0 + j, 0.5});
    s->channels.push_back({Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    s->end_sites.push_back(std::nullopt);
  }
  Clip clip;
  clip.skeleton = s;
  clip.frame_time = 1.0 / 120;
  clip.frames = kFrames;
  for (int t = 0; t < kFrames; ++t)
    for (int j = 0; j < kJoints; ++j) {
      const double a = 0.01 * t + 0.1 * j;
      for (float v : {float(std::cos(a / 2)), 0.0f, 0.0f, float(std::sin(a / 2))})
        clip.rotations.push_back(v);
      for (float v : {0.0f, float(1.0 + j), 0.5f}) clip.translations.push_back(v);
    }
  return clip;
}

void write_library(const fs::path& path, Compression compression, bool checksum = false) {
  std::string error;
  auto writer = LibraryWriter::create(path, compression, &error, checksum);
  ASSERT_TRUE(writer) << error;
  ASSERT_TRUE(writer->write_clip("c", make_clip(), &error)) << error;
  ASSERT_TRUE(writer->close(&error)) << error;
}

// Reads clip "c" of `path`: the error, which must name the file and the clip ("" if it read).
std::string read_error(const fs::path& path) {
  std::string error;
  const auto reader = LibraryReader::open(path, &error);
  if (!reader) return error;
  if (reader->clips().size() != 1) return "clips: " + std::to_string(reader->clips().size());
  if (!reader->clips()[0].error.empty())
    error = reader->clips()[0].error;
  else if (reader->read_clip("c", &error))
    return "";
  EXPECT_NE(error.find(path.string()), std::string::npos) << error;
  EXPECT_NE(error.find("clip 'c'"), std::string::npos) << error;
  return error;
}

TEST(HostileChunks, TheUndamagedLibrariesRead) {
  test::TempDir dir("hostile-chunks");
  write_library(dir / "deflate.h5", Compression::deflate);
  EXPECT_EQ(read_error(dir / "deflate.h5"), "");
  if (!compression_available(Compression::lz4)) GTEST_SKIP() << "no LZ4 plugin";
  write_library(dir / "lz4.h5", Compression::lz4);
  EXPECT_EQ(read_error(dir / "lz4.h5"), "");
}

// A 2-frame clip whose chunk claims 2^20 frames (48 MiB): HDF5 allocates a whole chunk to
// decompress one, whatever the data. (An extendible dataset may have chunks beyond its shape.)
TEST(HostileChunks, AChunkLargerThanTheDataIsRefusedBeforeReading) {
  test::TempDir dir("hostile-chunks");
  const fs::path lib = dir / "lib.h5";
  write_library(lib, Compression::deflate);
  {
    const hid_t file = H5Fopen(lib.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    ASSERT_GE(H5Ldelete(file, "/clips/c/rotations", H5P_DEFAULT), 0);
    const hsize_t dims[3] = {kFrames, kJoints, 4}, most[3] = {H5S_UNLIMITED, kJoints, 4};
    const hsize_t chunk[3] = {hsize_t(1) << 20, kJoints, 4};
    const hid_t space = H5Screate_simple(3, dims, most);
    const hid_t properties = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(properties, 3, chunk);
    H5Pset_deflate(properties, 4);
    const hid_t dataset = H5Dcreate2(file, "/clips/c/rotations", H5T_IEEE_F32LE, space, H5P_DEFAULT,
                                     properties, H5P_DEFAULT);
    ASSERT_GE(dataset, 0);
    const Clip clip = make_clip();
    EXPECT_GE(
        H5Dwrite(dataset, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, clip.rotations.data()),
        0);
    H5Dclose(dataset);
    H5Pclose(properties);
    H5Sclose(space);
    H5Fclose(file);
  }
  EXPECT_LT(fs::file_size(lib), 1u << 20);
  const std::string error = read_error(lib);
  EXPECT_NE(error.find("(50331648 bytes) are larger than its data (96 bytes)"), std::string::npos)
      << error;
}

// The chunk index is only numbers: a chunk recorded as 2 GiB in a file of a few KB. HDF5
// allocates the recorded size before it reads the chunk.
TEST(HostileChunks, AStoredChunkLargerThanTheFileIsRefused) {
  test::TempDir dir("hostile-chunks");
  const fs::path lib = dir / "lib.h5";
  write_library(lib, Compression::deflate);
  hsize_t stored = 0;
  {
    const hid_t file = H5Fopen(lib.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t dataset = H5Dopen2(file, "/clips/c/rotations", H5P_DEFAULT);
    const hsize_t origin[3] = {0, 0, 0};
    ASSERT_GE(H5Dget_chunk_storage_size(dataset, origin, &stored), 0);
    H5Dclose(dataset);
    H5Fclose(file);
  }
  // The version-1 B-tree key of the chunk at the origin: size (4 bytes, little-endian), filter
  // mask (4), then 4 zero offsets of 8 bytes. Patched to 0x7fffffff.
  std::ifstream in(lib, std::ios::binary);
  std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
  in.close();
  std::vector<char> key(40, '\0');
  for (int i = 0; i < 4; ++i) key[std::size_t(i)] = char((stored >> (8 * i)) & 0xff);
  int patched = 0;
  for (auto at = bytes.begin();
       (at = std::search(at, bytes.end(), key.begin(), key.end())) != bytes.end(); ++at) {
    at[0] = char(0xff), at[1] = char(0xff), at[2] = char(0xff), at[3] = char(0x7f);
    ++patched;
  }
  ASSERT_GE(patched, 1) << "no chunk key of " << stored << " bytes found";
  std::ofstream(lib, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
  const std::string error = read_error(lib);
  EXPECT_NE(error.find("claims 2147483647 stored bytes, more than the file's"), std::string::npos)
      << error;
}

// libhdf5 1.10's Fletcher-32 filter subtracts its 4 bytes from a chunk's stored size unchecked:
// a chunk stored in 2 bytes made it checksum the whole address space (SEGV, library_image_fuzz).
TEST(HostileChunks, AChunkShorterThanItsChecksumIsRefusedBeforeHdf5ReadsIt) {
  test::TempDir dir("hostile-chunks");
  const fs::path lib = dir / "lib.h5";
  for (Compression compression : {Compression::none, Compression::deflate}) {
    write_library(lib, compression, true);
    {
      const hid_t file = H5Fopen(lib.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
      const hid_t dataset = H5Dopen2(file, "/clips/c/rotations", H5P_DEFAULT);
      const hsize_t origin[3] = {0, 0, 0};
      const std::uint8_t two[2] = {1, 2};
      EXPECT_GE(H5Dwrite_chunk(dataset, H5P_DEFAULT, 0, origin, 2, two), 0);
      H5Dclose(dataset);
      H5Fclose(file);
    }
    const std::string error = read_error(lib);
    // Unfiltered but for the checksum, a chunk has one right size; compressed, at least 4.
    EXPECT_NE(error.find(compression == Compression::none
                             ? "stores 2 bytes where a chunk of it holds 100"
                             : "stores 2 bytes, fewer than its Fletcher-32 checksum's 4"),
              std::string::npos)
        << error;
  }
}

// An unfiltered chunk is stored whole; HDF5 copies a whole chunk out of what it read, whatever
// the index says was stored (a heap-buffer-overflow, library_image_fuzz: a single-chunk index
// whose storage size was short, which the API cannot write). Checksummed only, the index records
// each chunk's size, and a short one is refused before HDF5 reads it. (Without any filter HDF5
// records no size: a chunk is whole by definition.)
TEST(HostileChunks, AnUnfilteredChunkStoredShortIsRefusedBeforeHdf5ReadsIt) {
  test::TempDir dir("hostile-chunks");
  const fs::path lib = dir / "lib.h5";
  const std::size_t whole = kFrames * kJoints * 4 * 4 + 4;  // the clip in one chunk, checksummed
  write_library(lib, Compression::none, true);
  {
    const hid_t file = H5Fopen(lib.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t dataset = H5Dopen2(file, "/clips/c/rotations", H5P_DEFAULT);
    const hsize_t origin[3] = {0, 0, 0};
    const std::vector<std::uint8_t> half(whole / 2, 0);
    EXPECT_GE(H5Dwrite_chunk(dataset, H5P_DEFAULT, 0, origin, half.size(), half.data()), 0);
    H5Dclose(dataset);
    H5Fclose(file);
  }
  const std::string error = read_error(lib);
  EXPECT_NE(error.find("stores " + std::to_string(whole / 2) + " bytes where a chunk of it holds " +
                       std::to_string(whole)),
            std::string::npos)
      << error;
}

// The LZ4 plugin allocates the size a chunk's header states and decodes with
// LZ4_decompress_fast, which trusts the block; the reader decodes each chunk safely first.
TEST(HostileChunks, AnLz4ChunkThatLiesIsRefusedBeforeThePluginDecodesIt) {
  if (!compression_available(Compression::lz4)) GTEST_SKIP() << "no LZ4 plugin";
  test::TempDir dir("hostile-chunks");
  const fs::path lib = dir / "lib.h5";
  const std::uint64_t raw = kFrames * kJoints * 4 * 4;  // one chunk holds the clip
  auto header = [](std::uint64_t size, std::uint32_t block) {
    std::vector<std::uint8_t> out;
    for (int i = 7; i >= 0; --i) out.push_back(std::uint8_t(size >> (8 * i)));
    for (int i = 3; i >= 0; --i) out.push_back(std::uint8_t(block >> (8 * i)));
    return out;
  };
  // A header claiming 1 TiB; then the right size with a block whose stored length is not its
  // size (so LZ4-compressed) but whose bytes are no LZ4 block.
  std::vector<std::uint8_t> huge = header(std::uint64_t(1) << 40, 1u << 30);
  for (std::uint8_t b : {0, 0, 0, 4, 0xff, 0xff, 0xff, 0xff}) huge.push_back(b);
  std::vector<std::uint8_t> broken = header(raw, std::uint32_t(raw));
  for (std::uint8_t b : {0, 0, 0, 8, 0xf0, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff})
    broken.push_back(b);
  for (const auto& chunk : {huge, broken}) {
    write_library(lib, Compression::lz4);
    const hid_t file = H5Fopen(lib.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t dataset = H5Dopen2(file, "/clips/c/rotations", H5P_DEFAULT);
    const hsize_t origin[3] = {0, 0, 0};
    EXPECT_GE(H5Dwrite_chunk(dataset, H5P_DEFAULT, 0, origin, chunk.size(), chunk.data()), 0);
    H5Dclose(dataset);
    H5Fclose(file);
    const std::string error = read_error(lib);
    EXPECT_NE(error.find("'rotations' chunk at frame 0 is not a valid LZ4 chunk of 96 bytes"),
              std::string::npos)
        << error;
  }
}

// A chunk's filter mask is stored per chunk and may skip any filter; libhdf5 1.10 copies what
// the filters left into the dataset without comparing its size with a chunk's (a heap-buffer-
// overflow in H5VM_memcpyvv, library_image_fuzz: a mask of 0xfe on a 26-byte deflate chunk, so
// only the shuffle ran). The reader runs each chunk through the filters its mask leaves first.
TEST(HostileChunks, AChunkWhoseMaskSkipsItsCompressionMustStillHoldAWholeChunk) {
  test::TempDir dir("hostile-chunks");
  const fs::path lib = dir / "lib.h5";
  const Clip clip = make_clip();
  const auto* raw = reinterpret_cast<const std::uint8_t*>(clip.rotations.data());
  const std::size_t raw_bytes = clip.rotations.size() * sizeof(float);  // one chunk, 96 bytes
  // Filters [shuffle, deflate, Fletcher-32]: a chunk written with deflate skipped (mask bit 1),
  // as HDF5 does when deflate saves nothing, holds the shuffled chunk and its checksum.
  std::vector<std::uint8_t> shuffled(raw_bytes);
  shuffle_bytes({raw, raw_bytes}, sizeof(float), shuffled);
  std::vector<std::uint8_t> whole = shuffled;
  const std::uint32_t sum = fletcher32(whole);
  for (int i = 0; i < 4; ++i) whole.push_back(std::uint8_t(sum >> (8 * i)));
  // Then the fuzzed case, a short chunk with every filter but the shuffle skipped; and a
  // deflate stream of half a chunk under the checksum.
  const std::vector<std::uint8_t> short_chunk(26, 7);
  std::vector<std::uint8_t> half_stream;
  ASSERT_TRUE(deflate_encode({raw, raw_bytes / 2}, 4, half_stream));
  const std::uint32_t half_sum = fletcher32(half_stream);
  for (int i = 0; i < 4; ++i) half_stream.push_back(std::uint8_t(half_sum >> (8 * i)));
  struct Case {
    std::uint32_t mask;
    const std::vector<std::uint8_t>* stored;
    std::string error;  // "" when the clip must read back exactly
  };
  for (const Case& c : {Case{2u, &whole, ""},
                        Case{0xfeu, &short_chunk, "decodes to 26 bytes, not the 96 of a chunk"},
                        Case{0u, &half_stream, "is not a valid deflate chunk of 96 bytes"}}) {
    SCOPED_TRACE(c.mask);
    write_library(lib, Compression::deflate, true);
    {
      const hid_t file = H5Fopen(lib.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
      const hid_t dataset = H5Dopen2(file, "/clips/c/rotations", H5P_DEFAULT);
      const hsize_t origin[3] = {0, 0, 0};
      EXPECT_GE(
          H5Dwrite_chunk(dataset, H5P_DEFAULT, c.mask, origin, c.stored->size(), c.stored->data()),
          0);
      H5Dclose(dataset);
      H5Fclose(file);
    }
    if (c.error.empty()) {
      std::string error;
      const auto reader = LibraryReader::open(lib, &error);
      ASSERT_TRUE(reader) << error;
      const auto read = reader->read_clip("c", &error);
      ASSERT_TRUE(read) << error;
      EXPECT_EQ(read->rotations, clip.rotations);
      continue;
    }
    const std::string error = read_error(lib);
    EXPECT_NE(error.find("its 'rotations' chunk at frame 0 " + c.error), std::string::npos)
        << error;
  }
}

}  // namespace
}  // namespace mocap::io
