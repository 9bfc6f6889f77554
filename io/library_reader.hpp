#pragma once
// Reads a library file (layout: io/library_format.hpp). Single-threaded like the writer: one
// reader is used from one thread at a time (it caches skeletons, and HDF5 is not thread-safe).
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "io/clip.hpp"
#include "io/library_format.hpp"

namespace mocap::io {

namespace detail {
struct LibraryReaderState;
}

class LibraryReader {
 public:
  // Opens `path` read-only and lists its clips. Nullptr, with a message naming the file, when it
  // is missing, not HDF5, or not a mocap-clean library of a supported format_version.
  static std::unique_ptr<LibraryReader> open(const std::filesystem::path& path, std::string* error);
  ~LibraryReader();
  LibraryReader(const LibraryReader&) = delete;
  LibraryReader& operator=(const LibraryReader&) = delete;

  // Every clip below /clips, sorted by path: each group holding a "rotations" dataset, found
  // through hard, soft and external links (how parts written by separate processes join). A
  // clip whose header cannot be read, or a link that leads nowhere, is listed with its error.
  const std::vector<ClipHeader>& clips() const;
  // The clip at `clip_path`, its shapes checked against its skeleton. Skeletons are read once
  // and shared between clips. Looked up in /skeletons of this file, then of the file the clip's
  // group lives in (an external part).
  std::optional<Clip> read_clip(const std::string& clip_path, std::string* error) const;
  std::shared_ptr<const Skeleton> skeleton(const std::string& name, std::string* error) const;
  std::optional<Provenance> provenance() const;  // nullopt when the file has no /provenance
  const std::filesystem::path& path() const;

 private:
  explicit LibraryReader(std::unique_ptr<detail::LibraryReaderState> state);
  std::unique_ptr<detail::LibraryReaderState> state_;
};

}  // namespace mocap::io
