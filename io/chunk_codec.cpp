#include "io/chunk_codec.hpp"

#include <lz4.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <limits>

namespace mocap::io {

namespace {

constexpr std::size_t kLz4DefaultBlockSize = std::size_t(1) << 30;

void append_be(std::vector<std::uint8_t>& out, std::uint64_t value, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) out.push_back(std::uint8_t(value >> (8 * i)));
}

std::uint64_t read_be(const std::uint8_t* in, int bytes) {
  std::uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) value = (value << 8) | in[i];
  return value;
}

}  // namespace

void shuffle_bytes(std::span<const std::uint8_t> in, std::size_t element_size,
                   std::span<std::uint8_t> out) {
  const std::size_t n = element_size > 0 ? in.size() / element_size : 0;
  if (element_size <= 1 || n <= 1) {  // HDF5 leaves such chunks as they are
    std::copy(in.begin(), in.end(), out.begin());
    return;
  }
  if (element_size == 4) {
    // float32, the store's only type: the four planes in one pass, as unshuffle_bytes reads
    // them (a strided byte loop per plane, with the element size known only at run time, ran a
    // byte a cycle: 3 % of a one-thread `filter`).
    const std::uint8_t* __restrict src = in.data();
    std::uint8_t* __restrict b0 = out.data();
    std::uint8_t* __restrict b1 = b0 + n;
    std::uint8_t* __restrict b2 = b1 + n;
    std::uint8_t* __restrict b3 = b2 + n;
    for (std::size_t i = 0; i < n; ++i, src += 4) {
      b0[i] = src[0];
      b1[i] = src[1];
      b2[i] = src[2];
      b3[i] = src[3];
    }
  } else {
    for (std::size_t b = 0; b < element_size; ++b) {
      std::uint8_t* dst = out.data() + b * n;
      const std::uint8_t* src = in.data() + b;
      for (std::size_t i = 0; i < n; ++i) dst[i] = src[i * element_size];
    }
  }
  const std::size_t whole = n * element_size;
  std::copy(in.begin() + std::ptrdiff_t(whole), in.end(), out.begin() + std::ptrdiff_t(whole));
}

void unshuffle_bytes(std::span<const std::uint8_t> in, std::size_t element_size,
                     std::span<std::uint8_t> out) {
  const std::size_t n = element_size > 0 ? in.size() / element_size : 0;
  if (element_size <= 1 || n <= 1) {  // as shuffle_bytes left them
    std::copy(in.begin(), in.end(), out.begin());
    return;
  }
  if (element_size == 4) {  // float32, the store's only type: the four planes in one pass
    const std::uint8_t *b0 = in.data(), *b1 = b0 + n, *b2 = b1 + n, *b3 = b2 + n;
    std::uint8_t* dst = out.data();
    for (std::size_t i = 0; i < n; ++i, dst += 4) {
      dst[0] = b0[i];
      dst[1] = b1[i];
      dst[2] = b2[i];
      dst[3] = b3[i];
    }
  } else {
    for (std::size_t b = 0; b < element_size; ++b) {
      const std::uint8_t* src = in.data() + b * n;
      std::uint8_t* dst = out.data() + b;
      for (std::size_t i = 0; i < n; ++i) dst[i * element_size] = src[i];
    }
  }
  const std::size_t whole = n * element_size;
  std::copy(in.begin() + std::ptrdiff_t(whole), in.end(), out.begin() + std::ptrdiff_t(whole));
}

bool lz4_filter_encode(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out) {
  if (in.size() > std::size_t(std::numeric_limits<std::int32_t>::max())) return false;
  const std::size_t total = in.size();
  const std::size_t block_size = std::min(kLz4DefaultBlockSize, total);
  append_be(out, total, 8);
  append_be(out, block_size, 4);
  for (std::size_t start = 0; start < total; start += block_size) {
    const int length = int(std::min(block_size, total - start));
    const std::size_t size_at = out.size();
    out.resize(size_at + 4 + std::size_t(LZ4_compressBound(length)));
    const char* src = reinterpret_cast<const char*>(in.data() + start);
    char* dst = reinterpret_cast<char*>(out.data() + size_at + 4);
    int stored = LZ4_compress_default(src, dst, length, LZ4_compressBound(length));
    if (stored <= 0) return false;
    if (stored >= length) {  // the plugin stores such a block raw, marked by size == length
      stored = length;
      std::memcpy(dst, src, std::size_t(length));
    }
    out.resize(size_at + 4 + std::size_t(stored));
    for (int i = 0; i < 4; ++i)
      out[size_at + std::size_t(i)] = std::uint8_t(stored >> (8 * (3 - i)));
  }
  return true;
}

