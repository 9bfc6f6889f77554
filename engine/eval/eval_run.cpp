#include "engine/eval/eval_run.hpp"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>

#include "core/quaternion.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "engine/clip/hinge_stage.hpp"
#include "engine/clip/motion_guard.hpp"
#include "engine/eval/eval_methods.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/noise_estimate.hpp"
#include "kernels/noise_model.hpp"

namespace mocap::engine::eval {
namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RotationView segment_view(const std::vector<float>& rotations, int joints, const Segment& s) {
  return {rotations.data() + std::size_t(s.begin) * std::size_t(joints) * 4, s.frames(), joints};
}
RotationSpan segment_span(std::vector<float>& rotations, int joints, const Segment& s) {
  return {rotations.data() + std::size_t(s.begin) * std::size_t(joints) * 4, s.frames(), joints};
}

// The legs, their contacts and what locking did, for report.json.
nlohmann::json feet_json(const ClipFeet& feet) {
  nlohmann::json legs = nlohmann::json::array();
  for (std::size_t l = 0; l < feet.legs.size(); ++l) {
    nlohmann::json intervals = nlohmann::json::array();
    for (const ContactInterval& c : feet.contacts[l]) intervals.push_back({c.begin, c.end});
    legs.push_back({{"ankle", feet.legs[l].ankle}, {"contacts", intervals}});
  }
  return {{"legs", legs},
          {"locked_frames", feet.stats.locked_frames},
          {"root_lowered_frames", feet.stats.lowered_frames}};
}

// The feet of a noisy clip: its rotations and translations on the clean clip's skeleton.
ClipFeet noisy_feet(const Clip& clean, const std::vector<float>& rotations,
                    const std::vector<float>& translations) {
  return detect_feet(with_motion(clean, rotations, translations));
}

}  // namespace

std::uint64_t noise_seed(std::uint64_t seed, const std::string& clip,
                         const std::string& condition) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : clip + '\n' + condition) h = (h ^ c) * 1099511628211ull;
  std::uint64_t z = seed + h + 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

std::vector<float> make_noisy(const Clip& clean, const NoiseCondition& condition,
                              std::uint64_t seed) {
  std::vector<float> rotations = clean.rotations;
  const RotationSpan span{rotations.data(), clean.frames, clean.joints()};
  if (condition.is_gaussian()) {
    add_noise(GaussianNoise{condition.sigma, seed}, span);
  } else {
    ImpulseNoise noise = condition.impulse;
    noise.seed = seed;
    add_noise(noise, span);
  }
  return rotations;
}

std::vector<float> make_noisy_translations(const Clip& clean, const NoiseCondition& condition,
                                           double body_height, std::uint64_t seed) {
  std::vector<float> translations = clean.translations;
  if (condition.position_sigma > 0) {
    add_noise(PositionNoise{condition.position_sigma * body_height, position_noise_seed(seed)},
              {translations.data(), clean.frames, clean.joints()},
              clean.skeleton->translated_mask());
  }
  return translations;
}

// The impossible steps are a property of the source, so eval finds them in the clean clip: every
// method and noise condition then sees the same segments, and the synthetic noise (whose pops
// stay below the threshold anyway) can neither add nor hide a cut.
EvalClip prepare_clip(std::string name, Clip source, const EvalConfig& config, int frame_step) {
  // The capture's own glitches, found at its own rate: what the pop stage flags on the source
  // (counting only, on a copy), kept at the frames the decimation keeps. Below 60 fps the stage
  // takes some fast motion for pops, and a glitch set found there would excuse every such flag.
  std::vector<float> copy = source.rotations;
  const int source_joints = source.joints();
  const ClipConditioning glitches =
      condition_rotations(PopsMode::detect, {copy.data(), source.frames, source_joints},
                          source.frame_time, source.skeleton->parents);
  const int step = std::max(frame_step, 1);

  EvalClip c;
  c.name = std::move(name);
  c.clean = decimate(std::move(source), step);
  if (config.split_impossible) {
    // As clean splits (engine/clip/clip_conditioning.cpp): a flipping joint's flips are not
    // motion and cut nothing (06_14's LThumb would otherwise cut that clip into 18 segments).
    c.steps = find_impossible_steps(c.clean.rotation_view(), c.clean.frame_time, config.split,
                                    flipping_joints(classify_joints(c.clean.rotation_view())));
  }
  c.segments = split_segments(c.clean.frames, c.steps);
  c.geometry = describe_clip(c.clean, config.unit_cm, c.segments);
  c.reference = make_reference(c.clean, c.geometry, c.segments);
  c.reference.glitches.assign(std::size_t(c.clean.frames) * std::size_t(source_joints), 0);
  for (std::size_t p = 0; p + 1 < glitches.pop_samples.size(); p += 2) {
    const int t = glitches.pop_samples[p];
    if (t % step != 0) continue;
    c.reference.glitches[std::size_t(t / step) * std::size_t(source_joints) +
                         std::size_t(glitches.pop_samples[p + 1])] = 1;
  }
  return c;
}

