// `mocap-clean info FILE.bvh`: what one BVH file holds (joints, frames, frame rate, channel
// orders, garbage joints), in the words of `info` on a library.
#include <fmt/core.h>

#include <map>

#include "app/commands.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "io/bvh_reader.hpp"

namespace mocap::engine {

int run_info_bvh(const InfoCommand& command) {
  const io::BvhReadResult result = io::read_bvh(command.input);
  if (result.error) {
    fmt::print(stderr, "mocap-clean: info: {}\n", result.error->what());
    return 2;
  }
  Clip clip = *result.clip;
  const Skeleton& skeleton = *clip.skeleton;
  nlohmann::json joints = nlohmann::json::array();
  std::map<std::string, int> orders;  // rotation order -> joints
  for (int j = 0; j < skeleton.joint_count(); ++j) {
    const int parent = skeleton.parents[std::size_t(j)];
    nlohmann::json joint = {
        {"name", skeleton.joint_names[std::size_t(j)]},
        {"parent", parent < 0 ? nlohmann::json(nullptr)
                              : nlohmann::json(skeleton.joint_names[std::size_t(parent)])},
        {"channels", skeleton.channel_list(j)}};
    if (skeleton.has_rotation(j)) {
      const std::string order(to_string(skeleton.rotation_order(j)));
      joint["rotation_order"] = order;
      ++orders[order];
    }
    joints.push_back(std::move(joint));
  }
  // Garbage joints as `info --joints` and the pop stage classify them (nothing repaired).
  ConditioningTally tally;
  tally.add(command.input, clip,
            condition_rotations(PopsMode::off, clip.rotation_span(), clip.frame_time));
  nlohmann::json garbage = nlohmann::json::array();
  if (!tally.garbage.empty()) garbage = tally.garbage[0]["joints"];

  nlohmann::json j;
  j["file"] = command.input;
  j["format"] = "bvh";
  j["frames"] = clip.frames;
  j["frame_time"] = clip.frame_time;
  j["frame_rate"] = 1.0 / clip.frame_time;
  j["seconds"] = clip.frames * clip.frame_time;
  j["joints"] = skeleton.joint_count();
  j["channels"] = skeleton.channel_count();
  j["rotation_orders"] = orders;
  j["garbage_joints"] = garbage;
  j["joint_list"] = joints;
  if (command.json) {
    fmt::print("{}\n", j.dump());
    return 0;
  }
  fmt::print("{}: BVH, {} frames at {:.6g} fps ({:.2f} s), {} joints, {} channels\n", command.input,
             clip.frames, 1.0 / clip.frame_time, clip.frames * clip.frame_time,
             skeleton.joint_count(), skeleton.channel_count());
  std::string order_text;
  for (const auto& [order, count] : orders)
    order_text += fmt::format("{}{} ({} joints)", order_text.empty() ? "" : ", ", order, count);
  fmt::print("  rotation orders: {}\n", order_text.empty() ? "none" : order_text);
  std::string garbage_text;
  for (const auto& g : garbage)
    garbage_text += fmt::format("{}{} ({})", garbage_text.empty() ? "" : ", ",
                                g["joint"].get<std::string>(), g["class"].get<std::string>());
  fmt::print("  garbage joints: {}\n", garbage_text.empty() ? "none" : garbage_text);
  for (const auto& joint : joints)
    fmt::print("  {:<20} {:<20} {}\n", joint["name"].get<std::string>(),
               joint["parent"].is_null() ? "(root)" : "< " + joint["parent"].get<std::string>(),
               joint["channels"].get<std::string>());
  return 0;
}

}  // namespace mocap::engine
