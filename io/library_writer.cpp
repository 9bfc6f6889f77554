#include "io/library_writer.hpp"

#include <cstdint>
#include <functional>
#include <map>
#include <vector>

#include "io/hdf5_handle.hpp"
#include "io/hdf5_helpers.hpp"

namespace mocap::io {

namespace detail {

struct LibraryWriterState {
  std::filesystem::path path;
  Compression compression = Compression::none;
  bool checksum = true;
  h5::File file;
  h5::Group skeletons, clips;
  // Skeletons this file holds, by name: a clip's skeleton is written with its first clip only.
  std::map<std::string, std::shared_ptr<const Skeleton>> written_skeletons;

  bool fail(std::string* error, const std::string& message) const {
    if (error) *error = path.string() + ": " + message;
    return false;
  }
};

}  // namespace detail

using State = detail::LibraryWriterState;

namespace {

// What write_clip and write_encoded have in common: everything but the two datasets.
struct ClipFields {
  const std::shared_ptr<const Skeleton>& skeleton;
  double frame_time;
  const std::string& source;
};
// Writes the rotations and translations into the clip group; returns a problem or "".
using DatasetWriter = std::function<std::string(hid_t clip_group)>;

std::vector<std::string> split(const std::string& path) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t slash; (slash = path.find('/', start)) != std::string::npos; start = slash + 1)
    parts.push_back(path.substr(start, slash - start));
  parts.push_back(path.substr(start));
  return parts;
}

h5::Dataset create_motion_dataset(hid_t group, const char* name, int frames, int joints,
                                  int channels, Compression compression, bool checksum) {
  const hsize_t dims[3] = {hsize_t(frames), hsize_t(joints), hsize_t(channels)};
  // A chunked dataset's chunk may not exceed a fixed extent, so an empty clip gets an
  // unlimited frame axis for its one-frame chunk.
  const hsize_t max_dims[3] = {frames == 0 ? H5S_UNLIMITED : dims[0], dims[1], dims[2]};
  const hsize_t chunk[3] = {
      hsize_t(chunk_frames(frames, std::size_t(joints) * std::size_t(channels) * sizeof(float))),
      dims[1], dims[2]};
  const h5::Dataspace space(H5Screate_simple(3, dims, max_dims));
  const h5::PropertyList properties = h5::motion_dataset_properties(compression, checksum, chunk);
  if (!space || !properties) return {};
  return h5::Dataset(H5Dcreate2(group, name, H5T_IEEE_F32LE, space.get(), H5P_DEFAULT,
                                properties.get(), H5P_DEFAULT));
}

