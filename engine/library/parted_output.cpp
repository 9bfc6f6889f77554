#include "engine/library/parted_output.hpp"

#include <fmt/core.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>

#include "io/library_join.hpp"
#include "io/library_reader.hpp"

namespace mocap::engine {

namespace fs = std::filesystem;

namespace {

bool fail(std::string* error, std::string message) {
  if (error) *error = std::move(message);
  return false;
}

bool is_committed_part(const fs::path& p) {
  const std::string name = p.filename().string();
  return name.starts_with("part-") && p.extension() == ".h5";
}

// The sequence number of "part-<tag>-<n>.h5" for this tag, or -1.
int part_number(const fs::path& p, const std::string& tag) {
  const std::string stem = p.stem().string(), prefix = "part-" + tag + "-";
  if (!stem.starts_with(prefix)) return -1;
  int n = -1;
  const char* begin = stem.data() + prefix.size();
  const auto [end, ec] = std::from_chars(begin, stem.data() + stem.size(), n);
  return ec == std::errc() && end == stem.data() + stem.size() ? n : -1;
}

}  // namespace

fs::path PartedOutput::parts_dir() const {
  return fs::path(options_.output.string() + ".parts");
}

std::unique_ptr<PartedOutput> PartedOutput::open(const PartedOutputOptions& options,
                                                 std::string* error) {
  std::unique_ptr<PartedOutput> out(new PartedOutput(options));
  out->options_.output = fs::absolute(options.output);
  const fs::path dir = out->parts_dir();
  std::error_code ec;
  if (fs::exists(dir, ec) && !options.resume && !options.shared_parts) {
    fail(error, fmt::format("{} holds the parts of an unfinished run: add --resume to complete it, "
                            "or delete the folder to start again",
                            dir.string()));
    return nullptr;
  }
  fs::create_directories(dir, ec);
  if (ec) {
    fail(error, fmt::format("cannot create {}: {}", dir.string(), ec.message()));
    return nullptr;
  }
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path& p = entry.path();
    if (p.extension() == ".tmp") {
      // A part that was being written when this writer died; other writers' are in use.
      if (!options.shared_parts || p.filename().string().starts_with("part-" + options.tag + "-"))
        fs::remove(p, ec);
      continue;
    }
    if (!is_committed_part(p)) continue;
    const int number = part_number(p, options.tag);
    if (number >= 0 && !options.resume) {
      fail(error,
           fmt::format("{} holds parts of an unfinished run of this shard ({}): add --resume "
                       "to complete it, or delete the folder to start again",
                       dir.string(), options.tag));
      return nullptr;
    }
    out->next_part_ = std::max(out->next_part_, number + 1);
    if (!options.resume) continue;  // another writer's part: not ours to skip
    auto reader = io::LibraryReader::open(p, error);
    if (!reader) return nullptr;
    for (const auto& clip : reader->clips())
      if (clip.error.empty()) out->done_.insert(clip.path);
  }
  // A resumed run's committed parts are not in a joined copy; they are joined at the end.
  out->joining_ = !options.shared_parts && out->committed_parts().empty();
  return out;
}

PartedOutput::~PartedOutput() {
  drop_joined();
}

fs::path PartedOutput::joined_path() const {
  return parts_dir() / "joined.h5.tmp";
}

void PartedOutput::add_to_joined(const std::string& clip_path, const io::EncodedClip& clip) {
  // Its failures cost nothing but the time saved: finish() joins the parts instead.
  std::string ignored;
  if (!joined_) joined_ = io::LibraryWriter::create(joined_path(), io::Compression::none, &ignored);
  if (!joined_ || !joined_->write_encoded_as_is(clip_path, clip, &ignored)) drop_joined();
}

void PartedOutput::drop_joined() {
  joining_ = false;
  if (!joined_) return;
  std::string ignored;
  joined_->close(&ignored);
  joined_.reset();
  std::error_code ec;
  fs::remove(joined_path(), ec);
}

