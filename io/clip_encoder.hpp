#pragma once
// A clip compressed off the writer thread: the chunks of its two datasets exactly as HDF5 would
// store them, ready for LibraryWriter::write_encoded (which hands them to H5Dwrite_chunk).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/clip.hpp"
#include "io/compression.hpp"

namespace mocap::io {

// One [frames][joints][channels] float32 dataset, chunked every chunk_frames frames (the last
// chunk zero-padded to full size, as HDF5 stores it), each chunk filtered.
struct EncodedDataset {
  int frames = 0, joints = 0, channels = 0;
  int chunk_frames = 1;
  std::vector<std::uint8_t> bytes;      // the stored chunks, back to back
  std::vector<std::size_t> chunk_ends;  // chunk k is bytes [chunk_ends[k-1], chunk_ends[k])

  std::size_t chunk_count() const { return chunk_ends.size(); }
  std::span<const std::uint8_t> chunk(std::size_t k) const {
    const std::size_t begin = k == 0 ? 0 : chunk_ends[k - 1];
    return {bytes.data() + begin, chunk_ends[k] - begin};
  }
};

struct EncodedClip {
  Compression compression = Compression::none;
  bool checksum = true;  // each chunk ends with its Fletcher-32 checksum
  std::shared_ptr<const Skeleton> skeleton;
  double frame_time = 0;
  int frames = 0;
  std::string source;
  ClipProvenance provenance;
  EncodedDataset rotations, translations;

  std::size_t stored_bytes() const { return rotations.bytes.size() + translations.bytes.size(); }
};

// Pure CPU and thread-safe (no HDF5 call): run it on any thread. Nullopt, with the reason in
// *error, when check_clip() rejects the clip or a compressor fails.
std::optional<EncodedClip> encode_clip(const Clip& clip, Compression compression,
                                       std::string* error, bool checksum = true);

}  // namespace mocap::io
