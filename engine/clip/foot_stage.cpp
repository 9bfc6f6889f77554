#include "engine/clip/foot_stage.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "engine/clip/filter_settings.hpp"
#include "kernels/forward_kinematics.hpp"

namespace mocap::engine {

bool joint_positions_into(const Clip& clip, std::span<const int> joints,
                          std::span<float> positions) {
  const Skeleton& sk = *clip.skeleton;
  const int outputs = joints.empty() ? sk.joint_count() : int(joints.size());
  if (positions.size() != std::size_t(clip.frames) * std::size_t(outputs) * 3) return false;
  const std::vector<std::uint8_t> translated = sk.translated_mask();
  ForwardKinematicsJob fk;
  fk.parents = sk.parents;
  fk.offsets = sk.offsets;
  fk.rotations = clip.rotation_view();
  fk.translations = clip.translation_view();
  fk.translated_joints = translated;
  fk.output_joints = joints;
  fk.positions = {positions.data(), clip.frames, outputs};
  return fk.run().ok();
}

std::vector<float> joint_positions(const Clip& clip, std::span<const int> joints) {
  const int outputs = joints.empty() ? clip.skeleton->joint_count() : int(joints.size());
  std::vector<float> positions(std::size_t(clip.frames) * std::size_t(outputs) * 3);
  if (!joint_positions_into(clip, joints, positions)) positions.clear();
  return positions;
}

namespace {

// The legs' ankles' global positions [F][legs][3]; empty when the clip's shapes do not agree.
std::vector<float> ankle_tracks(const Clip& clip, const std::vector<FootChain>& legs) {
  std::vector<int> ankles;
  for (const FootChain& leg : legs) ankles.push_back(leg.ankle);
  return joint_positions(clip, ankles);
}

// Contacts [leg] of the ankle tracks; false for a flat skeleton (no height).
bool find_contacts(const Clip& clip, const std::vector<FootChain>& legs,
                   const std::vector<float>& ankles,
                   std::vector<std::vector<ContactInterval>>& contacts, double allowance) {
  FootContactJob job;
  job.feet = {ankles.data(), clip.frames, int(legs.size())};
  job.frame_time = clip.frame_time;
  job.body_height = body_height(*clip.skeleton);
  job.contacts = &contacts;
  job.params.noise_allowance = allowance;
  return job.run().ok();
}

// The input's contacts widened by the filtered motion's (kernels/foot_contacts.hpp,
// widen_contacts; docs/feet.md, "Widening").
void widen_by_filtered(ClipFeet& feet, const Clip& filtered) {
  const std::vector<float> ankles = ankle_tracks(filtered, feet.legs);
  std::vector<std::vector<ContactInterval>> found;
  if (ankles.empty() || !find_contacts(filtered, feet.legs, ankles, found, 0)) return;
  const double reach = kWidenReach * body_height(*filtered.skeleton);
  const std::size_t N = feet.legs.size();
  std::vector<Vec3> track(std::size_t(filtered.frames));
  for (std::size_t n = 0; n < N; ++n) {
    for (int t = 0; t < filtered.frames; ++t)
      track[std::size_t(t)] = load_vec3(&ankles[(std::size_t(t) * N + n) * 3]);
    feet.contacts[n] = widen_contacts(feet.contacts[n], found[n], track, reach);
  }
}

}  // namespace

ClipFeet detect_feet(const Clip& clip) {
  ClipFeet feet;
  if (!clip.skeleton || clip.frames == 0) return feet;
  const Skeleton& sk = *clip.skeleton;
  for (const FootChain& c : find_feet(sk.joint_names, sk.parents, sk.offsets))
    if (c.hip >= 0 && c.knee >= 0 && c.ankle >= 0) feet.legs.push_back(c);
  if (feet.legs.empty()) return feet;
  const std::size_t L = feet.legs.size();
  std::vector<int> anchor_joints;
  for (const FootChain& leg : feet.legs) {
    anchor_joints.push_back(leg.ankle);
    anchor_joints.push_back(leg.toe >= 0 ? leg.toe : leg.ankle);
  }
  feet.anchors = joint_positions(clip, anchor_joints);
  if (feet.anchors.empty()) return {};  // checked clips always pass; nothing to lock otherwise
  std::vector<float> ankles(std::size_t(clip.frames) * L * 3);
  for (std::size_t i = 0; i < std::size_t(clip.frames) * L; ++i)
    std::copy_n(&feet.anchors[i * 6], 3, &ankles[i * 3]);
  if (!find_contacts(clip, feet.legs, ankles, feet.contacts, kContactNoiseAllowance))
    return {};  // a flat skeleton
  return feet;
}

Status lock_feet(ClipFeet& feet, Clip& filtered, const FootLockParams& params,
                 std::span<const std::uint8_t> counted_steps, FootLockScratch* scratch) {
  if (feet.legs.empty()) return {};
  widen_by_filtered(feet, filtered);
  const Skeleton& sk = *filtered.skeleton;
  const std::vector<std::uint8_t> translated = sk.translated_mask();
  FootLockJob job;
  job.params = params;
  job.parents = sk.parents;
  job.offsets = sk.offsets;
  job.translated_joints = translated;
  job.frame_time = filtered.frame_time;
  job.rotations = filtered.rotation_span();
  job.translations = filtered.translation_span();
  job.legs = feet.legs;
  job.contacts = feet.contacts;
  job.counted_steps = counted_steps;
  job.input_anchors = feet.anchors;
  job.body_height = body_height(sk);
  job.stats = &feet.stats;
  job.scratch = scratch;
  if (Status s = job.run(); !s) return s;
  feet.locked = true;
  return {};
}

void FeetTally::add(const std::string& clip, const Clip& data, const ClipFeet& feet) {
  ++clips;
  nlohmann::json legs = nlohmann::json::array();
  for (std::size_t l = 0; l < feet.legs.size(); ++l) {
    nlohmann::json intervals = nlohmann::json::array();
    for (const ContactInterval& c : feet.contacts[l]) intervals.push_back({c.begin, c.end});
    if (feet.locked) contacts += feet.contacts[l].size();  // the guard may have unlocked them
    legs.push_back({{"joint", data.skeleton->joint_names[std::size_t(feet.legs[l].ankle)]},
                    {"contacts", feet.contacts[l].size()},
                    {"intervals", std::move(intervals)}});
  }
  locked_frames += std::size_t(feet.stats.locked_frames);
  lowered_frames += std::size_t(feet.stats.lowered_frames);
  nlohmann::json entry = {{"clip", clip}, {"feet", std::move(legs)}, {"locked", feet.locked}};
  if (feet.locked) {
    entry["root_lowered_frames"] = feet.stats.lowered_frames;
    entry["anchor_noise"] = feet.stats.anchor_noise;  // body heights
    entry["pin_sigma_s"] = feet.stats.pin_sigma;
  }
  by_clip.push_back(std::move(entry));
}

void FeetTally::write_to(nlohmann::json& summary) const {
  if (!lock) {
    summary["feet"] = {{"mode", "off"}};
    return;
  }
  summary["feet"] = {{"mode", "lock"},
                     {"clips", clips},
                     {"contacts", contacts},
                     {"locked_frames", locked_frames},
                     {"root_lowered_frames", lowered_frames},
                     {"by_clip", by_clip}};
}

std::string describe_feet(const nlohmann::json& summary) {
  if (!summary.contains("feet") || summary["feet"]["mode"] != "lock") return "";
  const auto& f = summary["feet"];
  const std::size_t lowered = f["root_lowered_frames"].get<std::size_t>();
  return fmt::format("  feet: {} contacts locked in {} clips ({} leg-frames){}\n",
                     f["contacts"].get<std::size_t>(), f["clips"].get<std::size_t>(),
                     f["locked_frames"].get<std::size_t>(),
                     lowered ? fmt::format(", root lowered on {} frames", lowered) : "");
}

Status lock_feet_in_segments(ClipFeet& feet, Clip& filtered, const std::vector<Segment>& segments,
                             FootLockScratch* scratch) {
  const std::size_t joints = std::size_t(filtered.joints());
  std::vector<std::pair<Segment, std::pair<std::vector<float>, std::vector<float>>>> kept;
  for (const Segment& s : segments) {
    if (s.frames() >= 2) continue;
    const std::size_t begin = std::size_t(s.begin) * joints, end = std::size_t(s.end) * joints;
    kept.push_back({s,
                    {std::vector<float>(filtered.rotations.begin() + std::ptrdiff_t(begin * 4),
                                        filtered.rotations.begin() + std::ptrdiff_t(end * 4)),
                     std::vector<float>(filtered.translations.begin() + std::ptrdiff_t(begin * 3),
                                        filtered.translations.begin() + std::ptrdiff_t(end * 3))}});
  }
  // The knee's speed limit: the filtered clip's peak over the steps inside its segments (a
  // step into CMU's T-pose frame is not motion), which the job finds itself (max_knee_speed 0:
  // peak_knee_speed over counted_steps, from the pass it makes anyway); a peak of 0 (knees that
  // never turn) binds nothing.
  std::vector<std::uint8_t> counted(std::size_t(filtered.frames), segments.empty() ? 1 : 0);
  for (const Segment& s : segments)
    for (int t = s.begin + 1; t < s.end; ++t) counted[std::size_t(t)] = 1;
  FootLockParams params;
  params.max_knee_speed = 0;
  const Status status = lock_feet(feet, filtered, params, counted, scratch);
  for (const auto& [s, values] : kept) {
    const std::size_t begin = std::size_t(s.begin) * joints;
    std::copy(values.first.begin(), values.first.end(),
              filtered.rotations.begin() + std::ptrdiff_t(begin * 4));
    std::copy(values.second.begin(), values.second.end(),
              filtered.translations.begin() + std::ptrdiff_t(begin * 3));
  }
  return status;
}

}  // namespace mocap::engine
