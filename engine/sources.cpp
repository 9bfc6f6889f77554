#include "engine/sources.hpp"

#include <algorithm>
#include <cctype>
#include <set>

namespace mocap::engine {
namespace {

bool has_bvh_extension(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".bvh";
}

}  // namespace

SourceList collect_bvh_sources(const std::vector<std::string>& arguments) {
  namespace fs = std::filesystem;
  SourceList out;
  std::set<std::string> seen;
  auto add = [&](const fs::path& path, const fs::path& relative) {
    std::string rel = relative.generic_string();
    if (seen.insert(rel).second) out.files.push_back({path, std::move(rel)});
  };
  for (const std::string& arg : arguments) {
    std::error_code ec;
    const fs::path path(arg);
    if (fs::is_directory(path, ec)) {
      for (auto it = fs::recursive_directory_iterator(
               path, fs::directory_options::skip_permission_denied, ec);
           !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
        if (it->is_regular_file(ec) && has_bvh_extension(it->path()))
          add(it->path(), it->path().lexically_relative(path));
      }
      if (ec) out.errors.push_back(arg + ": cannot list folder: " + ec.message());
    } else if (fs::is_regular_file(path, ec)) {
      add(path, path.filename());
    } else {
      out.errors.push_back(arg + ": no such file or folder");
    }
  }
  std::sort(out.files.begin(), out.files.end(),
            [](const SourceFile& a, const SourceFile& b) { return a.relative < b.relative; });
  return out;
}

}  // namespace mocap::engine
