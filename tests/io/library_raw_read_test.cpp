// Issue 15, parallel I/O: a library clip read as its stored chunks (H5Dread_chunk, the serial
// half) and decoded without HDF5 (decode_chunk, the parallel half) must give exactly what HDF5's
// own filters give (H5Dread), for every pipeline the store writes, for layouts other tools
// write (h5py's chunks of 1024 frames), and for those it leaves to HDF5 (float64, chunks that
// split the joints); damaged chunks are refused with the file and the clip named.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <thread>
#include <vector>

#include "io/chunk_codec.hpp"
#include "io/library_store.hpp"
#include "tests/test_support.hpp"

namespace mocap::io {
namespace {

namespace fs = std::filesystem;

std::shared_ptr<const Skeleton> make_skeleton(int joints) {
  auto s = std::make_shared<Skeleton>();
  for (int j = 0; j < joints; ++j) {
    s->joint_names.push_back(j == 0 ? "Hips" : "J" + std::to_string(j));
    s->parents.push_back(j - 1);
    s->offsets.push_back({0.0, 1.0 + j, 0.5});
    if (j == 0)
      s->channels.push_back({Channel::Xposition, Channel::Yposition, Channel::Zposition,
                             Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    else
      s->channels.push_back({Channel::Zrotation, Channel::Xrotation, Channel::Yrotation});
    s->end_sites.push_back(std::nullopt);
  }
  return s;
}

Clip make_clip(int joints, int frames, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Clip clip;
  clip.skeleton = make_skeleton(joints);
  clip.frame_time = 1.0 / 120;
  clip.frames = frames;
  clip.source = "take.bvh";
  clip.rotations = test::random_motion(rng, frames, joints, 0.8);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < joints; ++j)
      for (float v : {j == 0 ? 0.1f * float(t) + noise(rng) : 0.0f, float(1 + j), 0.5f})
        clip.translations.push_back(v);
  return clip;
}

// A dataset as HDF5 itself decodes it (H5Dread through its filters, the LZ4 plugin's too).
std::vector<float> hdf5_read(const fs::path& path, const std::string& dataset) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t set = H5Dopen2(file, dataset.c_str(), H5P_DEFAULT);
  const hid_t space = H5Dget_space(set);
  std::vector<float> out(std::size_t(H5Sget_simple_extent_npoints(space)));
  EXPECT_GE(H5Dread(set, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), 0);
  H5Sclose(space);
  H5Dclose(set);
  H5Fclose(file);
  return out;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

// Reads `clip_path` in two halves; expects the chunks path (not HDF5's) when `raw`, and the
// values HDF5 decodes, bit for bit.
void expect_reads_as_hdf5(const fs::path& path, const std::string& clip_path, bool raw) {
  SCOPED_TRACE(path.string() + " " + clip_path);
  std::string error;
  const auto reader = LibraryReader::open(path, &error);
  ASSERT_TRUE(reader) << error;
  auto stored = reader->read_stored(clip_path, &error);
  ASSERT_TRUE(stored) << error;
  EXPECT_EQ(!stored->decoded.has_value(), raw);
  if (raw) {
    EXPECT_EQ(stored->chunks.stored_bytes() > 0, stored->chunks.frames > 0);
    EXPECT_NE(stored->where.find(path.string()), std::string::npos);
    EXPECT_NE(stored->where.find("clip '" + clip_path + "'"), std::string::npos);
  }
  const auto clip = LibraryReader::decode_stored(*stored, &error);
  ASSERT_TRUE(clip) << error;
  EXPECT_TRUE(same_bits(clip->rotations, hdf5_read(path, "/clips/" + clip_path + "/rotations")));
  EXPECT_TRUE(
      same_bits(clip->translations, hdf5_read(path, "/clips/" + clip_path + "/translations")));
  const auto whole = reader->read_clip(clip_path, &error);
  ASSERT_TRUE(whole) << error;
  EXPECT_TRUE(same_bits(whole->rotations, clip->rotations));
  EXPECT_TRUE(same_bits(whole->translations, clip->translations));
  EXPECT_EQ(whole->frames, clip->frames);
  EXPECT_EQ(whole->source, clip->source);
}

TEST(ChunkCodec, UnshuffleUndoesShuffle) {
  std::mt19937_64 rng(3);
  for (std::size_t element : {1u, 2u, 4u, 8u})
    for (std::size_t size : {0u, 3u, 4u, 7u, 96u, 4099u}) {
      std::vector<std::uint8_t> in(size), shuffled(size), back(size);
      for (auto& b : in) b = std::uint8_t(rng());
      shuffle_bytes(in, element, shuffled);
      unshuffle_bytes(shuffled, element, back);
      EXPECT_EQ(back, in) << element << " " << size;
    }
}

TEST(ChunkCodec, ShuffleSendsByteBOfElementIToPlaneB) {
  std::mt19937_64 rng(5);
  for (std::size_t element : {1u, 2u, 3u, 4u, 8u})
    for (std::size_t size : {0u, 1u, 4u, 5u, 63u, 64u, 65u, 4099u, 126976u}) {
      std::vector<std::uint8_t> in(size), out(size);
      for (auto& b : in) b = std::uint8_t(rng());
      shuffle_bytes(in, element, out);
      const std::size_t n = in.size() / element, whole = n * element;
      bool same = true;
      for (std::size_t i = 0; i < whole; ++i) {
        const std::size_t plane = n > 1 ? i % element : 0, index = n > 1 ? i / element : i;
        same = same && out[plane * n + index] == in[i];
      }
      for (std::size_t i = whole; i < size; ++i) same = same && out[i] == in[i];
      EXPECT_TRUE(same) << element << " " << size;
    }
}

// The fast checksum against HDF5's loop: random bytes of every length near the lanes' and the
// blocks' edges, all zeros (0, not 65535), all ones (the sums' largest words), and lengths
// where a half is a multiple of 65535.
TEST(ChunkCodec, Fletcher32MatchesHdf5sLoop) {
  std::mt19937_64 rng(6);
  std::vector<std::size_t> sizes;
  for (std::size_t s = 0; s < 80; ++s) sizes.push_back(s);
  for (std::size_t edge : {512u, 8192u, 8192u * 3, 126976u * 4})
    for (std::size_t d = 0; d < 5; ++d) sizes.insert(sizes.end(), {edge - d, edge + d});
  for (std::size_t size : sizes)
    for (int pattern = 0; pattern < 4; ++pattern) {
      std::vector<std::uint8_t> bytes(size);
      for (auto& b : bytes)
        b = pattern == 0   ? 0
            : pattern == 1 ? 0xff
            : pattern == 2 ? std::uint8_t(rng())
                           : std::uint8_t(rng() % 3);
      ASSERT_EQ(fletcher32(bytes), fletcher32_reference(bytes)) << size << " " << pattern;
    }
  // 65535 words of 1: S1 = 65535 exactly (the reference keeps 65535, not 0).
  std::vector<std::uint8_t> ones(2 * 65535);
  for (std::size_t i = 1; i < ones.size(); i += 2) ones[i] = 1;
  EXPECT_EQ(fletcher32(ones) & 0xffff, 65535u);
  EXPECT_EQ(fletcher32(ones), fletcher32_reference(ones));
}

// What a writer reserves holds any chunk, and little more: random bytes (LZ4 and deflate save
// nothing), zeros (they save most), a tiny chunk.
TEST(ChunkCodec, EncodedChunksStayWithinTheirBound) {
  std::mt19937_64 rng(7);
  for (std::size_t size : {4u, 64u, 4096u, 126976u * 4})
    for (bool random : {false, true}) {
      std::vector<std::uint8_t> raw(size);
      if (random)
        for (auto& b : raw) b = std::uint8_t(rng());
      for (Compression compression : {Compression::none, Compression::lz4, Compression::deflate})
        for (bool checksum : {false, true}) {
          std::vector<std::uint8_t> stored, scratch;
          ASSERT_TRUE(encode_chunk(raw, compression, checksum, stored, scratch));
          EXPECT_LE(stored.size(), encoded_chunk_bound(size, compression, checksum))
              << size << " " << random << " " << to_string(compression) << " " << checksum;
          // and reserves little more than the chunk itself
          EXPECT_LE(encoded_chunk_bound(size, compression, checksum), size + size / 200 + 40);
        }
    }
}

TEST(ChunkCodec, DecodeChunkUndoesEncodeChunk) {
  std::mt19937_64 rng(4);
  std::vector<float> values(3 * 31 * 4 * 50);
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (float& v : values) v = n(rng);
  const std::span<const std::uint8_t> raw(reinterpret_cast<const std::uint8_t*>(values.data()),
                                          values.size() * sizeof(float));
  for (Compression compression : {Compression::none, Compression::lz4, Compression::deflate})
    for (bool checksum : {false, true}) {
      SCOPED_TRACE(std::string(to_string(compression)) + (checksum ? " checksum" : ""));
      std::vector<std::uint8_t> stored, scratch, back(raw.size());
      ASSERT_TRUE(encode_chunk(raw, compression, checksum, stored, scratch));
      EXPECT_EQ(decode_chunk(stored, compression, checksum, back, scratch), "");
      EXPECT_TRUE(std::equal(back.begin(), back.end(), raw.begin()));
      // A chunk of another size than the dataset's is damage, not a shorter chunk.
      std::vector<std::uint8_t> longer(raw.size() + 4);
      EXPECT_NE(decode_chunk(stored, compression, checksum, longer, scratch), "");
      stored[stored.size() / 2] ^= 0x5a;
      const std::string problem = decode_chunk(stored, compression, checksum, back, scratch);
      // Without a checksum a flip in literal bytes decodes to other values: what it is for.
      if (checksum) {
        EXPECT_EQ(problem, "fails its Fletcher32 checksum (the file is damaged)");
      }
    }
}

// HDF5's Fletcher-32 filter also accepts the checksum with each 16-bit half byte-swapped (what
// releases before 1.6.3 wrote); a file HDF5 reads must read here too.
TEST(ChunkCodec, TheReversedFletcherChecksumReadsAsInHdf5) {
  test::TempDir dir("raw-read");
  const fs::path path = dir / "lib.h5";
  std::string error;
  auto writer = LibraryWriter::create(path, Compression::none, &error, true);
  ASSERT_TRUE(writer) << error;
  ASSERT_TRUE(writer->write_clip("c", make_clip(3, 20, 1), &error)) << error;
  ASSERT_TRUE(writer->close(&error)) << error;
  {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t set = H5Dopen2(file, "/clips/c/rotations", H5P_DEFAULT);
    const hsize_t origin[3] = {0, 0, 0};
    hsize_t size = 0;
    ASSERT_GE(H5Dget_chunk_storage_size(set, origin, &size), 0);
    std::vector<std::uint8_t> chunk(size);
    std::uint32_t mask = 0;
    ASSERT_GE(H5Dread_chunk(set, H5P_DEFAULT, origin, &mask, chunk.data()), 0);
    std::swap(chunk[size - 4], chunk[size - 3]);
    std::swap(chunk[size - 2], chunk[size - 1]);
    // The swap changed the stored checksum.
    ASSERT_TRUE(chunk[size - 4] != chunk[size - 3] || chunk[size - 2] != chunk[size - 1]);
    ASSERT_GE(H5Dwrite_chunk(set, H5P_DEFAULT, 0, origin, size, chunk.data()), 0);
    H5Dclose(set);
    H5Fclose(file);
  }
  expect_reads_as_hdf5(path, "c", true);
}

// Every pipeline the store writes, through HDF5's filters (write_clip) and the store's own
// encoder (write_encoded): many chunks, the last one padded.
TEST(LibraryRawRead, EveryStorePipelineDecodesAsHdf5Does) {
  test::TempDir dir("raw-read");
  const std::vector<std::pair<std::string, Clip>> clips = {{"long", make_clip(31, 2345, 1)},
                                                           {"short", make_clip(5, 3, 2)},
                                                           {"empty", make_clip(4, 0, 3)}};
  for (Compression compression : {Compression::none, Compression::lz4, Compression::deflate})
    for (bool checksum : {false, true}) {
      if (!compression_available(compression)) continue;
      const fs::path path =
          dir / (std::string(to_string(compression)) + (checksum ? "-fletcher" : "") + ".h5");
      std::string error;
      auto writer = LibraryWriter::create(path, compression, &error, checksum);
      ASSERT_TRUE(writer) << error;
      for (const auto& [name, clip] : clips) {
        ASSERT_TRUE(writer->write_clip("plain/" + name, clip, &error)) << error;
        const auto encoded = encode_clip(clip, compression, &error, checksum);
        ASSERT_TRUE(encoded) << error;
        ASSERT_TRUE(writer->write_encoded("encoded/" + name, *encoded, &error)) << error;
      }
      ASSERT_TRUE(writer->close(&error)) << error;
      for (const auto& [name, clip] : clips)
        for (const std::string folder : {"plain/", "encoded/"}) {
          expect_reads_as_hdf5(path, folder + name, true);
          const auto reader = LibraryReader::open(path, &error);
          const auto read = reader->read_clip(folder + name, &error);
          ASSERT_TRUE(read) << error;
          EXPECT_TRUE(same_bits(read->rotations, clip.rotations));
          EXPECT_TRUE(same_bits(read->translations, clip.translations));
        }
    }
}

// Replaces a clip's dataset with one of `file_type`, chunks `chunk` and no filters, holding
// `values` (floats).
void rewrite(const fs::path& path, const std::string& dataset, hid_t file_type,
             std::vector<hsize_t> dims, std::vector<hsize_t> chunk,
             const std::vector<float>& values) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(H5Ldelete(file, dataset.c_str(), H5P_DEFAULT), 0);
  // Extendible in frames, as HDF5 then allows a chunk longer than the clip.
  const hsize_t most[3] = {H5S_UNLIMITED, dims[1], dims[2]};
  const hid_t space = H5Screate_simple(3, dims.data(), most);
  const hid_t properties = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(properties, 3, chunk.data());
  const hid_t set =
      H5Dcreate2(file, dataset.c_str(), file_type, space, H5P_DEFAULT, properties, H5P_DEFAULT);
  ASSERT_GE(set, 0);
  EXPECT_GE(H5Dwrite(set, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0);
  H5Dclose(set);
  H5Pclose(properties);
  H5Sclose(space);
  H5Fclose(file);
}

// What bench/replicate_library.py (h5py) writes: unfiltered chunks of up to 1024 frames, the
// last one padded, and a chunk longer than a short clip. Read as chunks.
TEST(LibraryRawRead, OtherToolsChunksOfWholeFramesAreDecodedToo) {
  test::TempDir dir("raw-read");
  const fs::path path = dir / "h5py.h5";
  const Clip clip = make_clip(31, 2500, 5), small = make_clip(31, 10, 6);
  std::string error;
  auto writer = LibraryWriter::create(path, Compression::none, &error, false);
  ASSERT_TRUE(writer) << error;
  ASSERT_TRUE(writer->write_clip("c", clip, &error)) << error;
  ASSERT_TRUE(writer->write_clip("small", small, &error)) << error;
  ASSERT_TRUE(writer->close(&error)) << error;
  rewrite(path, "/clips/c/rotations", H5T_IEEE_F32LE, {2500, 31, 4}, {1024, 31, 4}, clip.rotations);
  rewrite(path, "/clips/c/translations", H5T_IEEE_F32LE, {2500, 31, 3}, {1024, 31, 3},
          clip.translations);
  rewrite(path, "/clips/small/rotations", H5T_IEEE_F32LE, {10, 31, 4}, {1024, 31, 4},
          small.rotations);
  rewrite(path, "/clips/small/translations", H5T_IEEE_F32LE, {10, 31, 3}, {1024, 31, 3},
          small.translations);
  expect_reads_as_hdf5(path, "c", true);
  expect_reads_as_hdf5(path, "small", true);
  const auto reader = LibraryReader::open(path, &error);
  const auto read = reader->read_clip("c", &error);
  ASSERT_TRUE(read) << error;
  EXPECT_TRUE(same_bits(read->rotations, clip.rotations));
}

// Layouts whose raw bytes are not the clip's floats in order are left to HDF5 (its type
// conversion, its chunk assembly), with the same values as before.
TEST(LibraryRawRead, OtherLayoutsAreDecodedByHdf5) {
  test::TempDir dir("raw-read");
  const fs::path path = dir / "other.h5";
  const Clip clip = make_clip(7, 300, 8);
  std::string error;
  auto writer = LibraryWriter::create(path, Compression::deflate, &error, true);
  ASSERT_TRUE(writer) << error;
  ASSERT_TRUE(writer->write_clip("f64", clip, &error)) << error;
  ASSERT_TRUE(writer->write_clip("split", clip, &error)) << error;
  ASSERT_TRUE(writer->close(&error)) << error;
  rewrite(path, "/clips/f64/rotations", H5T_IEEE_F64LE, {300, 7, 4}, {64, 7, 4}, clip.rotations);
  rewrite(path, "/clips/split/translations", H5T_IEEE_F32LE, {300, 7, 3}, {64, 2, 3},
          clip.translations);
  expect_reads_as_hdf5(path, "f64", false);
  expect_reads_as_hdf5(path, "split", false);
}

// decode_stored() touches no HDF5 and no reader: clips read in order decode on several threads
// at once into the same values.
TEST(LibraryRawRead, StoredClipsDecodeOnManyThreadsAtOnce) {
  test::TempDir dir("raw-read");
  const fs::path path = dir / "lib.h5";
  std::string error;
  auto writer = LibraryWriter::create(path, Compression::deflate, &error, true);
  ASSERT_TRUE(writer) << error;
  std::vector<Clip> clips;
  for (int i = 0; i < 8; ++i) {
    clips.push_back(make_clip(31, 400 + 97 * i, 20 + std::uint64_t(i)));
    ASSERT_TRUE(writer->write_clip("c" + std::to_string(i), clips.back(), &error)) << error;
  }
  ASSERT_TRUE(writer->close(&error)) << error;
  const auto reader = LibraryReader::open(path, &error);
  ASSERT_TRUE(reader) << error;
  std::vector<StoredClip> stored;
  for (int i = 0; i < 8; ++i) {
    auto s = reader->read_stored("c" + std::to_string(i), &error);
    ASSERT_TRUE(s) << error;
    stored.push_back(std::move(*s));
  }
  std::vector<std::optional<Clip>> decoded(8);
  std::vector<std::thread> threads;
  for (int i = 0; i < 8; ++i)
    threads.emplace_back([&, i] {
      std::string problem;
      decoded[std::size_t(i)] = LibraryReader::decode_stored(stored[std::size_t(i)], &problem);
    });
  for (auto& t : threads) t.join();
  for (int i = 0; i < 8; ++i) {
    ASSERT_TRUE(decoded[std::size_t(i)]) << i;
    EXPECT_TRUE(same_bits(decoded[std::size_t(i)]->rotations, clips[std::size_t(i)].rotations));
    EXPECT_TRUE(
        same_bits(decoded[std::size_t(i)]->translations, clips[std::size_t(i)].translations));
  }
}

// A run recycles the chunk buffers of decoded clips into the next reads: a shorter clip read
// into a longer clip's buffers, and back, reads as it does into fresh ones.
TEST(LibraryRawRead, RecycledBuffersReadLikeFreshOnes) {
  if (!compression_available(Compression::lz4)) GTEST_SKIP() << "no LZ4 plugin";
  test::TempDir dir("raw-read");
  const fs::path path = dir / "lib.h5";
  std::string error;
  auto writer = LibraryWriter::create(path, Compression::lz4, &error, true);
  ASSERT_TRUE(writer) << error;
  const std::vector<Clip> clips = {make_clip(31, 2000, 30), make_clip(31, 50, 31),
                                   make_clip(31, 1500, 32)};
  for (std::size_t i = 0; i < clips.size(); ++i)
    ASSERT_TRUE(writer->write_clip("c" + std::to_string(i), clips[i], &error)) << error;
  ASSERT_TRUE(writer->close(&error)) << error;
  const auto reader = LibraryReader::open(path, &error);
  ASSERT_TRUE(reader) << error;
  StoredClip recycled;
  for (std::size_t i = 0; i < clips.size(); ++i) {
    auto stored = reader->read_stored("c" + std::to_string(i), &error, std::move(recycled));
    ASSERT_TRUE(stored) << error;
    const auto clip = LibraryReader::decode_stored(*stored, &error);
    ASSERT_TRUE(clip) << error;
    EXPECT_TRUE(same_bits(clip->rotations, clips[i].rotations)) << i;
    EXPECT_TRUE(same_bits(clip->translations, clips[i].translations)) << i;
    recycled = std::move(*stored);
  }
}

// A flipped byte in a stored chunk: read_stored() takes it as it is (no decoding in the serial
// half), decode_stored() refuses it naming the file, the clip, the dataset and the frame.
TEST(LibraryRawRead, ADamagedChunkIsNamedWhenDecoded) {
  test::TempDir dir("raw-read");
  const fs::path path = dir / "lib.h5";
  const Clip clip = make_clip(31, 1000, 9);
  for (Compression compression : {Compression::none, Compression::deflate}) {
    std::string error;
    auto writer = LibraryWriter::create(path, compression, &error, true);
    ASSERT_TRUE(writer) << error;
    ASSERT_TRUE(writer->write_clip("a/victim", clip, &error)) << error;
    ASSERT_TRUE(writer->close(&error)) << error;
    {
      const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
      const hid_t set = H5Dopen2(file, "/clips/a/victim/rotations", H5P_DEFAULT);
      const hid_t properties = H5Dget_create_plist(set);
      hsize_t chunk[3];
      H5Pget_chunk(properties, 3, chunk);
      ASSERT_LT(chunk[0], 1000u);
      const hsize_t second[3] = {chunk[0], 0, 0};
      hsize_t size = 0;
      ASSERT_GE(H5Dget_chunk_storage_size(set, second, &size), 0);
      std::vector<std::uint8_t> bytes(size);
      std::uint32_t mask = 0;
      ASSERT_GE(H5Dread_chunk(set, H5P_DEFAULT, second, &mask, bytes.data()), 0);
      bytes[size / 3] ^= 0xff;
      ASSERT_GE(H5Dwrite_chunk(set, H5P_DEFAULT, 0, second, size, bytes.data()), 0);
      H5Pclose(properties);
      H5Dclose(set);
      H5Fclose(file);
      const auto reader = LibraryReader::open(path, &error);
      ASSERT_TRUE(reader) << error;
      auto stored = reader->read_stored("a/victim", &error);
      ASSERT_TRUE(stored) << error;
      EXPECT_FALSE(LibraryReader::decode_stored(*stored, &error));
      EXPECT_EQ(error, path.string() + ": clip 'a/victim': its 'rotations' chunk at frame " +
                           std::to_string(chunk[0]) +
                           " fails its Fletcher32 checksum (the file is damaged)");
    }
  }
}

}  // namespace
}  // namespace mocap::io
