#pragma once
// What the automatic parameters became, clip by clip (--method auto, nlpm without --h, bof with
// --sigma-g 0 ...): the --json summary's "automatic" field and a closing line, so a run that
// chose its own parameters says which, and a result can be reproduced with them.
#include <cstddef>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/clip/filter_settings.hpp"

namespace mocap::engine {

struct AutomaticTally {
  // [{clip, noise_sigma, method, parameters}], in the order the clips were written.
  nlohmann::json by_clip = nlohmann::json::array();
  std::map<std::string, std::size_t> methods;  // method chosen -> clips ("unchanged": none moves)
  double sigma_min = 0, sigma_max = 0;

  // Records `resolved` when it was derived from the clip's estimated noise; ignores it otherwise.
  void add(const std::string& clip, const ResolvedSettings& resolved);
  // Adds "automatic" {clips, methods, noise_sigma {min, max}, by_clip} when a clip was recorded.
  void write_to(nlohmann::json& summary) const;
};

// The closing line's words for a summary holding "automatic" ("" otherwise): "automatic: nlpm on
// 3 clips, bof on 1; estimated noise 0.004-0.031 rad (per clip: --json)".
std::string describe_automatic(const nlohmann::json& summary);

}  // namespace mocap::engine
