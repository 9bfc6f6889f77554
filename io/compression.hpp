#pragma once
// How the library store compresses its motion datasets, and how large their chunks are.
//   none:    chunked, unfiltered.
//   lz4:     HDF5 byte shuffle, then the HDF5 LZ4 filter (registered id 32004, a dynamically
//            loaded plugin: Debian's hdf5-filter-plugin; h5py readers need it too, or hdf5plugin).
//   deflate: HDF5 byte shuffle, then deflate (zlib) level 4; built into every HDF5.
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace mocap::io {

enum class Compression { none, lz4, deflate };

inline constexpr unsigned kLz4FilterId = 32004;
inline constexpr int kDeflateLevel = 4;

std::optional<Compression> parse_compression(std::string_view name);  // "none", "lz4", "deflate"
std::string_view to_string(Compression compression);

// Whether this process can write (and read) `compression`; for lz4 this loads the plugin.
bool compression_available(Compression compression);
// Why `compression` is unavailable, naming what to install; "" when it is available.
std::string compression_unavailable_reason(Compression compression);

// Frames per chunk of a [frames][joints][C] dataset whose frames take `bytes_per_frame` bytes:
// the fewest chunks of at most 128 KiB (or one frame, if larger), made equal so that the last
// chunk's padding is small. Chunks of a long clip then hold 64-128 KiB when a frame is at most
// 64 KiB (up to 4096 joints). A chunk holds whole frames: one read gets a time window of all
// joints. At least 1, at most max(frames, 1).
int chunk_frames(int frames, std::size_t bytes_per_frame);

}  // namespace mocap::io
