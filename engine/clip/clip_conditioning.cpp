#include "engine/clip/clip_conditioning.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <numeric>
#include <stdexcept>

#include "core/quaternion.hpp"
#include "engine/run/run_summary.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/pop_repair.hpp"

namespace mocap::engine {

bool ClipConditioning::any_garbage() const {
  return std::any_of(garbage.begin(), garbage.end(), [](std::uint8_t g) { return g != 0; });
}

std::size_t ClipConditioning::pop_count() const {
  return std::accumulate(pops.begin(), pops.end(), std::size_t(0));
}

// Frames [begin, end) between steps that no joint can make, over the joints that are not garbage.
ClipConditioning condition_rotations(PopsMode mode, RotationSpan rotations, double frame_time) {
  ClipConditioning c;
  const int J = rotations.joints;
  const RotationView view{rotations.data, rotations.frames, J};
  c.joints = classify_joints(view);
  c.garbage.resize(std::size_t(J));
  for (int j = 0; j < J; ++j)
    c.garbage[std::size_t(j)] = is_garbage(c.joints[std::size_t(j)].joint_class);
  c.pops.assign(std::size_t(J), 0);
  if (mode == PopsMode::off || J == 0) return c;

  // Constant and rounding-only joints are repaired too (a pop on a still joint is the easiest to
  // tell); a flipping joint is all pops to the test and is left as it came.
  std::vector<std::uint8_t> flipping(static_cast<std::size_t>(J));
  for (int j = 0; j < J; ++j)
    flipping[std::size_t(j)] = c.joints[std::size_t(j)].joint_class == JointClass::flipping;
  c.repaired = mode == PopsMode::repair || (mode == PopsMode::automatic && frame_time > 0 &&
                                            1.0 / frame_time >= kPopsRepairMinFps);
  std::vector<int> found(std::size_t(J), 0);
  std::vector<float> repaired;
  std::vector<std::uint8_t> flagged;
  for (const Segment& seg : motion_segments(view, frame_time, flipping)) {
    flagged.assign(std::size_t(seg.frames()) * std::size_t(J), 0);
    const std::size_t offset = std::size_t(seg.begin) * std::size_t(J) * 4;
    repaired.resize(std::size_t(seg.frames()) * std::size_t(J) * 4);
    PopRepairJob job;
    job.io.frame_time = frame_time;
    job.io.rotations = {rotations.data + offset, seg.frames(), J};
    job.io.filtered_rotations = {repaired.data(), seg.frames(), J};
    job.skip_joints = flipping;
    job.flagged_per_joint = found;
    job.flagged_samples = flagged;
    job.repair = c.repaired;
    if (const Status s = job.run(); !s.ok()) throw std::runtime_error("pop repair: " + s.message());
    for (int j = 0; j < J; ++j) c.pops[std::size_t(j)] += found[std::size_t(j)];
    for (std::size_t i = 0; i < flagged.size(); ++i)
      if (flagged[i]) {
        c.pop_samples.push_back(std::int32_t(seg.begin + int(i / std::size_t(J))));
        c.pop_samples.push_back(std::int32_t(i % std::size_t(J)));
      }
    if (c.repaired) std::copy(repaired.begin(), repaired.end(), rotations.data + offset);
  }
  return c;
}

ClipConditioning condition_clip(const FilterSettings& settings, Clip& clip) {
  // none is a copy; pops off is the spec's filter alone, at no extra cost (not even the joint
  // classification, which costs about a geodesic per sample).
  if (settings.method == Method::none || settings.pops == PopsMode::off) return {};
  return condition_rotations(settings.pops, clip.rotation_span(), clip.frame_time);
}

void ConditioningTally::add(const std::string& clip, const Clip& data, const ClipConditioning& c) {
  const std::size_t found = c.pop_count();
  if (found > 0) {
    pops += found;
    if (c.repaired) repaired += found;
    ++clips_with_pops;
    for (std::size_t j = 0; j < c.pops.size(); ++j)
      if (c.pops[j] > 0) pops_by_joint[data.skeleton->joint_names[j]] += std::size_t(c.pops[j]);
  }
  if (!c.any_garbage()) return;
  nlohmann::json joints = nlohmann::json::array();
  for (std::size_t j = 0; j < c.garbage.size(); ++j)
    if (c.garbage[j])
      joints.push_back({{"joint", data.skeleton->joint_names[j]},
                        {"class", std::string(to_string(c.joints[j].joint_class))}});
  garbage_joints += joints.size();
  ++clips_with_garbage;
  garbage.push_back({{"clip", clip}, {"joints", std::move(joints)}});
}

void ConditioningTally::write_to(nlohmann::json& summary) const {
  if (mode == PopsMode::off) {  // nothing was looked at
    summary["pops"] = {{"mode", "off"}};
    return;
  }
  summary["pops"] = {{"mode", std::string(to_string(mode))},
                     {"samples", pops},
                     {"repaired", repaired},
                     {"clips", clips_with_pops},
                     {"by_joint", pops_by_joint}};
  summary["garbage_joints"] = {
      {"joints", garbage_joints},
      {"clips", clips_with_garbage},
      {"handling", keep_garbage ? "kept as they came" : "filtered like the others"},
      {"by_clip", garbage}};
}

namespace {

std::string describe_garbage(const nlohmann::json& g) {
  if (g["joints"].get<std::size_t>() == 0) return "";
  return fmt::format("  garbage joints (constant, rounding or flipping): {} in {} clips, {}\n",
                     g["joints"].get<std::size_t>(), g["clips"].get<std::size_t>(),
                     g["handling"].get<std::string>());
}

}  // namespace

std::string describe_conditioning(const nlohmann::json& summary) {
  if (!summary.contains("pops") || !summary.contains("garbage_joints")) return "";  // pops off
  const auto& p = summary["pops"];
  const auto& g = summary["garbage_joints"];
  const std::string mode = p["mode"].get<std::string>();
  std::string line;
  if (mode != "off") {
    // The joints with most pops first (at most three).
    const auto most = largest_first(p["by_joint"]);
    std::string top;
    for (std::size_t i = 0; i < std::min<std::size_t>(3, most.size()); ++i)
      top += fmt::format("{}{} {}", i ? ", " : " (", most[i].second, most[i].first);
    if (!top.empty()) top += most.size() > 3 ? ", ...)" : ")";
    const std::size_t found = p["samples"].get<std::size_t>(),
                      fixed = p["repaired"].get<std::size_t>();
    if (found == 0) return line + "  pops: none found\n" + describe_garbage(g);
    line += fmt::format(
        "  pops: {} found in {} clips{}, {}\n", found, p["clips"].get<std::size_t>(), top,
        fixed == found ? std::string("all repaired")
        : fixed == 0   ? std::string("none repaired (--pops repair to force)")
                       : fmt::format("{} repaired (below 60 fps only counted)", fixed));
  }
  return line + describe_garbage(g);
}

}  // namespace mocap::engine
