#pragma once
// Where a job's clips come from: BVH files, or the clips of a library file. Read from the
// graph's serial reader stage only.
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "core/clip.hpp"
#include "engine/run/sources.hpp"
#include "io/library_reader.hpp"

namespace mocap::engine {

class ClipSource {
 public:
  virtual ~ClipSource() = default;
  virtual std::size_t count() const = 0;
  // How the clip is named in messages and summaries.
  virtual std::string name(std::size_t index) const = 0;
  // Its path inside a library file ("cmu/01/01_01").
  virtual std::string clip_path(std::size_t index) const = 0;
  // Its path as a BVH file below an output folder ("cmu/01/01_01.bvh").
  virtual std::string relative_path(std::size_t index) const = 0;
  // Frames x joints when known before reading (for cost-balanced splits), else 0.
  virtual std::size_t cost(std::size_t index) const = 0;
  virtual std::optional<Clip> read(std::size_t index, std::string* error) = 0;

  // read() in two halves for the task graph: load() in its serial reader stage (the file or
  // HDF5 access), decode() in a parallel task (parsing, chunk decoding). By default load() does
  // all of read().
  struct Loaded {
    std::optional<Clip> clip;
    std::string bytes;                     // a BVH file's text, for decode()
    std::optional<io::StoredClip> stored;  // a library clip's chunks as stored, for decode()
  };
  virtual bool load(std::size_t index, Loaded& loaded, std::string* error) {
    loaded.clip = read(index, error);
    return loaded.clip.has_value();
  }
  virtual std::optional<Clip> decode(std::size_t, Loaded&& loaded, std::string*) {
    return std::move(loaded.clip);
  }
};

class BvhSource final : public ClipSource {
 public:
  // `keep_source_angles`: keep each file's Euler values, so a BVH sink writes the source's
  // branch of every angle (Clip::source_angles).
  explicit BvhSource(std::vector<SourceFile> files, bool keep_source_angles = false)
      : files_(std::move(files)), keep_source_angles_(keep_source_angles) {}
  std::size_t count() const override { return files_.size(); }
  std::string name(std::size_t i) const override { return files_[i].relative; }
  std::string clip_path(std::size_t i) const override;
  std::string relative_path(std::size_t i) const override { return files_[i].relative; }
  std::size_t cost(std::size_t i) const override;
  std::optional<Clip> read(std::size_t i, std::string* error) override;
  // The file's bytes; parse_bvh in decode().
  bool load(std::size_t i, Loaded& loaded, std::string* error) override;
  std::optional<Clip> decode(std::size_t i, Loaded&& loaded, std::string* error) override;

 private:
  std::vector<SourceFile> files_;
  bool keep_source_angles_;
};

class LibrarySource final : public ClipSource {
 public:
  static std::unique_ptr<LibrarySource> open(const std::filesystem::path& path, std::string* error);
  std::size_t count() const override { return reader_->clips().size(); }
  std::string name(std::size_t i) const override { return reader_->clips()[i].path; }
  std::string clip_path(std::size_t i) const override { return reader_->clips()[i].path; }
  std::string relative_path(std::size_t i) const override { return clip_path(i) + ".bvh"; }
  std::size_t cost(std::size_t i) const override;
  std::optional<Clip> read(std::size_t i, std::string* error) override;
  // The clip's chunks as stored (LibraryReader::read_stored); their decoding in decode(), which
  // hands the chunk buffers back for a later load() to reuse.
  bool load(std::size_t i, Loaded& loaded, std::string* error) override;
  std::optional<Clip> decode(std::size_t i, Loaded&& loaded, std::string* error) override;
  const io::LibraryReader& reader() const { return *reader_; }

 private:
  std::unique_ptr<io::LibraryReader> reader_;
  std::mutex spare_mutex_;  // decode() runs on several threads
  std::vector<io::StoredClip> spare_;
};

}  // namespace mocap::engine