Status filter_clip(const EvalClip& clip, const NoisyClip& noisy, EvalMethod method, bool repaired,
                   const ParamPoint* point, std::vector<float>& out,
                   std::vector<float>& out_translations, nlohmann::json* resolved, bool lock_feet,
                   bool guard) {
  const int joints = clip.clean.joints();
  const std::vector<float>& input = repaired ? noisy.repaired : noisy.rotations;
  const std::vector<double>& sigma_hats = repaired ? noisy.repaired_sigma_hats : noisy.sigma_hats;
  // As the engine does (resolve_for_clip): garbage joints kept, the others for the distance.
  const bool any_garbage =
      repaired && std::find(noisy.garbage.begin(), noisy.garbage.end(), 1) != noisy.garbage.end();
  const std::vector<std::uint8_t> distance =
      any_garbage ? distance_joints_without(noisy.garbage) : std::vector<std::uint8_t>{};
  out.resize(input.size());
  out_translations.resize(noisy.translations.size());
  const std::vector<std::uint8_t> translated = clip.clean.skeleton->translated_mask();
  if (resolved) *resolved = nlohmann::json::array();
  for (std::size_t s = 0; s < clip.segments.size(); ++s) {
    const Segment& seg = clip.segments[s];
    SegmentJob job;
    job.noisy = segment_view(input, joints, seg);
    job.output = segment_span(out, joints, seg);
    job.frame_time = clip.clean.frame_time;
    job.sigma_hat = sigma_hats[s];
    job.body_height = clip.geometry.body_height_units;
    const std::size_t at = std::size_t(seg.begin) * std::size_t(joints) * 3;
    job.translations = {noisy.translations.data() + at, seg.frames(), joints};
    job.output_translations = {out_translations.data() + at, seg.frames(), joints};
    job.translated_joints = translated;
    job.skeleton = clip.clean.skeleton.get();
    if (any_garbage) {
      job.kept_joints = noisy.garbage;
      job.distance_joints = distance;
      job.flip_joints = noisy.flipping;
    }
    nlohmann::json used;
    if (Status st = filter_segment(method, point, job, resolved ? &used : nullptr); !st)
      return Status::error(fmt::format("frames {}-{}: {}", seg.begin, seg.end, st.message()));
    if (resolved && seg.frames() >= 2) {
      used["frames"] = {seg.begin, seg.end};
      used["sigma_hat"] = sigma_hats[s];
      resolved->push_back(used);
    }
  }
  if (method.automatic()) {
    // As `clean` does (engine/clip/hinge_stage.hpp), with each segment's noise estimate.
    const int frames = clip.clean.frames;
    const Status s = project_hinges_in_segments(
        {input.data(), frames, joints}, {out.data(), frames, joints}, clip.segments, sigma_hats,
        any_garbage ? std::span<const std::uint8_t>(noisy.garbage)
                    : std::span<const std::uint8_t>{});
    if (!s) return s;
  }
  if (!guard && !lock_feet) return {};
  // Then as `clean` does: the lock and, for auto's runs, the guard (engine/clip/motion_guard.hpp).
  Clip filtered = with_motion(clip.clean, std::move(out), std::move(out_translations));
  const Clip in = guard ? with_motion(clip.clean, input, noisy.translations) : Clip{};
  const Clip raw = guard ? with_motion(clip.clean, noisy.rotations, noisy.translations) : Clip{};
  ClipFeet feet = repaired ? noisy.repaired_feet : noisy.feet;
  MotionGuardJob g;
  g.input = guard ? &in : nullptr;
  g.raw = guard ? &raw : nullptr;
  g.before = guard ? &noisy.before : nullptr;
  g.guard = guard;
  g.segments = &clip.segments;
  g.feet = lock_feet ? &feet : nullptr;
  g.output = &filtered;
  const Status s = g.run();
  out = std::move(filtered.rotations);
  out_translations = std::move(filtered.translations);
  if (!s) return guard ? s : Status::error("foot locking: " + s.message());
  if (resolved) {
    *resolved = {{"segments", *resolved}};
    if (guard) (*resolved)["kept"] = std::string(to_string(g.kept));
    if (lock_feet) (*resolved)["feet"] = feet_json(feet);
  }
  return {};
}

