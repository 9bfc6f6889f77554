#include "io/hdf5_helpers.hpp"

#include <algorithm>
#include <cstring>
#include <functional>

namespace mocap::io::h5 {

ErrorSilence::ErrorSilence() {
  H5Eget_auto2(H5E_DEFAULT, &function_, &data_);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

ErrorSilence::~ErrorSilence() {
  H5Eset_auto2(H5E_DEFAULT, function_, data_);
}

std::string last_error_detail() {
  std::string detail;
  // Walking upward starts at the innermost error, the one that says what actually went wrong.
  auto keep_first = [](unsigned n, const H5E_error2_t* e, void* out) -> herr_t {
    if (n == 0 && e->desc) *static_cast<std::string*>(out) = e->desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, keep_first, &detail);
  H5Eclear2(H5E_DEFAULT);
  // The file drivers' "file write failed: time = ..., errno = 28, error message = 'No space left
  // on device', buf = 0x..., ..." becomes "file write failed: No space left on device".
  const std::string marker = "error message = '";
  if (const auto at = detail.find(marker); at != std::string::npos) {
    const auto end = detail.find('\'', at + marker.size());
    const auto colon = detail.find(':');
    if (end != std::string::npos && colon < at)
      detail = detail.substr(0, colon) + ": " +
               detail.substr(at + marker.size(), end - at - marker.size());
  }
  return detail;
}

std::string with_detail(std::string message) {
  const std::string detail = last_error_detail();
  if (!detail.empty()) message += " (HDF5: " + detail + ")";
  return message;
}

bool link_exists(hid_t location, const std::string& name) {
  return H5Lexists(location, name.c_str(), H5P_DEFAULT) > 0;
}

bool has_variable_string_attribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) return false;
  const Attribute attribute(H5Aopen(object, name, H5P_DEFAULT));
  const Datatype type(attribute ? H5Aget_type(attribute.get()) : H5I_INVALID_HID);
  return type && H5Tget_class(type.get()) == H5T_STRING && H5Tis_variable_str(type.get()) > 0;
}

Datatype utf8_string_type(std::size_t size) {
  Datatype type(H5Tcopy(H5T_C_S1));
  if (!type || H5Tset_size(type.get(), std::max<std::size_t>(size, 1)) < 0 ||
      H5Tset_strpad(type.get(), H5T_STR_NULLPAD) < 0 || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0)
    return {};
  return type;
}

namespace {

bool write_attribute(hid_t object, const char* name, hid_t file_type, hid_t memory_type,
                     const void* value) {
  if (H5Aexists(object, name) > 0 && H5Adelete(object, name) < 0) return false;
  const Dataspace space(H5Screate(H5S_SCALAR));
  if (!space) return false;
  const Attribute attribute(
      H5Acreate2(object, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT));
  return attribute && H5Awrite(attribute.get(), memory_type, value) >= 0;
}

// Reads every element of a fixed-length string attribute or dataset, whose type and space are
// given, with `read(memory_type, buffer)`. Variable-length strings are refused before HDF5 reads
// them: their bytes live in the file's global heap, whose decoding in libhdf5 1.10 crashes and
// hangs on damaged files (docs/reliability.md).
template <class Read>
std::optional<std::vector<std::string>> read_strings(hid_t file_type, hid_t space, Read read) {
  if (H5Tget_class(file_type) != H5T_STRING || H5Tis_variable_str(file_type) != 0)
    return std::nullopt;
  const hssize_t count = H5Sget_simple_extent_npoints(space);
  const std::size_t size = H5Tget_size(file_type);
  if (count < 0 || size == 0 || size > kMaxStringBytes ||
      std::size_t(count) > kMaxStringBytes / size)
    return std::nullopt;
  std::vector<std::string> out(static_cast<std::size_t>(count));
  // A memory type of the file's size, character set and padding: HDF5 copies the bytes as stored.
  const Datatype memory_type(H5Tcopy(H5T_C_S1));
  if (!memory_type || H5Tset_size(memory_type.get(), size) < 0 ||
      H5Tset_cset(memory_type.get(), H5Tget_cset(file_type)) < 0 ||
      H5Tset_strpad(memory_type.get(), H5Tget_strpad(file_type)) < 0)
    return std::nullopt;
  std::vector<char> buffer(size * out.size() + 1, '\0');
  if (!read(memory_type.get(), buffer.data())) return std::nullopt;
  for (std::size_t i = 0; i < out.size(); ++i) {
    const char* text = buffer.data() + i * size;
    std::size_t length = std::find(text, text + size, '\0') - text;
    while (length > 0 && H5Tget_strpad(file_type) == H5T_STR_SPACEPAD && text[length - 1] == ' ')
      --length;
    out[i].assign(text, length);
  }
  return out;
}

}  // namespace

