// libFuzzer target for the library reader. The input does not feed HDF5's own parser (that is
// Debian's libhdf5, not this project); it drives a builder that makes a well-formed HDF5 file
// with hostile contents: shapes that disagree or exceed what is stored, NaN, infinite and
// non-unit values, parent cycles, several roots, empty and repeated names, unknown channels,
// missing or misplaced objects, links to nowhere and loops. The reader must report every such
// clip with an error (never crash, never allocate beyond what the file holds: -rss_limit_mb),
// and every clip it reads and validates must be one export writes and import reads back.
#include <hdf5.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "io/clip_validation.hpp"
#include "io/library_reader.hpp"

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "finding: %s: %s\n", what, detail.c_str());
  std::abort();
}

class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : p_(data), end_(data + size) {}
  bool empty() const { return p_ == end_; }
  unsigned byte() { return p_ == end_ ? 0u : *p_++; }
  float special_float() {
    static const float values[] = {0.0f,
                                   1.0f,
                                   -1.0f,
                                   0.5f,
                                   std::nanf(""),
                                   std::numeric_limits<float>::infinity(),
                                   -std::numeric_limits<float>::infinity(),
                                   1e30f,
                                   FLT_MAX,
                                   1e-40f,
                                   -0.0f,
                                   0.70710678f};
    return values[byte() % (sizeof values / sizeof values[0])];
  }
  double special_double() {
    static const double values[] = {
        0.0,   1.0,    -1.0,    1.0 / 120, std::nan(""), std::numeric_limits<double>::infinity(),
        1e300, -1e300, DBL_MAX, 1e-310,    3.5e38,       2.5};
    return values[byte() % (sizeof values / sizeof values[0])];
  }
  hsize_t extent() {
    static const hsize_t values[] = {0,          1, 2, 3, 4, 5, 7, 1000, 1u << 20, 2'000'000'000ull,
                                     1ull << 40, 3};
    return values[byte() % (sizeof values / sizeof values[0])];
  }
  std::string name() {
    static const char letters[] = {'a', 'B', ' ', '\n', '{', '/', '.', '\t'};
    std::string out;
    for (unsigned n = byte() % 4; n > 0; --n) out += letters[byte() % sizeof letters];
    return out;
  }

 private:
  const std::uint8_t* p_;
  const std::uint8_t* end_;
};

// Fixed-length UTF-8 of `size` bytes as the library holds them, or variable-length strings
// (size 0), which the reader must refuse unread.
hid_t string_type(std::size_t size) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, size == 0 ? H5T_VARIABLE : size);
  H5Tset_cset(type, H5T_CSET_UTF8);
  return type;
}

// The bytes to write for `values` in a type of string_type(size); `pointers` (for variable-length
// strings) point into `values`.
std::vector<char> string_bytes(const std::vector<std::string>& values, std::size_t size,
                               std::vector<const char*>& pointers) {
  std::vector<char> bytes(size * values.size(), '\0');
  for (std::size_t i = 0; i < values.size(); ++i) {
    pointers.push_back(values[i].c_str());
    if (size > 0)
      std::copy_n(values[i].begin(), std::min(size, values[i].size()), bytes.begin() + i * size);
  }
  return bytes;
}

std::size_t longest(const std::vector<std::string>& values) {
  std::size_t size = 1;
  for (const auto& v : values) size = std::max(size, v.size());
  return size;
}

void remove(hid_t file, const std::string& path) {
  if (H5Lexists(file, path.c_str(), H5P_DEFAULT) > 0) H5Ldelete(file, path.c_str(), H5P_DEFAULT);
}

