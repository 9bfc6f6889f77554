#pragma once
#include <filesystem>
#include <string>
#include <string_view>

namespace mocap::engine {

// Writes `text` to path + ".tmp" and renames it over `path`: readers never see half a file.
bool write_file_atomically(const std::filesystem::path& path, std::string_view text,
                           std::string* error);

}  // namespace mocap::engine