bool lz4_filter_decode(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out) {
  if (in.size() < 12) return false;
  const std::uint64_t total = read_be(in.data(), 8);
  std::uint64_t block_size = std::min<std::uint64_t>(read_be(in.data() + 8, 4), total);
  if (total > std::uint64_t(std::numeric_limits<std::int32_t>::max())) return false;
  if (block_size == 0 && total > 0) return false;
  std::size_t at = 12;
  const std::size_t base = out.size();
  out.resize(base + std::size_t(total));
  for (std::uint64_t done = 0; done < total; done += block_size) {
    block_size = std::min(block_size, total - done);
    if (at + 4 > in.size()) return false;
    const std::uint64_t stored = read_be(in.data() + at, 4);
    at += 4;
    if (stored > in.size() - at) return false;
    char* dst = reinterpret_cast<char*>(out.data() + base + done);
    const char* src = reinterpret_cast<const char*>(in.data() + at);
    if (stored == block_size) {
      std::memcpy(dst, src, std::size_t(block_size));
    } else if (LZ4_decompress_safe(src, dst, int(stored), int(block_size)) != int(block_size)) {
      return false;
    }
    at += std::size_t(stored);
  }
  return true;
}

bool lz4_filter_decode_into(std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
  if (in.size() < 12) return false;
  const std::uint64_t total = read_be(in.data(), 8);
  std::uint64_t block_size = std::min<std::uint64_t>(read_be(in.data() + 8, 4), total);
  if (total != out.size() || total > std::uint64_t(std::numeric_limits<std::int32_t>::max()))
    return false;
  if (block_size == 0 && total > 0) return false;
  std::size_t at = 12;
  for (std::uint64_t done = 0; done < total; done += block_size) {
    block_size = std::min(block_size, total - done);
    if (at + 4 > in.size()) return false;
    const std::uint64_t stored = read_be(in.data() + at, 4);
    at += 4;
    if (stored > in.size() - at) return false;
    char* dst = reinterpret_cast<char*>(out.data() + done);
    const char* src = reinterpret_cast<const char*>(in.data() + at);
    if (stored == block_size) {
      std::memcpy(dst, src, std::size_t(block_size));
    } else if (LZ4_decompress_safe(src, dst, int(stored), int(block_size)) != int(block_size)) {
      return false;
    }
    at += std::size_t(stored);
  }
  return true;
}

bool deflate_decode_into(std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
  uLongf size = uLongf(out.size());
  // uncompress() stops at the end of the stream (HDF5's filter ignores what follows it too) and
  // fails when the stream would not fit; a shorter one is caught by the size.
  return uncompress(out.data(), &size, in.data(), uLong(in.size())) == Z_OK && size == out.size();
}

bool deflate_encode(std::span<const std::uint8_t> in, int level, std::vector<std::uint8_t>& out) {
  const std::size_t base = out.size();
  uLongf stored = compressBound(uLong(in.size()));
  out.resize(base + stored);
  if (compress2(out.data() + base, &stored, in.data(), uLong(in.size()), level) != Z_OK)
    return false;
  out.resize(base + stored);
  return true;
}

