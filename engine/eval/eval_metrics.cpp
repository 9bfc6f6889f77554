#include "engine/eval/eval_metrics.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>

#include "core/quaternion.hpp"
#include "engine/clip/filter_settings.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/metrics.hpp"

namespace mocap::engine::eval {
namespace {

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}
bool contains(const std::string& s, const char* part) {
  return s.find(part) != std::string::npos;
}

// 'L', 'R' or '?' from "Left...", "Right...", "L...", "R..." (also "l_hand", "r_foot").
char side_of(const std::string& name) {
  if (contains(name, "left")) return 'L';
  if (contains(name, "right")) return 'R';
  if (!name.empty() && (name[0] == 'l' || name[0] == 'r')) return name[0] == 'l' ? 'L' : 'R';
  return '?';
}

bool scored(const Segment& s) {
  return s.frames() >= 2;
}

Effector effector_at(const Skeleton& skeleton, int j, bool foot) {
  Effector e;
  e.foot = foot;
  e.site.joint = j;
  e.name = skeleton.joint_names[std::size_t(j)];
  if (skeleton.end_sites[std::size_t(j)]) {
    e.site.offset = *skeleton.end_sites[std::size_t(j)];
    e.name += " (End Site)";
  }
  return e;
}

std::vector<Effector> effectors_by_name(const Skeleton& skeleton) {
  const int joints = skeleton.joint_count();
  std::vector<int> depth(std::size_t(joints), 0);
  std::map<std::pair<char, bool>, int> deepest;  // (side, foot) -> joint
  for (int j = 0; j < joints; ++j) {
    const int p = skeleton.parents[std::size_t(j)];
    depth[std::size_t(j)] = p < 0 ? 0 : depth[std::size_t(p)] + 1;
    const std::string name = lower(skeleton.joint_names[std::size_t(j)]);
    const bool hand = contains(name, "hand") || contains(name, "wrist");
    const bool foot = contains(name, "foot") || contains(name, "ankle") || contains(name, "toe");
    if (!hand && !foot) continue;
    const auto key = std::pair{side_of(name), foot};
    const auto it = deepest.find(key);
    if (it == deepest.end() || depth[std::size_t(j)] >= depth[std::size_t(it->second)])
      deepest[key] = j;
  }
  std::vector<Effector> out;
  for (const auto& [key, j] : deepest) out.push_back(effector_at(skeleton, j, key.second));
  return out;
}

std::vector<Vec3> track_of(const std::vector<float>& positions, int effectors, int e) {
  const std::size_t frames = positions.size() / (3 * std::size_t(effectors));
  std::vector<Vec3> track(frames);
  for (std::size_t t = 0; t < frames; ++t)
    track[t] = load_vec3(&positions[(t * std::size_t(effectors) + std::size_t(e)) * 3]);
  return track;
}

double lowest_foot(const std::vector<float>& positions, const ClipGeometry& g,
                   const std::vector<Segment>& segments) {
  const int effectors = int(g.effectors.size());
  double ground = std::numeric_limits<double>::infinity();
  const bool any_foot =
      std::any_of(g.effectors.begin(), g.effectors.end(), [](const Effector& e) { return e.foot; });
  for (const Segment& s : segments) {
    if (!scored(s)) continue;
    for (int t = s.begin; t < s.end; ++t)
      for (int e = 0; e < effectors; ++e)
        if (g.effectors[std::size_t(e)].foot || !any_foot)
          ground = std::min(
              ground, double(positions[(std::size_t(t) * std::size_t(effectors) + e) * 3 + 1]));
  }
  return std::isfinite(ground) ? ground : 0.0;
}

}  // namespace

void effector_positions(const Clip& clean, const ClipGeometry& geometry, RotationView rotations,
                        std::vector<float>& out, TranslationView translations,
                        std::vector<float>* joint_positions) {
  std::vector<float> local;
  std::vector<float>& joints = joint_positions ? *joint_positions : local;
  joints.assign(std::size_t(rotations.frames) * std::size_t(rotations.joints) * 3, 0.0f);
  out.assign(std::size_t(rotations.frames) * geometry.sites.size() * 3, 0.0f);
  ForwardKinematicsJob fk;
  fk.parents = geometry.parents;
  fk.offsets = geometry.offsets;
  fk.rotations = rotations;
  fk.translations = translations.empty() ? clean.translation_view() : translations;
  fk.translated_joints = geometry.translated;
  fk.sites = geometry.sites;
  fk.positions = {joints.data(), rotations.frames, rotations.joints};
  fk.site_positions = {out.data(), rotations.frames, int(geometry.sites.size())};
  (void)fk.run();  // shapes come from the clip itself
}

