#include "engine/run/clip_sink.hpp"

#include <fmt/core.h>

#include "engine/run/atomic_file.hpp"
#include "io/bvh_writer.hpp"
#include "io/clip_encoder.hpp"

namespace mocap::engine {

namespace fs = std::filesystem;

bool BvhFolderSink::prepare(const Clip& clip, std::any& prepared, std::string* error) {
  if (std::string why = io::check_clip_for_bvh(clip); !why.empty()) {
    if (error) *error = why;
    return false;
  }
  prepared = io::format_bvh(clip);  // the text, formatted in parallel
  return true;
}

bool BvhFolderSink::write(const std::string&, const std::string& relative, std::any& prepared,
                          std::string* error) {
  const fs::path target = folder_ / relative;
  std::error_code ec;
  fs::create_directories(target.parent_path(), ec);
  if (ec) {
    if (error)
      *error =
          fmt::format("cannot create folder {}: {}", target.parent_path().string(), ec.message());
    return false;
  }
  return write_file_atomically(target, std::any_cast<const std::string&>(prepared), error);
}

bool LibrarySink::prepare(const Clip& clip, std::any& prepared, std::string* error) {
  auto encoded = io::encode_clip(clip, compression, error, checksum);
  if (!encoded) return false;
  prepared = std::move(*encoded);
  return true;
}

bool LibrarySink::write(const std::string& clip_path, const std::string&, std::any& prepared,
                        std::string* error) {
  return output_->add(clip_path, std::any_cast<const io::EncodedClip&>(prepared), error);
}

}  // namespace mocap::engine
