#include "io/clip_encoder.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

#include "io/chunk_codec.hpp"
#include "io/library_format.hpp"

namespace mocap::io {

// The file type of the datasets is little-endian float32; the encoder copies memory as it is.
static_assert(std::endian::native == std::endian::little,
              "encode_clip assumes a little-endian host");

namespace {

bool encode_dataset(const std::vector<float>& values, int frames, int joints, int channels,
                    Compression compression, bool checksum, EncodedDataset& out) {
  out.frames = frames;
  out.joints = joints;
  out.channels = channels;
  const std::size_t floats_per_frame = std::size_t(joints) * std::size_t(channels);
  out.chunk_frames = chunk_frames(frames, floats_per_frame * sizeof(float));
  const std::size_t chunk_floats = std::size_t(out.chunk_frames) * floats_per_frame;
  const std::size_t chunks =
      (std::size_t(frames) + std::size_t(out.chunk_frames) - 1) / std::size_t(out.chunk_frames);
  out.bytes.clear();
  out.chunk_ends.clear();
  out.chunk_ends.reserve(chunks);
  // Room for every chunk at once: grown by doubling, the buffer was copied over and over
  // (a profile's memmove inside lz4_filter_encode).
  out.bytes.reserve(chunks *
                    encoded_chunk_bound(chunk_floats * sizeof(float), compression, checksum));
  std::vector<float> padded;  // the last chunk, zero-filled past the clip's end
  std::vector<std::uint8_t> scratch;
  for (std::size_t k = 0; k < chunks; ++k) {
    const std::size_t begin = k * chunk_floats;
    const std::size_t length = std::min(chunk_floats, values.size() - begin);
    const float* chunk = values.data() + begin;
    if (length < chunk_floats) {
      padded.assign(chunk_floats, 0.0f);
      std::copy_n(chunk, length, padded.begin());
      chunk = padded.data();
    }
    const std::span<const std::uint8_t> raw(reinterpret_cast<const std::uint8_t*>(chunk),
                                            chunk_floats * sizeof(float));
    if (!encode_chunk(raw, compression, checksum, out.bytes, scratch)) return false;
    out.chunk_ends.push_back(out.bytes.size());
  }
  return true;
}

}  // namespace

std::optional<EncodedClip> encode_clip(const Clip& clip, Compression compression,
                                       std::string* error, bool checksum) {
  if (std::string problem = check_clip(clip); !problem.empty()) {
    if (error) *error = problem;
    return std::nullopt;
  }
  EncodedClip out;
  out.compression = compression;
  out.checksum = checksum;
  out.skeleton = clip.skeleton;
  out.frame_time = clip.frame_time;
  out.frames = clip.frames;
  out.source = clip.source;
  out.provenance = clip.provenance;
  if (!encode_dataset(clip.rotations, clip.frames, clip.joints(), 4, compression, checksum,
                      out.rotations) ||
      !encode_dataset(clip.translations, clip.frames, clip.joints(), 3, compression, checksum,
                      out.translations)) {
    if (error) *error = std::string(to_string(compression)) + " compression of a chunk failed";
    return std::nullopt;
  }
  return out;
}

}  // namespace mocap::io
