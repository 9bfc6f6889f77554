#include "engine/run/stage_times.hpp"

#include <iterator>

namespace mocap::engine {

nlohmann::json StageTimes::to_json() const {
  static constexpr const char* kNames[] = {"read",     "check",   "condition", "resolve",
                                           "contacts", "filter",  "lock",      "metrics",
                                           "guard",    "prepare", "write",     "review"};
  static_assert(std::size(kNames) == kStages);
  nlohmann::json j = nlohmann::json::object();
  for (int s = 0; s < kStages; ++s)
    j[kNames[s]] = double(nanoseconds_[std::size_t(s)].load(std::memory_order_relaxed)) * 1e-9;
  return j;
}

}  // namespace mocap::engine
