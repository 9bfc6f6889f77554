#include "kernels/foot_lock.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "kernels/median.hpp"
#include "kernels/simd/foot_lock_simd.hpp"

namespace mocap {
namespace {

Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// The shortest-arc rotation taking the direction of u onto the direction of v:
// (|u||v| + u.v, u x v) normalized, one square root.
Quat rotation_between(Vec3 u, Vec3 v) {
  const double nn = std::sqrt(dot(u, u) * dot(v, v));
  if (!(nn > 0)) return {};
  const double w = nn + dot(u, v);
  if (w < 1e-12 * nn) {  // opposite: any axis perpendicular to u
    Vec3 axis = cross(u, std::abs(u.x) < 0.9 * norm(u) ? Vec3{1, 0, 0} : Vec3{0, 1, 0});
    axis = (1 / norm(axis)) * axis;
    return {0, axis.x, axis.y, axis.z};
  }
  const Vec3 c = cross(u, v);
  const double inv = 1 / std::sqrt(w * w + dot(c, c));
  return {w * inv, c.x * inv, c.y * inv, c.z * inv};
}

// q v q^-1 for a unit q, as v + 2 w (r x v) + 2 r x (r x v), r = q's vector part (inline:
// the lock runs it a few times per leg and frame).
Vec3 rotate_unit(Quat q, Vec3 v) {
  const Vec3 r{q.x, q.y, q.z};
  const Vec3 t = 2 * cross(r, v);
  return v + q.w * t + cross(r, t);
}

// The unit quaternion of a rotation by delta about the unit axis n, from cos(theta0), cos(theta1)
// with delta = theta0 - theta1, theta in [0, pi]: no inverse trigonometry (cos and sin of delta
// from the angles' sums, then the half angle).
Quat turn_between(double c0, double c1, Vec3 n) {
  const double s0 = std::sqrt(std::max(0.0, 1 - c0 * c0)),
               s1 = std::sqrt(std::max(0.0, 1 - c1 * c1));
  const double cd = std::clamp(c0 * c1 + s0 * s1, -1.0, 1.0), sd = s0 * c1 - c0 * s1;
  const double ch = std::sqrt(0.5 * (1 + cd));  // cos(delta / 2) >= 0, |delta| <= pi
  // sin(delta / 2): from sin(delta) where the half angle is small (accurate), else from cos.
  const double sh = ch > 0.5 ? sd / (2 * ch) : std::copysign(std::sqrt(0.5 * (1 - cd)), sd);
  return {ch, sh * n.x, sh * n.y, sh * n.z};
}

// The frames where the filtered knee bends to the far side of the clip's own bend (header, "Bend
// side"): out[t] = 1 where touched[t] and the bend-plane normal in the thigh's frame, h(t) = o_k x
// (q_k(t) o_a) (o_k, o_a the knee's and the ankle's local offsets, or their translations where
// they have them; q_k the knee's local rotation), points against h at the frame where the knee
// bends most, among every kBendSideStride-th frame (a bend lasts longer). Returns that h, unit;
// zero, and out all 0, when the knee never bends kBendSideMinBend there: no frame tells the side.
Vec3 hyperextended_frames(RotationView rotations, TranslationView translations,
                          std::span<const Vec3> offsets, std::span<const std::uint8_t> translated,
                          const FootChain& leg, std::span<const std::uint8_t> touched,
                          std::span<std::uint8_t> out) {
  constexpr int kBendSideStride = 4;
  std::fill(out.begin(), out.end(), std::uint8_t{0});
  const auto local = [&](int t, int j) {
    return !translated.empty() && translated[std::size_t(j)] != 0 ? load_vec3(translations.at(t, j))
                                                                  : offsets[std::size_t(j)];
  };
  const auto shin_in_thigh = [&](int t) {
    return rotate_unit(load_quat(rotations.at(t, leg.knee)), local(t, leg.ankle));
  };
  Vec3 reference{};
  double most = -std::cos(kBendSideMinBend);  // the interior angle's cosine at that bend
  for (int t = 0; t < rotations.frames; t += kBendSideStride) {
    const Vec3 thigh = local(t, leg.knee), shin = shin_in_thigh(t);
    const double lengths = norm(thigh) * norm(shin);
    if (!(lengths > 0)) continue;
    const double c = -dot(thigh, shin) / lengths;  // the interior angle's cosine
    if (c > most) {
      most = c;
      reference = cross(thigh, shin);
    }
  }
  if (norm(reference) == 0) return {};
  for (int t = 0; t < rotations.frames; ++t)
    if (touched[std::size_t(t)])
      out[std::size_t(t)] = dot(cross(local(t, leg.knee), shin_in_thigh(t)), reference) < 0;
  return (1 / norm(reference)) * reference;
}

// The knee's turn axis (header, "Bend side"): the bend plane's normal `plane` (unit, on the
// clip's side) where the filtered knee bends at least kBendSideMinBend; below, blended by a
// smoothstep of the bend into the clip's hinge (unit, in the thigh's frame: global through the
// hip's rotation), made perpendicular to the shin, which a straight leg's noisy plane lacks.
// Without a hinge (zero), the plane's normal.
Vec3 knee_axis(Vec3 plane, double bend, Vec3 hinge, Quat hip_rotation, Vec3 shin) {
  const double w = bend >= kBendSideMinBend ? 1.0 : std::max(0.0, bend) / kBendSideMinBend;
  if (w >= 1 || norm(hinge) == 0) return plane;
  Vec3 axis = rotate_unit(hip_rotation, hinge);
  const double ss = dot(shin, shin);
  if (ss > 0) axis = axis - (dot(axis, shin) / ss) * shin;
  const double s = w * w * (3 - 2 * w);
  const Vec3 n = s * plane + (1 - s) * axis;
  const double length = norm(n);
  return length > 0 ? (1 / length) * n : plane;
}

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3 - 2 * x);
}

// What the IK needs of one leg at one frame, from the filtered motion.
struct LegFrame {
  Vec3 hip, knee, ankle, toe;
  Quat parent_rotation, hip_rotation, knee_rotation, ankle_rotation;  // global
};

// label[t]: 1 where the ankle is in contact, else 2 where the toe is, else 0.
void contact_labels(const std::vector<ContactInterval>* ankle,
                    const std::vector<ContactInterval>* toe, std::span<std::uint8_t> label) {
  const int frames = int(label.size());
  std::fill(label.begin(), label.end(), std::uint8_t(0));
  auto mark = [&](const std::vector<ContactInterval>* list, std::uint8_t value) {
    if (list == nullptr) return;
    for (const ContactInterval& c : *list)
      for (int t = std::max(c.begin, 0); t < std::min(c.end, frames); ++t)
        if (label[std::size_t(t)] == 0) label[std::size_t(t)] = value;
  };
  mark(ankle, 1);
  mark(toe, 2);
}

