#pragma once
// A one-line progress bar on stderr (clips, frames/s, ETA), drawn only when stderr is a
// terminal and redrawn at most ten times a second. Called from the serial writer stage.
#include <chrono>
#include <cstddef>
#include <string>

namespace mocap::engine {

class Progress {
 public:
  Progress(std::string label, std::size_t total_clips, bool enabled);
  ~Progress();
  void advance(std::size_t frames, bool failed);
  void finish();

  static bool stderr_is_terminal();

 private:
  void draw(bool final_draw);

  std::string label_;
  std::size_t total_ = 0, done_ = 0, failed_ = 0, frames_ = 0;
  bool enabled_ = false, finished_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace mocap::engine
