#include "io/library_reader.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <map>
#include <new>
#include <set>
#include <sstream>
#include <utility>

#include "io/bvh_reader.hpp"
#include "io/chunk_codec.hpp"
#include "io/clip_encoder.hpp"
#include "io/clip_validation.hpp"
#include "io/hdf5_handle.hpp"
#include "io/hdf5_helpers.hpp"

namespace mocap::io {

namespace detail {

struct LibraryReaderState {
  std::filesystem::path path;
  h5::File file;
  std::vector<ClipHeader> clips;
  std::map<std::string, std::shared_ptr<const Skeleton>> skeletons;  // read so far, by name

  std::string message(const std::string& text) const { return path.string() + ": " + text; }
  bool fail(std::string* error, const std::string& text) const {
    if (error) *error = message(text);
    return false;
  }
};

}  // namespace detail

using State = detail::LibraryReaderState;

namespace {

std::string shape_text(const std::vector<hsize_t>& dims) {
  std::string out = "[";
  for (std::size_t i = 0; i < dims.size(); ++i) out += (i ? ", " : "") + std::to_string(dims[i]);
  return out + "]";
}

bool is_valid_name(const std::string& name) {
  return !name.empty() && name != "." && name != ".." && name.find('/') == std::string::npos;
}

// The shape of dataset `name` of a clip group, or a problem. Checks it is float and rank 3.
std::optional<std::vector<hsize_t>> motion_dims(hid_t clip, const char* name,
                                                std::string* problem) {
  if (!h5::link_exists(clip, name)) {
    *problem = std::string("it has no '") + name + "' dataset";
    return std::nullopt;
  }
  const h5::Dataset dataset(H5Dopen2(clip, name, H5P_DEFAULT));
  const h5::Datatype type(dataset ? H5Dget_type(dataset.get()) : H5I_INVALID_HID);
  auto dims = dataset ? h5::dataset_dims(dataset.get()) : std::nullopt;
  if (!dataset || !type || !dims) {
    *problem = h5::with_detail(std::string("cannot open its '") + name + "' dataset");
    return std::nullopt;
  }
  if (H5Tget_class(type.get()) != H5T_FLOAT) {
    *problem = std::string("its '") + name + "' dataset is not floating point";
    return std::nullopt;
  }
  if (dims->size() != 3) {
    *problem = std::string("its '") + name + "' dataset has shape " + shape_text(*dims) +
               "; expected rank 3";
    return std::nullopt;
  }
  // Bounded before anything is allocated: a shape is only a number in the file.
  if ((*dims)[0] > hsize_t(INT_MAX) || (*dims)[1] > hsize_t(kMaxBvhJoints) || (*dims)[2] > 4 ||
      (*dims)[0] * (*dims)[1] > hsize_t(kMaxClipJointFrames)) {
    *problem = std::string("its '") + name + "' dataset has shape " + shape_text(*dims) +
               ", more than the " + std::to_string(kMaxClipJointFrames) + " joint-frames (or " +
               std::to_string(kMaxBvhJoints) + " joints) one clip may hold";
    return std::nullopt;
  }
  if (std::string storage = h5::check_storage(dataset.get(), *dims); !storage.empty()) {
    *problem = std::string("its '") + name + "' dataset has shape " + shape_text(*dims) + ", but " +
               storage;
    return std::nullopt;
  }
  return dims;
}

// The attributes and shape of the clip group `clip`; a problem goes to header.error.
ClipHeader read_header(const State& state, hid_t clip, const std::string& path) {
  ClipHeader header;
  header.path = path;
  auto fail = [&](const std::string& problem) {
    header.error = state.message("clip '" + path + "': " + problem);
    return header;
  };
  const auto skeleton = h5::read_string_attribute(clip, "skeleton");
  if (!skeleton || !is_valid_name(*skeleton))
    return fail(
        "it has no valid 'skeleton' attribute (a fixed-length string naming a group in "
        "/skeletons)");
  header.skeleton = *skeleton;
  const auto frame_time = h5::read_double_attribute(clip, "frame_time");
  if (!frame_time || !valid_frame_time(*frame_time))
    return fail("it has no 'frame_time' attribute " + frame_time_range());
  header.frame_time = *frame_time;
  header.source = h5::read_string_attribute(clip, "source").value_or("");
  std::string problem;
  const auto dims = motion_dims(clip, "rotations", &problem);
  if (!dims) return fail(problem);
  const auto translations = motion_dims(clip, "translations", &problem);
  if (!translations) return fail(problem);
  // The joint count is checked against the skeleton by read_clip().
  if ((*dims)[2] != 4 || (*translations)[2] != 3 || (*translations)[0] != (*dims)[0])
    return fail("rotations " + shape_text(*dims) + " and translations " +
                shape_text(*translations) + " are not [F, J, 4] and [F, J, 3]");
  header.frames = int((*dims)[0]);
  header.joints = int((*dims)[1]);
  return header;
}

// Why the link `name` in `group` leads nowhere, naming its target.
std::string dangling_link_problem(hid_t group, const std::string& name) {
  H5L_info_t info{};
  if (H5Lget_info(group, name.c_str(), &info, H5P_DEFAULT) < 0)
    return h5::with_detail("cannot follow the link");
  if (info.type != H5L_TYPE_EXTERNAL && info.type != H5L_TYPE_SOFT)
    return h5::with_detail("cannot open the object");
  std::vector<char> value(info.u.val_size + 1, '\0');
  if (H5Lget_val(group, name.c_str(), value.data(), value.size(), H5P_DEFAULT) < 0)
    return h5::with_detail("cannot read the link");
  h5::last_error_detail();  // clears the stack left by the failed open
  if (info.type == H5L_TYPE_SOFT)
    return "soft link to '" + std::string(value.data()) + "' leads nowhere";
  unsigned flags = 0;
  const char* file = nullptr;
  const char* object = nullptr;
  if (H5Lunpack_elink_val(value.data(), info.u.val_size, &flags, &file, &object) < 0)
    return "external link that cannot be decoded";
  return "external link to '" + std::string(file) + ":" + object +
         "' leads nowhere (is the file missing?)";
}

// The groups on the way down from /clips (file number, address): a link back to one of them
// would loop. A group reached by two links (a soft link alias) is listed under both paths.
using Ancestors = std::set<std::pair<unsigned long, haddr_t>>;

// Lists the clips below `group`, whose path below /clips is `prefix`.
void walk(const State& state, hid_t group, const std::string& prefix, Ancestors& ancestors,
          std::vector<ClipHeader>& out) {
  std::vector<std::string> names;
  auto collect = [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
    static_cast<std::vector<std::string>*>(data)->emplace_back(name);
    return 0;
  };
  if (H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &names) < 0) {
    ClipHeader broken;
    broken.path = prefix;
    broken.error = state.message(h5::with_detail("cannot list group '/clips/" + prefix + "'"));
    out.push_back(std::move(broken));
    return;
  }
  for (const std::string& name : names) {
    const std::string path = prefix.empty() ? name : prefix + "/" + name;
    H5O_info_t info{};
    if (H5Oget_info_by_name2(group, name.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0) {
      ClipHeader broken;
      broken.path = path;
      broken.error = state.message("clip '" + path + "': " + dangling_link_problem(group, name));
      out.push_back(std::move(broken));
      continue;
    }
    // Below /clips every object is a clip or a folder of clips: anything else is reported, so
    // that no clip a damaged file lost goes missing without a word.
    auto broken = [&](const std::string& problem) {
      ClipHeader header;
      header.path = path;
      header.error = state.message("clip '" + path + "': " + problem);
      out.push_back(std::move(header));
    };
    if (info.type != H5O_TYPE_GROUP) {
      broken("a dataset or other object where a clip group or a folder of clips should be");
      continue;
    }
    const auto key = std::pair{info.fileno, info.addr};
    if (ancestors.count(key)) continue;
    const h5::Group child(H5Gopen2(group, name.c_str(), H5P_DEFAULT));
    if (!child) {
      broken(h5::with_detail("cannot open the group"));
      continue;
    }
    H5G_info_t contents{};
    if (H5Gget_info(child.get(), &contents) < 0) {
      broken(h5::with_detail("cannot list the group"));
      continue;
    }
    // A clip group is recognised by any of its parts, so one that lost its rotations is
    // reported as a broken clip rather than walked as a folder.
    const bool is_clip =
        h5::link_exists(child.get(), "rotations") || h5::link_exists(child.get(), "translations") ||
        H5Aexists(child.get(), "skeleton") > 0 || H5Aexists(child.get(), "frame_time") > 0;
    if (is_clip) {
      out.push_back(read_header(state, child.get(), path));
    } else if (contents.nlinks == 0) {
      broken(
          "an empty group: neither a clip (no 'rotations', 'translations', 'skeleton' or "
          "'frame_time') nor a folder of clips");
    } else {
      ancestors.insert(key);
      walk(state, child.get(), path, ancestors, out);
      ancestors.erase(key);
    }
  }
}

// Splits a channel list such as "Zrotation Xrotation Yrotation".
std::optional<std::vector<Channel>> parse_channel_list(const std::string& list, std::string* bad) {
  std::vector<Channel> channels;
  std::istringstream words(list);
  for (std::string word; words >> word;) {
    const auto channel = parse_channel(word);
    if (!channel) {
      *bad = word;
      return std::nullopt;
    }
    channels.push_back(*channel);
  }
  return channels;
}

// The skeleton /skeletons/<name> of `file`, or a problem.
std::shared_ptr<const Skeleton> read_skeleton(hid_t file, const std::string& name,
                                              std::string* problem) {
  const std::string where = "skeleton '" + name + "': ";
  h5::Group group;
  if (is_valid_name(name) && h5::link_exists(file, "skeletons")) {
    const h5::Group skeletons(H5Gopen2(file, "skeletons", H5P_DEFAULT));
    if (skeletons && h5::link_exists(skeletons.get(), name))
      group = h5::Group(H5Gopen2(skeletons.get(), name.c_str(), H5P_DEFAULT));
  }
  if (!group) {
    *problem = "no skeleton '" + name + "' in /skeletons";
    return nullptr;
  }
  const hid_t g = group.get();
  auto skeleton = std::make_shared<Skeleton>();
  if (h5::link_exists(g, "joint_names")) {
    const h5::Dataset names_dataset(H5Dopen2(g, "joint_names", H5P_DEFAULT));
    const auto dims = names_dataset ? h5::dataset_dims(names_dataset.get()) : std::nullopt;
    if (dims && dims->size() == 1 && (*dims)[0] > hsize_t(kMaxBvhJoints)) {
      *problem = where + "'joint_names' claims " + std::to_string((*dims)[0]) +
                 " joints, more than the " + std::to_string(kMaxBvhJoints) + " allowed";
      return nullptr;
    }
  }
  auto names = h5::read_string_dataset(g, "joint_names");
  if (!names) {
    *problem = where + "no readable 'joint_names' (fixed-length strings)";
    return nullptr;
  }
  skeleton->joint_names = std::move(*names);
  const std::size_t n = skeleton->joint_names.size();
  skeleton->parents.resize(n);
  std::vector<double> offsets(3 * n);
  if (!h5::read_dataset(g, "parents", H5T_NATIVE_INT, n, skeleton->parents.data()) ||
      !h5::read_dataset(g, "offsets", H5T_NATIVE_DOUBLE, 3 * n, offsets.data())) {
    *problem = where +
               "'parents' [J] and 'offsets' [J,3] are missing or of another size than "
               "'joint_names' (" +
               std::to_string(n) + " joints)";
    return nullptr;
  }
  const auto channels = h5::read_string_dataset(g, "channels");
  if (!channels || channels->size() != n) {
    *problem = where + "'channels' must hold one fixed-length string per joint";
    return nullptr;
  }
  for (std::size_t j = 0; j < n; ++j) {
    skeleton->offsets.push_back({offsets[3 * j], offsets[3 * j + 1], offsets[3 * j + 2]});
    std::string bad;
    auto list = parse_channel_list((*channels)[j], &bad);
    if (!list) {
      *problem =
          where + "joint '" + skeleton->joint_names[j] + "' has unknown channel '" + bad + "'";
      return nullptr;
    }
    skeleton->channels.push_back(std::move(*list));
  }
  // end_sites and has_end_site are this format's additions; a file without them has none.
  skeleton->end_sites.assign(n, std::nullopt);
  if (h5::link_exists(g, "end_sites") || h5::link_exists(g, "has_end_site")) {
    std::vector<double> ends(3 * n);
    std::vector<std::uint8_t> has(n);
    if (!h5::read_dataset(g, "end_sites", H5T_NATIVE_DOUBLE, 3 * n, ends.data()) ||
        !h5::read_dataset(g, "has_end_site", H5T_NATIVE_UINT8, n, has.data())) {
      *problem = where + "'end_sites' [J,3] and 'has_end_site' [J] must come together";
      return nullptr;
    }
    for (std::size_t j = 0; j < n; ++j)
      if (has[j]) skeleton->end_sites[j] = Vec3{ends[3 * j], ends[3 * j + 1], ends[3 * j + 2]};
  }
  if (std::string structure = check_structure(*skeleton); !structure.empty()) {
    *problem = where + structure;
    return nullptr;
  }
  return skeleton;
}

// Why the chunks of `dataset` must not reach HDF5's filters, or "". libhdf5 1.10 copies a
// chunk's decoded bytes into the dataset without comparing their count with the chunk's size,
// and a chunk's filter mask (stored per chunk, in the index) may skip any filter: a chunk whose
// mask skips the compression then "decodes" to its stored size, and the copy overflowed (a
// fuzz finding: a mask of 0xfe on a 26-byte deflate chunk). The LZ4 plugin also trusts a
// chunk's header and decodes with LZ4_decompress_fast, which reads past a damaged block. So
// each chunk is run through the filters its mask leaves, in reverse, by the store's own
// decoders (every size checked), and must give exactly one chunk's bytes; a filter they do not
// know is refused, since what it would give cannot be checked. check_storage() has bounded the
// chunk shape by the data and each stored chunk by the file.
std::string check_filtered_chunks(hid_t dataset, const char* name,
                                  const std::vector<hsize_t>& dims) {
  const h5::PropertyList properties(H5Dget_create_plist(dataset));
  if (!properties) return h5::with_detail(std::string("cannot open its '") + name + "' dataset");
  if (H5Pget_layout(properties.get()) != H5D_CHUNKED) return {};
  const int filters = H5Pget_nfilters(properties.get());
  if (filters <= 0) return {};  // unfiltered chunks: check_storage() required their exact size
  std::vector<H5Z_filter_t> ids;
  for (int i = 0; i < filters; ++i) {
    unsigned flags = 0;
    std::size_t values = 0;
    const H5Z_filter_t id = H5Pget_filter2(properties.get(), unsigned(i), &flags, &values, nullptr,
                                           0, nullptr, nullptr);
    if (id != H5Z_FILTER_SHUFFLE && id != H5Z_FILTER_DEFLATE && id != H5Z_FILTER_FLETCHER32 &&
        id != H5Z_filter_t(kLz4FilterId))
      return std::string("its '") + name + "' dataset is stored through HDF5 filter " +
             std::to_string(id) +
             ", which this reader does not decode (it reads shuffle, deflate, LZ4 and "
             "Fletcher-32)";
    ids.push_back(id);
  }
  const int rank = int(dims.size());
  std::vector<hsize_t> chunk(dims.size());
  const h5::Datatype type(H5Dget_type(dataset));
  if (H5Pget_chunk(properties.get(), rank, chunk.data()) != rank || !type)
    return h5::with_detail(std::string("cannot read the chunk shape of its '") + name +
                           "' dataset");
  std::size_t chunk_bytes = H5Tget_size(type.get());
  for (hsize_t c : chunk) chunk_bytes *= std::size_t(c);  // bounded by check_storage()
  std::vector<std::uint8_t> stored, decoded(chunk_bytes);
  std::string problem;
  h5::for_each_chunk(dims, chunk, [&](const hsize_t* offset) {
    const std::string where =
        "its '" + std::string(name) + "' chunk at frame " + std::to_string(offset[0]);
    hsize_t size = 0;
    uint32_t mask = 0;
    if (H5Dget_chunk_storage_size(dataset, offset, &size) < 0) {
      problem = h5::with_detail("cannot find " + where);
      return false;
    }
    stored.resize(std::size_t(size));
    if (H5Dread_chunk(dataset, H5P_DEFAULT, offset, &mask, stored.data()) < 0) {
      problem = h5::with_detail("cannot read " + where);
      return false;
    }
    std::span<const std::uint8_t> bytes(stored);
    bool expanded = false;  // whether `bytes` now are the decoded chunk
    for (int i = filters - 1; i >= 0 && problem.empty(); --i) {
      if (mask & (1u << unsigned(i))) continue;  // skipped when this chunk was written
      switch (ids[std::size_t(i)]) {
        case H5Z_FILTER_FLETCHER32:
          if (bytes.size() < 4)
            problem = where + " is shorter than its Fletcher-32 checksum";
          else
            bytes = bytes.first(bytes.size() - 4);
          break;
        case H5Z_FILTER_SHUFFLE:  // keeps the size
          break;
        default:  // a compression: one chunk's bytes, from a stream that is whole
          if (expanded ||
              !(ids[std::size_t(i)] == H5Z_FILTER_DEFLATE ? deflate_decode_into(bytes, decoded)
                                                          : lz4_filter_decode_into(bytes, decoded)))
            problem = where + " is not a valid " +
                      (ids[std::size_t(i)] == H5Z_FILTER_DEFLATE ? "deflate" : "LZ4") +
                      " chunk of " + std::to_string(chunk_bytes) + " bytes (the file is damaged)";
          bytes = decoded;
          expanded = true;
      }
    }
    if (problem.empty() && bytes.size() != chunk_bytes)
      problem = where + " decodes to " + std::to_string(bytes.size()) + " bytes, not the " +
                std::to_string(chunk_bytes) + " of a chunk (the file is damaged)";
    return problem.empty();
  });
  return problem;
}

// Reads a whole motion dataset of `dims` (checked by motion_dims()); a problem (naming the
// missing LZ4 plugin if that is it) or "".
std::string read_floats(hid_t clip, const char* name, const std::vector<hsize_t>& dims,
                        std::vector<float>& out) {
  const h5::Dataset dataset(H5Dopen2(clip, name, H5P_DEFAULT));
  if (dataset && !out.empty())
    if (std::string problem = check_filtered_chunks(dataset.get(), name, dims); !problem.empty())
      return problem;
  if (dataset && (out.empty() || H5Dread(dataset.get(), H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL,
                                         H5P_DEFAULT, out.data()) >= 0))
    return {};
  std::string problem = h5::with_detail(std::string("cannot read its '") + name + "' dataset");
  const h5::PropertyList properties(dataset ? H5Dget_create_plist(dataset.get()) : H5I_INVALID_HID);
  unsigned flags = 0;
  std::size_t values = 0;
  if (properties && H5Pget_filter_by_id2(properties.get(), H5Z_filter_t(kLz4FilterId), &flags,
                                         &values, nullptr, 0, nullptr, nullptr) >= 0)
    if (std::string reason = compression_unavailable_reason(Compression::lz4); !reason.empty())
      problem += "; " + reason;
  h5::last_error_detail();
  return problem;
}

}  // namespace

LibraryReader::LibraryReader(std::unique_ptr<State> state) : state_(std::move(state)) {}

LibraryReader::~LibraryReader() = default;

std::unique_ptr<LibraryReader> LibraryReader::open(const std::filesystem::path& path,
                                                   std::string* error) {
  const h5::ErrorSilence quiet;
  auto state = std::make_unique<State>();
  state->path = path;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    state->fail(error, "no such file");
    return nullptr;
  }
  if (std::filesystem::is_directory(path, ec)) {
    state->fail(error, "is a folder, not a library file");
    return nullptr;
  }
  const htri_t is_hdf5 = H5Fis_hdf5(path.c_str());
  if (is_hdf5 == 0) {
    state->fail(error, "not an HDF5 file (a mocap-clean library is HDF5)");
    return nullptr;
  }
  state->file =
      h5::File(is_hdf5 > 0 ? H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT) : H5I_INVALID_HID);
  return open_state(std::move(state), error);
}