ClipGeometry describe_clip(const Clip& clean, double unit_cm,
                           const std::vector<Segment>& segments) {
  const Skeleton& skeleton = *clean.skeleton;
  ClipGeometry g;
  g.parents = skeleton.parents;
  g.offsets = skeleton.offsets;
  g.translated = skeleton.translated_mask();
  for (const JointQuality& q : classify_joints(clean.rotation_view()))
    g.garbage.push_back(is_garbage(q.joint_class) ? 1 : 0);
  g.effectors = effectors_by_name(skeleton);
  if (g.effectors.empty()) {
    // Chain ends: every joint without children, at its End Site when it has one.
    g.by_name = false;
    std::vector<bool> has_child(std::size_t(skeleton.joint_count()), false);
    for (int p : skeleton.parents)
      if (p >= 0) has_child[std::size_t(p)] = true;
    for (int j = 0; j < skeleton.joint_count(); ++j)
      if (!has_child[std::size_t(j)]) g.effectors.push_back(effector_at(skeleton, j, false));
  }
  for (const Effector& e : g.effectors) g.sites.push_back(e.site);
  g.feet = find_feet(skeleton.joint_names, skeleton.parents, skeleton.offsets);
  g.body_height_units = body_height(skeleton);

  std::vector<float> positions;
  effector_positions(clean, g, clean.rotation_view(), positions);
  const int first = [&] {
    for (const Segment& s : segments)
      if (scored(s)) return s.begin;
    return 0;
  }();
  if (!g.by_name && clean.frames > 0 && g.effectors.size() >= 2) {
    // Feet of an unnamed skeleton: the two lowest chain ends in the first scored frame.
    std::vector<std::size_t> order(g.effectors.size());
    for (std::size_t e = 0; e < order.size(); ++e) order[e] = e;
    auto height = [&](std::size_t e) {
      return positions[(std::size_t(first) * g.effectors.size() + e) * 3 + 1];
    };
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return height(a) < height(b); });
    g.effectors[order[0]].foot = g.effectors[order[1]].foot = true;
  }

  // Hip height: the median height of the root above the lowest foot point.
  const double ground = lowest_foot(positions, g, segments);
  std::vector<double> heights;
  for (const Segment& s : segments)
    if (scored(s))
      for (int t = s.begin; t < s.end; ++t) heights.push_back(clean.translation_view().at(t, 0)[1]);
  if (!heights.empty()) {
    std::nth_element(heights.begin(), heights.begin() + std::ptrdiff_t(heights.size() / 2),
                     heights.end());
    g.hip_height_units = heights[heights.size() / 2] - ground;
  }
  if (unit_cm > 0) {
    g.unit_cm = unit_cm;
    g.unit_guessed = false;
  } else {
    g.unit_cm = g.hip_height_units >= kCmuHipHeightMin && g.hip_height_units <= kCmuHipHeightMax
                    ? kCmuCmPerUnit
                    : 1.0;
  }
  return g;
}

void Score::add(const Score& o) {
  rotation_sq += o.rotation_sq;
  rotation_n += o.rotation_n;
  unglitched_sq += o.unglitched_sq;
  unglitched_n += o.unglitched_n;
  effector_sq += o.effector_sq;
  effector_n += o.effector_n;
  skate_steps += o.skate_steps;
  foot_steps += o.foot_steps;
  speed_sq += o.speed_sq;
  speed_n += o.speed_n;
  max_error = std::max(max_error, o.max_error);
  knee_peak_ratio = std::max(knee_peak_ratio, o.knee_peak_ratio);
  positions.add(o.positions);
}

namespace {
double ratio(double a, double n) {
  return n > 0 ? a / n : std::numeric_limits<double>::quiet_NaN();
}
}  // namespace

