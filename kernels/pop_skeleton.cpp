#include "kernels/pop_skeleton.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/quaternion.hpp"
#include "kernels/pop_detour.hpp"

namespace mocap {

Status PopSkeletonJob::validate() const {
  if (Status s = validate_sample_flags("pop skeleton test", rotations, skip, flags); !s) return s;
  const std::size_t J = std::size_t(rotations.joints);
  if (parents.size() != J)
    return Status::error("pop skeleton test: parents must have one entry per joint (" +
                         std::to_string(J) + "), got " + std::to_string(parents.size()));
  for (std::size_t j = 0; j < J; ++j)
    if (parents[j] < -1 || parents[j] >= int(J) || parents[j] == int(j))
      return Status::error("pop skeleton test: joint " + std::to_string(j) + " has parent " +
                           std::to_string(parents[j]) + ", not a joint of the clip");
  if (!(coherence > 0)) return Status::error("pop skeleton test: coherence must be > 0");
  if (reach < 0) return Status::error("pop skeleton test: reach must be >= 0 frames");
  if (pop_group < 0) return Status::error("pop skeleton test: pop_group must be >= 0 joints");
  if (!(strong_detour >= 0) || !std::isfinite(strong_detour))
    return Status::error("pop skeleton test: strong_detour must be a finite angle >= 0 rad");
  if (!median_detours.empty() && median_detours.size() != J)
    return Status::error("pop skeleton test: median_detours must have one entry per joint");
  return params.validate();
}

Status PopSkeletonJob::run() const {
  if (Status s = validate(); !s) return s;
  const int F = rotations.frames, J = rotations.joints;
  auto flagged = [&](int t, int j) { return flags[std::size_t(t) * std::size_t(J) + j] != 0; };
  auto usable = [&](int k) { return k >= 0 && (skip.empty() || !skip[std::size_t(k)]); };
  std::vector<std::vector<int>> neighbours(static_cast<std::size_t>(J));
  for (int j = 0; j < J; ++j)
    if (usable(j) && usable(parents[std::size_t(j)])) {
      neighbours[std::size_t(j)].push_back(parents[std::size_t(j)]);
      neighbours[std::size_t(parents[std::size_t(j)])].push_back(j);
    }
  // Residuals only of the joints the test reads: those with a flag and their neighbours.
  std::vector<std::uint8_t> needed(static_cast<std::size_t>(J), 0),
      any(static_cast<std::size_t>(J), 0);
  for (int t = 0; t < F; ++t)
    for (int j = 0; j < J; ++j)
      if (flagged(t, j)) any[std::size_t(j)] = 1;
  for (int j = 0; j < J; ++j)
    if (any[std::size_t(j)] && !neighbours[std::size_t(j)].empty()) {
      needed[std::size_t(j)] = 1;
      for (int k : neighbours[std::size_t(j)]) needed[std::size_t(k)] = 1;
    }
  // Of those, only the samples the test reads (a flag's own and its neighbours' within reach):
  // sample_residual is pop_residuals one sample at a time, so each has the same bits.
  std::vector<std::uint8_t> wanted(std::size_t(F) * std::size_t(J), 0);
  for (int t = 0; t < F; ++t)
    for (int j = 0; j < J; ++j) {
      if (!flagged(t, j) || !needed[std::size_t(j)]) continue;
      wanted[std::size_t(t) * std::size_t(J) + std::size_t(j)] = 1;
      for (int k : neighbours[std::size_t(j)])
        for (int u = std::max(0, t - reach); u <= std::min(F - 1, t + reach); ++u)
          wanted[std::size_t(u) * std::size_t(J) + std::size_t(k)] = 1;
    }
  std::vector<std::vector<double>> residual(static_cast<std::size_t>(J));
  std::vector<Quat> curve(static_cast<std::size_t>(F));
  std::vector<double> spreads(static_cast<std::size_t>(F)), fit_errors(static_cast<std::size_t>(F));
  const std::vector<pop_detail::BlockFit> whole_window = pop_detail::whole_window_blocks(params);
  const std::vector<std::vector<pop_detail::BlockFit>> end_windows =
      pop_detail::end_window_blocks(params);
  pop_detail::ChartScratch scratch(static_cast<std::size_t>(F));
  for (int j = 0; j < J; ++j) {
    if (!needed[std::size_t(j)] || F < kPopRepairMinFrames) continue;
    for (int t = 0; t < F; ++t) curve[std::size_t(t)] = load_quat(rotations.at(t, j));
    residual[std::size_t(j)].resize(std::size_t(F));
    for (int t = 0; t < F; ++t)
      if (wanted[std::size_t(t) * std::size_t(J) + std::size_t(j)])
        pop_detail::sample_residual(curve, params, whole_window, t, scratch,
                                    residual[std::size_t(j)], spreads, fit_errors, end_windows);
  }
  // The size of each flagged sample's group: the joints flagged at its frame that it reaches
  // through flagged neighbours (the input flags).
  std::vector<int> group(std::size_t(F) * std::size_t(J), 0);
  std::vector<int> stack, members;
  for (int t = 0; t < F; ++t)
    for (int j = 0; j < J; ++j) {
      if (!flagged(t, j) || group[std::size_t(t) * std::size_t(J) + std::size_t(j)] != 0) continue;
      stack.assign(1, j);
      members.clear();
      group[std::size_t(t) * std::size_t(J) + std::size_t(j)] = -1;  // visited
      while (!stack.empty()) {
        const int k = stack.back();
        stack.pop_back();
        members.push_back(k);
        for (int m : neighbours[std::size_t(k)]) {
          int& g = group[std::size_t(t) * std::size_t(J) + std::size_t(m)];
          if (flagged(t, m) && g == 0) {
            g = -1;
            stack.push_back(m);
          }
        }
      }
      for (int k : members)
        group[std::size_t(t) * std::size_t(J) + std::size_t(k)] = int(members.size());
    }
  const auto counts = [&](int u, int k) {
    return !flagged(u, k) || group[std::size_t(u) * std::size_t(J) + std::size_t(k)] > pop_group;
  };
  // E(t) of joint k, for 1 <= t < F - 1 (header, "Strong detours").
  const auto detour = [&](int t, int k) {
    return pop_detour(load_quat(rotations.at(t - 1, k)), load_quat(rotations.at(t, k)),
                      load_quat(rotations.at(t + 1, k)));
  };
  const auto inside = [&](int t) { return t >= 1 && t + 1 < F; };
  // Per joint, max(strong_detour, kStrongDetourOverMedian x its median detour): the detour
  // test's median where given, else measured where first needed.
  std::vector<double> strong_limit(static_cast<std::size_t>(J), -1.0), detours;
  const auto strong_at = [&](int j) {
    double& limit = strong_limit[std::size_t(j)];
    if (limit < 0) {
      double median_detour = median_detours.empty() ? std::nan("") : median_detours[std::size_t(j)];
      if (std::isnan(median_detour)) {
        detours.clear();
        for (int t = 1; t + 1 < F; ++t) detours.push_back(detour(t, j));
        median_detour = noise_floor(1.0, detours);
      }
      limit = std::max(strong_detour, kStrongDetourOverMedian * median_detour);
    }
    return limit;
  };
  // Decide on the input flags (a neighbour's flag counts as it came), then clear.
  std::vector<std::size_t> clear;
  for (int t = 0; t < F; ++t)
    for (int j = 0; j < J; ++j) {
      if (!flagged(t, j) || residual[std::size_t(j)].empty()) continue;
      const double own = residual[std::size_t(j)][std::size_t(t)];
      const double own_detour = strong_detour > 0 && inside(t) ? detour(t, j) : 0.0;
      const bool strong = own_detour > strong_detour && own_detour > strong_at(j);
      bool motion = false;
      for (int k : neighbours[std::size_t(j)])
        for (int u = std::max(0, t - reach); u <= std::min(F - 1, t + reach) && !motion; ++u)
          motion = counts(u, k) && residual[std::size_t(k)][std::size_t(u)] >= coherence * own &&
                   !(strong && inside(u) && detour(u, k) < coherence * own_detour);
      if (motion) clear.push_back(std::size_t(t) * std::size_t(J) + std::size_t(j));
    }
  for (std::size_t i : clear) flags[i] = 0;
  return {};
}

}  // namespace mocap
