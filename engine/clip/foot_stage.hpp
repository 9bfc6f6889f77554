#pragma once
// Foot locking as an engine stage (docs/feet.md): contacts found on a clip as it came (after
// pop repair, before the filter), and the planted feet pinned on the filtered clip
// (kernels/foot_lock.hpp). Also the tally of a run, for --json and the closing line.
#include <cstddef>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "core/clip.hpp"
#include "kernels/foot_contacts.hpp"
#include "kernels/foot_lock.hpp"
#include "kernels/motion_split.hpp"

namespace mocap::engine {

// How far (body heights, horizontal) a planted foot of the filtered motion may stand from its
// contact's pin for widen_contacts to grow the contact over it (docs/feet.md, "Widening", says
// how it was chosen).
constexpr double kWidenReach = 0.02;
// The lock's contact detector lets a foot enter a contact at up to this many times its track's
// noise speed above the enter threshold (FootContactParams::noise_allowance; docs/feet.md,
// "Contacts", says how it was chosen). The skating metric's contacts use none, nor does the
// widening's detector on the filtered motion, whose noise the filter removed (with the allowance
// there too, eval's report is the same but for one skating figure in the fourth digit, and the
// stage costs one more noise estimate per leg).
constexpr double kContactNoiseAllowance = 2;

struct ClipFeet {
  std::vector<FootChain> legs;  // the skeleton's feet (find_feet)
  // Per leg, its ankle's: found on the input, then widened by lock_feet.
  std::vector<std::vector<ContactInterval>> contacts;
  // [F][legs][2][3]: the input's ankle and toe positions per leg (the ankle again without toe).
  std::vector<float> anchors;
  FootLockStats stats;  // of lock_feet
  bool locked = false;
};

// Every joint's global position [F][J][3] by forward kinematics (the position channels where the
// skeleton has them, else the offsets); empty when the clip's shapes do not agree.
// `joints` (optional): only these joints' positions, [F][K][3] in this order, at the cost of
// their chains (ForwardKinematicsJob::output_joints).
std::vector<float> joint_positions(const Clip& clip, std::span<const int> joints = {});
// The same into `positions` ([F][K][3], K = joints.size() or every joint), which it overwrites
// whole, so a caller can hand it memory that was never zeroed; false where the former is empty.
bool joint_positions_into(const Clip& clip, std::span<const int> joints,
                          std::span<float> positions);

// The legs of the clip's skeleton and their contacts in `clip` (global ankle positions by
// forward kinematics; the body height from the rest pose).
ClipFeet detect_feet(const Clip& clip);

// Pins the planted feet of `filtered` (the clip detect_feet saw, filtered) in place.
// `counted_steps` (optional, one per frame): FootLockJob's. `scratch` (optional): working memory
// reused across clips, one per thread (tbb::enumerable_thread_specific): only the lock's run()
// uses it, and that makes no TBB call, so no task the thread steals can find it in use. Results
// do not depend on it.
// First widens feet.contacts by the contacts of `filtered` itself (widen_contacts, reach
// kWidenReach body heights): noise breaks and clips the input's contacts; the filtered motion
// holds them whole.
Status lock_feet(ClipFeet& feet, Clip& filtered, const FootLockParams& params = {},
                 std::span<const std::uint8_t> counted_steps = {},
                 FootLockScratch* scratch = nullptr);

// lock_feet, with the frames of the segments the filter leaves as they came (one-frame segments
// between impossible steps, kernels/motion_split.hpp: CMU's synthetic T-pose frame 0) restored
// afterwards: they are not motion, and a T-pose must come out a T-pose.
Status lock_feet_in_segments(ClipFeet& feet, Clip& filtered, const std::vector<Segment>& segments,
                             FootLockScratch* scratch = nullptr);

// Over a run: contacts per clip.
struct FeetTally {
  bool lock = false;
  std::size_t clips = 0, contacts = 0, locked_frames = 0, lowered_frames = 0;
  nlohmann::json by_clip = nlohmann::json::array();  // [{clip, feet: [{joint, intervals}]}]

  void add(const std::string& clip, const Clip& data, const ClipFeet& feet);
  // Adds "feet" to a --json summary.
  void write_to(nlohmann::json& summary) const;
};

// The closing line's words for a summary holding them ("" when it holds none):
// "  feet: 24 contacts locked in 3 clips (1810 leg-frames), root lowered on 12 frames".
std::string describe_feet(const nlohmann::json& summary);

}  // namespace mocap::engine