std::uint32_t fletcher32_reference(std::span<const std::uint8_t> bytes) {
  const std::uint8_t* data = bytes.data();
  std::size_t words = bytes.size() / 2;
  std::uint32_t sum1 = 0, sum2 = 0;
  while (words > 0) {
    // 360 words keep both sums below 2^32 before folding, as HDF5 does.
    std::size_t block = std::min<std::size_t>(words, 360);
    words -= block;
    do {
      sum1 += std::uint32_t(data[0]) << 8 | std::uint32_t(data[1]);
      data += 2;
      sum2 += sum1;
    } while (--block);
    sum1 = (sum1 & 0xffff) + (sum1 >> 16);
    sum2 = (sum2 & 0xffff) + (sum2 >> 16);
  }
  if (bytes.size() % 2) {
    sum1 += std::uint32_t(*data) << 8;
    sum2 += sum1;
    sum1 = (sum1 & 0xffff) + (sum1 >> 16);
    sum2 = (sum2 & 0xffff) + (sum2 >> 16);
  }
  sum1 = (sum1 & 0xffff) + (sum1 >> 16);
  sum2 = (sum2 & 0xffff) + (sum2 >> 16);
  return sum2 << 16 | sum1;
}

namespace {

constexpr std::size_t kFletcherLanes = 16;

// `steps` rows of kFletcherLanes big-endian words into the lanes' sums (fletcher32). Each row
// is widened whole, then added whole, so the adds run as vectors. Out of line on purpose:
// inlined into fletcher32, GCC 12 leaves the rows scalar (BM_Fletcher32, bench/io_bench.cpp).
[[gnu::noinline]] void fletcher_lanes(const std::uint8_t* data, std::size_t steps,
                                      std::uint32_t* __restrict s1, std::uint32_t* __restrict s2) {
  for (std::size_t m = 0; m < steps; ++m, data += 2 * kFletcherLanes) {
    std::uint32_t words[kFletcherLanes];
    for (std::size_t l = 0; l < kFletcherLanes; ++l)
      words[l] = std::uint32_t(data[2 * l]) << 8 | std::uint32_t(data[2 * l + 1]);
    for (std::size_t l = 0; l < kFletcherLanes; ++l) s1[l] += words[l];
    for (std::size_t l = 0; l < kFletcherLanes; ++l) s2[l] += s1[l];
  }
}

}  // namespace

std::uint32_t fletcher32(std::span<const std::uint8_t> bytes) {
  // Word i of n adds (n - i) w_i to S2. Lane l of L sums words i = L m + l over the iterations
  // m < M of a block: s1[l] = sum w, s2[l] = sum (M - m) w, so the block adds
  // sum_l (L s2[l] - l s1[l]) plus L M times the S1 before it. M = 256 keeps s2 below 2^32;
  // the sums are kept mod 65535, and both are 0 exactly when every word is.
  constexpr std::uint64_t kModulus = 65535;
  constexpr std::size_t kLanes = kFletcherLanes, kBlock = 256;
  const std::uint8_t* data = bytes.data();
  const std::size_t words = bytes.size() / 2;
  std::uint64_t sum1 = 0, sum2 = 0;
  bool nonzero = false;
  std::size_t i = 0;
  while (i + kLanes <= words) {
    const std::size_t steps = std::min(kBlock, (words - i) / kLanes);
    std::uint32_t s1[kLanes] = {}, s2[kLanes] = {};
    fletcher_lanes(data + 2 * i, steps, s1, s2);
    i += kLanes * steps;
    std::uint64_t block1 = 0, block2 = 0;
    for (std::size_t l = 0; l < kLanes; ++l) {
      block1 += s1[l];
      block2 += kLanes * std::uint64_t(s2[l]) - l * std::uint64_t(s1[l]);
    }
    nonzero = nonzero || block1 != 0;
    sum2 = (sum2 + (kLanes * steps % kModulus) * sum1 + block2) % kModulus;
    sum1 = (sum1 + block1) % kModulus;
  }
  for (; i < words; ++i) {
    const std::uint32_t w = std::uint32_t(data[2 * i]) << 8 | std::uint32_t(data[2 * i + 1]);
    nonzero = nonzero || w != 0;
    sum1 += w;
    sum2 += sum1;
  }
  if (bytes.size() % 2) {
    nonzero = nonzero || data[2 * words] != 0;
    sum1 += std::uint32_t(data[2 * words]) << 8;
    sum2 += sum1;
  }
  if (!nonzero) return 0;
  const auto residue = [](std::uint64_t sum) {
    const auto r = std::uint32_t(sum % kModulus);
    return r == 0 ? std::uint32_t(kModulus) : r;
  };
  return residue(sum2) << 16 | residue(sum1);
}

