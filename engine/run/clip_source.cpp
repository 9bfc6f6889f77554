#include "engine/run/clip_source.hpp"

#include "io/bvh_reader.hpp"

namespace mocap::engine {

std::string BvhSource::clip_path(std::size_t i) const {
  return io::clip_path_from_source(files_[i].relative);
}

std::size_t BvhSource::cost(std::size_t i) const {
  std::error_code ec;
  const auto size = std::filesystem::file_size(files_[i].path, ec);
  return ec ? 0 : std::size_t(size);  // bytes of text: proportional to frames x channels
}

std::optional<Clip> BvhSource::read(std::size_t i, std::string* error) {
  io::BvhReadResult result = io::read_bvh(files_[i].path, keep_source_angles_);
  if (result.error) {
    if (error) *error = result.error->what();
    return std::nullopt;
  }
  result.clip->source = files_[i].relative;
  return std::move(result.clip);
}

bool BvhSource::load(std::size_t i, Loaded& loaded, std::string* error) {
  if (std::optional<io::BvhError> e = io::read_bvh_text(files_[i].path, loaded.bytes)) {
    if (error) *error = e->what();
    return false;
  }
  return true;
}

std::optional<Clip> BvhSource::decode(std::size_t i, Loaded&& loaded, std::string* error) {
  io::BvhReadResult result =
      io::parse_bvh(loaded.bytes, files_[i].path.string(), keep_source_angles_);
  loaded.bytes = {};  // the text is not needed any more: free it before the clip's work
  if (result.error) {
    if (error) *error = result.error->what();
    return std::nullopt;
  }
  result.clip->source = files_[i].relative;
  return std::move(result.clip);
}

std::unique_ptr<LibrarySource> LibrarySource::open(const std::filesystem::path& path,
                                                   std::string* error) {
  auto reader = io::LibraryReader::open(path, error);
  if (!reader) return nullptr;
  auto source = std::make_unique<LibrarySource>();
  source->reader_ = std::move(reader);
  return source;
}

std::size_t LibrarySource::cost(std::size_t i) const {
  const auto& h = reader_->clips()[i];
  return std::size_t(h.frames) * std::size_t(h.joints);
}

std::optional<Clip> LibrarySource::read(std::size_t i, std::string* error) {
  const auto& header = reader_->clips()[i];
  if (!header.error.empty()) {
    if (error) *error = header.error;
    return std::nullopt;
  }
  return reader_->read_clip(header.path, error);
}

bool LibrarySource::load(std::size_t i, Loaded& loaded, std::string* error) {
  const auto& header = reader_->clips()[i];
  if (!header.error.empty()) {
    if (error) *error = header.error;
    return false;
  }
  io::StoredClip recycled;
  {
    const std::lock_guard lock(spare_mutex_);
    if (!spare_.empty()) {
      recycled = std::move(spare_.back());
      spare_.pop_back();
    }
  }
  loaded.stored = reader_->read_stored(header.path, error, std::move(recycled));
  return loaded.stored.has_value();
}

std::optional<Clip> LibrarySource::decode(std::size_t, Loaded&& loaded, std::string* error) {
  if (!loaded.stored) return std::move(loaded.clip);
  std::optional<Clip> clip = io::LibraryReader::decode_stored(*loaded.stored, error);
  // A few spare buffers cover the clips between the reader and the decoding tasks; each holds
  // at most one clip's stored chunks.
  constexpr std::size_t kSpares = 4;
  const std::lock_guard lock(spare_mutex_);
  if (spare_.size() < kSpares) spare_.push_back(std::move(*loaded.stored));
  loaded.stored.reset();
  return clip;
}

}  // namespace mocap::engine
