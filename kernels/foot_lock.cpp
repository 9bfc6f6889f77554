#include "kernels/foot_lock.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace mocap {
namespace {

Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// The shortest-arc rotation taking the direction of u onto the direction of v.
Quat rotation_between(Vec3 u, Vec3 v) {
  const double nu = norm(u), nv = norm(v);
  if (nu <= 0 || nv <= 0) return {};
  u = (1 / nu) * u;
  v = (1 / nv) * v;
  const double w = 1 + dot(u, v);
  if (w < 1e-12) {  // opposite: any axis perpendicular to u
    Vec3 axis = cross(u, std::abs(u.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0});
    axis = (1 / norm(axis)) * axis;
    return {0, axis.x, axis.y, axis.z};
  }
  const Vec3 c = cross(u, v);
  return normalized({w, c.x, c.y, c.z});
}

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

double median(std::vector<double>& values) {
  const std::size_t n = values.size();
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(n / 2), values.end());
  const double upper = values[n / 2];
  if (n % 2 == 1) return upper;
  return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + std::ptrdiff_t(n / 2)));
}

// What the IK needs of one leg at one frame, from the filtered motion.
struct LegFrame {
  Vec3 hip, knee, ankle, toe;
  Quat parent_rotation, hip_rotation, knee_rotation, ankle_rotation;  // global
};

// A run of frames with the same anchor (1: ankle, 2: toe).
struct Segment {
  int begin, end, anchor;
};

// label[t]: 1 where the ankle is in contact, else 2 where the toe is, else 0.
std::vector<std::uint8_t> contact_labels(const std::vector<ContactInterval>* ankle,
                                         const std::vector<ContactInterval>* toe, int frames) {
  std::vector<std::uint8_t> label(std::size_t(frames), 0);
  auto mark = [&](const std::vector<ContactInterval>* list, std::uint8_t value) {
    if (list == nullptr) return;
    for (const ContactInterval& c : *list)
      for (int t = std::max(c.begin, 0); t < std::min(c.end, frames); ++t)
        if (label[std::size_t(t)] == 0) label[std::size_t(t)] = value;
  };
  mark(ankle, 1);
  mark(toe, 2);
  return label;
}