bool write_string_attribute(hid_t object, const char* name, std::string_view value) {
  const Datatype type = utf8_string_type(value.size());
  std::string text(value);
  text.resize(std::max<std::size_t>(text.size(), 1), '\0');  // "" is one NUL: no size-0 type
  return type && write_attribute(object, name, type.get(), type.get(), text.data());
}

bool write_int_attribute(hid_t object, const char* name, int value) {
  return write_attribute(object, name, H5T_STD_I32LE, H5T_NATIVE_INT, &value);
}

bool write_double_attribute(hid_t object, const char* name, double value) {
  return write_attribute(object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value);
}

std::optional<std::string> read_string_attribute(hid_t object, const char* name) {
  if (H5Aexists(object, name) <= 0) return std::nullopt;
  const Attribute attribute(H5Aopen(object, name, H5P_DEFAULT));
  if (!attribute) return std::nullopt;
  const Datatype type(H5Aget_type(attribute.get()));
  const Dataspace space(H5Aget_space(attribute.get()));
  if (!type || !space) return std::nullopt;
  auto strings = read_strings(type.get(), space.get(), [&](hid_t memory_type, void* buffer) {
    return H5Aread(attribute.get(), memory_type, buffer) >= 0;
  });
  if (!strings || strings->size() != 1) return std::nullopt;
  return std::move(strings->front());
}

namespace {

template <class T>
std::optional<T> read_number_attribute(hid_t object, const char* name, H5T_class_t wanted,
                                       hid_t memory_type) {
  if (H5Aexists(object, name) <= 0) return std::nullopt;
  const Attribute attribute(H5Aopen(object, name, H5P_DEFAULT));
  if (!attribute) return std::nullopt;
  const Datatype type(H5Aget_type(attribute.get()));
  const Dataspace space(H5Aget_space(attribute.get()));
  if (!type || !space || H5Tget_class(type.get()) != wanted ||
      H5Sget_simple_extent_npoints(space.get()) != 1)
    return std::nullopt;
  T value{};
  if (H5Aread(attribute.get(), memory_type, &value) < 0) return std::nullopt;
  return value;
}

}  // namespace

std::optional<long long> read_int_attribute(hid_t object, const char* name) {
  return read_number_attribute<long long>(object, name, H5T_INTEGER, H5T_NATIVE_LLONG);
}

std::optional<double> read_double_attribute(hid_t object, const char* name) {
  return read_number_attribute<double>(object, name, H5T_FLOAT, H5T_NATIVE_DOUBLE);
}

bool write_string_dataset(hid_t group, const char* name, const std::vector<std::string>& values) {
  std::size_t size = 1;
  for (const auto& v : values) size = std::max(size, v.size());
  const Datatype type = utf8_string_type(size);
  if (!type) return false;
  std::vector<char> bytes(size * values.size(), '\0');
  for (std::size_t i = 0; i < values.size(); ++i)
    std::copy(values[i].begin(), values[i].end(), bytes.begin() + i * size);
  const hsize_t dims[1] = {values.size()};
  return write_dataset(group, name, type.get(), type.get(), dims, bytes.data());
}

std::optional<std::vector<std::string>> read_string_dataset(hid_t group, const char* name) {
  if (!link_exists(group, name)) return std::nullopt;
  const Dataset dataset(H5Dopen2(group, name, H5P_DEFAULT));
  if (!dataset) return std::nullopt;
  const Datatype type(H5Dget_type(dataset.get()));
  const Dataspace space(H5Dget_space(dataset.get()));
  if (!type || !space || H5Sget_simple_extent_ndims(space.get()) != 1) return std::nullopt;
  return read_strings(type.get(), space.get(), [&](hid_t memory_type, void* buffer) {
    return H5Dread(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer) >= 0;
  });
}

bool write_dataset(hid_t group, const char* name, hid_t file_type, hid_t memory_type,
                   std::span<const hsize_t> dims, const void* data) {
  const Dataspace space(H5Screate_simple(int(dims.size()), dims.data(), nullptr));
  if (!space) return false;
  const Dataset dataset(
      H5Dcreate2(group, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!dataset) return false;
  const bool empty = std::any_of(dims.begin(), dims.end(), [](hsize_t d) { return d == 0; });
  return empty || H5Dwrite(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0;
}

std::optional<std::vector<hsize_t>> dataset_dims(hid_t dataset) {
  const Dataspace space(H5Dget_space(dataset));
  if (!space) return std::nullopt;
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) return std::nullopt;
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0)
    return std::nullopt;
  return dims;
}

