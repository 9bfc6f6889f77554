#pragma once
// Reads a library file (layout: io/library_format.hpp). Single-threaded like the writer: one
// reader is used from one thread at a time (it caches skeletons, and HDF5 is not thread-safe);
// only the static decode_stored() runs on any thread.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/clip.hpp"
#include "io/clip_encoder.hpp"
#include "io/library_format.hpp"

namespace mocap::io {

namespace detail {
struct LibraryReaderState;
}

// A clip between the two halves of LibraryReader::read_clip(): its chunks as the file stores
// them, or, for a layout the store's own decoder does not take, the clip HDF5 decoded.
struct StoredClip {
  std::string where;  // "<file>: clip '<path>': ", how decode_stored() starts its messages
  EncodedClip chunks;
  std::optional<Clip> decoded;  // set: HDF5 decoded it already, `chunks` is empty
};

class LibraryReader {
 public:
  // Opens `path` read-only and lists its clips. Nullptr, with a message naming the file, when it
  // is missing, not HDF5, or not a mocap-clean library of a supported format_version.
  static std::unique_ptr<LibraryReader> open(const std::filesystem::path& path, std::string* error);
  // The same for the bytes of a library file held in memory (HDF5's core driver); `name` names
  // it in messages. For tools and the fuzz target (fuzz/), which build libraries in memory.
  static std::unique_ptr<LibraryReader> open_image(std::span<const std::uint8_t> image,
                                                   const std::string& name, std::string* error);
  ~LibraryReader();
  LibraryReader(const LibraryReader&) = delete;
  LibraryReader& operator=(const LibraryReader&) = delete;

  // Every clip below /clips, sorted by path: each group holding a "rotations" or "translations"
  // dataset or a "skeleton" or "frame_time" attribute, found through hard, soft and external
  // links (how parts written by separate processes join). A clip whose header cannot be read, a
  // link that leads nowhere, an empty group or a dataset where a clip or folder should be is
  // listed with its error: nothing below /clips is skipped in silence.
  const std::vector<ClipHeader>& clips() const;
  // The clip at `clip_path`, its shapes checked against its skeleton. Skeletons are read once
  // and shared between clips. Looked up in /skeletons of this file, then of the file the clip's
  // group lives in (an external part).
  std::optional<Clip> read_clip(const std::string& clip_path, std::string* error) const;
  // read_clip() in two halves, so that a task graph keeps HDF5 in its serial stage and decodes
  // in its parallel ones: read_stored() makes every HDF5 call (the clip's header and skeleton,
  // its chunks as stored by H5Dread_chunk); decode_stored() verifies each chunk's Fletcher-32,
  // decompresses and unshuffles it (io/chunk_codec.hpp) without HDF5, on any thread. A clip laid
  // out otherwise than float32 chunks of whole frames through this store's filters is decoded
  // by HDF5 in read_stored(). read_clip(p) is decode_stored(read_stored(p)). read_stored()
  // reads into the buffers of `recycled` (a clip decode_stored() is done with), so that a run
  // does not allocate and page-fault them afresh for every clip; decode_stored() leaves
  // stored.chunks as they were for that.
  std::optional<StoredClip> read_stored(const std::string& clip_path, std::string* error,
                                        StoredClip recycled = {}) const;
  static std::optional<Clip> decode_stored(StoredClip& stored, std::string* error);
  // The clip's chunks as stored (H5Dread_chunk, each Fletcher-32 checked when the file has
  // checksums), ready for LibraryWriter::write_encoded_as_is: how the join copies clips without
  // decoding them. A clip laid out otherwise than this store writes is decoded and re-encoded.
  std::optional<EncodedClip> read_encoded(const std::string& clip_path, std::string* error) const;
  std::shared_ptr<const Skeleton> skeleton(const std::string& name, std::string* error) const;
  std::optional<Provenance> provenance() const;  // nullopt when the file has no /provenance
  const std::filesystem::path& path() const;

 private:
  explicit LibraryReader(std::unique_ptr<detail::LibraryReaderState> state);
  static std::unique_ptr<LibraryReader> open_state(
      std::unique_ptr<detail::LibraryReaderState> state, std::string* error);
  std::unique_ptr<detail::LibraryReaderState> state_;
};

}  // namespace mocap::io