double Score::rmse() const {
  return std::sqrt(ratio(rotation_sq, rotation_n));
}
double Score::psnr() const {
  return psnr_from_rmse(rmse());
}
double Score::unglitched_psnr() const {
  return psnr_from_rmse(std::sqrt(ratio(unglitched_sq, unglitched_n)));
}
double Score::effector_rms_cm() const {
  return std::sqrt(ratio(effector_sq, effector_n));
}
double Score::skating_percent() const {
  return 100.0 * ratio(skate_steps, foot_steps);
}
double Score::speed_rms() const {
  return std::sqrt(ratio(speed_sq, speed_n));
}
double Score::mpjpe_mm() const {
  return positions.mpjpe();
}
double Score::jitter_mm() const {
  return positions.jitter();
}
double Score::accel_error_mm() const {
  return positions.accel_error();
}
double Score::skating_mm() const {
  return positions.skating();
}

namespace {

// Sums in file units to sums in mm, so that clips of different units pool.
void in_mm(PositionSums& p, double mm) {
  p.error *= mm;
  p.jitter_sq *= mm * mm;
  p.accel_error_sq *= mm * mm;
  p.skate *= mm;
}

void add_position_scores(const Clip& clean, const ClipGeometry& geometry,
                         const ClipReference& reference, const std::vector<Segment>& segments,
                         const std::vector<float>& positions, bool against_truth,
                         PositionSums& sums) {
  const TensorView<const float, 3> p{positions.data(), clean.frames, clean.joints()};
  const TensorView<const float, 3> g{reference.positions.data(), clean.frames, clean.joints()};
  for (const Segment& seg : segments) {
    if (seg.frames() < 3) continue;
    const FrameRange range = scored_frames(seg.begin, seg.end, clean.frame_time);
    if (against_truth) {
      add_position_error(p, g, range, sums);
      add_acceleration_error(p, g, range, sums);
    }
    add_jitter(p, range, sums);
    for (std::size_t f = 0; f < geometry.feet.size() && f < reference.contacts.size(); ++f)
      add_skating(p, geometry.feet[f].ankle, reference.contacts[f], range, sums);
  }
}

}  // namespace

void count_skating(std::span<const Vec3> track, const std::vector<Segment>& segments, double ground,
                   double cm_per_unit, double* skates, double* steps) {
  const double height_limit = kSkateHeightCm / cm_per_unit;
  const double step_limit = kSkateStepCm / cm_per_unit;
  for (const Segment& s : segments) {
    if (!scored(s)) continue;
    for (int t = s.begin; t + 1 < s.end; ++t) {
      const Vec3 a = track[std::size_t(t)], b = track[std::size_t(t) + 1];
      *steps += 1;
      const bool low = a.y - ground < height_limit && b.y - ground < height_limit;
      const double dx = b.x - a.x, dz = b.z - a.z;
      if (low && std::sqrt(dx * dx + dz * dz) > step_limit) *skates += 1;
    }
  }
}

ClipReference make_reference(const Clip& clean, const ClipGeometry& geometry,
                             const std::vector<Segment>& segments) {
  ClipReference r;
  effector_positions(clean, geometry, clean.rotation_view(), r.effectors, {}, &r.positions);
  // Contacts of the clean clip's ankles: where a viewer expects the feet to stay planted.
  {
    const std::size_t feet = geometry.feet.size();
    std::vector<float> tracks(std::size_t(clean.frames) * feet * 3);
    for (int t = 0; t < clean.frames; ++t)
      for (std::size_t f = 0; f < feet; ++f)
        std::copy_n(&r.positions[(std::size_t(t) * std::size_t(clean.joints()) +
                                  std::size_t(geometry.feet[f].ankle)) *
                                 3],
                    3, &tracks[(std::size_t(t) * feet + f) * 3]);
    FootContactJob job;
    job.feet = {tracks.data(), clean.frames, int(feet)};
    job.frame_time = clean.frame_time;
    job.body_height = geometry.body_height_units;
    job.contacts = &r.contacts;
    if (!job.run().ok()) r.contacts.assign(feet, {});
  }
  add_position_scores(clean, geometry, r, segments, r.positions, false, r.clean_positions);
  in_mm(r.clean_positions, geometry.unit_cm * 10);
  r.ground = lowest_foot(r.effectors, geometry, segments);
  const int frames = clean.frames, joints = clean.joints();
  r.speeds.assign(std::size_t(joints) * std::size_t(std::max(frames - 1, 0)), 0.0);
  for (int j = 0; j < joints && frames > 1; ++j)
    angular_speed(clean.rotation_view(), clean.frame_time, j,
                  std::span<double>(r.speeds).subspan(std::size_t(j) * std::size_t(frames - 1),
                                                      std::size_t(frames - 1)));
  const int effectors = int(geometry.effectors.size());
  for (int e = 0; e < effectors; ++e)
    if (geometry.effectors[std::size_t(e)].foot)
      count_skating(track_of(r.effectors, effectors, e), segments, r.ground, geometry.unit_cm,
                    &r.clean_skating.skate_steps, &r.clean_skating.foot_steps);
  return r;
}