namespace {

std::string shape(const std::vector<hsize_t>& dims) {
  std::string out = "[";
  for (std::size_t i = 0; i < dims.size(); ++i) out += (i ? ", " : "") + std::to_string(dims[i]);
  return out + "]";
}

}  // namespace

bool for_each_chunk(const std::vector<hsize_t>& dims, const std::vector<hsize_t>& chunk,
                    const std::function<bool(const hsize_t* offset)>& visit) {
  std::vector<hsize_t> offset(dims.size(), 0);
  if (std::any_of(dims.begin(), dims.end(), [](hsize_t d) { return d == 0; })) return true;
  while (true) {
    if (!visit(offset.data())) return false;
    // The next offset, last axis fastest (HDF5's order of chunk coordinates).
    std::size_t axis = dims.size();
    while (axis > 0) {
      --axis;
      offset[axis] += chunk[axis];
      if (offset[axis] < dims[axis]) break;
      offset[axis] = 0;
      if (axis == 0) return true;
    }
    if (dims.empty()) return true;
  }
}

namespace {

// Not H5Pget_filter_by_id2: for an absent filter it pushes an error onto HDF5's stack, which
// the next with_detail() would then report as the cause of an unrelated failure.
bool has_filter(hid_t properties, H5Z_filter_t wanted) {
  const int count = H5Pget_nfilters(properties);
  for (int i = 0; i < count; ++i) {
    unsigned flags = 0;
    std::size_t values = 0;
    if (H5Pget_filter2(properties, unsigned(i), &flags, &values, nullptr, 0, nullptr, nullptr) ==
        wanted)
      return true;
  }
  return false;
}

}  // namespace

std::string check_storage(hid_t dataset, const std::vector<hsize_t>& dims) {
  hsize_t elements = 1;
  for (hsize_t d : dims) elements *= d;
  if (elements == 0) return {};
  const PropertyList properties(H5Dget_create_plist(dataset));
  if (!properties) return with_detail("cannot read its creation properties");
  if (H5Pget_external_count(properties.get()) != 0) return "its data lives in external files";
  switch (H5Pget_layout(properties.get())) {
    case H5D_COMPACT:  // held in the object header itself, under 64 KiB
    // libhdf5 1.10 copies a compact dataset's elements out of the buffer its layout message
    // holds without comparing their sizes: a buffer shorter than the data overflowed (a fuzz
    // finding), so the same check as contiguous storage.
    case H5D_CONTIGUOUS: {
      const Datatype type(H5Dget_type(dataset));
      const std::size_t size = type ? H5Tget_size(type.get()) : 0;
      const hsize_t stored = H5Dget_storage_size(dataset);
      if (size == 0 || stored < elements * size)
        return "the file stores " + std::to_string(stored) + " of its " +
               std::to_string(elements * size) + " bytes";
      return {};
    }
    case H5D_CHUNKED: {
      const int rank = int(dims.size());
      std::vector<hsize_t> chunk(dims.size());
      if (H5Pget_chunk(properties.get(), rank, chunk.data()) != rank)
        return with_detail("cannot read its chunk shape");
      const Datatype type(H5Dget_type(dataset));
      const hsize_t size = type ? H5Tget_size(type.get()) : 0;
      if (size == 0) return with_detail("cannot read its element type");
      // HDF5 allocates a whole chunk to decode one: a chunk shape is bounded by the data (a
      // small dataset may have a chunk of up to kMaxChunkBytesOfSmallData), so a 5-frame
      // clip cannot claim a 4 GiB chunk.
      hsize_t chunk_bytes = size;
      for (hsize_t c : chunk) {
        if (c == 0) return "its chunk shape has a zero extent";
        chunk_bytes = c > kMaxChunkBytes / chunk_bytes ? kMaxChunkBytes + 1 : chunk_bytes * c;
      }
      const hsize_t data_bytes = elements * size;
      if (chunk_bytes > std::max(data_bytes, kMaxChunkBytesOfSmallData))
        return "its chunks of " + shape(chunk) + " (" + std::to_string(chunk_bytes) +
               " bytes) are larger than its data (" + std::to_string(data_bytes) + " bytes)";
      hsize_t expected = 1;
      for (int i = 0; i < rank; ++i)
        expected *= (dims[std::size_t(i)] + chunk[std::size_t(i)] - 1) / chunk[std::size_t(i)];
      hsize_t stored = 0;
      const Dataspace space(H5Dget_space(dataset));
      if (!space || H5Dget_num_chunks(dataset, space.get(), &stored) < 0)
        return with_detail("cannot count its chunks");
      if (stored != expected)
        return "the file stores " + std::to_string(stored) + " of its " + std::to_string(expected) +
               " chunks (a shape larger than its data)";
      // HDF5 allocates a chunk's stored size, as its index records it, before it reads it.
      const File file(H5Iget_file_id(dataset));
      hsize_t file_size = 0;
      if (!file || H5Fget_filesize(file.get(), &file_size) < 0)
        return with_detail("cannot read the size of its file");
      // libhdf5 1.10's Fletcher-32 filter takes the checksum off the chunk's end unchecked: a
      // chunk stored shorter than the checksum reads the whole address space (a fuzz finding).
      const bool fletcher = has_filter(properties.get(), H5Z_FILTER_FLETCHER32);
      const hsize_t least = fletcher ? 4 : 0;
      // Unfiltered chunks (or checksummed only) are stored whole: HDF5 copies a chunk's bytes
      // out of the buffer it read without comparing the two sizes (a short one overflowed, a
      // fuzz finding).
      const int filters = H5Pget_nfilters(properties.get());
      const hsize_t exact = filters == 0               ? chunk_bytes
                            : filters == 1 && fletcher ? chunk_bytes + 4
                                                       : 0;
      std::string problem;
      for_each_chunk(dims, chunk, [&](const hsize_t* offset) {
        hsize_t bytes = 0;
        if (H5Dget_chunk_storage_size(dataset, offset, &bytes) < 0) {
          problem = with_detail("cannot find its chunk at " +
                                shape(std::vector<hsize_t>(offset, offset + rank)));
        } else if (exact != 0 && bytes != exact) {
          problem = "its chunk at " + shape(std::vector<hsize_t>(offset, offset + rank)) +
                    " stores " + std::to_string(bytes) + " bytes where a chunk of it holds " +
                    std::to_string(exact);
        } else if (bytes < least) {
          problem = "its chunk at " + shape(std::vector<hsize_t>(offset, offset + rank)) +
                    " stores " + std::to_string(bytes) +
                    " bytes, fewer than its Fletcher-32 checksum's 4";
        } else if (bytes > file_size) {
          problem = "its chunk at " + shape(std::vector<hsize_t>(offset, offset + rank)) +
                    " claims " + std::to_string(bytes) + " stored bytes, more than the file's " +
                    std::to_string(file_size);
        }
        return problem.empty();
      });
      if (!problem.empty()) return problem;
      // The index may contradict itself (a single chunk's size implied whole, its storage size
      // short): both must agree.
      if (exact != 0 && H5Dget_storage_size(dataset) != stored * exact)
        return "the file stores " + std::to_string(H5Dget_storage_size(dataset)) + " of its " +
               std::to_string(stored * exact) + " bytes of chunks";
      return {};
    }
    default:
      return "its storage layout is unknown";
  }
}