// D(t) of the header for one leg; active[t] = 1 where the leg is locked or blending.
// Returns the number of contacts (clusters of adjacent segments).
int leg_offsets(const FootChain& leg, std::span<const LegFrame> frames,
                std::span<const std::uint8_t> label, int blend, std::vector<Vec3>& offset,
                std::vector<std::uint8_t>& active) {
  const int count = int(frames.size());
  offset.assign(std::size_t(count), Vec3{});
  active.assign(std::size_t(count), 0);
  auto anchor_at = [&](int anchor, int t) {
    const LegFrame& f = frames[std::size_t(t)];
    return anchor == 1 || leg.toe < 0 ? f.ankle : f.toe;
  };
  std::vector<Segment> segments;
  for (int t = 0; t < count;) {
    if (label[std::size_t(t)] == 0) {
      ++t;
      continue;
    }
    int e = t;
    while (e < count && label[std::size_t(e)] == label[std::size_t(t)]) ++e;
    segments.push_back({t, e, label[std::size_t(t)]});
    t = e;
  }
  // Clusters: maximal runs of segments with no frame between them.
  struct Cluster {
    int first, last;  // segment indices, inclusive
  };
  std::vector<Cluster> clusters;
  for (int s = 0; s < int(segments.size()); ++s) {
    if (!clusters.empty() &&
        segments[std::size_t(clusters.back().last)].end == segments[std::size_t(s)].begin)
      clusters.back().last = s;
    else
      clusters.push_back({s, s});
  }
  std::vector<double> xs, ys, zs;
  for (const Cluster& c : clusters) {
    // The primary segment: the longest ankle segment, else the longest.
    int primary = c.first;
    for (int s = c.first; s <= c.last; ++s) {
      const Segment& a = segments[std::size_t(s)];
      const Segment& p = segments[std::size_t(primary)];
      const bool better =
          (a.anchor == 1) != (p.anchor == 1) ? a.anchor == 1 : a.end - a.begin > p.end - p.begin;
      if (better) primary = s;
    }
    const Segment& p = segments[std::size_t(primary)];
    xs.clear();
    ys.clear();
    zs.clear();
    for (int t = p.begin; t < p.end; ++t) {
      const Vec3 v = anchor_at(p.anchor, t);
      xs.push_back(v.x);
      ys.push_back(v.y);
      zs.push_back(v.z);
    }
    const Vec3 pin{median(xs), median(ys), median(zs)};
    for (int t = p.begin; t < p.end; ++t) offset[std::size_t(t)] = pin - anchor_at(p.anchor, t);
    // Neighbouring segments continue the offset the anchor had next to them.
    for (int s = primary + 1; s <= c.last; ++s) {
      const Segment& g = segments[std::size_t(s)];
      const Vec3 pin_s = anchor_at(g.anchor, g.begin) + offset[std::size_t(g.begin - 1)];
      for (int t = g.begin; t < g.end; ++t) offset[std::size_t(t)] = pin_s - anchor_at(g.anchor, t);
    }
    for (int s = primary - 1; s >= c.first; --s) {
      const Segment& g = segments[std::size_t(s)];
      const Vec3 pin_s = anchor_at(g.anchor, g.end - 1) + offset[std::size_t(g.end)];
      for (int t = g.begin; t < g.end; ++t) offset[std::size_t(t)] = pin_s - anchor_at(g.anchor, t);
    }
    for (int t = segments[std::size_t(c.first)].begin; t < segments[std::size_t(c.last)].end; ++t)
      active[std::size_t(t)] = 1;
  }
  // Between and around contacts.
  auto fade = [&](int edge, int step, Vec3 from) {  // from edge (inside), B frames outwards
    for (int k = 1; k <= blend; ++k) {
      const int t = edge + step * k;
      if (t < 0 || t >= count) break;
      offset[std::size_t(t)] = smoothstep(1 - double(k) / (blend + 1)) * from;
      active[std::size_t(t)] = 1;
    }
  };
  for (std::size_t k = 0; k < clusters.size(); ++k) {
    const int begin = segments[std::size_t(clusters[k].first)].begin;
    const int end = segments[std::size_t(clusters[k].last)].end;
    if (k == 0) fade(begin, -1, offset[std::size_t(begin)]);
    if (k + 1 == clusters.size()) {
      fade(end - 1, +1, offset[std::size_t(end - 1)]);
      continue;
    }
    const int next = segments[std::size_t(clusters[k + 1].first)].begin;
    if (next - end <= 2 * blend) {
      const Vec3 left = offset[std::size_t(end - 1)], right = offset[std::size_t(next)];
      for (int t = end; t < next; ++t) {
        const double u = double(t - (end - 1)) / double(next - (end - 1));
        offset[std::size_t(t)] = (1 - u) * left + u * right;
        active[std::size_t(t)] = 1;
      }
    } else {
      fade(end - 1, +1, offset[std::size_t(end - 1)]);
      fade(next, -1, offset[std::size_t(next)]);
    }
  }
  return int(clusters.size());
}

int top_ancestor(std::span<const int> parents, int joint) {
  while (parents[std::size_t(joint)] >= 0) joint = parents[std::size_t(joint)];
  return joint;
}

}  // namespace

Status FootLockParams::validate() const {
  if (!(blend_time >= 0) || !std::isfinite(blend_time))
    return Status::error("foot lock: blend_time must be finite and >= 0");
  if (!(max_reach > 0 && max_reach <= 1))
    return Status::error("foot lock: max_reach must be in (0, 1]");
  return {};
}

