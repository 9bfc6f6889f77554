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

}  // namespace

bool join_libraries(const std::vector<fs::path>& parts, const fs::path& output,
                    const Provenance& provenance, std::string* error) {
  // Clip by clip through LibraryReader::read_encoded and LibraryWriter: the stored chunks are
  // copied as they are (checksums verified on the way), and every write is one the writer checks.
  // Not H5Ocopy: HDF5 1.10 crashes inside it (H5T_close_real) when the disk fills up mid-copy.
  auto writer = LibraryWriter::create(output, Compression::none, error);
  if (!writer) return false;
  std::map<std::string, fs::path> owner;  // clip path -> part that holds it
  for (const fs::path& part : parts) {
    auto reader = LibraryReader::open(part, error);
    if (!reader) return false;
    for (const ClipHeader& clip : reader->clips()) {
      if (!clip.error.empty()) return fail(error, clip.error);
      const auto [it, fresh] = owner.emplace(clip.path, part);
      if (!fresh)
        return fail(error, "clip '" + clip.path + "' is in both " + it->second.string() + " and " +
                               part.string());
      auto encoded = reader->read_encoded(clip.path, error);
      if (!encoded || !writer->write_encoded_as_is(clip.path, *encoded, error)) return false;
    }
  }
  if (!provenance.method.empty() && !writer->write_provenance(provenance, error)) return false;
  return writer->close(error);
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
