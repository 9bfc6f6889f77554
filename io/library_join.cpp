#include "io/library_join.hpp"

#include <map>
#include <set>

#include "io/hdf5_handle.hpp"
#include "io/hdf5_helpers.hpp"
#include "io/library_reader.hpp"
#include "io/library_writer.hpp"

namespace mocap::io {
namespace {

namespace fs = std::filesystem;

bool fail(std::string* error, const std::string& message) {
  if (error) *error = message;
  return false;
}

// Creates an empty library at `output` (root attributes, /skeletons, /clips) and reopens it.
h5::File create_empty_library(const fs::path& output, std::string* error) {
  {
    auto writer = LibraryWriter::create(output, Compression::none, error);
    if (!writer || !writer->close(error)) return {};
  }
  h5::File file(H5Fopen(output.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  if (!file) fail(error, h5::with_detail(output.string() + ": cannot reopen for writing"));
  return file;
}

h5::PropertyList intermediate_groups() {
  h5::PropertyList lcpl(H5Pcreate(H5P_LINK_CREATE));
  if (lcpl) H5Pset_create_intermediate_group(lcpl.get(), 1);
  return lcpl;
}

bool write_provenance_attributes(hid_t file, const Provenance& p, std::string* error,
                                 const fs::path& output) {
  if (p.method.empty()) return true;
  h5::Group group(H5Gcreate2(file, "provenance", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  const std::string created = p.created.empty() ? utc_now_iso8601() : p.created;
  const bool ok = group && h5::write_string_attribute(group.get(), "method", p.method) &&
                  h5::write_string_attribute(group.get(), "parameters", p.parameters_json) &&
                  h5::write_string_attribute(group.get(), "engine_version", p.engine_version) &&
                  h5::write_string_attribute(group.get(), "input_file", p.input_file) &&
                  h5::write_string_attribute(group.get(), "created", created);
  return ok || fail(error, h5::with_detail(output.string() + ": cannot write /provenance"));
}

}  // namespace

bool join_libraries(const std::vector<fs::path>& parts, const fs::path& output,
                    const Provenance& provenance, std::string* error) {
  const h5::ErrorSilence quiet;
  h5::File out = create_empty_library(output, error);
  if (!out) return false;
  const h5::PropertyList lcpl = intermediate_groups();
  std::map<std::string, fs::path> owner;  // clip path -> part that holds it
  std::set<std::string> skeletons;
  for (const fs::path& part : parts) {
    auto reader = LibraryReader::open(part, error);
    if (!reader) return false;
    h5::File in(H5Fopen(part.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    if (!in) return fail(error, h5::with_detail(part.string() + ": cannot open"));
    for (const ClipHeader& clip : reader->clips()) {
      if (!clip.error.empty())
        return fail(error, part.string() + ": " + clip.path + ": " + clip.error);
      const auto [it, fresh] = owner.emplace(clip.path, part);
      if (!fresh)
        return fail(error, "clip '" + clip.path + "' is in both " + it->second.string() + " and " +
                               part.string());
      const std::string where = "/clips/" + clip.path;
      if (H5Ocopy(in.get(), where.c_str(), out.get(), where.c_str(), H5P_DEFAULT, lcpl.get()) < 0)
        return fail(error, h5::with_detail(output.string() + ": cannot copy clip '" + clip.path +
                                           "' from " + part.string()));
      if (skeletons.insert(clip.skeleton).second) {
        const std::string skeleton = "/skeletons/" + clip.skeleton;
        if (H5Ocopy(in.get(), skeleton.c_str(), out.get(), skeleton.c_str(), H5P_DEFAULT,
                    lcpl.get()) < 0)
          return fail(error, h5::with_detail(output.string() + ": cannot copy skeleton '" +
                                             clip.skeleton + "' from " + part.string()));
      }
    }
  }
  if (!write_provenance_attributes(out.get(), provenance, error, output)) return false;
  if (!out.reset()) return fail(error, h5::with_detail(output.string() + ": cannot close"));
  return true;
}

namespace {

// Links the clips of `part` into the open library `out`.
bool link_part(hid_t out, const fs::path& part, const fs::path& output, std::string* error) {
  auto reader = LibraryReader::open(part, error);
  if (!reader) return false;
  const h5::PropertyList lcpl = intermediate_groups();
  const fs::path base = output.parent_path().empty() ? fs::path(".") : output.parent_path();
  const std::string target = part.lexically_relative(base).generic_string();
  for (const ClipHeader& clip : reader->clips()) {
    if (!clip.error.empty()) continue;
    const std::string where = "/clips/" + clip.path;
    if (H5Lexists(out, where.c_str(), H5P_DEFAULT) > 0) continue;
    if (H5Lcreate_external(target.c_str(), where.c_str(), out, where.c_str(), lcpl.get(),
                           H5P_DEFAULT) < 0)
      return fail(error,
                  h5::with_detail(output.string() + ": cannot link clip '" + clip.path + "'"));
  }
  return true;
}

}  // namespace

bool link_libraries(const std::vector<fs::path>& parts, const fs::path& output,
                    std::string* error) {
  const h5::ErrorSilence quiet;
  h5::File out = create_empty_library(output, error);
  if (!out) return false;
  for (const fs::path& part : parts)
    if (!link_part(out.get(), part, output, error)) return false;
  if (!out.reset()) return fail(error, h5::with_detail(output.string() + ": cannot close"));
  return true;
}

bool add_library_links(const fs::path& part, const fs::path& output, std::string* error) {
  const h5::ErrorSilence quiet;
  h5::File out(H5Fopen(output.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  if (!out) return fail(error, h5::with_detail(output.string() + ": cannot open for writing"));
  if (!link_part(out.get(), part, output, error)) return false;
  if (!out.reset()) return fail(error, h5::with_detail(output.string() + ": cannot close"));
  return true;
}

}  // namespace mocap::io