std::unique_ptr<LibraryReader> LibraryReader::open_image(std::span<const std::uint8_t> image,
                                                         const std::string& name,
                                                         std::string* error) {
  const h5::ErrorSilence quiet;
  auto state = std::make_unique<State>();
  state->path = name;
  // The core driver reads the image in place of a file; HDF5 copies it, so `image` may go.
  const h5::PropertyList access(H5Pcreate(H5P_FILE_ACCESS));
  if (access && H5Pset_fapl_core(access.get(), 1 << 16, 0) >= 0 &&
      H5Pset_file_image(access.get(), const_cast<std::uint8_t*>(image.data()), image.size()) >= 0)
    state->file = h5::File(H5Fopen(name.c_str(), H5F_ACC_RDONLY, access.get()));
  return open_state(std::move(state), error);
}

std::unique_ptr<LibraryReader> LibraryReader::open_state(std::unique_ptr<State> state,
                                                         std::string* error) {
  if (!state->file) {
    state->fail(error, h5::with_detail("cannot open the file"));
    return nullptr;
  }
  const hid_t file = state->file.get();
  // The version first: it is an integer, and a version 1 file's strings must not be read.
  const auto version = h5::read_int_attribute(file, "format_version");
  if (version == 1 && h5::has_variable_string_attribute(file, "format")) {
    state->fail(error,
                "a mocap-clean library of format_version 1, whose variable-length strings "
                "this build does not read (libhdf5 1.10 is not safe on a damaged one); "
                "convert it to version " +
                    std::to_string(kLibraryFormatVersion) +
                    " with scripts/upgrade_library.py (README, \"Library file\")");
    return nullptr;
  }
  const auto format = h5::read_string_attribute(file, "format");
  if (format != kLibraryFormat) {
    state->fail(error, "an HDF5 file but not a mocap-clean library: " +
                           (format ? "its 'format' attribute is '" + *format + "'"
                            : h5::has_variable_string_attribute(file, "format")
                                ? std::string("its 'format' attribute is a variable-length string")
                                : std::string("no 'format' attribute on /")) +
                           ", expected '" + std::string(kLibraryFormat) + "'");
    return nullptr;
  }
  if (!version) {
    state->fail(error, "no integer 'format_version' attribute on /");
    return nullptr;
  }
  if (*version != kLibraryFormatVersion) {
    state->fail(error, "format_version " + std::to_string(*version) +
                           " is not supported (this build reads version " +
                           std::to_string(kLibraryFormatVersion) + ")");
    return nullptr;
  }
  if (!h5::link_exists(file, "clips")) {
    state->fail(error, "no /clips group");
    return nullptr;
  }
  const h5::Group clips(H5Gopen2(file, "clips", H5P_DEFAULT));
  if (!clips) {
    state->fail(error, h5::with_detail("cannot open /clips"));
    return nullptr;
  }
  Ancestors ancestors;
  H5O_info_t info{};
  if (H5Oget_info2(clips.get(), &info, H5O_INFO_BASIC) >= 0)
    ancestors.insert({info.fileno, info.addr});
  walk(*state, clips.get(), "", ancestors, state->clips);
  std::sort(state->clips.begin(), state->clips.end(),
            [](const ClipHeader& a, const ClipHeader& b) { return a.path < b.path; });
  return std::unique_ptr<LibraryReader>(new LibraryReader(std::move(state)));
}