EvalResults run_evaluation(std::vector<EvalClip> clips, const EvalConfig& config,
                           const std::function<void(std::size_t, std::size_t)>& progress) {
  EvalResults r;
  r.clips = std::move(clips);
  const std::size_t C = config.conditions.size(), N = r.clips.size(), M = config.grids.size();

  // The noisy clips, their noise estimates and the unfiltered scores.
  const auto start = std::chrono::steady_clock::now();
  r.noisy.assign(C, std::vector<NoisyClip>(N));
  r.noisy_scores.assign(C, std::vector<Score>(N));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, C * N, 1), [&](const auto& range) {
    for (std::size_t i = range.begin(); i < range.end(); ++i) {
      const std::size_t c = i / N, k = i % N;
      const EvalClip& clip = r.clips[k];
      NoisyClip& noisy = r.noisy[c][k];
      const std::string label = config.conditions[c].label();
      const std::uint64_t seed = noise_seed(config.seed, clip.name, label);
      noisy.rotations = make_noisy(clip.clean, config.conditions[c], seed);
      noisy.translations = make_noisy_translations(clip.clean, config.conditions[c],
                                                   clip.geometry.body_height_units, seed);
      for (const Segment& s : clip.segments)
        noisy.sigma_hats.push_back(
            estimate_noise(segment_view(noisy.rotations, clip.clean.joints(), s)).sigma);
      if (config.repaired) {
        noisy.repaired = noisy.rotations;
        const ClipConditioning cond = condition_rotations(
            config.pop_stage, {noisy.repaired.data(), clip.clean.frames, clip.clean.joints()},
            clip.clean.frame_time, clip.clean.skeleton->parents);
        noisy.garbage = cond.garbage;
        noisy.flipping = flipping_joints(cond.joints);
        noisy.pops = cond.pop_count();
        const std::size_t J = std::size_t(clip.clean.joints());
        auto moved = [&](const std::vector<float>& rotations, std::size_t sample) {
          return geodesic(load_quat(rotations.data() + sample * 4),
                          load_quat(clip.clean.rotations.data() + sample * 4)) > kPoppedAngle;
        };
        std::vector<std::uint8_t> lone(std::size_t(clip.clean.frames), 0);
        for (const Segment& s : clip.segments)
          if (s.frames() == 1) lone[std::size_t(s.begin)] = 1;
        for (std::size_t sample = 0; sample < noisy.rotations.size() / 4; ++sample)
          if (moved(noisy.rotations, sample)) {
            const bool on_lone_frame = lone[sample / J] != 0;
            ++noisy.popped;
            noisy.popped_lone += on_lone_frame;
            if (moved(noisy.repaired, sample)) {
              ++noisy.pops_left;
              noisy.pops_left_lone += on_lone_frame;
              noisy.left_samples.push_back({int(sample / J), int(sample % J)});
            }
          }
        for (std::size_t p = 0; p + 1 < cond.pop_samples.size(); p += 2) {
          const std::size_t sample =
              std::size_t(cond.pop_samples[p]) * J + std::size_t(cond.pop_samples[p + 1]);
          if (moved(noisy.rotations, sample))
            ++noisy.pops_caught;
          else
            ++noisy.false_repairs;
        }
        for (const Segment& s : clip.segments)
          noisy.repaired_sigma_hats.push_back(
              estimate_noise(segment_view(noisy.repaired, clip.clean.joints(), s), noisy.garbage)
                  .sigma);
      }
      if (config.lock_feet) {
        noisy.feet = noisy_feet(clip.clean, noisy.rotations, noisy.translations);
        if (config.repaired)
          noisy.repaired_feet = noisy_feet(clip.clean, noisy.repaired, noisy.translations);
      }
      if (config.guard)
        noisy.before = measure_motion(with_motion(clip.clean, noisy.rotations, noisy.translations),
                                      nullptr, clip.segments);
      r.noisy_scores[c][k] =
          score_clip(clip.clean, clip.geometry, clip.reference, clip.segments,
                     {noisy.rotations.data(), clip.clean.frames, clip.clean.joints()},
                     {noisy.translations.data(), clip.clean.frames, clip.clean.joints()});
    }
  });
  r.prepare_seconds = seconds_since(start);

  // Every (method, point, condition, clip) task; point == points.size() is the automatic one.
  struct Task {
    std::size_t m, p, c, k;
  };
  std::vector<Task> tasks;
  r.results.resize(M);
  for (std::size_t m = 0; m < M; ++m) {
    const std::size_t P = config.grids[m].points.size() + 1;
    r.results[m].assign(P, std::vector<std::vector<TaskResult>>(C, std::vector<TaskResult>(N)));
    for (std::size_t p = 0; p < P; ++p)
      for (std::size_t c = 0; c < C; ++c)
        for (std::size_t k = 0; k < N; ++k) tasks.push_back({m, p, c, k});
  }
  r.tasks = tasks.size();
  std::mutex progress_mutex;
  std::size_t done = 0;
  const auto filter_start = std::chrono::steady_clock::now();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tasks.size(), 1), [&](const auto& range) {
    std::vector<float> out, out_translations;
    for (std::size_t i = range.begin(); i < range.end(); ++i) {
      const Task& t = tasks[i];
      const MethodGrid& grid = config.grids[t.m];
      const ParamPoint* point = t.p < grid.points.size() ? &grid.points[t.p] : nullptr;
      const EvalClip& clip = r.clips[t.k];
      TaskResult& result = r.results[t.m][t.p][t.c][t.k];
      const Status s = filter_clip(clip, r.noisy[t.c][t.k], grid.method, grid.repaired, point, out,
                                   out_translations, point ? nullptr : &result.resolved,
                                   grid.lock_feet, config.guard && grid.method.automatic());
      if (!s) {
        result.error = s.message();
      } else {
        result.score =
            score_clip(clip.clean, clip.geometry, clip.reference, clip.segments,
                       {out.data(), clip.clean.frames, clip.clean.joints()},
                       {out_translations.data(), clip.clean.frames, clip.clean.joints()});
      }
      if (progress) {
        std::lock_guard lock(progress_mutex);
        progress(++done, tasks.size());
      }
    }
  });
  r.filter_seconds = seconds_since(filter_start);
  return r;
}

