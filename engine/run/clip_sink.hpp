#pragma once
// Where a job's clips go: BVH files in a folder, or a library file written through parts.
// prepare() runs in parallel (compression, formatting); write() in the serial writer stage.
#include <any>
#include <filesystem>
#include <memory>
#include <string>

#include "core/clip.hpp"
#include "engine/library/parted_output.hpp"

namespace mocap::engine {

class ClipSink {
 public:
  virtual ~ClipSink() = default;
  // Turns the finished clip into what write() stores; parallel across clips.
  virtual bool prepare(const Clip& clip, std::any& prepared, std::string* error) = 0;
  // Stores it under `clip_path` (library) or `relative` (BVH folder); serial, in clip order.
  virtual bool write(const std::string& clip_path, const std::string& relative, std::any& prepared,
                     std::string* error) = 0;
};

// BVH files below a folder, keeping each clip's relative path ("02/02_01.bvh").
class BvhFolderSink final : public ClipSink {
 public:
  explicit BvhFolderSink(std::filesystem::path folder) : folder_(std::move(folder)) {}
  bool prepare(const Clip& clip, std::any& prepared, std::string* error) override;
  bool write(const std::string& clip_path, const std::string& relative, std::any& prepared,
             std::string* error) override;

 private:
  std::filesystem::path folder_;
};

// A library file, crash-safe through PartedOutput; chunks are compressed in prepare().
class LibrarySink final : public ClipSink {
 public:
  explicit LibrarySink(std::unique_ptr<PartedOutput> output) : output_(std::move(output)) {}
  bool prepare(const Clip& clip, std::any& prepared, std::string* error) override;
  bool write(const std::string& clip_path, const std::string& relative, std::any& prepared,
             std::string* error) override;
  PartedOutput& output() { return *output_; }
  io::Compression compression = io::Compression::lz4;
  bool checksum = true;

 private:
  std::unique_ptr<PartedOutput> output_;
};

}  // namespace mocap::engine