void put_strings(hid_t file, const std::string& path, const std::vector<std::string>& values,
                 bool variable = false) {
  remove(file, path);
  const std::size_t size = variable ? 0 : longest(values);
  const hid_t type = string_type(size);
  std::vector<const char*> pointers;
  const std::vector<char> bytes = string_bytes(values, size, pointers);
  const void* data = variable ? static_cast<const void*>(pointers.data()) : bytes.data();
  const hsize_t dims[1] = {values.size()};
  const hid_t space = H5Screate_simple(1, dims, nullptr);
  const hid_t d =
      H5Dcreate2(file, path.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (d >= 0 && !values.empty()) H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
  if (d >= 0) H5Dclose(d);
  H5Sclose(space);
  H5Tclose(type);
}

// A dataset of `dims`; with `chunked` stored in chunks of up to 4 along the first axis and 64
// along the others; written in full from `values` (repeated) when small and not `sparse`; else,
// when chunked, one element (one chunk) stored; else nothing stored. The chunk is bounded because
// HDF5 allocates a chunk's file space whole: a chunk as wide as a 2^40 axis made the in-memory
// file grow to terabytes (ASan refused a 4-24 TB realloc in H5FD_truncate under H5Fflush, in
// this builder, before the reader ever ran).
void put_numbers(hid_t file, const std::string& path, hid_t file_type, hid_t memory_type,
                 std::vector<hsize_t> dims, const std::vector<double>& values, bool chunked,
                 bool sparse) {
  remove(file, path);
  hsize_t count = 1;
  for (hsize_t d : dims) count *= d;
  const hid_t space = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
  if (space < 0) return;
  const hid_t properties = H5Pcreate(H5P_DATASET_CREATE);
  if (chunked && count > 0) {
    std::vector<hsize_t> chunk = dims;
    for (hsize_t& c : chunk) c = std::clamp<hsize_t>(c, 1, 64);
    chunk[0] = std::min<hsize_t>(chunk[0], 4);
    H5Pset_chunk(properties, int(chunk.size()), chunk.data());
  }
  const hid_t d =
      H5Dcreate2(file, path.c_str(), file_type, space, H5P_DEFAULT, properties, H5P_DEFAULT);
  if (d >= 0 && count > 0 && count <= 4096 && !sparse) {
    std::vector<double> data(count);
    for (hsize_t i = 0; i < count; ++i) data[i] = values.empty() ? 0.0 : values[i % values.size()];
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data());
  } else if (d >= 0 && count > 0 && chunked) {
    // One chunk stored of a huge shape (a contiguous one would be allocated whole: gigabytes).
    const double one = 1.0;
    std::vector<hsize_t> start(dims.size(), 0), single(dims.size(), 1);
    const hid_t memory = H5Screate_simple(1, single.data(), nullptr);
    H5Sselect_hyperslab(space, H5S_SELECT_SET, start.data(), nullptr, single.data(), nullptr);
    H5Dwrite(d, H5T_NATIVE_DOUBLE, memory, space, H5P_DEFAULT, &one);
    H5Sclose(memory);
  }
  (void)memory_type;
  if (d >= 0) H5Dclose(d);
  H5Pclose(properties);
  H5Sclose(space);
}

