// libFuzzer target: any bytes as BVH text. The reader must return a clip or one error naming a
// line, never crash; a clip it returns must pass the shared validation (io/clip_validation.hpp),
// and export's text of it must read back: what import accepts, export writes, and the reverse.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "io/clip_validation.hpp"

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "finding: %s: %s\n", what, detail.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mocap::io;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const BvhReadResult read = parse_bvh(text, "fuzz.bvh");
  if (read.clip.has_value() == read.error.has_value()) finding("result", "not exactly one of two");
  if (read.error) {
    if (read.error->line < 0) finding("error line", read.error->what());
    return 0;
  }
  const mocap::Clip& clip = *read.clip;
  if (std::string why = validate_clip(clip); !why.empty()) finding("accepted an invalid clip", why);
  if (std::string why = check_clip_for_bvh(clip); !why.empty())
    finding("export refuses what import accepted", why);
  const BvhReadResult again = parse_bvh(format_bvh(clip), "again.bvh");
  if (!again.clip) finding("import refuses what export wrote", again.error->what());
  if (again.clip->frames != clip.frames || !(*again.clip->skeleton == *clip.skeleton))
    finding("round trip", "frames or skeleton changed");
  return 0;
}