const std::vector<ClipHeader>& LibraryReader::clips() const {
  return state_->clips;
}

const std::filesystem::path& LibraryReader::path() const {
  return state_->path;
}

std::shared_ptr<const Skeleton> LibraryReader::skeleton(const std::string& name,
                                                        std::string* error) const {
  const h5::ErrorSilence quiet;
  if (auto known = state_->skeletons.find(name); known != state_->skeletons.end())
    return known->second;
  std::string problem;
  auto skeleton = read_skeleton(state_->file.get(), name, &problem);
  if (!skeleton) {
    state_->fail(error, problem);
    return nullptr;
  }
  state_->skeletons.emplace(name, skeleton);
  return skeleton;
}

namespace {

// A clip group opened, its header read and its shapes checked against its skeleton.
struct OpenedClip {
  h5::Group group;
  ClipHeader header;
  std::shared_ptr<const Skeleton> skeleton;
};

std::optional<OpenedClip> open_clip(State& state, const std::string& clip_path,
                                    std::string* error) {
  const std::string where = "clip '" + clip_path + "': ";
  if (std::string problem = check_clip_path(clip_path); !problem.empty()) {
    state.fail(error, problem);
    return std::nullopt;
  }
  OpenedClip out;
  out.group = h5::Group(H5Gopen2(state.file.get(), ("clips/" + clip_path).c_str(), H5P_DEFAULT));
  if (!out.group) {
    h5::last_error_detail();
    state.fail(error, "no clip '" + clip_path + "' in /clips");
    return std::nullopt;
  }
  const hid_t group = out.group.get();
  out.header = read_header(state, group, clip_path);
  if (!out.header.error.empty()) {
    if (error) *error = out.header.error;
    return std::nullopt;
  }
  const std::string& name = out.header.skeleton;
  if (auto known = state.skeletons.find(name); known != state.skeletons.end()) {
    out.skeleton = known->second;
  } else {
    // This file's /skeletons first, then those of the file holding the clip (an external part).
    std::string problem;
    out.skeleton = read_skeleton(state.file.get(), name, &problem);
    if (!out.skeleton) {
      const h5::File own_file(H5Iget_file_id(group));
      std::string own_problem;
      if (own_file) out.skeleton = read_skeleton(own_file.get(), name, &own_problem);
      if (!out.skeleton) {
        state.fail(error, where + problem);
        return std::nullopt;
      }
    }
    state.skeletons.emplace(name, out.skeleton);
  }
  const int joints = out.skeleton->joint_count();
  std::string problem;
  const auto rotations = motion_dims(group, "rotations", &problem);
  const auto translations = rotations ? motion_dims(group, "translations", &problem) : std::nullopt;
  if (!rotations || !translations) {
    state.fail(error, where + problem);
    return std::nullopt;
  }
  const std::vector<hsize_t> want_rotations = {(*rotations)[0], hsize_t(joints), 4};
  const std::vector<hsize_t> want_translations = {(*rotations)[0], hsize_t(joints), 3};
  if (*rotations != want_rotations || *translations != want_translations) {
    state.fail(error, where + "rotations " + shape_text(*rotations) + " and translations " +
                          shape_text(*translations) + " do not match skeleton '" + name + "' of " +
                          std::to_string(joints) + " joints: expected [F, " +
                          std::to_string(joints) + ", 4] and [F, " + std::to_string(joints) +
                          ", 3] with equal F");
    return std::nullopt;
  }
  return out;
}

// The filters of a motion dataset as (compression, checksum), when they are a pipeline this
// store writes: [shuffle, lz4 | deflate] or none, then optionally Fletcher-32.
std::optional<std::pair<Compression, bool>> known_pipeline(hid_t properties) {
  const int count = H5Pget_nfilters(properties);
  if (count < 0) return std::nullopt;
  std::vector<H5Z_filter_t> ids;
  for (int i = 0; i < count; ++i) {
    unsigned flags = 0;
    std::size_t values = 0;
    ids.push_back(
        H5Pget_filter2(properties, unsigned(i), &flags, &values, nullptr, 0, nullptr, nullptr));
  }
  const bool checksum = !ids.empty() && ids.back() == H5Z_FILTER_FLETCHER32;
  if (checksum) ids.pop_back();
  if (ids.empty()) return std::pair{Compression::none, checksum};
  if (ids.size() == 2 && ids[0] == H5Z_FILTER_SHUFFLE) {
    if (ids[1] == H5Z_filter_t(kLz4FilterId)) return std::pair{Compression::lz4, checksum};
    if (ids[1] == H5Z_FILTER_DEFLATE) return std::pair{Compression::deflate, checksum};
  }
  return std::nullopt;
}

// Reads the stored chunks of a motion dataset as they are, into `out`; a problem, or "" . Sets
// *unusual when the dataset is not laid out as this store writes it (then nothing is read).
std::string read_stored_chunks(hid_t group, const char* name, int frames, int joints, int channels,
                               Compression compression, bool checksum, EncodedDataset& out,
                               bool* unusual) {
  const h5::Dataset dataset(H5Dopen2(group, name, H5P_DEFAULT));
  const h5::PropertyList properties(dataset ? H5Dget_create_plist(dataset.get()) : H5I_INVALID_HID);
  if (!dataset || !properties)
    return h5::with_detail(std::string("cannot open its '") + name + "' dataset");
  out.frames = frames;
  out.joints = joints;
  out.channels = channels;
  out.chunk_frames = chunk_frames(frames, std::size_t(joints) * std::size_t(channels) * 4);
  const auto pipeline = known_pipeline(properties.get());
  hsize_t chunk[3] = {0, 0, 0};
  if (!pipeline || pipeline->first != compression || pipeline->second != checksum ||
      H5Pget_layout(properties.get()) != H5D_CHUNKED ||
      H5Pget_chunk(properties.get(), 3, chunk) != 3 || chunk[0] != hsize_t(out.chunk_frames) ||
      chunk[1] != hsize_t(joints) || chunk[2] != hsize_t(channels)) {
    *unusual = true;
    return {};
  }
  const std::size_t chunks =
      (std::size_t(frames) + std::size_t(out.chunk_frames) - 1) / std::size_t(out.chunk_frames);
  // One allocation for the dataset's chunks, not a copy per doubling, when their sizes add up to
  // no more than the data (with room for incompressible chunks); else it grows as it reads.
  std::size_t total = 0;
  for (std::size_t k = 0; k < chunks; ++k) {
    const hsize_t offset[3] = {hsize_t(k) * hsize_t(out.chunk_frames), 0, 0};
    hsize_t size = 0;
    if (H5Dget_chunk_storage_size(dataset.get(), offset, &size) >= 0) total += std::size_t(size);
  }
  const std::size_t data = std::size_t(frames) * std::size_t(joints) * std::size_t(channels) * 4;
  if (total <= 2 * data + (std::size_t(1) << 20)) out.bytes.reserve(out.bytes.size() + total);
  for (std::size_t k = 0; k < chunks; ++k) {
    const hsize_t offset[3] = {hsize_t(k) * hsize_t(out.chunk_frames), 0, 0};
    hsize_t size = 0;
    uint32_t mask = 0;
    if (H5Dget_chunk_storage_size(dataset.get(), offset, &size) < 0 || size == 0)
      return h5::with_detail("cannot find chunk " + std::to_string(k) + " of its '" + name +
                             "' dataset");
    const std::size_t begin = out.bytes.size();
    out.bytes.resize(begin + std::size_t(size));
    if (H5Dread_chunk(dataset.get(), H5P_DEFAULT, offset, &mask, out.bytes.data() + begin) < 0)
      return h5::with_detail("cannot read chunk " + std::to_string(k) + " of its '" + name +
                             "' dataset");
    if (mask != 0) {  // a chunk stored with some filter skipped: decode it instead
      *unusual = true;
      return {};
    }
    // Raw reads bypass HDF5's verification: the checksum is checked here, so a copy never
    // carries a damaged chunk on under a fresh name.
    if (checksum) {
      const std::span<const std::uint8_t> stored(out.bytes.data() + begin, std::size_t(size));
      std::uint32_t recorded = 0;
      for (int i = 0; i < 4 && size >= 4; ++i)
        recorded |= std::uint32_t(stored[stored.size() - 4 + std::size_t(i)]) << (8 * i);
      if (size < 4 || fletcher32(stored.first(stored.size() - 4)) != recorded)
        return "chunk " + std::to_string(k) + " of its '" + name +
               "' dataset fails its Fletcher32 checksum (the file is damaged)";
    }
    out.chunk_ends.push_back(out.bytes.size());
  }
  return {};
}

}  // namespace

