#include "engine/run/progress.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <cstdio>

namespace mocap::engine {

Progress::Progress(std::string label, std::size_t total_clips, bool enabled)
    : label_(std::move(label)), total_(total_clips), enabled_(enabled && total_clips > 0) {
  start_ = last_draw_ = std::chrono::steady_clock::now();
}

Progress::~Progress() {
  finish();
}

bool Progress::stderr_is_terminal() {
  return isatty(STDERR_FILENO) == 1;
}

void Progress::advance(std::size_t frames, bool failed) {
  ++done_;
  frames_ += frames;
  failed_ += failed ? 1 : 0;
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ > std::chrono::milliseconds(100) || done_ == total_) {
    last_draw_ = now;
    draw(false);
  }
}

void Progress::finish() {
  if (!enabled_ || finished_) return;
  finished_ = true;
  draw(true);
}

void Progress::draw(bool final_draw) {
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double fraction = total_ ? double(done_) / double(total_) : 1.0;
  constexpr int width = 28;
  const int filled = int(fraction * width);
  const std::string bar = std::string(filled, '#') + std::string(width - filled, '.');
  const double fps = seconds > 0 ? double(frames_) / seconds : 0.0;
  const double eta = done_ > 0 ? seconds * double(total_ - done_) / double(done_) : 0.0;
  std::string line =
      fmt::format("\r{} [{}] {}/{} clips  {:.0f} frames/s  ", label_, bar, done_, total_, fps);
  line += final_draw ? fmt::format("{:.1f} s", seconds) : fmt::format("ETA {:.0f} s", eta);
  if (failed_) line += fmt::format("  {} failed", failed_);
  line += "\x1b[K";
  if (final_draw) line += "\n";
  std::fputs(line.c_str(), stderr);
  std::fflush(stderr);
}

}  // namespace mocap::engine
