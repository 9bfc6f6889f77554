// libFuzzer target: any bytes as an HDF5 library file, opened from memory (HDF5's core driver
// with a file image, LibraryReader::open_image), so no file is written and an input costs what
// the reader costs. Seeded with small valid libraries the store itself writes
// (make_library_corpus, run by CMake), which libFuzzer mutates byte by byte: superblock, object
// headers, B-trees, heaps, chunk indexes, filter pipelines and chunk bytes. This reaches HDF5's
// own parser (Debian's libhdf5, not instrumented), so a finding may lie inside HDF5; the reader's
// part is to check before calling HDF5 whatever HDF5 would trust (shapes, chunk shapes, stored
// sizes, compressed sizes) and to bound every allocation by what the image holds (run with
// -malloc_limit_mb and -rss_limit_mb, see docs/reliability.md).
// Every clip the reader reads and validates must be one export writes and import reads back,
// and every error must name the file (and the clip).
#include <hdf5.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>

#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "io/clip_validation.hpp"
#include "io/library_reader.hpp"

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "finding: %s: %s\n", what, detail.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  // HDF5 keeps freed blocks on its free lists only up to 64 KiB a list by default; a file's
  // metadata cache is larger, so every open went back to malloc for fresh, zeroed pages (over
  // half of each input's time in page faults and memset, perf). Unlimited lists reuse them.
  H5set_free_list_limits(-1, -1, -1, -1, -1, -1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mocap::io;
  std::string error;
  const auto reader =
      LibraryReader::open_image(std::span<const std::uint8_t>(data, size), "fuzz.h5", &error);
  if (!reader) {
    if (error.find("fuzz.h5") == std::string::npos) finding("error names no file", error);
    return 0;
  }
  (void)reader->provenance();
  for (const ClipHeader& header : reader->clips()) {
    if (!header.error.empty()) {
      if (header.error.find("fuzz.h5") == std::string::npos) finding("unnamed", header.error);
      continue;
    }
    // The join's path: stored chunks as they are (each checksum checked), else decoded.
    if (!reader->read_encoded(header.path, &error) && error.find(header.path) == std::string::npos)
      finding("error names no clip", error);
    auto clip = reader->read_clip(header.path, &error);
    if (!clip) {
      if (error.find(header.path) == std::string::npos) finding("error names no clip", error);
      continue;
    }
    if (!validate_clip(*clip).empty()) continue;
    // What info --check and filter accept, export must write and import must read back.
    if (std::string why = check_clip_for_bvh(*clip); !why.empty())
      finding("export refuses a valid clip", why);
    const BvhReadResult again = parse_bvh(format_bvh(*clip), "export.bvh");
    if (!again.clip) finding("import refuses what export wrote", again.error->what());
  }
  return 0;
}
