#include "engine/clip/motion_check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "engine/clip/filter_settings.hpp"
#include "engine/clip/foot_stage.hpp"
#include "kernels/forward_kinematics.hpp"
#include "kernels/median.hpp"
#include "kernels/position_metrics.hpp"

namespace mocap::engine {
namespace {

double ratio(double after, double before) {
  if (before > 0) return after / before;
  return after > 0 ? INFINITY : 1.0;
}

}  // namespace

MotionMeasure measure_motion(const Clip& clip, const MotionMeasure* input,
                             std::span<const Segment> segments) {
  MotionMeasure m;
  if (!clip.skeleton || clip.frames < 3) return m;
  // Every value is written by the forward kinematics: no zero-fill first (a clip's worth of
  // memset, measured in the guard's profile).
  const std::size_t values = std::size_t(clip.frames) * std::size_t(clip.joints()) * 3;
  const auto positions = std::make_unique_for_overwrite<float[]>(values);
  if (!joint_positions_into(clip, {}, {positions.get(), values})) return m;
  const TensorView<const float, 3> p{positions.get(), clip.frames, clip.joints()};
  const Segment whole{0, clip.frames};
  if (segments.empty()) segments = {&whole, 1};
  m.edge_frames = score_edge_frames(clip.frames, clip.frame_time);
  std::vector<FrameRange> ranges;
  for (const Segment& s : segments)
    if (s.frames() >= 3) ranges.push_back(scored_frames(s.begin, s.end, clip.frame_time));
  PositionSums sums;
  for (const FrameRange& range : ranges) add_jitter(p, range, sums);
  m.jitter = sums.jitter_n > 0 ? sums.jitter() : 0.0;

  if (input) {
    m.feet = input->feet;
    m.contacts = input->contacts;
  } else {
    const Skeleton& sk = *clip.skeleton;
    m.feet = find_feet(sk.joint_names, sk.parents, sk.offsets);
    const double height = body_height(sk);
    std::vector<float> feet(std::size_t(clip.frames) * m.feet.size() * 3);
    for (int t = 0; t < clip.frames; ++t)
      for (std::size_t f = 0; f < m.feet.size(); ++f)
        std::copy_n(p.at(t, m.feet[f].ankle), 3, &feet[(std::size_t(t) * m.feet.size() + f) * 3]);
    FootContactJob job;
    job.feet = {feet.data(), clip.frames, int(m.feet.size())};
    job.frame_time = clip.frame_time;
    job.body_height = height;
    job.contacts = &m.contacts;
    if (height <= 0 || !job.run().ok()) m.contacts.assign(m.feet.size(), {});
  }
  PositionSums skate;
  for (const FrameRange& range : ranges)
    for (std::size_t f = 0; f < m.feet.size() && f < m.contacts.size(); ++f)
      add_skating(p, m.feet[f].ankle, m.contacts[f], range, skate);
  m.skating = skate.skate_n > 0 ? skate.skating() : 0.0;
  m.contact_steps = int(skate.skate_n);
  return m;
}

void MotionTally::add(const std::string& clip, const MotionMeasure& before,
                      const MotionMeasure& after, std::optional<std::string_view> kept,
                      bool fell_back) {
  const double jr = ratio(after.jitter, before.jitter);
  const double sr = before.contact_steps > 0 ? ratio(after.skating, before.skating) : 1.0;
  jitter_ratios.push_back(jr);
  skating_ratios.push_back(sr);
  by_clip.push_back({{"clip", clip},
                     {"jitter_before", before.jitter},
                     {"jitter_after", after.jitter},
                     {"jitter_ratio", jr},
                     {"skating_before", before.skating},
                     {"skating_after", after.skating},
                     {"skating_ratio", sr},
                     {"contact_steps", before.contact_steps},
                     {"edge_frames", before.edge_frames},
                     {"worse", jr > kJitterWorse || sr > kSkatingWorse}});
  if (kept) {
    by_clip.back()["kept"] = std::string(*kept);
    ++guarded;
    if (fell_back) ++fallbacks;
  }
}

void MotionTally::write_to(nlohmann::json& summary) const {
  if (by_clip.empty()) return;
  std::vector<double> j = jitter_ratios, s = skating_ratios;
  nlohmann::json worse = nlohmann::json::array();
  for (const auto& c : by_clip)
    if (c["worse"].get<bool>()) worse.push_back(c["clip"]);
  summary["motion"] = {
      {"clips", by_clip.size()},
      {"jitter_ratio_median", median(j)},
      {"skating_ratio_median", median(s)},
      {"worse_limits", {{"jitter_ratio", kJitterWorse}, {"skating_ratio", kSkatingWorse}}},
      {"worse", worse},
      {"by_clip", by_clip}};
  if (guarded > 0) summary["motion"]["guard"] = {{"clips", guarded}, {"fallbacks", fallbacks}};
}

std::string describe_motion(const nlohmann::json& summary) {
  if (!summary.contains("motion")) return "";
  const auto& m = summary["motion"];
  std::string line = fmt::format(
      "  motion: jitter {:.2f}x, foot skating {:.2f}x the input's (median over {} clips)",
      m["jitter_ratio_median"].get<double>(), m["skating_ratio_median"].get<double>(),
      m["clips"].get<std::size_t>());
  if (m.contains("guard") && m["guard"]["fallbacks"].get<std::size_t>() > 0) {
    const auto n = m["guard"]["fallbacks"].get<std::size_t>();
    line += fmt::format(
        "; the guard kept {} {} nearer the input, where cleaning raised jitter "
        "or skating",
        n, n == 1 ? "clip" : "clips");
  }
  const auto& worse = m["worse"];
  if (worse.empty()) return line + "; no clip got worse\n";
  line += fmt::format("; {} {} worse (jitter > {}x or skating > {}x):", worse.size(),
                      worse.size() == 1 ? "clip" : "clips", kJitterWorse, kSkatingWorse);
  std::size_t shown = 0;
  for (const auto& c : m["by_clip"]) {
    if (!c["worse"].get<bool>()) continue;
    if (shown++ == 5) {
      line += " ...";
      break;
    }
    line += fmt::format(" {} (jitter {:.2f}x, skating {:.2f}x)", c["clip"].get<std::string>(),
                        c["jitter_ratio"].get<double>(), c["skating_ratio"].get<double>());
  }
  return line + " (per clip: --json)\n";
}

}  // namespace mocap::engine