bool PartedOutput::finish_joined(const io::Provenance& provenance) {
  if (!joining_ || !joined_) return false;
  std::string ignored;
  // As the join: the provenance after the clips, a writer created with no compression.
  if (!provenance.method.empty() && !joined_->write_provenance(provenance, &ignored)) return false;
  const bool closed = joined_->close(&ignored);
  joined_.reset();
  std::error_code ec;
  if (!closed || (fs::rename(joined_path(), options_.output, ec), ec)) return false;
  remove_parts();
  return true;
}

void PartedOutput::remove_parts() {
  std::error_code ec;
  // The finished markers go first, so that no shard that comes late joins again.
  for (const auto& entry : fs::directory_iterator(parts_dir(), ec))
    if (entry.path().filename().string().starts_with("finished-")) fs::remove(entry.path(), ec);
  fs::remove_all(parts_dir(), ec);
}

std::vector<fs::path> PartedOutput::committed_parts() const {
  std::vector<fs::path> parts;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(parts_dir(), ec))
    if (is_committed_part(entry.path())) parts.push_back(entry.path());
  std::sort(parts.begin(), parts.end());
  return parts;
}

bool PartedOutput::add(const std::string& clip_path, const io::EncodedClip& clip,
                       std::string* error) {
  if (!current_) {
    current_path_ = parts_dir() / fmt::format("part-{}-{:06d}.h5", options_.tag, next_part_++);
    const fs::path tmp = current_path_.string() + ".tmp";
    current_ = io::LibraryWriter::create(tmp, options_.compression, error, options_.checksum);
    if (!current_) {
      std::error_code ec;
      fs::remove(tmp, ec);
      return false;
    }
    clips_in_current_ = 0;
    opened_at_ = std::chrono::steady_clock::now();
    if (!options_.provenance.method.empty() &&
        !current_->write_provenance(options_.provenance, error)) {
      abandon_part(*error);
      return false;
    }
  }
  if (!current_->write_encoded(clip_path, clip, error)) {
    // A write that failed half-way (ENOSPC) leaves HDF5's view of the file in doubt: the part
    // is dropped whole rather than closed with unknown contents.
    abandon_part(*error);
    return false;
  }
  done_.insert(clip_path);
  if (joining_) add_to_joined(clip_path, clip);
  in_current_.push_back({clip_path,
                         {},
                         std::size_t(clip.frames),
                         std::size_t(clip.skeleton ? clip.skeleton->joint_count() : 0)});
  ++clips_in_current_;
  const double age =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - opened_at_).count();
  if (clips_in_current_ >= options_.clips_per_part || age >= options_.seconds_per_part)
    return commit(error);
  return true;
}

void PartedOutput::abandon_part(const std::string& why) {
  drop_joined();  // it may hold clips of this part
  if (current_) {
    const fs::path tmp = current_->path();
    std::string ignored;
    current_->close(&ignored);  // may fail as well: the file goes either way
    current_.reset();
    std::error_code ec;
    fs::remove(tmp, ec);
  }
  for (LostClip& clip : in_current_) {
    done_.erase(clip.clip_path);
    clip.error = "its part " + current_path_.filename().string() + " could not be written (" + why +
                 "); run again with --resume to redo it";
    lost_.push_back(std::move(clip));
  }
  in_current_.clear();
}

bool PartedOutput::commit(std::string* error) {
  if (!current_) return true;
  if (!commit_part(error)) return false;
  refresh_master_or_warn();
  return true;
}

bool PartedOutput::commit_part(std::string* error) {
  const fs::path tmp = current_->path();
  std::string problem;
  const bool closed = current_->close(&problem);
  std::error_code ec;
  if (closed) fs::rename(tmp, current_path_, ec);
  if (!closed || ec) {
    if (closed) problem = fmt::format("cannot rename {}: {}", tmp.string(), ec.message());
    abandon_part(problem);
    return fail(error, problem);
  }
  current_.reset();
  in_current_.clear();
  return true;
}

void PartedOutput::refresh_master_or_warn() {
  if (!options_.keep_master_current || options_.shared_parts) return;
  // The part is safe; OUT lagging behind costs nothing the join or --resume does not restore, so
  // a failure here (a full disk) is a warning, not a lost clip.
  if (std::string warning; !refresh_master(&warning)) {
    master_current_ = false;
    fmt::print(stderr,
               "mocap-clean: warning: {}; {} lists the clips of earlier parts only until the "
               "join\n",
               warning, options_.output.string());
  }
}

