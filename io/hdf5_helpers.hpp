#pragma once
// The HDF5 chores of the library store: quiet error handling with our own messages, string and
// scalar attributes, small datasets, and the creation properties of the motion datasets.
// Internal to io/library_*.cpp; every function here is called from one thread at a time.
#include <hdf5.h>

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "io/compression.hpp"
#include "io/hdf5_handle.hpp"

namespace mocap::io::h5 {

// Keeps HDF5 from printing its error stack while alive (restores the previous handler after);
// errors are still recorded, so last_error_detail() can quote them.
class ErrorSilence {
 public:
  ErrorSilence();
  ~ErrorSilence();
  ErrorSilence(const ErrorSilence&) = delete;
  ErrorSilence& operator=(const ErrorSilence&) = delete;

 private:
  H5E_auto2_t function_ = nullptr;
  void* data_ = nullptr;
};

// The innermost message of HDF5's current error stack ("" if none); clears the stack.
std::string last_error_detail();
// `message`, followed by ": " and last_error_detail() when HDF5 recorded one.
std::string with_detail(std::string message);

bool link_exists(hid_t location, const std::string& name);  // one path component
// Whether `object` has an attribute `name` of variable-length strings (which nothing here reads).
bool has_variable_string_attribute(hid_t object, const char* name);

// Fixed-length UTF-8 of `size` bytes (at least 1), NUL-padded: what h5py writes for numpy's
// "S" strings. The library holds no variable-length strings (see read_strings in the .cpp).
Datatype utf8_string_type(std::size_t size);
// The most bytes a string attribute or dataset may hold, all elements together.
inline constexpr std::size_t kMaxStringBytes = std::size_t(16) << 20;
bool write_string_attribute(hid_t object, const char* name, std::string_view value);
bool write_int_attribute(hid_t object, const char* name, int value);
bool write_double_attribute(hid_t object, const char* name, double value);
// Nullopt when absent, of another class, variable-length or over kMaxStringBytes.
std::optional<std::string> read_string_attribute(hid_t object, const char* name);
std::optional<long long> read_int_attribute(hid_t object, const char* name);
std::optional<double> read_double_attribute(hid_t object, const char* name);

bool write_string_dataset(hid_t group, const char* name, const std::vector<std::string>& values);
// A 1-D fixed-length string dataset; nullopt when absent, not such strings or too large.
std::optional<std::vector<std::string>> read_string_dataset(hid_t group, const char* name);
bool write_dataset(hid_t group, const char* name, hid_t file_type, hid_t memory_type,
                   std::span<const hsize_t> dims, const void* data);
// Dimensions of a dataset; nullopt if it cannot be queried.
std::optional<std::vector<hsize_t>> dataset_dims(hid_t dataset);
// Why reading the whole of `dataset` (of `dims`, the caller has them) would allocate more than
// the file holds for it, or "": a chunked dataset must have every chunk stored, a contiguous one
// all its bytes. HDF5 hands out the fill value for what is missing, so without this a few bytes
// claiming millions of frames would cost gigabytes of memory. A chunk may be no larger than the
// data (or kMaxChunkBytesOfSmallData), and no stored chunk larger than the file: HDF5 allocates
// both sizes as the file states them before it reads a chunk.
std::string check_storage(hid_t dataset, const std::vector<hsize_t>& dims);
inline constexpr hsize_t kMaxChunkBytesOfSmallData = hsize_t(1) << 20;
inline constexpr hsize_t kMaxChunkBytes = hsize_t(1) << 32;  // HDF5 1.10's own chunk limit
// Calls `visit` with the offset of every chunk of a dataset of `dims` in chunks of `chunk` (both
// non-zero), in HDF5's order, until it returns false; false then.
bool for_each_chunk(const std::vector<hsize_t>& dims, const std::vector<hsize_t>& chunk,
                    const std::function<bool(const hsize_t* offset)>& visit);
// Reads a whole numeric dataset of `count` elements converted to `memory_type`.
bool read_dataset(hid_t group, const char* name, hid_t memory_type, std::size_t count, void* out);

// Creation properties of a [frames][joints][channels] float32 motion dataset: chunks of
// chunk_frames() frames (io/compression.hpp), filtered for `compression`, then, with
// `checksum`, by Fletcher-32 (which HDF5 verifies on every read of a chunk).
PropertyList motion_dataset_properties(Compression compression, bool checksum,
                                       const hsize_t chunk[3]);

}  // namespace mocap::io::h5