namespace {

// Allocates a clip's motion: out of memory is a message, not an exception.
std::string allocate_motion(Clip& clip, int joints) {
  const std::size_t samples = std::size_t(clip.frames) * std::size_t(joints);
  try {
    clip.rotations.resize(samples * 4);
    clip.translations.resize(samples * 3);
  } catch (const std::bad_alloc&) {
    return "out of memory for its " + std::to_string(clip.frames) + " frames x " +
           std::to_string(joints) + " joints";
  }
  return {};
}

// The clip's motion read through HDF5's own filters (H5Dread): for layouts read_raw_chunks()
// leaves to HDF5.
std::optional<Clip> read_through_hdf5(const State& state, const OpenedClip& opened,
                                      const std::string& where, std::string* error) {
  const int joints = opened.skeleton->joint_count();
  Clip clip;
  clip.skeleton = opened.skeleton;
  clip.frame_time = opened.header.frame_time;
  clip.frames = opened.header.frames;
  clip.source = opened.header.source;
  std::string problem = allocate_motion(clip, joints);
  const std::vector<hsize_t> rotations = {hsize_t(clip.frames), hsize_t(joints), 4};
  const std::vector<hsize_t> translations = {hsize_t(clip.frames), hsize_t(joints), 3};
  if (problem.empty())
    problem = read_floats(opened.group.get(), "rotations", rotations, clip.rotations);
  if (problem.empty())
    problem = read_floats(opened.group.get(), "translations", translations, clip.translations);
  if (!problem.empty()) {
    state.fail(error, where + problem);
    return std::nullopt;
  }
  return clip;
}

// The filters of a motion dataset as (compression, checksum) when decode_chunk() undoes them
// exactly as HDF5 would: known_pipeline()'s, with the shuffle over 4-byte elements.
std::optional<std::pair<Compression, bool>> raw_pipeline(hid_t properties) {
  const auto pipeline = known_pipeline(properties);
  if (!pipeline || pipeline->first == Compression::none) return pipeline;
  unsigned flags = 0;
  std::size_t values = 1;
  unsigned element_size = 0;
  if (H5Pget_filter_by_id2(properties, H5Z_FILTER_SHUFFLE, &flags, &values, &element_size, 0,
                           nullptr, nullptr) < 0 ||
      values < 1 || element_size != sizeof(float))
    return std::nullopt;
  return pipeline;
}

// Reads the chunks of the motion dataset `name` ([frames][joints][channels]) as stored into
// `out`, each by H5Dread_chunk; "" or a problem. Sets *unusual, reading nothing, when HDF5 must
// decode the dataset instead: not little-endian float32, chunks not of whole frames, filters
// other than `pipeline`'s (set from the first dataset read, when `first`), a chunk stored with
// a filter skipped, or a chunk stored larger than its codec makes one. That last bound keeps
// the memory read to the dataset's real size: motion_dims() bounded the chunk shape by the data
// and every stored chunk by the file, and nothing is allocated before all sizes are checked.
std::string read_raw_chunks(hid_t group, const char* name, int frames, int joints, int channels,
                            std::pair<Compression, bool>& pipeline, bool first, EncodedDataset& out,
                            bool* unusual) {
  const h5::Dataset dataset(H5Dopen2(group, name, H5P_DEFAULT));
  const h5::PropertyList properties(dataset ? H5Dget_create_plist(dataset.get()) : H5I_INVALID_HID);
  const h5::Datatype type(dataset ? H5Dget_type(dataset.get()) : H5I_INVALID_HID);
  if (!dataset || !properties || !type)
    return h5::with_detail(std::string("cannot open its '") + name + "' dataset");
  const auto filters = raw_pipeline(properties.get());
  hsize_t chunk[3] = {0, 0, 0};
  if (H5Tequal(type.get(), H5T_IEEE_F32LE) <= 0 || !filters || (!first && *filters != pipeline) ||
      H5Pget_layout(properties.get()) != H5D_CHUNKED ||
      H5Pget_chunk(properties.get(), 3, chunk) != 3 || chunk[0] == 0 ||
      chunk[1] != hsize_t(joints) || chunk[2] != hsize_t(channels)) {
    *unusual = true;
    return {};
  }
  pipeline = *filters;
  out.frames = frames;
  out.joints = joints;
  out.channels = channels;
  if (frames == 0) {  // no chunk to read (and motion_dims() bounds no chunk shape)
    out.bytes.clear();
    return {};
  }
  // Bounded by motion_dims(): at most max(the data, 1 MiB).
  const std::size_t chunk_bytes =
      std::size_t(chunk[0]) * std::size_t(joints) * std::size_t(channels) * sizeof(float);
  out.chunk_frames = int(chunk[0]);
  const std::size_t checksum_bytes = pipeline.second ? 4 : 0;
  const std::size_t most = pipeline.first == Compression::none
                               ? chunk_bytes + checksum_bytes
                               : chunk_bytes + chunk_bytes / 64 + 1024 + checksum_bytes;
  const std::size_t chunks =
      (std::size_t(frames) + std::size_t(chunk[0]) - 1) / std::size_t(chunk[0]);
  std::vector<std::size_t> sizes(chunks);
  std::size_t total = 0;
  for (std::size_t k = 0; k < chunks; ++k) {
    const hsize_t offset[3] = {hsize_t(k) * chunk[0], 0, 0};
    unsigned mask = 0;
    haddr_t address = 0;
    hsize_t size = 0;
    if (H5Dget_chunk_info_by_coord(dataset.get(), offset, &mask, &address, &size) < 0)
      return h5::with_detail("cannot find its '" + std::string(name) + "' chunk at frame " +
                             std::to_string(offset[0]));
    const bool exact = pipeline.first != Compression::none || size == most;
    if (mask != 0 || size == 0 || size > most || !exact) {
      *unusual = true;
      return {};
    }
    sizes[k] = std::size_t(size);
    total += sizes[k];
  }
  // Shrinking keeps a recycled buffer's pages; only growth is zero-filled.
  out.bytes.resize(total);
  out.chunk_ends.clear();
  out.chunk_ends.reserve(chunks);
  std::size_t at = 0;
  for (std::size_t k = 0; k < chunks; ++k) {
    const hsize_t offset[3] = {hsize_t(k) * chunk[0], 0, 0};
    std::uint32_t mask = 0;
    if (H5Dread_chunk(dataset.get(), H5P_DEFAULT, offset, &mask, out.bytes.data() + at) < 0)
      return h5::with_detail("cannot read its '" + std::string(name) + "' chunk at frame " +
                             std::to_string(offset[0]));
    if (mask != 0) {
      *unusual = true;
      return {};
    }
    at += sizes[k];
    out.chunk_ends.push_back(at);
  }
  return {};
}

// Decodes the chunks of `in` into `out` (frames x joints x channels floats, allocated); "" or
// the damaged chunk and why.
std::string decode_dataset(const EncodedDataset& in, const char* name, Compression compression,
                           bool checksum, std::vector<float>& out) {
  // Per thread and kept: a clip's chunks decode without fresh allocations (and page faults).
  thread_local std::vector<std::uint8_t> scratch, last;
  const std::size_t chunk_floats =
      std::size_t(in.chunk_frames) * std::size_t(in.joints) * std::size_t(in.channels);
  auto* bytes = reinterpret_cast<std::uint8_t*>(out.data());
  for (std::size_t k = 0; k < in.chunk_count(); ++k) {
    const std::size_t begin = k * chunk_floats;
    if (begin >= out.size()) return std::string("its '") + name + "' dataset has extra chunks";
    // The last chunk is padded past the clip's end: decoded aside, its frames copied.
    const std::size_t floats = std::min(chunk_floats, out.size() - begin);
    std::span<std::uint8_t> target(bytes + begin * sizeof(float), chunk_floats * sizeof(float));
    if (floats < chunk_floats) {
      last.resize(chunk_floats * sizeof(float));
      target = last;
    }
    if (std::string problem = decode_chunk(in.chunk(k), compression, checksum, target, scratch);
        !problem.empty())
      return std::string("its '") + name + "' chunk at frame " +
             std::to_string(k * std::size_t(in.chunk_frames)) + " " + problem;
    if (floats < chunk_floats)
      std::memcpy(bytes + begin * sizeof(float), last.data(), floats * sizeof(float));
  }
  if (in.chunk_count() * chunk_floats < out.size())
    return std::string("its '") + name + "' dataset misses chunks";
  return {};
}

}  // namespace

