// The review page's files, built into the program so that `--report` needs nothing at run time:
// the template and script from web/review/, and three.js from web/review/node_modules (installed
// by scripts/setup.sh; MOCAP_REVIEW_THREE is undefined when the build did not find it). The files
// are included by the assembler (.incbin), byte for byte, whatever they hold.
#include <string_view>

#include "engine/run/review_report.hpp"

// clang-format off
#define MOCAP_INCBIN(name, file)                                                        \
  asm(".section .rodata\n"                                                              \
      ".global " #name "_begin\n" #name "_begin:\n.incbin \"" file "\"\n"               \
      ".global " #name "_end\n" #name "_end:\n.byte 0\n.previous\n");                    \
  extern "C" const char name##_begin[];                                                 \
  extern "C" const char name##_end[];
// clang-format on

MOCAP_INCBIN(mocap_review_template, MOCAP_REVIEW_TEMPLATE)
MOCAP_INCBIN(mocap_review_script, MOCAP_REVIEW_SCRIPT)
#ifdef MOCAP_REVIEW_THREE
MOCAP_INCBIN(mocap_review_three, MOCAP_REVIEW_THREE)
#endif

namespace mocap::engine {

std::string_view review_page_template() {
  return {mocap_review_template_begin,
          std::size_t(mocap_review_template_end - mocap_review_template_begin)};
}
std::string_view review_page_script() {
  return {mocap_review_script_begin,
          std::size_t(mocap_review_script_end - mocap_review_script_begin)};
}
std::string_view review_three_js() {
#ifdef MOCAP_REVIEW_THREE
  return {mocap_review_three_begin, std::size_t(mocap_review_three_end - mocap_review_three_begin)};
#else
  return {};
#endif
}

}  // namespace mocap::engine
