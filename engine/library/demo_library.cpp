#include "engine/library/demo_library.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>

#include "core/euler.hpp"

namespace mocap::engine {
namespace {

constexpr double kDeg = kPi / 180.0;

struct JointSpec {
  const char* name;
  int parent;
  Vec3 offset;  // cm
  bool end_site;
};

// A 21-joint humanoid, Y up, facing +Z, lengths in cm.
constexpr JointSpec kJoints[] = {
    {"Hips", -1, {0, 95, 0}, false},      {"Spine", 0, {0, 10, 0}, false},
    {"Chest", 1, {0, 20, 0}, false},      {"Neck", 2, {0, 22, 0}, false},
    {"Head", 3, {0, 10, 0}, true},        {"LeftShoulder", 2, {4, 18, 0}, false},
    {"LeftArm", 5, {14, 0, 0}, false},    {"LeftForeArm", 6, {28, 0, 0}, false},
    {"LeftHand", 7, {25, 0, 0}, true},    {"RightShoulder", 2, {-4, 18, 0}, false},
    {"RightArm", 9, {-14, 0, 0}, false},  {"RightForeArm", 10, {-28, 0, 0}, false},
    {"RightHand", 11, {-25, 0, 0}, true}, {"LeftUpLeg", 0, {9, -6, 0}, false},
    {"LeftLeg", 13, {0, -42, 0}, false},  {"LeftFoot", 14, {0, -41, 0}, false},
    {"LeftToe", 15, {0, -6, 13}, true},   {"RightUpLeg", 0, {-9, -6, 0}, false},
    {"RightLeg", 17, {0, -42, 0}, false},
};
// The right foot and toe complete the legs (kept apart to keep the table above readable).
constexpr JointSpec kRightFoot[] = {{"RightFoot", 18, {0, -41, 0}, false},
                                    {"RightToe", 19, {0, -6, 13}, true}};

std::shared_ptr<const Skeleton> make_skeleton(RotationOrder order) {
  auto s = std::make_shared<Skeleton>();
  auto add = [&](const JointSpec& j) {
    s->joint_names.push_back(j.name);
    s->parents.push_back(j.parent);
    s->offsets.push_back(j.offset);
    s->end_sites.push_back(j.end_site ? std::optional<Vec3>(Vec3{0, 0, 8}) : std::nullopt);
    std::vector<Channel> channels;
    if (j.parent < 0) channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
    for (int i = 0; i < 3; ++i) channels.push_back(Channel(3 + order_axis(order, i)));
    s->channels.push_back(channels);
  };
  for (const auto& j : kJoints) add(j);
  for (const auto& j : kRightFoot) add(j);
  return s;
}

int joint_index(const Skeleton& s, const char* name) {
  for (int j = 0; j < s.joint_count(); ++j)
    if (s.joint_names[j] == name) return j;
  return -1;
}

// Per-frame pose: Euler angles (x, y, z about the parent's axes, degrees) per joint name, and
// the root position.
struct Pose {
  std::vector<Vec3> angles_deg;  // per joint: rotation about x, y, z
  Vec3 root;
};

using PoseFunction = std::function<void(double time, const Skeleton&, Pose&)>;

// The local rotation of a joint in the pose (angles in the skeleton's order for the joint).
Quat local_rotation(const Skeleton& s, const Pose& p, int joint) {
  const RotationOrder order = s.rotation_order(joint);
  EulerAngles e;
  for (int i = 0; i < 3; ++i) {
    const int axis = order_axis(order, i);
    const Vec3& a = p.angles_deg[std::size_t(joint)];
    e[i] = (axis == 0 ? a.x : axis == 1 ? a.y : a.z) * kDeg;
  }
  return euler_to_quat(order, e);
}

Clip make_clip(std::shared_ptr<const Skeleton> skeleton, double fps, int frames,
               const PoseFunction& pose_at) {
  Clip clip;
  clip.skeleton = skeleton;
  clip.frame_time = 1.0 / fps;
  clip.frames = frames;
  const int J = skeleton->joint_count();
  clip.rotations.resize(std::size_t(frames) * J * 4);
  clip.translations.resize(std::size_t(frames) * J * 3);
  Pose pose;
  for (int t = 0; t < frames; ++t) {
    pose.angles_deg.assign(J, Vec3{});
    pose.root = skeleton->offsets[0];
    pose_at(t / fps, *skeleton, pose);
    for (int j = 0; j < J; ++j) {
      store_quat(local_rotation(*skeleton, pose, j), clip.rotation_span().at(t, j));
      store_vec3(j == 0 ? pose.root : skeleton->offsets[j], clip.translation_span().at(t, j));
    }
  }
  make_hemisphere_continuous(clip.rotation_span());
  return clip;
}

// A gait: legs swing in antiphase, knees bend in the swing phase, arms counter-swing.
PoseFunction gait(double cycle_s, double speed_cm_s, double stride_deg, double knee_deg,
                  double arm_deg, double bob_cm) {
  return [=](double time, const Skeleton& s, Pose& p) {
    const double ph = 2 * kPi * time / cycle_s;
    auto set = [&](const char* name, Vec3 v) { p.angles_deg[joint_index(s, name)] = v; };
    set("Hips", {0, 8 * std::sin(ph), 0});
    set("Spine", {3, -5 * std::sin(ph), 0});
    set("Chest", {2, -4 * std::sin(ph), 0});
    set("Head", {-4, 3 * std::sin(ph), 0});
    for (int side = 0; side < 2; ++side) {
      const double phase = ph + side * kPi;
      const double knee = knee_deg * std::pow(std::max(0.0, std::sin(phase + 0.8)), 2);
      const bool left = side == 0;
      set(left ? "LeftUpLeg" : "RightUpLeg", {-stride_deg * std::sin(phase), 0, left ? -3.0 : 3.0});
      set(left ? "LeftLeg" : "RightLeg", {knee, 0, 0});
      set(left ? "LeftFoot" : "RightFoot", {10 * std::sin(phase - 0.6), 0, 0});
      set(left ? "LeftToe" : "RightToe", {-12 * std::max(0.0, std::sin(phase - 1.4)), 0, 0});
      set(left ? "LeftArm" : "RightArm", {arm_deg * std::sin(phase), 0, left ? -70.0 : 70.0});
      set(left ? "LeftForeArm" : "RightForeArm", {0, left ? -20.0 : 20.0, 0});
    }
    p.root = {0, 95 + bob_cm * std::cos(2 * ph), speed_cm_s * time};
  };
}

// Standing, the right hand waves quickly: a small fast gesture a smoothing filter would blur.
void wave(double time, const Skeleton& s, Pose& p) {
  auto set = [&](const char* name, Vec3 v) { p.angles_deg[joint_index(s, name)] = v; };
  set("Spine", {2, 4 * std::sin(0.8 * time), 0});
  set("LeftArm", {0, 0, -75});
  set("RightArm", {0, -10, 10 + 5 * std::sin(1.3 * time)});
  set("RightForeArm", {0, 100, 0});
  set("RightHand", {0, 0, 25 * std::sin(2 * kPi * 3.0 * time)});
  set("Head", {0, 15 * std::sin(0.5 * time), 0});
}

// A joint's position relative to the root's, by forward kinematics of the pose.
Vec3 from_root(const Skeleton& s, const Pose& p, int joint) {
  Vec3 position{};
  for (int j = joint; s.parents[std::size_t(j)] >= 0; j = s.parents[std::size_t(j)]) {
    const int parent = s.parents[std::size_t(j)];
    position = rotate(local_rotation(s, p, parent), s.offsets[std::size_t(j)] + position);
  }
  return position;
}

// The legs of the turn: the foot of `side` (0 left, 1 right) lifts while the other stands.
void turn_pose(double time, const Skeleton& s, Pose& p) {
  p.angles_deg[std::size_t(joint_index(s, "Hips"))] = {0, 360.0 * time / 3.0, 0};
  auto set = [&](const char* name, Vec3 v) { p.angles_deg[std::size_t(joint_index(s, name))] = v; };
  const double step = 2 * kPi * time / 0.75;
  set("LeftUpLeg", {-30 * std::max(0.0, std::sin(step)), 0, -3});
  set("LeftLeg", {60 * std::max(0.0, std::sin(step)), 0, 0});
  set("RightUpLeg", {-30 * std::max(0.0, -std::sin(step)), 0, 3});
  set("RightLeg", {60 * std::max(0.0, -std::sin(step)), 0, 0});
  set("LeftArm", {0, 0, -70});
  set("RightArm", {0, 0, 70});
}

// Turning on the spot through a full circle (the root rotation passes pi) in steps, as a body
// does: the feet lift in turn every 0.375 s, and the standing foot stays where it landed while
// the body turns about it (the root moves so that the standing ankle holds still), so the
// ground truth itself has planted feet for the lock to keep.
void turn(double time, const Skeleton& s, Pose& p) {
  constexpr double half_step = 0.375;
  const int ankles[2] = {joint_index(s, "LeftFoot"), joint_index(s, "RightFoot")};
  Pose at = p;
  auto ankle_at = [&](double t, int side) {
    at.angles_deg = p.angles_deg;
    turn_pose(t, s, at);
    return from_root(s, at, ankles[side]);
  };
  const Vec3 start = p.root;
  // Each half step: the right foot stands while the left lifts (even), then the other.
  const int halves = int(std::floor(time / half_step));
  Vec3 root = start;
  for (int k = 0; k < halves; ++k) {
    // At the end of half k the standing foot changes; the root at that moment places both.
    const double t1 = (k + 1) * half_step;
    const int stance = k % 2 == 0 ? 1 : 0;
    const Vec3 planted = root + ankle_at(k * half_step, stance);
    root = planted - ankle_at(t1, stance);
  }
  const int stance = halves % 2 == 0 ? 1 : 0;
  const Vec3 planted = root + ankle_at(halves * half_step, stance);
  root = planted - ankle_at(time, stance);
  turn_pose(time, s, p);
  p.root = {root.x, start.y, root.z};
}

}  // namespace

std::vector<DemoClip> make_demo_library() {
  const auto daz = make_skeleton(RotationOrder::ZXY);
  const auto cmu = make_skeleton(RotationOrder::ZYX);
  std::vector<DemoClip> clips;
  clips.push_back(
      {"walk/walk_120fps.bvh", make_clip(cmu, 120, 480, gait(1.1, 130, 25, 55, 20, 2))});
  clips.push_back({"walk/run_120fps.bvh", make_clip(cmu, 120, 360, gait(0.7, 320, 40, 90, 35, 4))});
  clips.push_back({"gesture/wave_120fps.bvh", make_clip(daz, 120, 360, wave)});
  clips.push_back({"gesture/turn_30fps.bvh", make_clip(daz, 30, 120, turn)});
  return clips;
}

}  // namespace mocap::engine