void put_attribute(hid_t file, const std::string& object, const char* name, hid_t type,
                   const void* value) {
  const hid_t o = H5Oopen(file, object.c_str(), H5P_DEFAULT);
  if (o < 0) return;
  if (H5Aexists(o, name) > 0) H5Adelete(o, name);
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate2(o, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  if (a >= 0) {
    H5Awrite(a, type, value);
    H5Aclose(a);
  }
  H5Sclose(space);
  H5Oclose(o);
}

void put_string_attribute(hid_t file, const std::string& object, const char* name,
                          const std::string& value, bool variable = false) {
  const std::size_t size = variable ? 0 : std::max<std::size_t>(value.size(), 1);
  const hid_t type = string_type(size);
  const std::vector<std::string> values{value};  // alive while `pointers` point into it
  std::vector<const char*> pointers;
  const std::vector<char> bytes = string_bytes(values, size, pointers);
  put_attribute(file, object, name, type,
                variable ? static_cast<const void*>(pointers.data()) : bytes.data());
  H5Tclose(type);
}

void group(hid_t file, const std::string& path) {
  const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  const hid_t g = H5Gcreate2(file, path.c_str(), lcpl, H5P_DEFAULT, H5P_DEFAULT);
  if (g >= 0) H5Gclose(g);
  H5Pclose(lcpl);
}

const char* const kClips[] = {"/clips/c0", "/clips/d/c1", "/clips/d/e/c2"};
const char* const kChannelLists[] = {"Zrotation Xrotation Yrotation",
                                     "Xposition Yposition Zposition Zrotation Xrotation Yrotation",
                                     "",
                                     "Xrotation",
                                     "Zrotation Zrotation Yrotation",
                                     "Wrotation",
                                     "Xposition Yposition Zposition"};

// Builds the library in memory; returns its bytes.
std::vector<std::uint8_t> build(Bytes& in) {
  const hid_t access = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_fapl_core(access, 1 << 16, 0);
  const hid_t file = H5Fcreate("fuzz.h5", H5F_ACC_TRUNC, H5P_DEFAULT, access);
  H5Pclose(access);
  std::vector<std::uint8_t> image;
  if (file < 0) return image;
  put_string_attribute(file, "/", "format", "mocap-clean-library");
  const int version = 2;
  put_attribute(file, "/", "format_version", H5T_NATIVE_INT, &version);
  const int joints = 1 + int(in.byte() % 5);
  const hsize_t J = hsize_t(joints);
  group(file, "/skeletons/S");
  std::vector<std::string> names;
  std::vector<double> parents, offsets, channels_unused;
  std::vector<std::string> channels;
  for (int j = 0; j < joints; ++j) {
    names.push_back("J" + std::to_string(j));
    parents.push_back(j - 1);
    channels.push_back(kChannelLists[j == 0 ? 1 : 0]);
    for (int c = 0; c < 3; ++c) offsets.push_back(c + j);
  }
  put_strings(file, "/skeletons/S/joint_names", names);
  put_numbers(file, "/skeletons/S/parents", H5T_STD_I32LE, 0, {J}, parents, false, false);
  put_numbers(file, "/skeletons/S/offsets", H5T_IEEE_F64LE, 0, {J, 3}, offsets, false, false);
  put_strings(file, "/skeletons/S/channels", channels);
  put_numbers(file, "/skeletons/S/end_sites", H5T_IEEE_F64LE, 0, {J, 3}, {0.0, 1.0, 0.0}, false,
              false);
  put_numbers(file, "/skeletons/S/has_end_site", H5T_STD_U8LE, 0, {J}, {1.0}, false, false);
  const int clips = 1 + int(in.byte() % 3);
  for (int c = 0; c < clips; ++c) {
    const std::string path = kClips[c];
    group(file, path);
    put_string_attribute(file, path, "skeleton", "S");
    const double frame_time = 1.0 / 120;
    put_attribute(file, path, "frame_time", H5T_NATIVE_DOUBLE, &frame_time);
    const hsize_t F = in.byte() % 6;
    put_numbers(file, path + "/rotations", H5T_IEEE_F32LE, 0, {F, J, 4}, {1, 0, 0, 0}, true, false);
    put_numbers(file, path + "/translations", H5T_IEEE_F32LE, 0, {F, J, 3}, {0, 1, 2}, true, false);
  }
  // The damage, one operation per few input bytes.
  for (int ops = 0; !in.empty() && ops < 12; ++ops) {
    const std::string clip = kClips[in.byte() % 3];
    switch (in.byte() % 16) {
      case 0:
      case 1: {  // other values (and shapes) for a motion dataset
        const bool rotations = in.byte() % 2;
        std::vector<double> values;
        for (int k = in.byte() % 5 + 1; k > 0; --k) values.push_back(in.special_float());
        std::vector<hsize_t> dims = {in.extent(), in.byte() % 3 ? J : in.extent(),
                                     in.byte() % 4 ? hsize_t(rotations ? 4 : 3) : in.extent()};
        if (in.byte() % 4 == 0) dims.pop_back();
        const unsigned how = in.byte();
        put_numbers(file, clip + (rotations ? "/rotations" : "/translations"), H5T_IEEE_F32LE, 0,
                    dims, values, how % 2, how % 3 == 0);
        break;
      }
      case 2: {
        std::vector<double> p = parents;
        p[in.byte() % joints] = double(int(in.byte()) % 8 - 3);
        put_numbers(file, "/skeletons/S/parents", H5T_STD_I32LE, 0,
                    {in.byte() % 4 ? J : in.extent()}, p, false, false);
        break;
      }
      case 3: {
        std::vector<double> o = offsets;
        o[in.byte() % o.size()] = in.special_double();
        put_numbers(file, "/skeletons/S/offsets", H5T_IEEE_F64LE, 0, {J, 3}, o, false, false);
        break;
      }
      case 4: {
        std::vector<std::string> n = names;
        n[in.byte() % joints] = in.byte() % 2 ? in.name() : n[in.byte() % joints];
        const std::uint8_t how = in.byte();
        if (how % 5 == 0) n.pop_back();
        put_strings(file, "/skeletons/S/joint_names", n, how % 7 == 6);
        break;
      }
      case 5: {
        std::vector<std::string> ch = channels;
        ch[in.byte() % joints] = kChannelLists[in.byte() % 7];
        put_strings(file, "/skeletons/S/channels", ch);
        break;
      }
      case 6: {
        const double t = in.special_double();
        put_attribute(file, clip, "frame_time", H5T_NATIVE_DOUBLE, &t);
        break;
      }
      case 7: {
        static const char* const parts[] = {"/rotations", "/translations", ""};
        const unsigned which = in.byte() % 6;
        if (which < 3) remove(file, clip + parts[which]);
        if (which == 3) remove(file, "/skeletons");
        if (which == 4) remove(file, "/skeletons/S/offsets");
        if (which == 5) {
          const hid_t o = H5Oopen(file, clip.c_str(), H5P_DEFAULT);
          if (o >= 0) {
            H5Adelete(o, in.byte() % 2 ? "skeleton" : "frame_time");
            H5Oclose(o);
          }
        }
        break;
      }
      case 8:  // a dataset where the clip group was
        remove(file, clip);
        put_numbers(file, clip, H5T_IEEE_F32LE, 0, {3}, {1.0}, false, false);
        break;
      case 9:  // an emptied clip group, or an empty folder
        remove(file, clip);
        group(file, in.byte() % 2 ? clip : "/clips/empty/folder");
        break;
      case 10:
        H5Lcreate_soft(in.byte() % 2 ? "/clips" : "/nowhere", file, "/clips/link", H5P_DEFAULT,
                       H5P_DEFAULT);
        break;
      case 11:
        H5Lcreate_external("missing.h5", "/clips/x", file, "/clips/external", H5P_DEFAULT,
                           H5P_DEFAULT);
        break;
      case 12:
        put_numbers(file, "/skeletons/S/end_sites", H5T_IEEE_F64LE, 0,
                    {in.byte() % 3 ? J : J + 1, 3}, {in.special_double()}, false, false);
        break;
      case 13: {
        const std::uint8_t how = in.byte();
        put_string_attribute(file, clip, "skeleton", how % 2 ? "T" : in.name(), how % 4 == 3);
        break;
      }
      case 14: {
        const int v = int(in.byte() % 4);
        put_attribute(file, "/", "format_version", H5T_NATIVE_INT, &v);
        break;
      }
      default:
        put_numbers(file, clip + "/rotations", H5T_IEEE_F64LE, 0, {2, J, 4},
                    {in.special_double(), 0, 0, 0}, true, false);
        break;
    }
  }
  H5Fflush(file, H5F_SCOPE_GLOBAL);
  const ssize_t size = H5Fget_file_image(file, nullptr, 0);
  if (size > 0) {
    image.resize(std::size_t(size));
    if (H5Fget_file_image(file, image.data(), image.size()) != size) image.clear();
  }
  H5Fclose(file);
  return image;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // As in library_image_fuzz: with HDF5's free lists capped at 64 KiB each, every file built
  // and opened took fresh, zeroed pages for its metadata cache from malloc (perf: over half of
  // each input's time in page faults and memset under H5FL_reg_calloc). Unlimited lists reuse
  // them.
  H5set_free_list_limits(-1, -1, -1, -1, -1, -1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mocap::io;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Bytes in(data, size);
  const std::vector<std::uint8_t> image = build(in);
  if (image.empty()) return 0;
  std::string error;
  const auto reader = LibraryReader::open_image(image, "fuzz.h5", &error);
  if (!reader) {
    if (error.find("fuzz.h5") == std::string::npos) finding("error names no file", error);
    return 0;
  }
  for (const ClipHeader& header : reader->clips()) {
    if (!header.error.empty()) {
      if (header.error.find("fuzz.h5") == std::string::npos) finding("unnamed", header.error);
      continue;
    }
    auto clip = reader->read_clip(header.path, &error);
    if (!clip) {
      if (error.find(header.path) == std::string::npos) finding("error names no clip", error);
      continue;
    }
    if (!validate_clip(*clip).empty()) continue;
    // What info --check and filter accept, export must write and import must read back.
    if (std::string why = check_clip_for_bvh(*clip); !why.empty())
      finding("export refuses a valid clip", why);
    const BvhReadResult again = parse_bvh(format_bvh(*clip), "export.bvh");
    if (!again.clip) finding("import refuses what export wrote", again.error->what());
  }
  return 0;
}
