#pragma once
// The bytes HDF5 stores for one chunk of a motion dataset, produced without HDF5: the byte
// shuffle (H5Z_FILTER_SHUFFLE), then the LZ4 plugin's format (filter 32004) or deflate (zlib).
// Pure CPU and thread-safe, so chunks can be compressed on worker threads and handed to the
// single HDF5 writer with H5Dwrite_chunk.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "io/compression.hpp"

namespace mocap::io {

// HDF5's shuffle: byte b of element i goes to out[b * n + i] (n = in.size() / element_size);
// trailing bytes that make no whole element are copied as they are. `out` has in.size() bytes.
void shuffle_bytes(std::span<const std::uint8_t> in, std::size_t element_size,
                   std::span<std::uint8_t> out);

// The LZ4 filter's format with its default block size (one block up to 1 GiB): original size
// (8 bytes, big-endian), block size (4, BE), then per block its stored size (4, BE) and the
// LZ4 block, or the raw bytes when LZ4 saves nothing. Appends to `out`; false on failure.
bool lz4_filter_encode(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out);
// Inverse of lz4_filter_encode (the plugin's decoder, for tests and tools); false if malformed.
bool lz4_filter_decode(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out);

// zlib's compress2 at `level`, as HDF5's deflate filter calls it. Appends to `out`.
bool deflate_encode(std::span<const std::uint8_t> in, int level, std::vector<std::uint8_t>& out);

// HDF5's Fletcher-32 (H5_checksum_fletcher32, the H5Z_FILTER_FLETCHER32 filter): sums of
// big-endian 16-bit words, an odd last byte as the high half of one, folded to 16 bits every
// 360 words; sum2 << 16 | sum1.
std::uint32_t fletcher32(std::span<const std::uint8_t> bytes);

// One raw chunk of float32 elements through the filter pipeline of `compression`, then, with
// `checksum`, the Fletcher-32 filter (the checksum of the stored bytes appended little-endian);
// appends the stored bytes to `out`. `scratch` is reused between calls to avoid allocations.
bool encode_chunk(std::span<const std::uint8_t> raw, Compression compression, bool checksum,
                  std::vector<std::uint8_t>& out, std::vector<std::uint8_t>& scratch);

}  // namespace mocap::io