Status FootLockJob::validate() const {
  if (Status s = params.validate(); !s) return s;
  const int joints = int(parents.size());
  if (offsets.size() != parents.size())
    return Status::error("foot lock: offsets has " + std::to_string(offsets.size()) +
                         " entries, parents " + std::to_string(joints));
  for (int j = 0; j < joints; ++j)
    if (parents[std::size_t(j)] >= j || parents[std::size_t(j)] < -1)
      return Status::error("foot lock: joint " + std::to_string(j) +
                           " does not come after its parent");
  if (rotations.joints != joints || (rotations.frames > 0 && rotations.data == nullptr))
    return Status::error("foot lock: rotations must be [frames][" + std::to_string(joints) +
                         "][4]");
  if (!translated_joints.empty()) {
    if (int(translated_joints.size()) != joints)
      return Status::error("foot lock: translated_joints must have one entry per joint");
    if (!translations.same_shape(rotations) || translations.data == nullptr)
      return Status::error("foot lock: translations must have the shape of the rotations");
  }
  if (!(frame_time > 0) || !std::isfinite(frame_time))
    return Status::error("foot lock: frame_time must be > 0");
  if (contacts.size() != legs.size())
    return Status::error("foot lock: " + std::to_string(contacts.size()) + " contact lists for " +
                         std::to_string(legs.size()) + " legs");
  if (!toe_contacts.empty() && toe_contacts.size() != legs.size())
    return Status::error("foot lock: " + std::to_string(toe_contacts.size()) +
                         " toe contact lists for " + std::to_string(legs.size()) + " legs");
  std::vector<std::uint8_t> used(std::size_t(joints), 0);
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const FootChain& leg = legs[l];
    if (leg.hip < 0 || leg.knee < 0 || leg.ankle < 0) continue;  // skipped by run()
    const std::string name = "foot lock: leg " + std::to_string(l);
    auto in_range = [&](int j) { return j >= 0 && j < joints; };
    if (!in_range(leg.hip) || !in_range(leg.knee) || !in_range(leg.ankle))
      return Status::error(name + " names a joint out of range");
    if (parents[std::size_t(leg.knee)] != leg.hip || parents[std::size_t(leg.ankle)] != leg.knee)
      return Status::error(name + " is not a hip -> knee -> ankle chain");
    if (leg.toe >= 0 && (!in_range(leg.toe) || parents[std::size_t(leg.toe)] != leg.ankle))
      return Status::error(name + ": its toe is not a child of its ankle");
    for (int j : {leg.hip, leg.knee, leg.ankle}) {
      if (used[std::size_t(j)]) return Status::error(name + " shares a joint with another leg");
      used[std::size_t(j)] = 1;
    }
    if (!toe_contacts.empty() && !toe_contacts[l].empty() && leg.toe < 0)
      return Status::error(name + " has toe contacts but no toe joint");
  }
  auto check = [](std::span<const std::vector<ContactInterval>> lists, const char* what) {
    for (std::size_t p = 0; p < lists.size(); ++p)
      for (std::size_t k = 0; k < lists[p].size(); ++k) {
        const ContactInterval& c = lists[p][k];
        if (c.begin >= c.end || (k > 0 && c.begin < lists[p][k - 1].end))
          return Status::error(std::string("foot lock: the ") + what + " contacts of leg " +
                               std::to_string(p) +
                               " are not ordered, disjoint, non-empty intervals");
      }
    return Status{};
  };
  if (Status s = check(contacts, "ankle"); !s) return s;
  if (Status s = check(toe_contacts, "toe"); !s) return s;
  return {};
}