bool fletcher32_matches(std::span<const std::uint8_t> stored) {
  if (stored.size() < 4) return false;
  const std::uint8_t* tail = stored.data() + stored.size() - 4;
  const std::uint32_t recorded = std::uint32_t(tail[0]) | std::uint32_t(tail[1]) << 8 |
                                 std::uint32_t(tail[2]) << 16 | std::uint32_t(tail[3]) << 24;
  const std::uint32_t sum = fletcher32(stored.first(stored.size() - 4));
  // H5Z_filter_fletcher32's "reversed" checksum, byte-swapped within each 16-bit half.
  const std::uint32_t reversed = (sum & 0x00ff00ffu) << 8 | (sum & 0xff00ff00u) >> 8;
  return recorded == sum || recorded == reversed;
}

namespace {

bool encode_filters(std::span<const std::uint8_t> raw, Compression compression,
                    std::vector<std::uint8_t>& out, std::vector<std::uint8_t>& scratch) {
  if (compression == Compression::none) {
    out.insert(out.end(), raw.begin(), raw.end());
    return true;
  }
  scratch.resize(raw.size());
  shuffle_bytes(raw, sizeof(float), scratch);
  if (compression == Compression::lz4) return lz4_filter_encode(scratch, out);
  return deflate_encode(scratch, kDeflateLevel, out);
}

}  // namespace

std::size_t encoded_chunk_bound(std::size_t raw_bytes, Compression compression, bool checksum) {
  std::size_t bound = raw_bytes;
  if (compression == Compression::lz4) {
    // lz4_filter_encode's header, then per block its size and LZ4's bound.
    const std::size_t blocks = raw_bytes == 0 ? 0 : (raw_bytes - 1) / kLz4DefaultBlockSize + 1;
    bound = 12 + blocks * 4 +
            std::size_t(LZ4_compressBound(int(std::min(raw_bytes, kLz4DefaultBlockSize)))) * blocks;
  } else if (compression == Compression::deflate) {
    bound = std::size_t(compressBound(uLong(raw_bytes)));
  }
  return bound + (checksum ? 4 : 0);
}

bool encode_chunk(std::span<const std::uint8_t> raw, Compression compression, bool checksum,
                  std::vector<std::uint8_t>& out, std::vector<std::uint8_t>& scratch) {
  const std::size_t begin = out.size();
  if (!encode_filters(raw, compression, out, scratch)) return false;
  if (checksum) {
    const std::uint32_t sum = fletcher32({out.data() + begin, out.size() - begin});
    for (int i = 0; i < 4; ++i) out.push_back(std::uint8_t(sum >> (8 * i)));
  }
  return true;
}

std::string decode_chunk(std::span<const std::uint8_t> stored, Compression compression,
                         bool checksum, std::span<std::uint8_t> raw,
                         std::vector<std::uint8_t>& scratch) {
  // Filters undo in reverse: the checksum covers the compressed bytes, so it comes first.
  if (checksum) {
    if (!fletcher32_matches(stored)) return "fails its Fletcher32 checksum (the file is damaged)";
    stored = stored.first(stored.size() - 4);
  }
  const std::string size = std::to_string(raw.size());
  switch (compression) {
    case Compression::none:
      if (stored.size() != raw.size())
        return "holds " + std::to_string(stored.size()) + " bytes, not the " + size +
               " of an uncompressed chunk (the file is damaged)";
      std::memcpy(raw.data(), stored.data(), raw.size());
      return {};
    case Compression::lz4:
    case Compression::deflate:
      scratch.resize(raw.size());
      if (compression == Compression::lz4 ? !lz4_filter_decode_into(stored, scratch)
                                          : !deflate_decode_into(stored, scratch))
        return std::string("is not a valid ") +
               (compression == Compression::lz4 ? "LZ4" : "deflate") + " chunk of " + size +
               " bytes (the file is damaged)";
      unshuffle_bytes(scratch, sizeof(float), raw);
      return {};
  }
  return "has an unknown compression";
}

}  // namespace mocap::io
