#pragma once
// The bytes HDF5 stores for one chunk of a motion dataset, produced without HDF5: the byte
// shuffle (H5Z_FILTER_SHUFFLE), then the LZ4 plugin's format (filter 32004) or deflate (zlib).
// Pure CPU and thread-safe, so chunks can be compressed on worker threads and handed to the
// single HDF5 writer with H5Dwrite_chunk, and, the other way, taken from the single reader's
// H5Dread_chunk and decoded on worker threads.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "io/compression.hpp"

namespace mocap::io {

// HDF5's shuffle: byte b of element i goes to out[b * n + i] (n = in.size() / element_size);
// trailing bytes that make no whole element are copied as they are. `out` has in.size() bytes.
void shuffle_bytes(std::span<const std::uint8_t> in, std::size_t element_size,
                   std::span<std::uint8_t> out);
// Its inverse (the shuffle filter on read): byte in[b * n + i] goes back to element i.
void unshuffle_bytes(std::span<const std::uint8_t> in, std::size_t element_size,
                     std::span<std::uint8_t> out);

// The LZ4 filter's format with its default block size (one block up to 1 GiB): original size
// (8 bytes, big-endian), block size (4, BE), then per block its stored size (4, BE) and the
// LZ4 block, or the raw bytes when LZ4 saves nothing. Appends to `out`; false on failure.
bool lz4_filter_encode(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out);
// Inverse of lz4_filter_encode (the plugin's decoder, for tests and tools); false if malformed.
bool lz4_filter_decode(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out);
// The same into `out`, which the chunk must fill exactly: false unless its header states
// out.size() bytes and every block decodes to its size. Allocates nothing, so a header's size
// is never trusted (the plugin allocates it and decodes with LZ4_decompress_fast).
bool lz4_filter_decode_into(std::span<const std::uint8_t> in, std::span<std::uint8_t> out);
// zlib's inflate of one deflate filter chunk into `out`, which it must fill exactly.
bool deflate_decode_into(std::span<const std::uint8_t> in, std::span<std::uint8_t> out);

// zlib's compress2 at `level`, as HDF5's deflate filter calls it. Appends to `out`.
bool deflate_encode(std::span<const std::uint8_t> in, int level, std::vector<std::uint8_t>& out);

// HDF5's Fletcher-32 (H5_checksum_fletcher32, the H5Z_FILTER_FLETCHER32 filter): sums of
// big-endian 16-bit words, an odd last byte as the high half of one, folded to 16 bits every
// 360 words; sum2 << 16 | sum1. This is HDF5's loop, the reference of fletcher32.
std::uint32_t fletcher32_reference(std::span<const std::uint8_t> bytes);
// The same checksum from the exact sums S1 = sum of the words and S2 = sum of their running
// sums, taken 16 words abreast: folding (x & 0xffff) + (x >> 16) keeps x mod 65535 and never
// turns a positive x into 0, so each half is 0 when its exact sum is 0 and otherwise the
// residue of the sum mod 65535 in [1, 65535], however the folds were scheduled.
std::uint32_t fletcher32(std::span<const std::uint8_t> bytes);
// Whether a stored chunk ending in its Fletcher-32 (4 bytes, little-endian) is intact, as the
// filter decides on read: HDF5 also accepts the checksum with the bytes of each 16-bit half
// swapped, which releases before 1.6.3 wrote on little-endian machines.
bool fletcher32_matches(std::span<const std::uint8_t> stored);

// One raw chunk of float32 elements through the filter pipeline of `compression`, then, with
// `checksum`, the Fletcher-32 filter (the checksum of the stored bytes appended little-endian);
// appends the stored bytes to `out`. `scratch` is reused between calls to avoid allocations.
bool encode_chunk(std::span<const std::uint8_t> raw, Compression compression, bool checksum,
                  std::vector<std::uint8_t>& out, std::vector<std::uint8_t>& scratch);

// The most bytes encode_chunk can append for a raw chunk of `raw_bytes`: what a writer reserves
// so that a clip's chunks are appended without the buffer moving.
std::size_t encoded_chunk_bound(std::size_t raw_bytes, Compression compression, bool checksum);

// Inverse of encode_chunk, what HDF5's filters do on read (H5Dread_chunk's bytes in, the chunk
// out): with `checksum` the Fletcher-32 is verified first, then the chunk is decompressed and
// unshuffled into `raw`, which it must fill exactly. "" or why the chunk is damaged, phrased to
// follow the chunk's name ("fails its Fletcher32 checksum ..."). Pure CPU and thread-safe, like
// encode_chunk; `scratch` is reused between calls.
std::string decode_chunk(std::span<const std::uint8_t> stored, Compression compression,
                         bool checksum, std::span<std::uint8_t> raw,
                         std::vector<std::uint8_t>& scratch);

}  // namespace mocap::io
