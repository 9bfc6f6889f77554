#include "io/compression.hpp"

#include <hdf5.h>

#include <algorithm>

namespace mocap::io {

namespace {
constexpr std::size_t kTargetChunkBytes = 128 * 1024;
}

std::optional<Compression> parse_compression(std::string_view name) {
  if (name == "none") return Compression::none;
  if (name == "lz4") return Compression::lz4;
  if (name == "deflate") return Compression::deflate;
  return std::nullopt;
}

std::string_view to_string(Compression compression) {
  switch (compression) {
    case Compression::none:
      return "none";
    case Compression::lz4:
      return "lz4";
    case Compression::deflate:
      return "deflate";
  }
  return "unknown";
}

bool compression_available(Compression compression) {
  switch (compression) {
    case Compression::none:
      return true;
    case Compression::lz4:
      // H5Zfilter_avail searches HDF5_PLUGIN_PATH (or the default plugin folder) and registers
      // the plugin it finds there.
      return H5Zfilter_avail(H5Z_filter_t(kLz4FilterId)) > 0;
    case Compression::deflate:
      return H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0 && H5Zfilter_avail(H5Z_FILTER_SHUFFLE) > 0;
  }
  return false;
}

std::string compression_unavailable_reason(Compression compression) {
  if (compression_available(compression)) return {};
  switch (compression) {
    case Compression::lz4:
      return "lz4 compression needs the HDF5 LZ4 filter plugin (filter id 32004), which HDF5 "
             "could not load: install the Debian package hdf5-filter-plugin, or set "
             "HDF5_PLUGIN_PATH to the folder holding libh5lz4.so";
    case Compression::deflate:
      return "deflate compression is not built into this HDF5 library";
    case Compression::none:
      break;
  }
  return "compression '" + std::string(to_string(compression)) + "' is unavailable";
}

int chunk_frames(int frames, std::size_t bytes_per_frame) {
  const std::size_t most = std::clamp<std::size_t>(
      kTargetChunkBytes / std::max<std::size_t>(bytes_per_frame, 1), 1, std::size_t(1) << 30);
  const std::size_t total = std::size_t(std::max(frames, 1));
  // As many chunks as the limit needs, then equal ones: the last chunk's padding (stored, and
  // compressed, like data) stays under one frame per chunk instead of up to a whole chunk.
  const std::size_t chunks = (total + most - 1) / most;
  return int((total + chunks - 1) / chunks);
}

}  // namespace mocap::io
