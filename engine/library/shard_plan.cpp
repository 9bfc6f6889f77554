#include "engine/library/shard_plan.hpp"

#include <algorithm>
#include <charconv>
#include <queue>

namespace mocap::engine {

std::string ShardSpec::tag() const {
  return "s" + std::to_string(index) + "of" + std::to_string(count);
}

std::optional<ShardSpec> parse_shard(const std::string& text, std::string* error) {
  const auto slash = text.find('/');
  ShardSpec spec;
  auto parse = [](std::string_view s, int& out) {
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return ec == std::errc() && end == s.data() + s.size();
  };
  if (slash == std::string::npos || !parse(std::string_view(text).substr(0, slash), spec.index) ||
      !parse(std::string_view(text).substr(slash + 1), spec.count) || spec.count < 1 ||
      spec.index < 0 || spec.index >= spec.count) {
    if (error) *error = "--shard takes I/N with 0 <= I < N (e.g. 3/64), got '" + text + "'";
    return std::nullopt;
  }
  return spec;
}

std::vector<std::size_t> shard_selection(const ClipSource& source,
                                         const std::vector<std::size_t>& candidates,
                                         ShardSpec spec) {
  if (!spec.active()) return candidates;
  std::vector<std::pair<std::size_t, std::size_t>> by_cost;  // (cost, index)
  for (std::size_t i : candidates) by_cost.emplace_back(source.cost(i), i);
  std::sort(by_cost.begin(), by_cost.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  // Least-loaded shard next (ties: lowest shard number).
  using Load = std::pair<std::size_t, int>;
  std::priority_queue<Load, std::vector<Load>, std::greater<>> loads;
  for (int s = 0; s < spec.count; ++s) loads.emplace(0, s);
  std::vector<std::size_t> mine;
  for (const auto& [cost, index] : by_cost) {
    auto [load, shard] = loads.top();
    loads.pop();
    if (shard == spec.index) mine.push_back(index);
    loads.emplace(load + std::max<std::size_t>(cost, 1), shard);
  }
  std::sort(mine.begin(), mine.end());
  return mine;
}

}  // namespace mocap::engine
