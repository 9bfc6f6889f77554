#include "engine/run/atomic_file.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace mocap::engine {

bool write_file_atomically(const std::filesystem::path& path, std::string_view text,
                           std::string* error) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  auto fail = [&](const char* what) {
    if (error) *error = path.string() + ": " + what + ": " + std::strerror(errno);
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    return false;
  };
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) return fail("cannot create");
  const bool written = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !written) return fail("cannot write");
  if (std::rename(tmp.c_str(), path.c_str()) != 0) return fail("cannot rename into place");
  return true;
}

}  // namespace mocap::engine