Score pooled(const EvalResults& results, std::size_t m, std::size_t p, std::size_t c) {
  Score s;
  for (const TaskResult& t : results.results[m][p][c]) {
    if (!t.error.empty()) return Score{};  // a point that failed on any clip is not comparable
    s.add(t.score);
  }
  return s;
}

Score pooled_noisy(const EvalResults& results, std::size_t c) {
  Score s;
  for (const Score& x : results.noisy_scores[c]) s.add(x);
  return s;
}

std::vector<std::string> edge_parameters(const MethodGrid& grid, std::size_t p) {
  std::vector<std::string> out;
  if (p >= grid.points.size()) return out;
  const ParamPoint& point = grid.points[p];
  for (std::size_t i = 0; i < point.size(); ++i) {
    double lo = point[i].second, hi = point[i].second;
    for (const ParamPoint& other : grid.points)
      if (i < other.size() && other[i].first == point[i].first) {
        lo = std::min(lo, other[i].second);
        hi = std::max(hi, other[i].second);
      }
    if (lo < hi && (point[i].second == lo || point[i].second == hi)) out.push_back(point[i].first);
  }
  return out;
}

Spread psnr_spread(const EvalResults& results, std::size_t m, std::size_t p, std::size_t c) {
  std::vector<double> v;
  for (const TaskResult& t : results.results[m][p][c])
    if (t.error.empty() && std::isfinite(t.score.psnr())) v.push_back(t.score.psnr());
  Spread s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.min = v.front();
  s.max = v.back();
  const std::size_t n = v.size();
  s.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  return s;
}

int best_point(const EvalResults& results, const EvalConfig& config, std::size_t m, std::size_t c) {
  int best = -1;
  double best_psnr = -std::numeric_limits<double>::infinity();
  for (std::size_t p = 0; p < config.grids[m].points.size(); ++p) {
    const double v = pooled(results, m, p, c).psnr();
    if (std::isfinite(v) && v > best_psnr) {
      best_psnr = v;
      best = int(p);
    }
  }
  return best;
}

}  // namespace mocap::engine::eval