Score score_clip(const Clip& clean, const ClipGeometry& geometry, const ClipReference& reference,
                 const std::vector<Segment>& segments, RotationView result,
                 TranslationView result_translations) {
  Score s;
  const RotationView truth = clean.rotation_view();
  const int joints = clean.joints(), frames = clean.frames;
  std::vector<double> speed(std::size_t(std::max(frames - 1, 0)));
  for (const Segment& seg : segments) {
    if (!scored(seg)) continue;
    for (int t = seg.begin; t < seg.end; ++t)
      for (int j = 0; j < joints; ++j) {
        const double d = geodesic(load_quat(result.at(t, j)), load_quat(truth.at(t, j)));
        s.rotation_sq += d * d;
        s.rotation_n += 1;
        if (reference.glitches.empty() ||
            !reference.glitches[std::size_t(t) * std::size_t(joints) + std::size_t(j)]) {
          s.unglitched_sq += d * d;
          s.unglitched_n += 1;
        }
        if (geometry.garbage.empty() || !geometry.garbage[std::size_t(j)])
          s.max_error = std::max(s.max_error, d);
      }
  }
  double knee_peak = 0, clean_knee_peak = 0;
  for (int j = 0; j < joints && frames > 1; ++j) {
    angular_speed(result, clean.frame_time, j, speed);
    const double* clean_speed = &reference.speeds[std::size_t(j) * std::size_t(frames - 1)];
    const bool knee = std::any_of(geometry.feet.begin(), geometry.feet.end(),
                                  [&](const FootChain& f) { return f.knee == j; });
    for (const Segment& seg : segments)
      if (scored(seg))
        for (int t = seg.begin; t + 1 < seg.end; ++t) {
          const double d = speed[std::size_t(t)] - clean_speed[t];
          s.speed_sq += d * d;
          s.speed_n += 1;
          if (knee) {
            knee_peak = std::max(knee_peak, speed[std::size_t(t)]);
            clean_knee_peak = std::max(clean_knee_peak, clean_speed[t]);
          }
        }
  }
  if (clean_knee_peak > 0) s.knee_peak_ratio = knee_peak / clean_knee_peak;

  std::vector<float> positions, joint_positions;
  effector_positions(clean, geometry, result, positions, result_translations, &joint_positions);
  add_position_scores(clean, geometry, reference, segments, joint_positions, true, s.positions);
  in_mm(s.positions, geometry.unit_cm * 10);
  const int effectors = int(geometry.effectors.size());
  const double unit2 = geometry.unit_cm * geometry.unit_cm;
  for (const Segment& seg : segments) {
    if (!scored(seg)) continue;
    for (int t = seg.begin; t < seg.end; ++t)
      for (int e = 0; e < effectors; ++e) {
        const std::size_t i = (std::size_t(t) * std::size_t(effectors) + std::size_t(e)) * 3;
        const double dx = positions[i] - reference.effectors[i],
                     dy = positions[i + 1] - reference.effectors[i + 1],
                     dz = positions[i + 2] - reference.effectors[i + 2];
        s.effector_sq += (dx * dx + dy * dy + dz * dz) * unit2;
        s.effector_n += 1;
      }
  }
  for (int e = 0; e < effectors; ++e)
    if (geometry.effectors[std::size_t(e)].foot)
      count_skating(track_of(positions, effectors, e), segments, reference.ground, geometry.unit_cm,
                    &s.skate_steps, &s.foot_steps);
  return s;
}

}  // namespace mocap::engine::eval
