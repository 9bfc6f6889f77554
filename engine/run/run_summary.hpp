#pragma once
// What a command did, for the human line at the end and the machine-readable --json summary.
#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace mocap::engine {

struct ClipFailure {
  std::string clip;
  std::string error;
};

// The entries of a {name: count} object of a summary, largest count first (then by name): the
// order the closing line names them in.
std::vector<std::pair<std::size_t, std::string>> largest_first(const nlohmann::json& counts);

struct RunSummary {
  std::string command;
  std::size_t clips = 0;         // clips written
  std::size_t frames = 0;        // frames of the clips written
  std::size_t joints = 0;        // joint curves of the clips written (sum of J over clips)
  std::size_t joint_frames = 0;  // sum of F x J over the clips written
  int threads = 0;
  double seconds = 0;  // wall time of the whole command
  bool interrupted = false;
  std::vector<ClipFailure> failed;
  nlohmann::json extra = nlohmann::json::object();  // command-specific fields

  void add_clip(std::size_t clip_frames, std::size_t clip_joints) {
    ++clips;
    frames += clip_frames;
    joints += clip_joints;
    joint_frames += clip_frames * clip_joints;
  }
  nlohmann::json to_json() const;
  // 0: all done; 1: some clips (or all) failed or the run was interrupted, the rest written.
  // (2, usage errors, is decided before a run starts.)
  int exit_status() const;
};

}  // namespace mocap::engine