bool PartedOutput::refresh_master(std::string* error) {
  // The first refresh of this process builds the link file from every committed part; later
  // ones copy it and add the new part's links, so each costs O(new clips), not O(all clips).
  const fs::path tmp = options_.output.string() + ".tmp";
  std::error_code ec;
  bool built = false;
  if (master_current_ &&
      fs::copy_file(options_.output, tmp, fs::copy_options::overwrite_existing, ec)) {
    built = io::add_library_links(current_path_, tmp, error);
  } else {
    built = io::link_libraries(committed_parts(), tmp, error);
  }
  if (built) fs::rename(tmp, options_.output, ec);
  if (!built || ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    return built ? fail(error, fmt::format("cannot rename {}: {}", tmp.string(), ec.message()))
                 : false;
  }
  master_current_ = true;
  return true;
}

bool PartedOutput::finish(const io::Provenance& provenance, std::string* error) {
  // The last part's links in OUT would live only until the joined copy replaces OUT a moment
  // later: they are written only if that copy cannot be used.
  const bool had_part = current_ != nullptr;
  if (had_part && !commit_part(error)) return false;
  if (finish_joined(provenance)) return true;
  drop_joined();
  if (had_part) refresh_master_or_warn();
  return join(provenance, error);
}

bool PartedOutput::mark_finished(std::string* error) {
  if (!commit(error)) return false;
  // The join lock exists before any marker does, so a joiner never has to create it (and never
  // recreates it in a folder that another joiner is removing).
  for (const fs::path& file :
       {parts_dir() / "join.lock", parts_dir() / ("finished-" + options_.tag)}) {
    std::FILE* f = std::fopen(file.c_str(), "a");
    if (!f || std::fclose(f) != 0) return fail(error, "cannot write " + file.string());
  }
  return true;
}

bool PartedOutput::all_finished(int count) const {
  std::error_code ec;
  for (int i = 0; i < count; ++i)
    if (!fs::exists(parts_dir() / fmt::format("finished-s{}of{}", i, count), ec)) return false;
  return true;
}

bool PartedOutput::join_if_all_finished(int count, const io::Provenance& provenance, bool* joined,
                                        std::string* error) {
  *joined = false;
  if (!all_finished(count)) return true;
  // Opening fails once a joiner has removed OUT.parts: the join is done.
  const fs::path lock = parts_dir() / "join.lock";
  const int fd = ::open(lock.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return true;
  bool ok = true;
  // Whoever holds the lock joins; the others leave it to them. Under the lock the markers are
  // checked again: a joiner that finished before us removed them first. File systems without
  // flock (some Lustre mounts) fall back to an exclusive claim file, which a killed joiner leaves
  // behind: then `mocap-clean join` completes the output.
  bool locked = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  if (!locked && errno != EWOULDBLOCK) {
    const fs::path claim = parts_dir() / "join.claimed";
    const int claim_fd = ::open(claim.c_str(), O_CREAT | O_EXCL | O_WRONLY | O_CLOEXEC, 0644);
    locked = claim_fd >= 0;
    if (locked) ::close(claim_fd);
  }
  if (locked && all_finished(count)) {
    ok = join(provenance, error);
    *joined = ok;
  }
  ::close(fd);
  return ok;
}

bool PartedOutput::join(const io::Provenance& provenance, std::string* error) {
  const fs::path tmp = options_.output.string() + ".tmp";
  std::error_code ec;
  std::string problem;
  bool joined = io::join_libraries(committed_parts(), tmp, provenance, &problem);
  if (joined) {
    fs::rename(tmp, options_.output, ec);
    if (ec) problem = fmt::format("cannot rename {}: {}", tmp.string(), ec.message());
    joined = !ec;
  }
  if (!joined) {
    fs::remove(tmp, ec);
    return fail(error, fmt::format("{}; the clips are safe in {}: free space if the disk is full, "
                                   "then run the same command with --resume to join them",
                                   problem, parts_dir().string()));
  }
  remove_parts();
  return true;
}

}  // namespace mocap::engine