std::optional<StoredClip> LibraryReader::read_stored(const std::string& clip_path,
                                                     std::string* error,
                                                     StoredClip recycled) const {
  const h5::ErrorSilence quiet;
  const std::string where = "clip '" + clip_path + "': ";
  auto opened = open_clip(*state_, clip_path, error);
  if (!opened) return std::nullopt;
  const int joints = opened->skeleton->joint_count();
  StoredClip out;
  out.where = state_->message(where);
  EncodedClip& clip = out.chunks;
  clip.rotations.bytes = std::move(recycled.chunks.rotations.bytes);
  clip.translations.bytes = std::move(recycled.chunks.translations.bytes);
  clip.skeleton = opened->skeleton;
  clip.frame_time = opened->header.frame_time;
  clip.frames = opened->header.frames;
  clip.source = opened->header.source;
  std::pair<Compression, bool> pipeline{Compression::none, false};
  bool unusual = false;
  std::string problem;
  try {
    problem = read_raw_chunks(opened->group.get(), "rotations", clip.frames, joints, 4, pipeline,
                              true, clip.rotations, &unusual);
    if (problem.empty() && !unusual)
      problem = read_raw_chunks(opened->group.get(), "translations", clip.frames, joints, 3,
                                pipeline, false, clip.translations, &unusual);
  } catch (const std::bad_alloc&) {
    problem = "out of memory for its stored chunks";
  }
  if (!problem.empty()) {
    state_->fail(error, where + problem);
    return std::nullopt;
  }
  clip.compression = pipeline.first;
  clip.checksum = pipeline.second;
  if (unusual) {
    out.chunks = EncodedClip{};
    out.decoded = read_through_hdf5(*state_, *opened, where, error);
    if (!out.decoded) return std::nullopt;
  }
  return out;
}

