#include "engine/library/summary_merge.hpp"

#include <algorithm>
#include <string>

namespace mocap::engine {
namespace {

void add_counts(nlohmann::json& into, const nlohmann::json& from, const char* key) {
  into[key] = into.value(key, std::size_t(0)) + from.value(key, std::size_t(0));
}

// {name: count} maps, summed name by name.
void add_count_map(nlohmann::json& into, const nlohmann::json& from, const char* key) {
  if (!from.contains(key)) return;
  nlohmann::json& map = into[key];
  if (map.is_null()) map = nlohmann::json::object();
  for (const auto& [name, n] : from[key].items())
    map[name] = map.value(name, std::size_t(0)) + n.get<std::size_t>();
}

void append_list(nlohmann::json& into, const nlohmann::json& from, const char* key) {
  if (!from.contains(key)) return;
  nlohmann::json& list = into[key];
  if (list.is_null()) list = nlohmann::json::array();
  for (const auto& item : from[key]) list.push_back(item);
}

}  // namespace

void merge_tallies(nlohmann::json& into, const nlohmann::json& from) {
  if (from.contains("pops") && from["pops"].contains("samples")) {
    nlohmann::json& pops = into["pops"];
    if (!pops.contains("samples"))
      pops = from["pops"];  // this rank found the first
    else {
      for (const char* key : {"samples", "repaired", "clips"}) add_counts(pops, from["pops"], key);
      add_count_map(pops, from["pops"], "by_joint");
    }
  }
  if (from.contains("garbage_joints")) {
    nlohmann::json& garbage = into["garbage_joints"];
    if (garbage.is_null())
      garbage = from["garbage_joints"];
    else {
      for (const char* key : {"joints", "clips"}) add_counts(garbage, from["garbage_joints"], key);
      append_list(garbage, from["garbage_joints"], "by_clip");
    }
  }
  if (from.contains("automatic")) {
    const nlohmann::json& a = from["automatic"];
    nlohmann::json& automatic = into["automatic"];
    if (automatic.is_null())
      automatic = a;
    else {
      add_counts(automatic, a, "clips");
      add_count_map(automatic, a, "methods");
      append_list(automatic, a, "by_clip");
      nlohmann::json& noise = automatic["noise_sigma"];
      noise["min"] = std::min(noise["min"].get<double>(), a["noise_sigma"]["min"].get<double>());
      noise["max"] = std::max(noise["max"].get<double>(), a["noise_sigma"]["max"].get<double>());
    }
  }
}

}  // namespace mocap::engine
