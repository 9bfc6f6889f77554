#include "engine/run/automatic_tally.hpp"

#include <fmt/core.h>

#include "engine/run/run_summary.hpp"

namespace mocap::engine {

void AutomaticTally::add(const std::string& clip, const ResolvedSettings& resolved) {
  if (resolved.noise_sigma < 0) return;  // nothing was derived from the noise
  const std::string method =
      resolved.unchanged ? "unchanged" : std::string(to_string(resolved.settings.method));
  nlohmann::json parameters = nlohmann::json::object();
  if (!resolved.unchanged) {
    parameters = resolved.settings.to_json();
    // The run's own choices are in "parameters" of the summary; keep what was resolved here.
    for (const char* run_wide :
         {"method", "translations", "pops", "garbage_joints", "split_impossible"})
      parameters.erase(run_wide);
  }
  if (methods.empty() || resolved.noise_sigma < sigma_min) sigma_min = resolved.noise_sigma;
  if (methods.empty() || resolved.noise_sigma > sigma_max) sigma_max = resolved.noise_sigma;
  ++methods[method];
  by_clip.push_back({{"clip", clip},
                     {"noise_sigma", resolved.noise_sigma},
                     {"method", method},
                     {"parameters", std::move(parameters)}});
}

void AutomaticTally::write_to(nlohmann::json& summary) const {
  if (methods.empty()) return;
  summary["automatic"] = {{"clips", by_clip.size()},
                          {"methods", methods},
                          {"noise_sigma", {{"min", sigma_min}, {"max", sigma_max}}},
                          {"by_clip", by_clip}};
}

std::string describe_automatic(const nlohmann::json& summary) {
  if (!summary.contains("automatic")) return "";
  const auto& a = summary["automatic"];
  const auto most = largest_first(a["methods"]);
  std::string methods;
  for (std::size_t i = 0; i < most.size(); ++i)
    methods += fmt::format("{}{} on {}{}", i ? ", " : "", most[i].second, most[i].first,
                           i == 0 ? (most[i].first == 1 ? " clip" : " clips") : "");
  const double lo = a["noise_sigma"]["min"].get<double>(),
               hi = a["noise_sigma"]["max"].get<double>();
  const std::string noise =
      lo == hi ? fmt::format("{:.3g} rad", lo) : fmt::format("{:.3g}-{:.3g} rad", lo, hi);
  return fmt::format("  automatic parameters: {}; estimated noise {} (per clip: --json)\n", methods,
                     noise);
}

}  // namespace mocap::engine
