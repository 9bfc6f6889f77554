#include "engine/run/run_summary.hpp"

#include <algorithm>

namespace mocap::engine {

std::vector<std::pair<std::size_t, std::string>> largest_first(const nlohmann::json& counts) {
  std::vector<std::pair<std::size_t, std::string>> entries;
  for (const auto& [name, n] : counts.items()) entries.push_back({n.get<std::size_t>(), name});
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  return entries;
}

nlohmann::json RunSummary::to_json() const {
  nlohmann::json j = extra;
  j["command"] = command;
  j["clips"] = clips;
  j["frames"] = frames;
  j["joints"] = joints;
  j["joint_frames"] = joint_frames;
  j["threads"] = threads;
  j["seconds"] = seconds;
  j["joint_frames_per_second"] = seconds > 0 ? double(joint_frames) / seconds : 0.0;
  j["interrupted"] = interrupted;
  nlohmann::json failures = nlohmann::json::array();
  for (const auto& f : failed) failures.push_back({{"clip", f.clip}, {"error", f.error}});
  j["failed"] = failures;
  return j;
}

int RunSummary::exit_status() const {
  return failed.empty() && !interrupted ? 0 : 1;
}

}  // namespace mocap::engine