// D(t) of the header for one leg; active[t] = 1 where the leg is locked or blending (both
// span `count` frames). Returns the number of contacts (clusters of adjacent segments).
// anchor_at(anchor, t): the anchor's position at frame t (count frames). The segments, clusters
// and the medians' buffers are the scratch's.
template <class Anchor, class Input>
int leg_offsets(int count, Anchor anchor_at, Input input_at, bool follow_input,
                std::span<const std::uint8_t> label, int blend, std::span<Vec3> offset,
                std::span<std::uint8_t> active, FootLockScratch& scratch) {
  std::fill(offset.begin(), offset.end(), Vec3{});
  std::fill(active.begin(), active.end(), std::uint8_t(0));
  using Segment = FootLockScratch::Segment;
  std::vector<Segment>& segments = scratch.segments;
  segments.clear();
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
  std::vector<FootLockScratch::Cluster>& clusters = scratch.clusters;
  clusters.clear();
  for (int s = 0; s < int(segments.size()); ++s) {
    if (!clusters.empty() &&
        segments[std::size_t(clusters.back().last)].end == segments[std::size_t(s)].begin)
      clusters.back().last = s;
    else
      clusters.push_back({s, s});
  }
  std::vector<double>&xs = scratch.xs, &zs = scratch.zs;
  std::vector<Vec3>& points = scratch.points;
  for (const FootLockScratch::Cluster& c : clusters) {
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
    // The anchor's positions read once (the medians reorder their copies).
    const std::size_t length = std::size_t(p.end - p.begin);
    points.resize(length);
    xs.resize(length);
    zs.resize(length);
    // The pin's height is not needed: only D's horizontal part is applied (header, "Target"),
    // and D's components never mix below. xs, zs: the points the pins come from, the input's
    // (follow_input) or the filtered motion's.
    for (std::size_t k = 0; k < length; ++k) {
      const int t = p.begin + int(k);
      const Vec3 v = anchor_at(p.anchor, t);
      const Vec3 from = follow_input ? input_at(p.anchor, t) : v;
      points[k] = v;
      xs[k] = from.x;
      zs[k] = from.z;
    }
    if (follow_input) {
      // The pin follows the input's anchor, smoothed (header, "Contacts").
      const std::vector<double>& w = scratch.pin_weights;
      const int radius = int(w.size()) - 1, n = int(length);
      double whole = w[0];  // the weights' sum where the window lies inside the segment
      for (int d = 1; d <= radius; ++d) whole += 2 * w[std::size_t(d)];
      for (int k = 0; k < n; ++k) {
        double sum = w[0], x = w[0] * xs[std::size_t(k)], z = w[0] * zs[std::size_t(k)];
        if (k >= radius && k + radius < n) {
          for (int d = 1; d <= radius; ++d) {
            const double wd = w[std::size_t(d)];
            x += wd * (xs[std::size_t(k - d)] + xs[std::size_t(k + d)]);
            z += wd * (zs[std::size_t(k - d)] + zs[std::size_t(k + d)]);
          }
          sum = whole;
        } else {
          // Past max(k, n - 1 - k) both taps lie outside the segment: the same sums, in the
          // same order, without the Gaussian's tail (a contact is often shorter than it).
          const int reach = std::min(radius, std::max(k, n - 1 - k));
          for (int d = 1; d <= reach; ++d) {
            const double wd = w[std::size_t(d)];
            if (k - d >= 0) {
              sum += wd;
              x += wd * xs[std::size_t(k - d)];
              z += wd * zs[std::size_t(k - d)];
            }
            if (k + d < n) {
              sum += wd;
              x += wd * xs[std::size_t(k + d)];
              z += wd * zs[std::size_t(k + d)];
            }
          }
        }
        offset[std::size_t(p.begin + k)] = Vec3{x / sum, 0, z / sum} - points[std::size_t(k)];
      }
    } else {
      const Vec3 pin{median(xs), 0, median(zs)};
      for (std::size_t k = 0; k < length; ++k) offset[std::size_t(p.begin) + k] = pin - points[k];
    }
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

// The target's lift (header, "Lift"): the height v, within [-lift, lift], that puts the target
// `to` (relative to the hip) as far from the hip as the filtered ankle (`ankle_distance2`, the
// squared distance), on the ankle's side of the hip; 0 where no height does (the horizontal
// distance is longer). The fast path computes the same in vector lanes (LegGeometryPlanes).
double target_lift(Vec3 to, double ankle_distance2, double lift) {
  const double horizontal2 = to.x * to.x + to.z * to.z;
  if (!(ankle_distance2 > horizontal2)) return 0.0;
  const double height = std::sqrt(ankle_distance2 - horizontal2);
  return std::clamp((to.y >= 0 ? height : -height) - to.y, -lift, lift);
}

// The roots' drops (header "Reach"), shared by both paths, each with its own geometry.
// The drop that lets a hip `height` above its target and `horizontal` from it reach it with
// reach r: a_y' = T_y + sqrt(r^2 - h^2), all of the height when h >= r; never negative.
double root_drop(double horizontal, double height, double reach) {
  const double drop =
      horizontal < reach ? height - std::sqrt(reach * reach - horizontal * horizontal) : height;
  return std::max(drop, 0.0);
}

// A root is lowered by the largest drop its legs ask at a frame (drops: (root, drop)).
void add_drop(std::vector<std::pair<int, double>>& drops, int root, double drop) {
  auto it =
      std::find_if(drops.begin(), drops.end(), [&](const auto& d) { return d.first == root; });
  if (it == drops.end())
    drops.emplace_back(root, drop);
  else
    it->second = std::max(it->second, drop);
}

// Lowers the roots of `drops` at frame t, and counts the frame when one was.
void lower_roots(TranslationSpan translations, int t,
                 const std::vector<std::pair<int, double>>& drops, FootLockStats& stats) {
  bool lowered = false;
  for (const auto& [r, drop] : drops) {
    if (drop <= 0) continue;
    float* p = translations.at(t, r);
    p[1] = float(double(p[1]) - drop);
    lowered = true;
    stats.max_drop = std::max(stats.max_drop, drop);
  }
  stats.lowered_frames += lowered;
}

// What a leg of `root` is lowered by at the frame of `drops` (0: its root is not).
double drop_of(const std::vector<std::pair<int, double>>& drops, int root) {
  for (const auto& [r, d] : drops)
    if (r == root) return std::max(d, 0.0);
  return 0.0;
}

// weights[d] = exp(-(d / sigma)^2 / 2) for d = 0 .. radius: the half of a Gaussian that the
// pins' and the drops' tables hold (sigma > 0 when radius > 0).
void half_gaussian(double sigma, int radius, std::vector<double>& weights) {
  weights.resize(std::size_t(radius) + 1);
  for (int d = 0; d <= radius; ++d) {
    const double u = double(d) / sigma;
    weights[std::size_t(d)] = d == 0 ? 1 : std::exp(-0.5 * u * u);
  }
}

// The envelope's Gaussian weights w[|k|], k in [-w, w], sigma = w / 2 (header, "Reach"; empty:
// none), their total over all 2w + 1 frames, the allowance m and the targets' lift (header,
// "Lift").
void drop_weights(const FootLockJob& job, FootLockScratch& s, const FootLockStats& stats) {
  const int w = int(std::lround(job.params.drop_time / job.frame_time));
  s.drop_allowance = stats.anchor_noise * job.body_height;  // 0 without input_anchors
  s.lift = job.params.lift * s.drop_allowance;
  s.drop_weights.clear();
  s.drop_total = 0;
  if (w <= 0) return;
  half_gaussian(w / 2.0, w, s.drop_weights);
  s.drop_total = s.drop_weights[0];
  for (int k = 1; k <= w; ++k) s.drop_total += 2 * s.drop_weights[std::size_t(k)];
}

// Header, "Reach": one leg's drops d over one run of consecutive touched frames, in place, as
// max(d - m, G * d), m = `allowance`: G the Gaussian weights over +-w, normalized over all 2w + 1
// of them, the frames outside the run taken as 0 (they are not lowered); the run's two end frames
// keep their own (0 where no leg is active there: the knee's speed limit needs the IK to end
// inside the run; with them in, the knee peaked at 56x the input's). Shared by both paths.
void envelope_drops(std::span<double> drops, std::span<const double> weights, double total,
                    double allowance, std::vector<double>& blurred) {
  if (weights.empty() || std::none_of(drops.begin(), drops.end(), [](double d) { return d > 0; }))
    return;
  const std::ptrdiff_t n = std::ssize(drops), w = std::ssize(weights) - 1;
  blurred.assign(drops.size(), 0.0);
  for (std::ptrdiff_t i = 1; i + 1 < n; ++i) {
    double sum = 0;
    for (std::ptrdiff_t k = std::max<std::ptrdiff_t>(0, i - w); k <= std::min(n - 1, i + w); ++k)
      sum += weights[std::size_t(std::abs(k - i))] * drops[std::size_t(k)];
    blurred[std::size_t(i)] = sum / total;
  }
  for (std::ptrdiff_t i = 1; i + 1 < n; ++i)
    drops[std::size_t(i)] = std::max(drops[std::size_t(i)] - allowance, blurred[std::size_t(i)]);
}

// The input anchors' noise (header, "Contacts"), body heights; 0 where no anchor stays in one
// contact for three frames.
double anchor_noise(const FootLockJob& job, FootLockScratch& s) {
  const std::size_t F = std::size_t(job.rotations.frames);
  std::vector<double>& d = s.xs;
  d.clear();
  for (std::size_t l = 0; l < s.chains.size(); ++l) {
    const std::uint8_t* label = s.labels.data() + l * F;
    const std::size_t leg = std::size_t(s.leg_of[l]);
    for (std::size_t t = 1; t + 1 < F; ++t) {
      if (label[t] == 0 || label[t - 1] != label[t] || label[t + 1] != label[t]) continue;
      const int w = label[t] - 1;  // the label's anchor (input_anchors hold a toeless ankle twice)
      const Vec3 a = job.input_anchor(leg, w, t - 1), b = job.input_anchor(leg, w, t),
                 c = job.input_anchor(leg, w, t + 1);
      d.push_back(std::abs(a.x - 2 * b.x + c.x));
      d.push_back(std::abs(a.z - 2 * b.z + c.z));
    }
  }
  if (d.empty()) return 0;
  return 1.4826 * median(d) / std::sqrt(6.0) / job.body_height;
}

// The pins' Gaussian weights w[|j - k|] for the run (scratch.pin_weights; empty: median pins),
// and the stats' noise and width.
void pin_weights(const FootLockJob& job, FootLockScratch& s, FootLockStats& stats) {
  s.pin_weights.clear();
  if (job.input_anchors.empty()) return;
  stats.anchor_noise = anchor_noise(job, s);
  const double sigma = std::clamp(job.params.pin_width * stats.anchor_noise,
                                  job.params.min_pin_sigma / job.frame_time,
                                  job.params.max_pin_sigma / job.frame_time);
  stats.pin_sigma = sigma * job.frame_time;
  half_gaussian(sigma, int(std::ceil(3 * sigma)), s.pin_weights);
}

// run()'s steps with the touched frames as planes (kernels/simd/foot_lock_simd.hpp): forward
// kinematics, the legs' geometry, the knee's cosines and the IK run in vector lanes over frames;
// the per-contact pins, the roots' drops and the knee's speed limit (sequential over frames) stay
// scalar. Same formulas as the reference below; the rounding differs. Every buffer is the
// scratch's (s): run() has put the complete legs, their contact lists and labels, and the
// touched frames there.
// The planes hold one chunk of kChunk touched frames at a time, so that they stay in cache and
// take the same memory for any clip (whole-clip planes, 1.3 KB per frame, were faulted in and
// streamed from memory: most of the lock's time in the pipeline). Three passes over the chunks,
// each computing the forward kinematics and the leg geometry again (every lane takes the same
// formula, so the values are the same each time) but where the chunk is still held: A keeps
// the anchors, the knee's interior angle and the first bend-plane normal; then the pins; B finds
// the roots' drops; then the knee limit's band; C solves the IK and lowers the roots (after the
// IK: C's forward kinematics reads the roots as they came).
void lock_fast(const FootLockJob& job, FootLockScratch& s, int blend, FootLockStats& stats) {
  const RotationSpan rotations = job.rotations;
  const std::span<const int> parents = job.parents;
  const std::vector<FootChain>& chains = s.chains;
  const int frames = rotations.frames, joints = int(parents.size());
  const std::size_t leg_count = chains.size(), F = std::size_t(frames);
  const auto backwards = [&](std::size_t l, int t) {
    return s.hyperextended[l * F + std::size_t(t)] != 0;
  };
  std::vector<int>&frame_of = s.frame_of, &index_of = s.index_of;  // plane index <-> frame
  frame_of.clear();
  index_of.assign(F, -1);
  for (int t = 0; t < frames; ++t)
    if (s.touched[std::size_t(t)]) {
      index_of[std::size_t(t)] = int(frame_of.size());
      frame_of.push_back(t);
    }
  const std::size_t n = frame_of.size();
  if (n == 0) return;  // no contact: nothing touched, nothing counted
  const std::size_t P = simd::kFootLockPad;
  const std::size_t padded = (n + P - 1) / P * P;  // whole-clip rows
  constexpr std::size_t kChunk = 512;              // a multiple of kFootLockPad
  static_assert(kChunk % simd::kFootLockPad == 0);
  // Frames per chunk, and the planes' stride: one pad more than a chunk where the chunk is a
  // power of two, so that the planes do not all start at the same offset modulo 4 KB (cache
  // set conflicts: measured, 512 frames at a 4 KB stride ran the microbench 3x slower).
  const std::size_t chunk = std::min(padded, kChunk), stride = chunk == kChunk ? chunk + P : chunk;
  auto translated = [&](int j) {
    return !job.translated_joints.empty() && job.translated_joints[std::size_t(j)] != 0;
  };

  std::vector<int>&slot = s.slot, &needed = s.needed;  // the legs and their ancestors
  slot.assign(std::size_t(joints), -1);
  needed.clear();
  {
    std::vector<std::uint8_t>& mark = s.marks;
    mark.assign(std::size_t(joints), 0);
    for (std::size_t l = 0; l < leg_count; ++l) {
      // The toe only where it anchors a contact (the engine gives none).
      const bool toe = chains[l].toe >= 0 && s.toe_lists[l] != nullptr && !s.toe_lists[l]->empty();
      for (int j = toe ? chains[l].toe : chains[l].ankle; j >= 0 && !mark[std::size_t(j)];
           j = parents[std::size_t(j)])
        mark[std::size_t(j)] = 1;
    }
    for (int j = 0; j < joints; ++j)
      if (mark[std::size_t(j)]) {
        slot[std::size_t(j)] = int(needed.size());
        needed.push_back(j);
      }
  }
  // All chunk planes in one block, the scratch's (grown only for a larger skeleton), zeroed once
  // when allocated: a lane past a chunk's frames holds an earlier chunk's finite values, computed
  // and ignored.
  // Per leg: ox, oz, u (3), v (3), len (3: l1, l2, reach), cos_f, theta_f, normal (3), bent,
  // to_target (3), distance.
  enum : std::size_t {
    kOx = 0,
    kOz = 1,
    kU = 2,
    kV = 5,
    kLen = 8,
    kCosF = 11,
    kThetaF = 12,
    kNormal = 13,
    kBent = 16,
    kToTarget = 17,
    kDistance = 20,
    kPerLeg = 21
  };
  constexpr std::size_t kShared = 7 + 3 + 1 + 1 + 3;  // identity, local, cos1, theta1, normal
  const std::size_t total = (11 * needed.size() + kPerLeg * leg_count + kShared) * stride;
  if (s.plane_capacity < total) {
    s.planes.reset();  // the old block first: never both at once
    s.planes.reset(new double[total]());
    s.plane_capacity = total;
  }
  double* const global = s.planes.get();
  double* const identity = global + 7 * needed.size() * stride;
  double* const qs = identity + 7 * stride;  // the local rotations
  double* const local = qs + 4 * needed.size() * stride;
  double* const leg_planes = local + 3 * stride;
  double* const cos1 = leg_planes + kPerLeg * leg_count * stride;
  double* const theta1 = cos1 + stride;
  double* const normal = theta1 + stride;
  std::fill(identity, identity + 7 * stride, 0.0);
  std::fill(identity, identity + stride, 1.0);
  auto leg_plane = [&](std::size_t l, std::size_t k) {
    return leg_planes + (l * kPerLeg + k) * stride;
  };
  auto rot = [&](int j) {
    return j < 0 ? identity : global + std::size_t(slot[std::size_t(j)]) * 7 * stride;
  };
  auto pos = [&](int j) { return rot(j) + 4 * stride; };
  auto local_rotation = [&](int j) { return qs + std::size_t(slot[std::size_t(j)]) * 4 * stride; };
  auto geometry = [&](std::size_t l) {
    simd::LegGeometry g;
    g.hip = pos(chains[l].hip);
    g.knee = pos(chains[l].knee);
    g.ankle = pos(chains[l].ankle);
    g.ox = leg_plane(l, kOx);
    g.oz = leg_plane(l, kOz);
    g.u = leg_plane(l, kU);
    g.v = leg_plane(l, kV);
    g.len = leg_plane(l, kLen);  // l1, l2, reach
    g.cos_f = leg_plane(l, kCosF);
    g.theta_f = leg_plane(l, kThetaF);
    g.normal = leg_plane(l, kNormal);
    g.bent = leg_plane(l, kBent);
    g.to_target = leg_plane(l, kToTarget);
    g.distance = leg_plane(l, kDistance);
    return g;
  };
  // Forward kinematics of the touched frames [begin, begin + m), one joint at a time.
  // The chunk whose forward kinematics the planes hold, and whose geometry with the offsets
  // (pass B ends on chunk 0, where pass C starts: one chunk's worth less of each per clip).
  std::size_t held = n, held_geometry = n;
  auto forward = [&](std::size_t begin, std::size_t m) {
    if (begin == held) return;
    held = begin;
    simd::gather_rotations(rotations.data, std::size_t(joints) * 4, frame_of.data() + begin, m,
                           needed.data(), needed.size(), qs, stride);
    for (int j : needed) {
      const bool moved = translated(j);
      if (moved)
        for (std::size_t k = 0; k < m; ++k) {
          const float* p = job.translations.at(frame_of[begin + k], j);
          for (std::size_t c = 0; c < 3; ++c) local[c * stride + k] = p[c];
        }
      const int p = parents[std::size_t(j)];
      simd::chain_step(rot(p), pos(p), local_rotation(j), moved ? local : nullptr,
                       job.offsets[std::size_t(j)], rot(j), pos(j), m, stride);
    }
  };
  // The offsets' horizontal part of the chunk (0 before the pins are known), then the geometry.
  const std::vector<Vec3>& offsets = s.offsets;
  auto geometry_of = [&](std::size_t l, std::size_t begin, std::size_t m, bool with_offsets) {
    double* const ox = leg_plane(l, kOx);
    double* const oz = leg_plane(l, kOz);
    for (std::size_t k = 0; k < m; ++k) {
      const Vec3 o = with_offsets ? offsets[l * F + std::size_t(frame_of[begin + k])] : Vec3{};
      ox[k] = o.x;
      oz[k] = o.z;
    }
    simd::leg_geometry(geometry(l), job.params.max_reach, with_offsets ? s.lift : 0.0, m, stride);
  };

  // Pass A: the anchors (ankle, toe) and the knee's interior angle theta_f per leg and touched
  // frame; the first bend-plane normal (carried over straight frames; without one, the hip's x
  // axis at frame 0).
  s.anchors.resize(leg_count * 2 * n);  // [leg][ankle, toe][touched frame]
  s.theta_f.resize(leg_count * n);
  s.first_normals.assign(leg_count, Vec3{});
  std::vector<Quat>& hip_at_0 = s.hip_rotations;
  hip_at_0.assign(leg_count, Quat{});
  for (std::size_t begin = 0; begin < n; begin += chunk) {
    const std::size_t m = std::min(chunk, n - begin);
    forward(begin, m);
    for (std::size_t l = 0; l < leg_count; ++l) {
      const FootChain& leg = chains[l];
      Vec3* const ankle = s.anchors.data() + l * 2 * n;
      Vec3* const toe = ankle + n;
      const double* a = pos(leg.ankle);
      for (std::size_t k = 0; k < m; ++k)
        ankle[begin + k] = {a[k], a[stride + k], a[2 * stride + k]};
      if (leg.toe >= 0 && slot[std::size_t(leg.toe)] >= 0) {
        const double* p = pos(leg.toe);
        for (std::size_t k = 0; k < m; ++k)
          toe[begin + k] = {p[k], p[stride + k], p[2 * stride + k]};
      }
      geometry_of(l, begin, m, false);
      const double* theta_f = leg_plane(l, kThetaF);
      std::copy(theta_f, theta_f + m, s.theta_f.data() + l * n + begin);
      for (std::size_t k = 0; k < m; ++k)
        if (backwards(l, frame_of[begin + k])) s.theta_f[l * n + begin + k] = kPi;
      Vec3& first = s.first_normals[l];
      if (norm(first) == 0) {
        const double *bent = leg_plane(l, kBent), *nrm = leg_plane(l, kNormal);
        for (std::size_t k = 0; k < m; ++k)
          if (bent[k] != 0) {
            first = (backwards(l, frame_of[begin + k]) ? -1.0 : 1.0) *
                    Vec3{nrm[k], nrm[stride + k], nrm[2 * stride + k]};
            break;
          }
      }
      if (begin == 0 && frame_of[0] == 0) {
        const double* r = rot(leg.hip);
        hip_at_0[l] = {r[0], r[stride], r[2 * stride], r[3 * stride]};
      }
    }
  }

  // The offsets D(t) per leg.
  s.offsets.resize(leg_count * F);
  s.active.resize(leg_count * F);
  auto active = [&](std::size_t l, int t) { return s.active[l * F + std::size_t(t)] != 0; };
  for (std::size_t l = 0; l < leg_count; ++l) {
    const std::span<const std::uint8_t> label(s.labels.data() + l * F, F);
    for (std::uint8_t v : label) stats.locked_frames += v != 0;
    const FootChain& leg = chains[l];
    const Vec3* const anchors = s.anchors.data() + l * 2 * n;
    auto anchor_at = [&](int anchor, int t) {
      const std::size_t i = std::size_t(index_of[std::size_t(t)]);
      return anchor == 1 || leg.toe < 0 ? anchors[i] : anchors[n + i];
    };
    const std::size_t input_leg = std::size_t(s.leg_of[l]);
    auto input_at = [&](int anchor, int t) {
      return job.input_anchor(input_leg, anchor - 1, std::size_t(t));
    };
    stats.contacts += leg_offsets(frames, anchor_at, input_at, !s.pin_weights.empty(), label, blend,
                                  std::span(s.offsets.data() + l * F, F),
                                  std::span(s.active.data() + l * F, F), s);
  }

  std::vector<int>& root = s.roots;
  root.resize(leg_count);
  for (std::size_t l = 0; l < leg_count; ++l) root[l] = top_ancestor(parents, chains[l].hip);
  double knee_speed_limit = job.params.max_knee_speed;
  // c(t) = |q_knee(t-1) . q_knee(t)| per leg (peak_knee_speed's; from the rotations as they
  // came: no IK has run), 1 where the step is not counted. One more entry, 1, after the last
  // frame: the peak's neighbours need no bounds check. The peak needs every frame; a given limit
  // only the touched ones (the IK's turns).
  s.knee_cos.resize(leg_count * (F + 1));
  for (std::size_t l = 0; l < leg_count; ++l) {
    const int knee = chains[l].knee;
    auto quat_at = [&](int t) { return load_quat(rotations.at(t, knee)); };
    auto counted = [&](int t) {
      return job.counted_steps.empty() || job.counted_steps[std::size_t(t)] != 0;
    };
    double* const c = s.knee_cos.data() + l * (F + 1);
    c[0] = c[F] = 1.0;
    if (knee_speed_limit == 0) {
      Quat before = quat_at(0);
      for (int t = 1; t < frames; ++t) {
        const Quat now = quat_at(t);
        c[t] = counted(t) ? std::abs(dot(before, now)) : 1.0;
        before = now;
      }
    } else {
      for (int t : frame_of)
        if (t > 0) c[t] = counted(t) ? std::abs(dot(quat_at(t - 1), quat_at(t))) : 1.0;
    }
  }
  if (knee_speed_limit == 0) {  // peak_knee_speed on knee_cos (c(0) = c(frames) = 1)
    // Four running minima (min is exact in any order): no chain of dependent minsd.
    double smallest[4] = {1, 1, 1, 1};
    for (std::size_t l = 0; l < leg_count; ++l) {
      const double* p = s.knee_cos.data() + l * (F + 1);
      auto step = [p](int t) { return std::max(p[t], std::min(p[t - 1], p[t + 1])); };
      int t = 1;
      for (; t + 3 < frames; t += 4)
        for (int k = 0; k < 4; ++k) smallest[k] = std::min(smallest[k], step(t + k));
      for (; t < frames; ++t) smallest[0] = std::min(smallest[0], step(t));
    }
    const double least =
        std::min(std::min(smallest[0], smallest[1]), std::min(smallest[2], smallest[3]));
    knee_speed_limit = 2 * std::acos(std::min(1.0, least)) / job.frame_time;
  }

  // Pass B: the roots' drops, per frame (only where a planted leg cannot reach its target), per
  // leg (padded rows: LegKneeCosine reads whole vectors); the roots are lowered in pass C.
  s.leg_drops.resize(leg_count * padded);
  std::fill(s.leg_drops.begin(), s.leg_drops.end(), 0.0);
  std::vector<std::pair<int, double>>& drops = s.drops;
  // Last chunk first: the first is then the one held for pass C (frames are independent here).
  for (std::size_t c = (n - 1) / chunk + 1; c-- > 0;) {
    const std::size_t begin = c * chunk, m = std::min(chunk, n - begin);
    forward(begin, m);
    for (std::size_t l = 0; l < leg_count; ++l) geometry_of(l, begin, m, true);
    held_geometry = begin;
    for (std::size_t k = 0; k < m; ++k) {
      const int t = frame_of[begin + k];
      drops.clear();
      for (std::size_t l = 0; l < leg_count; ++l) {
        if (!active(l, t)) continue;
        const double* len = leg_plane(l, kLen);
        const double* to_target = leg_plane(l, kToTarget);
        const double r = len[2 * stride + k];
        if (leg_plane(l, kDistance)[k] <= r * r || !translated(root[l])) continue;  // squared
        add_drop(drops, root[l],
                 root_drop(std::hypot(to_target[k], to_target[2 * stride + k]),
                           -to_target[stride + k], r));  // the hip's height above the target
      }
      for (std::size_t l = 0; l < leg_count; ++l)
        s.leg_drops[l * padded + begin + k] = drop_of(drops, root[l]);
    }
  }

  // The drops' envelope over each run of consecutive touched frames, per leg (the legs of one
  // root have the same row, and so the same envelope).
  for (std::size_t l = 0; l < leg_count; ++l)
    for (std::size_t begin = 0, end; begin < n; begin = end) {
      for (end = begin + 1; end < n && frame_of[end] == frame_of[end - 1] + 1;) ++end;
      envelope_drops(std::span(s.leg_drops.data() + l * padded + begin, end - begin),
                     s.drop_weights, s.drop_total, s.drop_allowance, s.envelope);
    }

  // The knee's speed limit per leg (reference: the same steps, frame by frame): which frames
  // the IK touches, the filter's knee turn per step, the band that returns to 0.
  const double step_limit = knee_speed_limit > 0 ? knee_speed_limit * job.frame_time : 0.0;
  // low and high are written on every IK frame before they are read (on the solved ones).
  s.low.resize(leg_count * F);
  s.high.resize(leg_count * F);
  s.gain.resize(leg_count * F);
  s.room.resize(leg_count * F);
  s.ik.resize(leg_count * F);
  s.turn.resize(padded);
  std::fill(s.turn.begin() + std::ptrdiff_t(n), s.turn.end(), 1.0);
  double* const turn = s.turn.data();
  for (std::size_t l = 0; l < leg_count; ++l) {
    const double* const drop = s.leg_drops.data() + l * padded;
    const double* const knee_cos = s.knee_cos.data() + l * (F + 1);
    const double* const theta_f = s.theta_f.data() + l * n;
    std::uint8_t* const ik = s.ik.data() + l * F;
    double *const low = s.low.data() + l * F, *const high = s.high.data() + l * F,
                  *const gain = s.gain.data() + l * F, *const room = s.room.data() + l * F;
    std::fill(ik, ik + F, 0);
    // The knee's turn per step into each touched frame next to this leg's IK (frames ascend:
    // ik[t - 1] is set before frame t is reached).
    auto steps = [&](int t) {
      return t > 0 && (job.counted_steps.empty() || job.counted_steps[std::size_t(t)]) &&
             (ik[t] || ik[t - 1]);
    };
    for (std::size_t i = 0; i < n; ++i) {
      const int t = frame_of[i];
      ik[t] = active(l, t) || drop[i] > 0;
      turn[i] = steps(t) ? std::min(1.0, knee_cos[t]) : 1.0;
    }
    simd::acos_planes(turn, turn, n);
    std::fill(gain, gain + F, 0.0);
    std::fill(room, room + F, step_limit);
    room[0] = INFINITY;
    if (!job.counted_steps.empty())
      for (int t = 1; t < frames; ++t)
        if (!job.counted_steps[std::size_t(t)]) room[t] = INFINITY;
    for (std::size_t i = 0; i < n; ++i) {
      const int t = frame_of[i];
      if (steps(t)) {
        const double turn_angle = 2 * turn[i];
        const double gi = theta_f[i] - theta_f[std::size_t(index_of[std::size_t(t - 1)])];
        const double twist2 = std::max(0.0, turn_angle * turn_angle - gi * gi);
        gain[t] = gi;
        room[t] = std::sqrt(std::max(0.0, step_limit * step_limit - twist2));
      }
    }
    double lo = -INFINITY, hi = INFINITY;
    for (int t = frames - 1; t >= 0; --t) {
      if (!ik[t]) {
        lo = hi = 0;
        continue;
      }
      if (t + 1 < frames) {
        lo += gain[t + 1] - room[t + 1];
        hi += gain[t + 1] + room[t + 1];
      }
      low[t] = lo;
      high[t] = hi;
    }
    Vec3& first = s.first_normals[l];
    if (norm(first) == 0) first = rotate(hip_at_0[l], Vec3{1, 0, 0});
  }

  // Pass C: the wanted cosine, the limit, the IK; then the chunk's roots lowered.
  std::vector<Vec3>& carried = s.first_normals;  // the normal carried over straight frames
  s.deltas.assign(leg_count, 0.0);               // Delta(t - 1) per leg
  s.solve.resize(stride);
  std::uint8_t* const solve = s.solve.data();
  for (std::size_t begin = 0; begin < n; begin += chunk) {
    const std::size_t m = std::min(chunk, n - begin);
    forward(begin, m);
    for (std::size_t l = 0; l < leg_count; ++l) {
      const FootChain& leg = chains[l];
      if (begin != held_geometry) geometry_of(l, begin, m, true);
      const simd::LegGeometry g = geometry(l);
      const std::uint8_t* const ik = s.ik.data() + l * F;
      const double *const low = s.low.data() + l * F, *const high = s.high.data() + l * F,
                          *const gain = s.gain.data() + l * F, *const room = s.room.data() + l * F;
      Vec3& nrm = carried[l];
      const double* const hip_rotation = rot(leg.hip);
      for (std::size_t k = 0; k < m; ++k) {
        const int t = frame_of[begin + k];
        const bool back = backwards(l, t);
        if (g.bent[k] != 0)
          nrm = (back ? -1.0 : 1.0) *
                Vec3{g.normal[k], g.normal[stride + k], g.normal[2 * stride + k]};
        if (back) {  // header, "Bend side": bent from straight, on the clip's side
          g.cos_f[k] = -1;
          g.theta_f[k] = kPi;
        }
        const double* r = hip_rotation;
        const Vec3 axis = knee_axis(nrm, kPi - g.theta_f[k], s.hinges[l],
                                    {r[k], r[stride + k], r[2 * stride + k], r[3 * stride + k]},
                                    {g.v[k], g.v[stride + k], g.v[2 * stride + k]});
        normal[k] = axis.x;
        normal[stride + k] = axis.y;
        normal[2 * stride + k] = axis.z;
        solve[k] = ik[t] && g.len[k] > 0 && g.len[stride + k] > 0;
      }
      simd::leg_knee_cosine(g.to_target, s.leg_drops.data() + l * padded + begin, g.len, cos1,
                            theta1, solve, m, stride);
      if (step_limit > 0) {
        double& delta = s.deltas[l];  // Delta(t - 1)
        for (std::size_t k = 0; k < m; ++k) {
          const std::size_t i = begin + k;
          const int t = frame_of[i];
          if (i > 0 && frame_of[i - 1] != t - 1) delta = 0;  // an untouched frame between
          if (!solve[k]) {
            delta = 0;
            continue;
          }
          const double wanted = theta1[k] - g.theta_f[k];
          const double gi = gain[t], qi = room[t];
          const double a = std::max(low[t], delta - gi - qi),
                       b = std::min(high[t], delta - gi + qi);
          const double limited = a <= b ? std::clamp(wanted, a, b) : 0.5 * (a + b);
          if (limited != wanted) cos1[k] = std::cos(g.theta_f[k] + limited);
          delta = limited;
        }
      }
      simd::LegIkPlanes io{
          g.u,
          g.v,
          normal,
          g.cos_f,
          cos1,
          g.to_target,
          rot(parents[std::size_t(leg.hip)]),
          rot(leg.hip),
          rot(leg.knee),
          rot(leg.ankle),
          {local_rotation(leg.hip), local_rotation(leg.knee), local_rotation(leg.ankle)},
          solve,
          rotations.data,
          std::size_t(joints) * 4,
          frame_of.data() + begin,
          {leg.hip, leg.knee, leg.ankle}};
      simd::leg_ik(io, m, stride);
    }
    held_geometry = n;  // LegKneeCosine has raised the targets by the drops
    for (std::size_t k = 0; k < m; ++k) {
      drops.clear();
      for (std::size_t l = 0; l < leg_count; ++l)
        add_drop(drops, root[l], s.leg_drops[l * padded + begin + k]);
      lower_roots(job.translations, frame_of[begin + k], drops, stats);
    }
  }
}

}  // namespace

double peak_knee_speed(RotationView rotations, std::span<const FootChain> legs, double frame_time,
                       std::span<const std::uint8_t> counted) {
  // Per step, c = |q_{t-1} . q_t| (the smaller, the larger the turn: one acos at the end). A
  // step counts up to the larger turn of its neighbouring steps: a lone spike (a glued T-pose
  // frame, a pop) is not the knee's motion, while a swing's peak has a neighbour near it.
  double smallest = 1;
  const int frames = rotations.frames;
  std::vector<double> c(std::size_t(std::max(frames, 0)), 1.0);
  for (const FootChain& leg : legs) {
    if (leg.knee < 0 || leg.knee >= rotations.joints) continue;
    for (int t = 1; t < frames; ++t)
      c[std::size_t(t)] = !counted.empty() && !counted[std::size_t(t)]
                              ? 1.0
                              : std::abs(dot(load_quat(rotations.at(t - 1, leg.knee)),
                                             load_quat(rotations.at(t, leg.knee))));
    for (int t = 1; t < frames; ++t) {
      const double before = t > 1 ? c[std::size_t(t - 1)] : 1.0,
                   after = t + 1 < frames ? c[std::size_t(t + 1)] : 1.0;
      smallest = std::min(smallest, std::max(c[std::size_t(t)], std::min(before, after)));
    }
  }
  return 2 * std::acos(std::min(1.0, smallest)) / frame_time;
}

Status FootLockParams::validate() const {
  if (!(blend_time >= 0) || !std::isfinite(blend_time))
    return Status::error("foot lock: blend_time must be finite and >= 0");
  if (!(max_reach > 0 && max_reach <= 1))
    return Status::error("foot lock: max_reach must be in (0, 1]");
  if (std::isnan(max_knee_speed) || std::isinf(max_knee_speed))
    return Status::error("foot lock: max_knee_speed must be finite");
  if (!(drop_time >= 0) || !std::isfinite(drop_time))
    return Status::error("foot lock: drop_time must be finite and >= 0");
  if (!(pin_width >= 0) || !std::isfinite(pin_width))
    return Status::error("foot lock: pin_width must be finite and >= 0");
  if (!(min_pin_sigma >= 0) || !(max_pin_sigma >= min_pin_sigma) || !std::isfinite(max_pin_sigma))
    return Status::error("foot lock: need 0 <= min_pin_sigma <= max_pin_sigma, finite");
  if (!(lift >= 0) || !std::isfinite(lift))
    return Status::error("foot lock: lift must be finite and >= 0");
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
  if (!counted_steps.empty() && int(counted_steps.size()) != rotations.frames)
    return Status::error("foot lock: counted_steps must have one entry per frame");
  if (!input_anchors.empty()) {
    if (input_anchors.size() != std::size_t(rotations.frames) * legs.size() * 6)
      return Status::error("foot lock: input_anchors must be [frames][legs][2][3]");
    if (!(body_height > 0) || !std::isfinite(body_height))
      return Status::error("foot lock: body_height must be > 0 with input_anchors");
  }
  if (contacts.size() != legs.size())
    return Status::error("foot lock: " + std::to_string(contacts.size()) + " contact lists for " +
                         std::to_string(legs.size()) + " legs");
  if (!toe_contacts.empty() && toe_contacts.size() != legs.size())
    return Status::error("foot lock: " + std::to_string(toe_contacts.size()) +
                         " toe contact lists for " + std::to_string(legs.size()) + " legs");
  // Run once per clip: nothing allocated unless there is an error to explain.
  for (std::size_t l = 0; l < legs.size(); ++l) {
    const FootChain& leg = legs[l];
    if (leg.hip < 0 || leg.knee < 0 || leg.ankle < 0) continue;  // skipped by run()
    auto name = [l] { return "foot lock: leg " + std::to_string(l); };
    auto in_range = [&](int j) { return j >= 0 && j < joints; };
    if (!in_range(leg.hip) || !in_range(leg.knee) || !in_range(leg.ankle))
      return Status::error(name() + " names a joint out of range");
    if (parents[std::size_t(leg.knee)] != leg.hip || parents[std::size_t(leg.ankle)] != leg.knee)
      return Status::error(name() + " is not a hip -> knee -> ankle chain");
    if (leg.toe >= 0 && (!in_range(leg.toe) || parents[std::size_t(leg.toe)] != leg.ankle))
      return Status::error(name() + ": its toe is not a child of its ankle");
    // A chain's three joints differ (parents precede children), so only earlier legs can share.
    for (std::size_t m = 0; m < l; ++m) {
      const FootChain& other = legs[m];
      if (other.hip < 0 || other.knee < 0 || other.ankle < 0) continue;
      for (int j : {leg.hip, leg.knee, leg.ankle})
        if (j == other.hip || j == other.knee || j == other.ankle)
          return Status::error(name() + " shares a joint with another leg");
    }
    if (!toe_contacts.empty() && !toe_contacts[l].empty() && leg.toe < 0)
      return Status::error(name() + " has toe contacts but no toe joint");
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
  FootLockScratch own;  // allocates nothing unless used
  FootLockScratch& work = scratch != nullptr ? *scratch : own;
  const int frames = rotations.frames, joints = int(parents.size());
  const std::vector<FootChain>& chains = work.chains;  // the complete legs
  const std::vector<const std::vector<ContactInterval>*>&ankle_lists = work.ankle_lists,
                          &toe_lists = work.toe_lists;
  work.chains.clear();
  work.leg_of.clear();
  work.ankle_lists.clear();
  work.toe_lists.clear();
  for (std::size_t l = 0; l < legs.size(); ++l) {
    if (legs[l].hip < 0 || legs[l].knee < 0 || legs[l].ankle < 0) continue;
    work.chains.push_back(legs[l]);
    work.leg_of.push_back(int(l));
    work.ankle_lists.push_back(&contacts[l]);
    work.toe_lists.push_back(toe_contacts.empty() || legs[l].toe < 0 ? nullptr : &toe_contacts[l]);
  }
  if (chains.empty() || frames == 0) {
    if (stats) *stats = local_stats;
    return {};
  }
  const std::size_t leg_count = chains.size(), F = std::size_t(frames);

  const int blend = std::max(1, int(std::lround(params.blend_time / frame_time)));
  work.labels.resize(leg_count * F);
  for (std::size_t l = 0; l < leg_count; ++l)
    contact_labels(ankle_lists[l], toe_lists[l], std::span(work.labels.data() + l * F, F));
  pin_weights(*this, work, local_stats);
  drop_weights(*this, work, local_stats);
  auto labels = [&](std::size_t l) { return std::span(work.labels.data() + l * F, F); };
  // The frames the lock can touch, within `blend` frames of a contact of some leg (the offsets
  // are 0 elsewhere), and one more each side (the knee's speed there): only there are the leg
  // frames needed.
  std::vector<std::uint8_t>& touched = work.touched;
  touched.assign(F, 0);
  for (std::size_t l = 0; l < leg_count; ++l) {
    const std::span<std::uint8_t> label = labels(l);
    for (int t = 0, last = -2 - blend; t < frames; ++t) {
      if (label[std::size_t(t)] != 0) {
        for (int u = std::max({0, t - blend - 1, last + 1}); u <= t; ++u)
          touched[std::size_t(u)] = 1;
        last = t;
      } else if (t - last <= blend + 1) {
        touched[std::size_t(t)] = 1;
      }
    }
  }

  // Header, "Bend side": per leg and frame, 1 where the filtered knee is bent backwards.
  work.hyperextended.resize(leg_count * F);
  work.hinges.assign(leg_count, Vec3{});
  for (std::size_t l = 0; l < leg_count; ++l)
    work.hinges[l] = hyperextended_frames(
        {rotations.data, rotations.frames, rotations.joints},
        {translations.data, translations.frames, translations.joints}, offsets, translated_joints,
        chains[l], touched, std::span(work.hyperextended.data() + l * F, F));
  const auto backwards = [&](std::size_t l, int t) {
    return work.hyperextended[l * F + std::size_t(t)] != 0;
  };

  if (implementation == Implementation::fast) {
    lock_fast(*this, work, blend, local_stats);
    if (stats) *stats = local_stats;
    return {};
  }

  // Pass 1: the filtered motion's leg frames at the touched frames (forward kinematics,
  // spec-free, as in forward_kinematics.hpp, with the global rotations kept).
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
            position[std::size_t(p)] + rotate_unit(rotation[std::size_t(p)], local);
      }
    }
  };
  for (int t = 0; t < frames; ++t) {
    if (!touched[std::size_t(t)]) continue;
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
  std::vector<std::vector<Vec3>> offset(leg_count, std::vector<Vec3>(F));
  std::vector<std::vector<std::uint8_t>> active(leg_count, std::vector<std::uint8_t>(F));
  for (std::size_t l = 0; l < leg_count; ++l) {
    const std::span<const std::uint8_t> label = labels(l);
    for (std::uint8_t v : label) local_stats.locked_frames += v != 0;
    auto anchor_at = [&](int anchor, int t) {
      const LegFrame& f = leg_frames[l][std::size_t(t)];
      return anchor == 1 || chains[l].toe < 0 ? f.ankle : f.toe;
    };
    const std::size_t input_leg = std::size_t(work.leg_of[l]);
    auto input_at = [&](int anchor, int t) {
      return input_anchor(input_leg, anchor - 1, std::size_t(t));
    };
    local_stats.contacts +=
        leg_offsets(frames, anchor_at, input_at, !work.pin_weights.empty(), label, blend,
                    std::span(offset[l]), std::span(active[l]), work);
  }

  // The bend-plane normal of each leg, carried over frames where the leg is straight: first the
  // first touched frame's that has one.
  std::vector<Vec3> normal(leg_count, Vec3{});
  for (std::size_t l = 0; l < leg_count; ++l) {
    for (int t = 0; t < frames; ++t) {
      if (!touched[std::size_t(t)]) continue;
      const LegFrame& f = leg_frames[l][std::size_t(t)];
      const Vec3 n = cross(f.knee - f.hip, f.ankle - f.hip);
      if (norm(n) >
          1e-9 * (dot(f.knee - f.hip, f.knee - f.hip) + dot(f.ankle - f.knee, f.ankle - f.knee))) {
        normal[l] = (backwards(l, t) ? -1 / norm(n) : 1 / norm(n)) * n;
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

  double knee_speed_limit = params.max_knee_speed;
  if (knee_speed_limit == 0)
    knee_speed_limit = peak_knee_speed({rotations.data, rotations.frames, rotations.joints}, chains,
                                       frame_time, counted_steps);

  // Pass 2: per frame, the legs' targets and reaches and the roots' drops.
  std::vector<std::vector<Vec3>> target(leg_count, std::vector<Vec3>(std::size_t(frames)));
  std::vector<std::vector<double>> reach(leg_count, std::vector<double>(std::size_t(frames), 0));
  std::vector<std::vector<double>> leg_drop(leg_count, std::vector<double>(std::size_t(frames), 0));
  std::vector<std::pair<int, double>> drops;  // (root, drop)
  auto reach_of = [&](const LegFrame& f) {
    const double l1 = norm(f.knee - f.hip), l2 = norm(f.ankle - f.knee);
    return std::min(l1 + l2, std::max(params.max_reach * (l1 + l2), norm(f.ankle - f.hip)));
  };
  for (int t = 0; t < frames; ++t) {
    if (!touched[std::size_t(t)]) continue;
    drops.clear();
    for (std::size_t l = 0; l < leg_count; ++l) {
      const LegFrame& f = leg_frames[l][std::size_t(t)];
      // The horizontal offset only (header: the height would move the knee), lifted within m
      // where that keeps the leg's length (header, "Lift").
      Vec3& goal = target[l][std::size_t(t)];
      goal = f.ankle + Vec3{offset[l][std::size_t(t)].x, 0, offset[l][std::size_t(t)].z};
      if (work.lift > 0)
        goal.y += target_lift(goal - f.hip, dot(f.ankle - f.hip, f.ankle - f.hip), work.lift);
      reach[l][std::size_t(t)] = reach_of(f);
      if (!active[l][std::size_t(t)]) continue;
      const Vec3 to_target = target[l][std::size_t(t)] - f.hip;
      const double r = reach[l][std::size_t(t)];
      if (norm(to_target) <= r || !lowerable(root[l])) continue;
      add_drop(drops, root[l],
               root_drop(std::hypot(to_target.x, to_target.z),
                         f.hip.y - target[l][std::size_t(t)].y, r));
    }
    for (std::size_t l = 0; l < leg_count; ++l)
      leg_drop[l][std::size_t(t)] = drop_of(drops, root[l]);
  }
  // Their envelope over each run of touched frames (header, "Reach"), then the roots lowered.
  for (std::size_t l = 0; l < leg_count; ++l)
    for (int begin = 0, end; begin < frames; begin = end) {
      for (end = begin + 1;
           end < frames && touched[std::size_t(end)] == touched[std::size_t(begin)];)
        ++end;
      if (touched[std::size_t(begin)])
        envelope_drops(std::span(leg_drop[l].data() + begin, std::size_t(end - begin)),
                       work.drop_weights, work.drop_total, work.drop_allowance, work.envelope);
    }
  for (int t = 0; t < frames; ++t) {
    if (!touched[std::size_t(t)]) continue;
    drops.clear();
    for (std::size_t l = 0; l < leg_count; ++l)
      add_drop(drops, root[l], leg_drop[l][std::size_t(t)]);
    lower_roots(translations, t, drops, local_stats);
  }

  // The knee's speed limit (header): per leg, the filtered interior angle theta_f and, over each
  // run of IK frames, the band of change Delta that can still return to 0 after the run.
  const double step_limit = knee_speed_limit > 0 ? knee_speed_limit * frame_time : 0.0;
  std::vector<double> theta_f(std::size_t(frames), 0), low(std::size_t(frames), 0),
      high(std::size_t(frames), 0);
  std::vector<std::uint8_t> ik(std::size_t(frames), 0);
  for (std::size_t l = 0; l < leg_count; ++l) {
    const FootChain& leg = chains[l];
    std::fill(ik.begin(), ik.end(), 0);  // this leg's
    for (int t = 0; t < frames; ++t) {
      if (!touched[std::size_t(t)]) continue;
      const LegFrame& f = leg_frames[l][std::size_t(t)];
      const double l1 = norm(f.knee - f.hip), l2 = norm(f.ankle - f.knee);
      theta_f[std::size_t(t)] =
          backwards(l, t) ? kPi
          : l1 > 0 && l2 > 0
              ? std::acos(std::clamp(dot(f.hip - f.knee, f.ankle - f.knee) / (l1 * l2), -1.0, 1.0))
              : 0.0;
      // A lowered root would drag the free legs down with it (and a leg whose lock starts next
      // frame would then jump back up): every leg of a lowered root keeps its ankle's target.
      ik[std::size_t(t)] = active[l][std::size_t(t)] || leg_drop[l][std::size_t(t)] > 0;
    }
    // The knee's step from t-1 to t: the filter's turn s_f(t) has an interior-angle part g(t)
    // and a remainder r(t) (twist, r^2 = s_f^2 - g^2) that the IK leaves as it is; the IK adds
    // Delta(t) - Delta(t-1) to the interior part. Under the limit: |g + Delta(t) - Delta(t-1)| <=
    // q(t) = sqrt(step^2 - r^2) (0 where the twist alone exceeds it). A step that is not motion
    // (counted_steps[t] == 0: into a glued T-pose frame) and the clip's first frame bind nothing.
    std::vector<double> gain(std::size_t(frames), 0), room(std::size_t(frames), step_limit);
    if (frames > 0) room[0] = INFINITY;
    for (int t = 1; t < frames; ++t) {
      if (!counted_steps.empty() && !counted_steps[std::size_t(t)]) {
        room[std::size_t(t)] = INFINITY;
        continue;
      }
      if (!ik[std::size_t(t)] && !ik[std::size_t(t - 1)]) continue;  // not next to this leg's IK
      const double c = std::abs(
          dot(load_quat(rotations.at(t - 1, leg.knee)), load_quat(rotations.at(t, leg.knee))));
      const double turn = 2 * std::acos(std::min(1.0, c));
      const double g = theta_f[std::size_t(t)] - theta_f[std::size_t(t - 1)];
      const double twist2 = std::max(0.0, turn * turn - g * g);
      gain[std::size_t(t)] = g;
      room[std::size_t(t)] = std::sqrt(std::max(0.0, step_limit * step_limit - twist2));
    }
    // Backwards: Delta(t) in Delta(t+1) + g(t+1) -+ q(t+1), with Delta = 0 on the frame after a
    // run (none after the clip's last frame).
    double lo = -INFINITY, hi = INFINITY;
    for (int t = frames - 1; t >= 0; --t) {
      if (!ik[std::size_t(t)]) {
        lo = hi = 0;
        continue;
      }
      if (t + 1 < frames) {
        lo += gain[std::size_t(t + 1)] - room[std::size_t(t + 1)];
        hi += gain[std::size_t(t + 1)] + room[std::size_t(t + 1)];
      }
      low[std::size_t(t)] = lo;
      high[std::size_t(t)] = hi;
    }

    double delta = 0;  // Delta(t - 1)
    Vec3 n = normal[l];
    for (int t = 0; t < frames; ++t) {
      if (!touched[std::size_t(t)]) {
        delta = 0;
        continue;
      }
      LegFrame f = leg_frames[l][std::size_t(t)];
      {
        const Vec3 c = cross(f.knee - f.hip, f.ankle - f.hip);
        const double l1 = norm(f.knee - f.hip), l2 = norm(f.ankle - f.knee);
        if (norm(c) > 1e-9 * (l1 * l1 + l2 * l2))
          n = (backwards(l, t) ? -1 / norm(c) : 1 / norm(c)) * c;
      }
      if (!ik[std::size_t(t)]) {
        delta = 0;
        continue;
      }
      const double drop = leg_drop[l][std::size_t(t)];
      const Vec3 goal = active[l][std::size_t(t)] ? target[l][std::size_t(t)] : f.ankle;
      const Vec3 down{0, -drop, 0};
      f.hip += down;
      f.knee += down;
      f.ankle += down;
      const double l1 = norm(f.knee - f.hip), l2 = norm(f.ankle - f.knee);
      if (l1 <= 0 || l2 <= 0) {  // a bone of zero length: nothing to bend
        delta = 0;
        continue;
      }
      const Vec3 to_target = goal - f.hip;
      const double d = std::clamp(norm(to_target), std::abs(l1 - l2) + 1e-9 * (l1 + l2),
                                  reach[l][std::size_t(t)]);
      const Vec3 thigh_back = f.hip - f.knee, shin = f.ankle - f.knee;
      const double cos0 =
          backwards(l, t) ? -1.0 : std::clamp(dot(thigh_back, shin) / (l1 * l2), -1.0, 1.0);
      double cos1 = std::clamp((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1.0, 1.0);
      if (step_limit > 0) {
        // Delta = theta_1 - theta_f, kept within one step of the previous frame's (the knee
        // then turns no faster than the limit) and within the band that returns to 0.
        const double wanted = std::acos(cos1) - theta_f[std::size_t(t)];
        const double g = gain[std::size_t(t)], q = room[std::size_t(t)];
        const double a = std::max(low[std::size_t(t)], delta - g - q),
                     b = std::min(high[std::size_t(t)], delta - g + q);
        const double limited = a <= b ? std::clamp(wanted, a, b) : 0.5 * (a + b);
        if (limited != wanted) cos1 = std::cos(theta_f[std::size_t(t)] + limited);
        delta = limited;
      }
      const Vec3 axis =
          knee_axis(n, kPi - theta_f[std::size_t(t)], work.hinges[l], f.hip_rotation, shin);
      const Quat knee_turn = turn_between(cos0, cos1, axis);
      const Vec3 bent_ankle = f.knee + rotate_unit(knee_turn, shin);
      const Quat hip_swing = rotation_between(bent_ankle - f.hip, to_target);
      const Quat hip_global = hip_swing * f.hip_rotation;
      const Quat knee_global = hip_swing * knee_turn * f.knee_rotation;
      const Quat locals[3] = {inverse(f.parent_rotation) * hip_global,
                              inverse(hip_global) * knee_global,
                              inverse(knee_global) * f.ankle_rotation};
      const int chain[3] = {leg.hip, leg.knee, leg.ankle};
      for (int k = 0; k < 3; ++k) {
        float* q = rotations.at(t, chain[k]);
        const Quat& v = locals[k];
        const double inv = 1 / std::sqrt(dot(v, v));  // products of unit quaternions: never 0
        Quat out{v.w * inv, v.x * inv, v.y * inv, v.z * inv};
        if (dot(out, load_quat(q)) < 0) out = negate(out);
        store_quat(out, q);
      }
    }
  }
  if (stats) *stats = local_stats;
  return {};
}

}  // namespace mocap
