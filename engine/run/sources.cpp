#include "engine/run/sources.hpp"

#include <algorithm>
#include <cctype>
#include <map>

namespace mocap::engine {
namespace {

bool has_bvh_extension(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".bvh";
}

}  // namespace

SourceList collect_bvh_sources(const std::vector<std::string>& arguments,
                               const std::filesystem::path& output_folder) {
  namespace fs = std::filesystem;
  SourceList out;
  std::map<std::string, std::pair<fs::path, fs::path>> seen;  // relative -> (canonical, given)
  std::error_code ec;
  const fs::path output =
      output_folder.empty() ? fs::path{} : fs::weakly_canonical(output_folder, ec);
  auto add = [&](const fs::path& path, const fs::path& relative) {
    std::error_code canonical_ec;
    const fs::path file = fs::weakly_canonical(path, canonical_ec);
    std::string rel = relative.generic_string();
    std::error_code output_ec;
    if (!output.empty() && fs::weakly_canonical(output / rel, output_ec) == file)
      out.errors.push_back(path.string() +
                           ": the output would overwrite this input; choose another -o");
    const auto [it, inserted] = seen.emplace(rel, std::pair{file, path});
    if (inserted)
      out.files.push_back({path, std::move(rel)});
    else if (it->second.first != file)
      out.errors.push_back(it->second.second.string() + " and " + path.string() +
                           " would both be written as " + rel + ": one would replace the other");
  };
  for (const std::string& arg : arguments) {
    const fs::path path(arg);
    if (fs::is_directory(path, ec)) {
      for (auto it = fs::recursive_directory_iterator(
               path, fs::directory_options::skip_permission_denied, ec);
           !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
        std::error_code entry_ec;
        if (!output.empty() && it->is_directory(entry_ec) &&
            fs::weakly_canonical(it->path(), entry_ec) == output) {
          it.disable_recursion_pending();  // the output of an earlier run
          continue;
        }
        if (it->is_regular_file(entry_ec) && has_bvh_extension(it->path()))
          add(it->path(), it->path().lexically_relative(path));
      }
      if (ec) out.errors.push_back(arg + ": cannot list folder: " + ec.message());
    } else if (fs::is_regular_file(path, ec)) {
      add(path, path.filename());
    } else {
      out.errors.push_back(arg + ": no such file or folder");
    }
    ec.clear();
  }
  std::sort(out.files.begin(), out.files.end(),
            [](const SourceFile& a, const SourceFile& b) { return a.relative < b.relative; });
  return out;
}

}  // namespace mocap::engine