bool read_dataset(hid_t group, const char* name, hid_t memory_type, std::size_t count, void* out) {
  if (!link_exists(group, name)) return false;
  const Dataset dataset(H5Dopen2(group, name, H5P_DEFAULT));
  if (!dataset) return false;
  const Dataspace space(H5Dget_space(dataset.get()));
  if (!space || H5Sget_simple_extent_npoints(space.get()) != hssize_t(count)) return false;
  return count == 0 || H5Dread(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out) >= 0;
}

PropertyList motion_dataset_properties(Compression compression, bool checksum,
                                       const hsize_t chunk[3]) {
  PropertyList properties(H5Pcreate(H5P_DATASET_CREATE));
  if (!properties || H5Pset_chunk(properties.get(), 3, chunk) < 0) return {};
  // The padding of a clip's last, partial chunk is written as zeros, so the stored bytes depend
  // on the clip alone (and encode_clip() can reproduce them).
  if (H5Pset_fill_time(properties.get(), H5D_FILL_TIME_ALLOC) < 0) return {};
  bool ok = true;
  switch (compression) {
    case Compression::none:
      break;
    case Compression::lz4:
      ok = H5Pset_shuffle(properties.get()) >= 0 &&
           H5Pset_filter(properties.get(), H5Z_filter_t(kLz4FilterId), H5Z_FLAG_MANDATORY, 0,
                         nullptr) >= 0;
      break;
    case Compression::deflate:
      ok = H5Pset_shuffle(properties.get()) >= 0 &&
           H5Pset_deflate(properties.get(), unsigned(kDeflateLevel)) >= 0;
      break;
  }
  if (!ok || (checksum && H5Pset_fletcher32(properties.get()) < 0)) return {};
  return properties;
}

}  // namespace mocap::io::h5
