#pragma once
// Crash-safe library output. Clips go into part files in OUT.parts/, each written as
// part-<tag>-<n>.h5.tmp and renamed into place once closed, so a committed part is always whole.
// After each commit OUT itself is rewritten (copy, append, rename) as a small library of external
// links into the committed parts: whatever kills the run, OUT is valid HDF5 holding only
// complete clips. finish() joins the parts into one self-contained OUT and removes OUT.parts.
// A single writer (not shared parts) that starts with no committed part also copies every clip
// into OUT.parts/joined.h5.tmp as it goes, so that finish() only closes and renames that file
// instead of reading every part back (the serial join's cost: docs/performance.md). That copy is
// dropped, and the parts joined as before, as soon as it could differ from the committed parts: an
// abandoned part, or any of its own writes failing.
// --resume reopens OUT.parts and skips the clips its committed parts hold.
#include <chrono>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "io/clip_encoder.hpp"
#include "io/compression.hpp"
#include "io/library_format.hpp"
#include "io/library_writer.hpp"

namespace mocap::engine {

struct PartedOutputOptions {
  std::filesystem::path output;
  io::Compression compression = io::Compression::lz4;
  bool checksum = true;  // Fletcher-32 on every chunk
  bool resume = false;
  std::string tag = "p";  // distinguishes writers sharing OUT.parts (ranks, shards)
  int clips_per_part = 256;
  double seconds_per_part = 5.0;    // a part is committed at least this often
  bool keep_master_current = true;  // rewrite OUT's links after each commit
  // Several processes (shards, ranks) write parts into the same folder at once: an existing
  // folder is expected, only this writer's own committed parts require --resume, and OUT is left
  // to the join.
  bool shared_parts = false;
  io::Provenance provenance;  // written into every part, so a join can restore it
};

class PartedOutput {
 public:
  static std::unique_ptr<PartedOutput> open(const PartedOutputOptions& options, std::string* error);
  ~PartedOutput();  // removes the joined copy of a run that did not finish
  PartedOutput(const PartedOutput&) = delete;
  PartedOutput& operator=(const PartedOutput&) = delete;

  std::filesystem::path parts_dir() const;
  // Clips held by committed parts (what --resume skips).
  const std::set<std::string>& done() const { return done_; }

  // A failed write (a full disk) abandons the open part: its file is removed and the clips it
  // held so far become lost() (they are not done(), so --resume redoes them).
  bool add(const std::string& clip_path, const io::EncodedClip& clip, std::string* error);
  // Closes the open part and renames it into place; on failure the part is abandoned as above.
  bool commit(std::string* error);
  // Clips accepted by add() whose part could not be written after all, with the reason.
  struct LostClip {
    std::string clip_path, error;
    std::size_t frames = 0, joints = 0;
  };
  std::vector<LostClip> take_lost() { return std::exchange(lost_, {}); }
  // Commits, joins every committed part into OUT (through OUT.tmp and a rename) and removes
  // OUT.parts.
  bool finish(const io::Provenance& provenance, std::string* error);
  // The committed part files, sorted.
  std::vector<std::filesystem::path> committed_parts() const;

  // For shared parts: marks this writer (tag) as finished.
  bool mark_finished(std::string* error);
  // For shared parts: once all `count` writers of this split have finished, exactly one caller
  // joins (under an flock on OUT.parts/join.lock, which the kernel releases if the joiner dies,
  // so a killed join never blocks the next). Sets *joined when this caller did the join.
  bool join_if_all_finished(int count, const io::Provenance& provenance, bool* joined,
                            std::string* error);
  // Joins every committed part into OUT (through OUT.tmp and a rename) and removes OUT.parts.
  bool join(const io::Provenance& provenance, std::string* error);

 private:
  explicit PartedOutput(PartedOutputOptions options) : options_(std::move(options)) {}
  bool commit_part(std::string* error);  // commit() without refreshing OUT's links
  bool refresh_master(std::string* error);
  void refresh_master_or_warn();
  std::filesystem::path joined_path() const;
  void add_to_joined(const std::string& clip_path, const io::EncodedClip& clip);
  bool finish_joined(const io::Provenance& provenance);
  void drop_joined();
  void remove_parts();
  void abandon_part(const std::string& why);
  bool all_finished(int count) const;

  PartedOutputOptions options_;
  std::set<std::string> done_;
  std::vector<LostClip> in_current_, lost_;  // clips of the open part; of abandoned parts
  std::unique_ptr<io::LibraryWriter> current_;
  std::filesystem::path current_path_;
  int clips_in_current_ = 0;
  int next_part_ = 0;
  bool master_current_ = false;  // OUT holds the links of every part committed so far
  // The joined copy (header); joining_: it holds exactly the clips of the parts so far.
  std::unique_ptr<io::LibraryWriter> joined_;
  bool joining_ = false;
  std::chrono::steady_clock::time_point opened_at_;
};

}  // namespace mocap::engine