std::optional<Clip> LibraryReader::decode_stored(StoredClip& stored, std::string* error) {
  if (stored.decoded) return std::move(stored.decoded);
  const EncodedClip& in = stored.chunks;
  Clip clip;
  clip.skeleton = in.skeleton;
  clip.frame_time = in.frame_time;
  clip.frames = in.frames;
  clip.source = in.source;
  std::string problem = allocate_motion(clip, in.skeleton ? in.skeleton->joint_count() : 0);
  if (problem.empty())
    problem =
        decode_dataset(in.rotations, "rotations", in.compression, in.checksum, clip.rotations);
  if (problem.empty())
    problem = decode_dataset(in.translations, "translations", in.compression, in.checksum,
                             clip.translations);
  if (!problem.empty()) {
    if (error) *error = stored.where + problem;
    return std::nullopt;
  }
  return clip;
}

std::optional<Clip> LibraryReader::read_clip(const std::string& clip_path,
                                             std::string* error) const {
  auto stored = read_stored(clip_path, error);
  if (!stored) return std::nullopt;
  return decode_stored(*stored, error);
}

namespace {

// The clip group's provenance as write_clip_provenance (library_writer.cpp) left it, so that a
// join carries it over; an [N][C] int32 dataset of at most kMaxRecords rows.
std::vector<std::int32_t> read_records(hid_t group, const char* name, hsize_t columns) {
  constexpr hsize_t kMaxRecords = 100'000'000;
  std::vector<std::int32_t> out;
  if (!h5::link_exists(group, name)) return out;
  const h5::Dataset set(H5Dopen2(group, name, H5P_DEFAULT));
  if (!set) return out;
  const h5::Dataspace space(H5Dget_space(set.get()));
  hsize_t dims[2] = {0, 0};
  if (!space || H5Sget_simple_extent_ndims(space.get()) != 2 ||
      H5Sget_simple_extent_dims(space.get(), dims, nullptr) != 2 || dims[1] != columns ||
      dims[0] > kMaxRecords)
    return out;
  out.resize(std::size_t(dims[0] * dims[1]));
  if (!out.empty() && !h5::read_dataset(group, name, H5T_NATIVE_INT32, out.size(), out.data()))
    out.clear();
  return out;
}

ClipProvenance read_clip_provenance(hid_t group) {
  ClipProvenance p;
  if (auto method = h5::read_string_attribute(group, "method")) p.method = *method;
  if (p.method.empty()) return p;
  if (auto parameters = h5::read_string_attribute(group, "parameters"))
    p.parameters_json = *parameters;
  if (auto sigma = h5::read_double_attribute(group, "noise_sigma")) p.noise_sigma = *sigma;
  p.pop_stage = h5::link_exists(group, "pops");
  if (p.pop_stage) {
    p.pops = read_records(group, "pops", 2);
    const h5::Dataset pops(H5Dopen2(group, "pops", H5P_DEFAULT));
    if (pops)
      if (auto repaired = h5::read_int_attribute(pops.get(), "repaired"))
        p.pops_repaired = *repaired != 0;
  }
  p.feet = h5::link_exists(group, "contacts");
  if (p.feet) p.contacts = read_records(group, "contacts", 3);
  return p;
}

}  // namespace