Status FootLockJob::run() const {
  if (Status s = validate(); !s) return s;
  FootLockStats local_stats;
  const int frames = rotations.frames, joints = int(parents.size());
  std::vector<FootChain> chains;  // the complete legs
  std::vector<const std::vector<ContactInterval>*> ankle_lists, toe_lists;
  for (std::size_t l = 0; l < legs.size(); ++l) {
    if (legs[l].hip < 0 || legs[l].knee < 0 || legs[l].ankle < 0) continue;
    chains.push_back(legs[l]);
    ankle_lists.push_back(&contacts[l]);
    toe_lists.push_back(toe_contacts.empty() || legs[l].toe < 0 ? nullptr : &toe_contacts[l]);
  }
  if (chains.empty() || frames == 0) {
    if (stats) *stats = local_stats;
    return {};
  }
  const std::size_t leg_count = chains.size();

  // Pass 1: the filtered motion's leg frames (forward kinematics, spec-free, as in
  // forward_kinematics.hpp, with the global rotations kept).
  std::vector<std::vector<LegFrame>> leg_frames(leg_count,
                                                std::vector<LegFrame>(std::size_t(frames)));
  std::vector<Quat> rotation(static_cast<std::size_t>(joints));
  std::vector<Vec3> position(static_cast<std::size_t>(joints));
  // Only the legs and their ancestors are needed (a third of a CMU skeleton).
  std::vector<std::uint8_t> needed(std::size_t(joints), 0);
  for (const FootChain& leg : chains)
    for (int j = leg.toe >= 0 ? leg.toe : leg.ankle; j >= 0 && !needed[std::size_t(j)];
         j = parents[std::size_t(j)])
      needed[std::size_t(j)] = 1;
  auto forward = [&](int t) {
    for (int j = 0; j < joints; ++j) {
      if (!needed[std::size_t(j)]) continue;
      const Quat q = load_quat(rotations.at(t, j));
      const Vec3 local = !translated_joints.empty() && translated_joints[std::size_t(j)] != 0
                             ? load_vec3(translations.at(t, j))
                             : offsets[std::size_t(j)];
      const int p = parents[std::size_t(j)];
      if (p < 0) {
        rotation[std::size_t(j)] = q;
        position[std::size_t(j)] = local;
      } else {
        rotation[std::size_t(j)] = rotation[std::size_t(p)] * q;
        position[std::size_t(j)] =
            position[std::size_t(p)] + rotate(rotation[std::size_t(p)], local);
      }
    }
  };
  for (int t = 0; t < frames; ++t) {
    forward(t);
    for (std::size_t l = 0; l < leg_count; ++l) {
      const FootChain& leg = chains[l];
      LegFrame& f = leg_frames[l][std::size_t(t)];
      f.hip = position[std::size_t(leg.hip)];
      f.knee = position[std::size_t(leg.knee)];
      f.ankle = position[std::size_t(leg.ankle)];
      f.toe = leg.toe >= 0 ? position[std::size_t(leg.toe)] : f.ankle;
      const int parent = parents[std::size_t(leg.hip)];
      f.parent_rotation = parent >= 0 ? rotation[std::size_t(parent)] : Quat{};
      f.hip_rotation = rotation[std::size_t(leg.hip)];
      f.knee_rotation = rotation[std::size_t(leg.knee)];
      f.ankle_rotation = rotation[std::size_t(leg.ankle)];
    }
  }

  // The offsets D(t) per leg.
  const int blend = std::max(1, int(std::lround(params.blend_time / frame_time)));
  std::vector<std::vector<Vec3>> offset(leg_count);
  std::vector<std::vector<std::uint8_t>> active(leg_count);
  for (std::size_t l = 0; l < leg_count; ++l) {
    const std::vector<std::uint8_t> label = contact_labels(ankle_lists[l], toe_lists[l], frames);
    for (std::uint8_t v : label) local_stats.locked_frames += v != 0;
    local_stats.contacts +=
        leg_offsets(chains[l], leg_frames[l], label, blend, offset[l], active[l]);
  }

  // The bend-plane normal of each leg, carried over frames where the leg is straight: first the
  // first frame's that has one.
  std::vector<Vec3> normal(leg_count, Vec3{});
  for (std::size_t l = 0; l < leg_count; ++l) {
    for (const LegFrame& f : leg_frames[l]) {
      const Vec3 n = cross(f.knee - f.hip, f.ankle - f.hip);
      if (norm(n) >
          1e-9 * (dot(f.knee - f.hip, f.knee - f.hip) + dot(f.ankle - f.knee, f.ankle - f.knee))) {
        normal[l] = (1 / norm(n)) * n;
        break;
      }
    }
    if (norm(normal[l]) == 0) normal[l] = rotate(leg_frames[l][0].hip_rotation, Vec3{1, 0, 0});
  }
  std::vector<int> root(leg_count);
  for (std::size_t l = 0; l < leg_count; ++l) root[l] = top_ancestor(parents, chains[l].hip);
  auto lowerable = [&](int r) {
    return !translated_joints.empty() && translated_joints[std::size_t(r)] != 0;
  };

  // Pass 2: per frame, the roots' drops, then the IK.
  std::vector<Vec3> target(leg_count);
  std::vector<double> reach(leg_count);
  std::vector<std::pair<int, double>> drops;  // (root, drop)
  for (int t = 0; t < frames; ++t) {
    drops.clear();
    for (std::size_t l = 0; l < leg_count; ++l) {
      const LegFrame& f = leg_frames[l][std::size_t(t)];
      const Vec3 n = cross(f.knee - f.hip, f.ankle - f.hip);
      const double l1 = norm(f.knee - f.hip), l2 = norm(f.ankle - f.knee);
      if (norm(n) > 1e-9 * (l1 * l1 + l2 * l2)) normal[l] = (1 / norm(n)) * n;
      if (!active[l][std::size_t(t)]) continue;
      // The horizontal offset only (header: the height would move the knee).
      target[l] = f.ankle + Vec3{offset[l][std::size_t(t)].x, 0, offset[l][std::size_t(t)].z};
      reach[l] = std::min(l1 + l2, std::max(params.max_reach * (l1 + l2), norm(f.ankle - f.hip)));
      const Vec3 to_target = target[l] - f.hip;
      if (norm(to_target) <= reach[l] || !lowerable(root[l])) continue;
      const double horizontal = std::hypot(to_target.x, to_target.z);
      const double height = f.hip.y - target[l].y;
      double drop = horizontal < reach[l]
                        ? height - std::sqrt(reach[l] * reach[l] - horizontal * horizontal)
                        : height;
      drop = std::max(drop, 0.0);
      auto it = std::find_if(drops.begin(), drops.end(),
                             [&](const auto& d) { return d.first == root[l]; });
      if (it == drops.end())
        drops.emplace_back(root[l], drop);
      else
        it->second = std::max(it->second, drop);
    }
    bool lowered = false;
    for (const auto& [r, drop] : drops) {
      if (drop <= 0) continue;
      float* p = translations.at(t, r);
      p[1] = float(double(p[1]) - drop);
      lowered = true;
      local_stats.max_drop = std::max(local_stats.max_drop, drop);
    }
    local_stats.lowered_frames += lowered;
    for (std::size_t l = 0; l < leg_count; ++l) {
      double drop = 0;
      for (const auto& [r, d] : drops)
        if (r == root[l]) drop = d;
      // A lowered root would drag the free legs down with it (and a leg whose lock starts next
      // frame would then jump back up): every leg of a lowered root keeps its ankle's target.
      if (!active[l][std::size_t(t)] && drop <= 0) continue;
      const FootChain& leg = chains[l];
      LegFrame f = leg_frames[l][std::size_t(t)];
      if (!active[l][std::size_t(t)]) {
        target[l] = f.ankle;
        const double l1 = norm(f.knee - f.hip), l2 = norm(f.ankle - f.knee);
        reach[l] = std::min(l1 + l2, std::max(params.max_reach * (l1 + l2), norm(f.ankle - f.hip)));
      }
      const Vec3 down{0, -drop, 0};
      f.hip += down;
      f.knee += down;
      f.ankle += down;
      const double l1 = norm(f.knee - f.hip), l2 = norm(f.ankle - f.knee);
      if (l1 <= 0 || l2 <= 0) continue;  // a bone of zero length: nothing to bend
      const Vec3 to_target = target[l] - f.hip;
      const double d = std::clamp(norm(to_target), std::abs(l1 - l2) + 1e-9 * (l1 + l2), reach[l]);
      const Vec3 thigh_back = f.hip - f.knee, shin = f.ankle - f.knee;
      const double theta0 = std::acos(std::clamp(dot(thigh_back, shin) / (l1 * l2), -1.0, 1.0));
      const double theta1 =
          std::acos(std::clamp((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1.0, 1.0));
      const Quat knee_turn = exp((theta0 - theta1) * normal[l]);
      const Vec3 bent_ankle = f.knee + rotate(knee_turn, shin);
      const Quat hip_swing = rotation_between(bent_ankle - f.hip, to_target);
      const Quat hip_global = hip_swing * f.hip_rotation;
      const Quat knee_global = hip_swing * knee_turn * f.knee_rotation;
      const Quat locals[3] = {inverse(f.parent_rotation) * hip_global,
                              inverse(hip_global) * knee_global,
                              inverse(knee_global) * f.ankle_rotation};
      const int chain[3] = {leg.hip, leg.knee, leg.ankle};
      for (int k = 0; k < 3; ++k) {
        float* q = rotations.at(t, chain[k]);
        Quat out = normalized(locals[k]);
        if (dot(out, load_quat(q)) < 0) out = negate(out);
        store_quat(out, q);
      }
    }
  }
  if (stats) *stats = local_stats;
  return {};
}

}  // namespace mocap