std::string write_motion(hid_t group, const char* name, const std::vector<float>& values,
                         int frames, int joints, int channels, Compression compression,
                         bool checksum) {
  const h5::Dataset dataset =
      create_motion_dataset(group, name, frames, joints, channels, compression, checksum);
  // The detail is taken at once: the next HDF5 call (a close) clears the error stack.
  if (!dataset) return h5::with_detail(std::string("cannot create dataset '") + name + "'");
  if (frames > 0 &&
      H5Dwrite(dataset.get(), H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0)
    return h5::with_detail(std::string("cannot write dataset '") + name + "'");
  return {};
}

std::string write_encoded_motion(hid_t group, const char* name, const EncodedDataset& encoded,
                                 int frames, int joints, int channels, Compression compression,
                                 bool checksum) {
  const std::size_t frame_bytes = std::size_t(joints) * std::size_t(channels) * sizeof(float);
  const int per_chunk = chunk_frames(frames, frame_bytes);
  const std::size_t chunks = (std::size_t(frames) + std::size_t(per_chunk) - 1) / per_chunk;
  if (encoded.frames != frames || encoded.joints != joints || encoded.channels != channels ||
      encoded.chunk_frames != per_chunk || encoded.chunk_count() != chunks)
    return std::string("the encoded '") + name + "' do not match the clip's shape [" +
           std::to_string(frames) + ", " + std::to_string(joints) + ", " +
           std::to_string(channels) + "]";
  const h5::Dataset dataset =
      create_motion_dataset(group, name, frames, joints, channels, compression, checksum);
  if (!dataset) return h5::with_detail(std::string("cannot create dataset '") + name + "'");
  for (std::size_t k = 0; k < chunks; ++k) {
    const hsize_t offset[3] = {hsize_t(k) * hsize_t(per_chunk), 0, 0};
    const auto bytes = encoded.chunk(k);
    if (H5Dwrite_chunk(dataset.get(), H5P_DEFAULT, 0, offset, bytes.size(), bytes.data()) < 0)
      return h5::with_detail(std::string("cannot write chunk ") + std::to_string(k) + " of '" +
                             name + "'");
  }
  return {};
}

// The clip's provenance (README, "The library file"): attributes method, parameters,
// noise_sigma, the dataset pops [N, 2] (frame, joint) with attribute repaired, and the dataset
// contacts [N, 3] (ankle joint, first frame, end frame) when feet were locked.
std::string write_clip_provenance(hid_t group, const ClipProvenance& p) {
  if (p.method.empty()) return {};
  if (!h5::write_string_attribute(group, "method", p.method) ||
      !h5::write_string_attribute(group, "parameters", p.parameters_json) ||
      (p.noise_sigma >= 0 && !h5::write_double_attribute(group, "noise_sigma", p.noise_sigma)))
    return "cannot write its provenance attributes";
  if (p.feet) {
    const hsize_t cdims[2] = {hsize_t(p.contacts.size() / 3), 3};
    if (!h5::write_dataset(group, "contacts", H5T_STD_I32LE, H5T_NATIVE_INT32, cdims,
                           p.contacts.data()))
      return "cannot write dataset 'contacts'";
  }
  if (!p.pop_stage) return {};
  const hsize_t dims[2] = {hsize_t(p.pops.size() / 2), 2};
  if (!h5::write_dataset(group, "pops", H5T_STD_I32LE, H5T_NATIVE_INT32, dims, p.pops.data()))
    return "cannot write dataset 'pops'";
  const h5::Dataset pops(H5Dopen2(group, "pops", H5P_DEFAULT));
  if (!pops || !h5::write_int_attribute(pops.get(), "repaired", p.pops_repaired ? 1 : 0))
    return "cannot write the attributes of 'pops'";
  return {};
}

std::string write_skeleton(hid_t skeletons, const std::string& name, const Skeleton& s) {
  const h5::Group group(H5Gcreate2(skeletons, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!group) return h5::with_detail("cannot create skeleton group '" + name + "'");
  const std::size_t n = std::size_t(s.joint_count());
  std::vector<std::string> channels(n);
  std::vector<double> offsets(n * 3), end_sites(n * 3, 0.0);
  std::vector<std::uint8_t> has_end_site(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    channels[j] = s.channel_list(int(j));
    const Vec3& o = s.offsets[j];
    offsets[3 * j] = o.x, offsets[3 * j + 1] = o.y, offsets[3 * j + 2] = o.z;
    if (s.end_sites[j]) {
      const Vec3& e = *s.end_sites[j];
      end_sites[3 * j] = e.x, end_sites[3 * j + 1] = e.y, end_sites[3 * j + 2] = e.z;
      has_end_site[j] = 1;
    }
  }
  const hsize_t list[1] = {n};
  const hsize_t rows[2] = {n, 3};
  const hid_t g = group.get();
  const bool ok =
      h5::write_string_dataset(g, "joint_names", s.joint_names) &&
      h5::write_dataset(g, "parents", H5T_STD_I32LE, H5T_NATIVE_INT, list, s.parents.data()) &&
      h5::write_dataset(g, "offsets", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, rows, offsets.data()) &&
      h5::write_string_dataset(g, "channels", channels) &&
      h5::write_dataset(g, "end_sites", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, rows,
                        end_sites.data()) &&
      h5::write_dataset(g, "has_end_site", H5T_STD_U8LE, H5T_NATIVE_UINT8, list,
                        has_end_site.data());
  return ok ? std::string() : h5::with_detail("cannot write skeleton '" + name + "'");
}

// Creates /clips/<clip_path> and its parents, fills it, and adds the skeleton if new; on any
// failure unlinks the topmost group it created and the skeleton it added.
bool write_clip_group(State& state, const std::string& clip_path, const ClipFields& fields,
                      const DatasetWriter& write_datasets, std::string* error) {
  const std::string where = "clip '" + clip_path + "': ";
  if (!state.file) return state.fail(error, where + "the writer is closed");
  if (std::string problem = check_clip_path(clip_path); !problem.empty())
    return state.fail(error, problem);
  const std::string name = skeleton_name(*fields.skeleton);
  const auto known = state.written_skeletons.find(name);
  const bool new_skeleton = known == state.written_skeletons.end();
  if (!new_skeleton && known->second != fields.skeleton && !(*known->second == *fields.skeleton))
    return state.fail(error, where + "its skeleton differs from skeleton '" + name +
                                 "' of another clip, yet has the same name (a hash collision)");

  // Walk down to the clip's parent, creating what is missing.
  const std::vector<std::string> parts = split(clip_path);
  std::vector<h5::Group> chain;  // open parents, innermost last
  std::string prefix, created;   // `created`: the topmost group this call made, below /clips
  auto parent = [&] { return chain.empty() ? state.clips.get() : chain.back().get(); };
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    prefix += (prefix.empty() ? "" : "/") + parts[i];
    h5::Group group;
    if (h5::link_exists(parent(), parts[i])) {
      H5O_info_t info{};
      if (H5Oget_info_by_name2(parent(), parts[i].c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT) <
              0 ||
          info.type != H5O_TYPE_GROUP)
        return state.fail(error, where + "'" + prefix + "' exists and is not a group");
      group = h5::Group(H5Gopen2(parent(), parts[i].c_str(), H5P_DEFAULT));
      if (group && h5::link_exists(group.get(), "rotations"))
        return state.fail(error, where + "'" + prefix + "' is a clip, and clips cannot nest");
    } else {
      group =
          h5::Group(H5Gcreate2(parent(), parts[i].c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
      if (group && created.empty()) created = prefix;
    }
    if (!group) {
      const std::string message = h5::with_detail(where + "cannot create group '" + prefix + "'");
      if (!created.empty()) H5Ldelete(state.clips.get(), created.c_str(), H5P_DEFAULT);
      return state.fail(error, message);
    }
    chain.push_back(std::move(group));
  }
  if (h5::link_exists(parent(), parts.back()))
    return state.fail(error, where + "it exists already");
  if (created.empty()) created = clip_path;

  std::string problem;
  {
    const h5::Group clip(
        H5Gcreate2(parent(), parts.back().c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    if (!clip) {
      problem = h5::with_detail("cannot create its group");
    } else if (!h5::write_string_attribute(clip.get(), "skeleton", name) ||
               !h5::write_double_attribute(clip.get(), "frame_time", fields.frame_time) ||
               !h5::write_string_attribute(clip.get(), "source", fields.source)) {
      problem = h5::with_detail("cannot write its attributes");
    } else {
      problem = write_datasets(clip.get());
    }
  }
  bool partial_skeleton = false;
  if (problem.empty() && new_skeleton) {
    problem = write_skeleton(state.skeletons.get(), name, *fields.skeleton);
    partial_skeleton = !problem.empty();
  }
  if (!problem.empty()) {
    const std::string message = h5::with_detail(where + problem);  // before the clean-up
    chain.clear();
    if (partial_skeleton) H5Ldelete(state.skeletons.get(), name.c_str(), H5P_DEFAULT);
    H5Ldelete(state.clips.get(), created.c_str(), H5P_DEFAULT);
    return state.fail(error, message);
  }
  if (new_skeleton) state.written_skeletons.emplace(name, fields.skeleton);
  return true;
}

}  // namespace

LibraryWriter::LibraryWriter(std::unique_ptr<State> state) : state_(std::move(state)) {}

LibraryWriter::~LibraryWriter() {
  if (state_ && state_->file) close(nullptr);
}

std::unique_ptr<LibraryWriter> LibraryWriter::create(const std::filesystem::path& path,
                                                     Compression compression, std::string* error,
                                                     bool checksum) {
  const h5::ErrorSilence quiet;
  auto state = std::make_unique<State>();
  state->path = path;
  state->compression = compression;
  state->checksum = checksum;
  if (std::string reason = compression_unavailable_reason(compression); !reason.empty()) {
    state->fail(error, reason);
    return nullptr;
  }
  // Objects in the HDF5 1.8 format at the oldest, so that any reader of the last 15 years opens
  // the file; newer features only where they need no newer reader.
  const h5::PropertyList access(H5Pcreate(H5P_FILE_ACCESS));
  if (!access || H5Pset_libver_bounds(access.get(), H5F_LIBVER_V18, H5F_LIBVER_LATEST) < 0) {
    state->fail(error, h5::with_detail("cannot set up the file access properties"));
    return nullptr;
  }
  state->file = h5::File(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, access.get()));
  if (!state->file) {
    state->fail(error, h5::with_detail("cannot create the file"));
    return nullptr;
  }
  const hid_t file = state->file.get();
  if (!h5::write_string_attribute(file, "format", kLibraryFormat) ||
      !h5::write_int_attribute(file, "format_version", kLibraryFormatVersion)) {
    state->fail(error, h5::with_detail("cannot write the root attributes"));
    return nullptr;
  }
  state->skeletons =
      h5::Group(H5Gcreate2(file, "skeletons", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  state->clips = h5::Group(H5Gcreate2(file, "clips", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!state->skeletons || !state->clips) {
    state->fail(error, h5::with_detail("cannot create /skeletons and /clips"));
    return nullptr;
  }
  return std::unique_ptr<LibraryWriter>(new LibraryWriter(std::move(state)));
}

bool LibraryWriter::write_clip(const std::string& clip_path, const Clip& clip, std::string* error) {
  const h5::ErrorSilence quiet;
  if (std::string problem = check_clip(clip); !problem.empty())
    return state_->fail(error, "clip '" + clip_path + "': " + problem);
  const Compression compression = state_->compression;
  const bool checksum = state_->checksum;
  const int frames = clip.frames, joints = clip.joints();
  return write_clip_group(
      *state_, clip_path, {clip.skeleton, clip.frame_time, clip.source},
      [&](hid_t group) {
        std::string problem = write_motion(group, "rotations", clip.rotations, frames, joints, 4,
                                           compression, checksum);
        if (problem.empty())
          problem = write_motion(group, "translations", clip.translations, frames, joints, 3,
                                 compression, checksum);
        if (problem.empty()) problem = write_clip_provenance(group, clip.provenance);
        return problem;
      },
      error);
}

bool LibraryWriter::write_encoded(const std::string& clip_path, const EncodedClip& clip,
                                  std::string* error) {
  const h5::ErrorSilence quiet;
  const std::string where = "clip '" + clip_path + "': ";
  if (clip.compression != state_->compression)
    return state_->fail(error, where + "encoded with " + std::string(to_string(clip.compression)) +
                                   ", but this file is written with " +
                                   std::string(to_string(state_->compression)));
  if (clip.checksum != state_->checksum)
    return state_->fail(error, where + "encoded " + (clip.checksum ? "with" : "without") +
                                   " checksums, but this file is written " +
                                   (state_->checksum ? "with" : "without"));
  return write_encoded_as_is(clip_path, clip, error);
}

bool LibraryWriter::write_encoded_as_is(const std::string& clip_path, const EncodedClip& clip,
                                        std::string* error) {
  const h5::ErrorSilence quiet;
  const std::string where = "clip '" + clip_path + "': ";
  if (!clip.skeleton || !check_structure(*clip.skeleton).empty())
    return state_->fail(error, where + "the encoded clip has no valid skeleton");
  const Compression compression = clip.compression;
  const bool checksum = clip.checksum;
  const int frames = clip.frames, joints = clip.skeleton->joint_count();
  return write_clip_group(
      *state_, clip_path, {clip.skeleton, clip.frame_time, clip.source},
      [&](hid_t group) {
        std::string problem = write_encoded_motion(group, "rotations", clip.rotations, frames,
                                                   joints, 4, compression, checksum);
        if (problem.empty())
          problem = write_encoded_motion(group, "translations", clip.translations, frames, joints,
                                         3, compression, checksum);
        if (problem.empty()) problem = write_clip_provenance(group, clip.provenance);
        return problem;
      },
      error);
}

bool LibraryWriter::write_provenance(const Provenance& provenance, std::string* error) {
  const h5::ErrorSilence quiet;
  if (!state_->file) return state_->fail(error, "provenance: the writer is closed");
  const hid_t file = state_->file.get();
  if (h5::link_exists(file, "provenance") && H5Ldelete(file, "provenance", H5P_DEFAULT) < 0)
    return state_->fail(error, h5::with_detail("cannot replace /provenance"));
  const h5::Group group(H5Gcreate2(file, "provenance", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  const std::string created = provenance.created.empty() ? utc_now_iso8601() : provenance.created;
  const bool ok =
      group && h5::write_string_attribute(group.get(), "method", provenance.method) &&
      h5::write_string_attribute(group.get(), "parameters", provenance.parameters_json) &&
      h5::write_string_attribute(group.get(), "engine_version", provenance.engine_version) &&
      h5::write_string_attribute(group.get(), "input_file", provenance.input_file) &&
      h5::write_string_attribute(group.get(), "created", created);
  if (!ok) return state_->fail(error, h5::with_detail("cannot write /provenance"));
  return true;
}

bool LibraryWriter::close(std::string* error) {
  const h5::ErrorSilence quiet;
  if (!state_->file) return true;
  const bool flushed = H5Fflush(state_->file.get(), H5F_SCOPE_GLOBAL) >= 0;
  std::string detail = flushed ? std::string() : h5::last_error_detail();  // before the closes
  state_->skeletons.reset();
  state_->clips.reset();
  const bool closed = state_->file.reset();
  if (!closed && detail.empty()) detail = h5::last_error_detail();
  if (!flushed || !closed)
    return state_->fail(error, "cannot flush and close the file" +
                                   (detail.empty() ? std::string() : " (HDF5: " + detail + ")"));
  return true;
}

Compression LibraryWriter::compression() const {
  return state_->compression;
}

bool LibraryWriter::checksum() const {
  return state_->checksum;
}

const std::filesystem::path& LibraryWriter::path() const {
  return state_->path;
}

}  // namespace mocap::io