std::optional<EncodedClip> LibraryReader::read_encoded(const std::string& clip_path,
                                                       std::string* error) const {
  const h5::ErrorSilence quiet;
  const std::string where = "clip '" + clip_path + "': ";
  auto opened = open_clip(*state_, clip_path, error);
  if (!opened) return std::nullopt;
  const hid_t group = opened->group.get();
  EncodedClip clip;
  clip.skeleton = opened->skeleton;
  clip.frame_time = opened->header.frame_time;
  clip.frames = opened->header.frames;
  clip.source = opened->header.source;
  clip.provenance = read_clip_provenance(group);
  const int joints = opened->skeleton->joint_count();
  // The rotations' pipeline decides; translations written otherwise are decoded below.
  const h5::Dataset rotations(H5Dopen2(group, "rotations", H5P_DEFAULT));
  const h5::PropertyList properties(rotations ? H5Dget_create_plist(rotations.get())
                                              : H5I_INVALID_HID);
  const auto pipeline = properties ? known_pipeline(properties.get()) : std::nullopt;
  bool unusual = !pipeline;
  std::string problem;
  try {
    if (pipeline) {
      clip.compression = pipeline->first;
      clip.checksum = pipeline->second;
      problem = read_stored_chunks(group, "rotations", clip.frames, joints, 4, clip.compression,
                                   clip.checksum, clip.rotations, &unusual);
      if (problem.empty() && !unusual)
        problem = read_stored_chunks(group, "translations", clip.frames, joints, 3,
                                     clip.compression, clip.checksum, clip.translations, &unusual);
    }
  } catch (const std::bad_alloc&) {
    problem = "out of memory for its stored chunks";
  }
  if (!problem.empty()) {
    state_->fail(error, where + problem);
    return std::nullopt;
  }
  if (!unusual) return clip;
  // Laid out otherwise (another tool wrote it): decoded, then stored as this store stores.
  auto decoded = read_clip(clip_path, error);
  if (!decoded) return std::nullopt;
  const Compression compression =
      pipeline && compression_available(pipeline->first) ? pipeline->first : Compression::none;
  auto encoded = encode_clip(*decoded, compression, error, true);
  if (!encoded && error) *error = state_->message(where + *error);
  if (encoded) encoded->provenance = clip.provenance;
  return encoded;
}

std::optional<Provenance> LibraryReader::provenance() const {
  const h5::ErrorSilence quiet;
  const hid_t file = state_->file.get();
  if (!h5::link_exists(file, "provenance")) return std::nullopt;
  const h5::Group group(H5Gopen2(file, "provenance", H5P_DEFAULT));
  if (!group) return std::nullopt;
  auto text = [&](const char* name) {
    return h5::read_string_attribute(group.get(), name).value_or("");
  };
  return Provenance{text("method"), text("parameters"), text("engine_version"), text("input_file"),
                    text("created")};
}

}  // namespace mocap::io
