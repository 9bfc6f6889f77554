#pragma once
// Writes a library file (layout: io/library_format.hpp). Single-threaded: HDF5 here is not
// thread-safe, so the engine calls one writer from one thread at a time; compression can still
// run in parallel beforehand with encode_clip() and write_encoded().
#include <filesystem>
#include <memory>
#include <string>

#include "core/clip.hpp"
#include "io/clip_encoder.hpp"
#include "io/compression.hpp"
#include "io/library_format.hpp"

namespace mocap::io {

namespace detail {
struct LibraryWriterState;
}

class LibraryWriter {
 public:
  // Creates (truncates) `path` with the root attributes and empty /skeletons and /clips.
  // Nullptr, with a message naming the file, when it cannot be created or `compression` is
  // unavailable (lz4 without its plugin). With `checksum`, every chunk of the motion datasets
  // carries HDF5's Fletcher-32 checksum, verified by HDF5 on every read.
  static std::unique_ptr<LibraryWriter> create(const std::filesystem::path& path,
                                               Compression compression, std::string* error,
                                               bool checksum = true);
  ~LibraryWriter();  // closes if close() was not called; errors are then lost
  LibraryWriter(const LibraryWriter&) = delete;
  LibraryWriter& operator=(const LibraryWriter&) = delete;

  // Writes the clip as /clips/<clip_path> (intermediate groups created) through HDF5's filters,
  // and its skeleton if the file does not hold it yet. Whole or not at all: on any failure what
  // this call created is unlinked again. Fails if the clip exists already or a parent of the
  // path is a clip.
  bool write_clip(const std::string& clip_path, const Clip& clip, std::string* error);
  // The same for a clip compressed by encode_clip() with this writer's compression: its chunks go
  // to the file as they are (H5Dwrite_chunk). The file's bytes equal write_clip()'s.
  bool write_encoded(const std::string& clip_path, const EncodedClip& clip, std::string* error);
  // The same with the clip's own compression and checksum, whatever this file's: how the join
  // copies the chunks of parts (LibraryReader::read_encoded) without decoding them.
  bool write_encoded_as_is(const std::string& clip_path, const EncodedClip& clip,
                           std::string* error);
  // Writes (or replaces) the /provenance attributes; an empty `created` becomes the time now.
  bool write_provenance(const Provenance& provenance, std::string* error);
  // Flushes and closes the file; later writes fail. Returns false if the final writes failed.
  bool close(std::string* error);

  Compression compression() const;
  bool checksum() const;
  const std::filesystem::path& path() const;

 private:
  explicit LibraryWriter(std::unique_ptr<detail::LibraryWriterState> state);
  std::unique_ptr<detail::LibraryWriterState> state_;
};

}  // namespace mocap::io
