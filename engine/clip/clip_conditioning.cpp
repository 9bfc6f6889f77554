#include "engine/clip/clip_conditioning.hpp"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <mutex>
#include <numeric>
#include <stdexcept>

#include "core/quaternion.hpp"
#include "engine/clip/flip_pieces.hpp"
#include "engine/run/run_summary.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/pop_detour.hpp"
#include "kernels/pop_repair.hpp"
#include "kernels/pop_skeleton.hpp"

namespace mocap::engine {

bool ClipConditioning::any_garbage() const {
  return std::any_of(garbage.begin(), garbage.end(), [](std::uint8_t g) { return g != 0; });
}

std::size_t ClipConditioning::pop_count() const {
  return std::accumulate(pops.begin(), pops.end(), std::size_t(0));
}

ClipFacts ClipConditioning::facts() const {
  if (joints.empty() || segments.empty() || (repaired && pop_count() > 0)) return {};
  return {joints, &segments};
}

namespace {

// `out` ([F][J][4], a copy of `in`) with each joint's flagged runs repaired (repair_pops), but
// for the `skip` joints (one entry per joint), left as they are in `out`.
void repair_flagged(RotationView in, std::span<const std::uint8_t> flags,
                    std::span<const std::uint8_t> skip, std::span<float> out) {
  const int F = in.frames, J = in.joints;
  std::vector<Quat> curve(static_cast<std::size_t>(F)), fixed(static_cast<std::size_t>(F));
  std::vector<std::uint8_t> joint_flags(static_cast<std::size_t>(F));
  for (int j = 0; j < J; ++j) {
    if (skip[std::size_t(j)]) continue;
    bool any = false;
    for (int t = 0; t < F; ++t) {
      joint_flags[std::size_t(t)] = flags[std::size_t(t) * std::size_t(J) + std::size_t(j)];
      any = any || joint_flags[std::size_t(t)];
    }
    if (!any) continue;
    for (int t = 0; t < F; ++t) curve[std::size_t(t)] = load_quat(in.at(t, j));
    repair_pops(curve, joint_flags, fixed);
    for (int t = 0; t < F; ++t)
      if (joint_flags[std::size_t(t)])
        store_quat(fixed[std::size_t(t)],
                   out.data() + (std::size_t(t) * std::size_t(J) + std::size_t(j)) * 4);
  }
}

// A job's joints as parallel tasks (a clip's few long joints would otherwise keep one thread
// busy while the others wait for the next clip); `slice(job, begin, end)` is the job on joints
// [begin, end), which writes only those joints' outputs, so the results are the same for any
// thread count.
template <class Job, class Slice>
void run_joints_in_parallel(const Job& job, int joints, Slice slice) {
  std::mutex mutex;
  std::string error;
  tbb::parallel_for(tbb::blocked_range<int>(0, joints, 1), [&](const auto& range) {
    if (const Status s = slice(job, range.begin(), range.end()).run(); !s.ok()) {
      const std::lock_guard lock(mutex);
      if (error.empty()) error = s.message();
    }
  });
  if (!error.empty()) throw std::runtime_error("pop repair: " + error);
}

void run_joints_in_parallel(const PopRepairJob& job) {
  run_joints_in_parallel(job, job.io.rotations.joints, [](PopRepairJob slice, int begin, int end) {
    slice.io.joint_begin = begin;
    slice.io.joint_end = end;
    return slice;
  });
}

void run_joints_in_parallel(const PopDetourJob& job) {
  run_joints_in_parallel(job, job.rotations.joints, [](PopDetourJob slice, int begin, int end) {
    slice.joint_begin = begin;
    slice.joint_end = end;
    return slice;
  });
}

// Flipping joints' pops, found and repaired piece by piece between the joint's flips
// (clip/flip_pieces.hpp): to the test over the whole curve every flip is a pop, inside a piece
// the joint moves as captured joints do. Writes the repaired samples and their flags.
void repair_between_flips(RotationView rotations, std::span<const std::uint8_t> flipping,
                          const PopRepairParams& params, std::span<std::uint8_t> flagged,
                          std::span<int> found, std::span<float> repaired) {
  const int J = rotations.joints;
  std::vector<Quat> curve, out;
  std::vector<std::uint8_t> flags;
  for (int j = 0; j < J; ++j) {
    if (!flipping[std::size_t(j)]) continue;
    for (const Segment& piece : flip_pieces(rotations, j)) {
      if (piece.frames() < kPopRepairMinFrames) continue;
      const std::size_t n = std::size_t(piece.frames());
      curve.resize(n);
      for (std::size_t t = 0; t < n; ++t)
        curve[t] = load_quat(rotations.at(piece.begin + int(t), j));
      flags.assign(n, 0);
      const int count = find_pops(curve, params, flags);
      if (count == 0) continue;
      out.resize(n);
      repair_pops(curve, flags, out);
      for (std::size_t t = 0; t < n; ++t) {
        if (!flags[t]) continue;
        const std::size_t sample = (std::size_t(piece.begin) + t) * std::size_t(J) + std::size_t(j);
        flagged[sample] = 1;
        store_quat(out[t], &repaired[sample * 4]);
      }
      found[std::size_t(j)] += count;
    }
  }
}

}  // namespace

PopRepairParams pop_params_at(double frame_time) {
  PopRepairParams params;
  if (frame_time > 0 && 1.0 / frame_time >= kPopsRepairMinFps) return params;
  params.max_run = 2;
  params.local_threshold = 8;
  return params;
}

ClipConditioning condition_rotations(PopsMode mode, RotationSpan rotations, double frame_time,
                                     std::span<const int> parents) {
  ClipConditioning c;
  const int J = rotations.joints;
  const bool high_rate = frame_time > 0 && 1.0 / frame_time >= kPopsRepairMinFps;
  if (mode == PopsMode::automatic && !high_rate) {
    // Below kPopsRepairMinFps auto counts first, and repairs only a clip whose flags are many
    // (kAutoRepairMinFlagged, filter_settings.hpp) at kAutoRepairMinFps or more; the low-rate
    // test needs the skeleton.
    ClipConditioning counted =
        condition_rotations(PopsMode::detect, rotations, frame_time, parents);
    const double samples = double(rotations.frames) * double(J);
    if (std::size_t(J) != parents.size() || !(samples > 0) ||
        !(frame_time > 0 && 1.0 / frame_time >= kAutoRepairMinFps) ||
        double(counted.pop_count()) < kAutoRepairMinFlagged * samples)
      return counted;
    return condition_rotations(PopsMode::repair, rotations, frame_time, parents);
  }
  const RotationView view{rotations.data, rotations.frames, J};
  // Joint by joint in parallel tasks, like the pop stage below (each writes its own entry).
  // The step angles the classification measures are kept for the impossible-step test below.
  c.joints.resize(std::size_t(J));
  const std::size_t steps = std::size_t(std::max(rotations.frames - 1, 0));
  std::vector<double> step_angles(steps * std::size_t(J));
  tbb::parallel_for(tbb::blocked_range<int>(0, J, 1), [&](const auto& range) {
    for (int j = range.begin(); j < range.end(); ++j)
      c.joints[std::size_t(j)] = classify_joint(
          view, j, std::span<double>(step_angles).subspan(std::size_t(j) * steps, steps));
  });
  c.garbage.resize(std::size_t(J));
  for (int j = 0; j < J; ++j)
    c.garbage[std::size_t(j)] = is_garbage(c.joints[std::size_t(j)].joint_class);
  c.pops.assign(std::size_t(J), 0);
  if (mode == PopsMode::off || J == 0) return c;

  // Constant and rounding-only joints are repaired too (a pop on a still joint is the easiest to
  // tell); a flipping joint is all pops to the test over its whole curve: where the stage
  // repairs, it is tested and repaired between its flips instead (it has no skeleton neighbours
  // to ask: it is garbage).
  std::vector<std::uint8_t> flipping(static_cast<std::size_t>(J));
  for (int j = 0; j < J; ++j)
    flipping[std::size_t(j)] = c.joints[std::size_t(j)].joint_class == JointClass::flipping;
  // Below kPopsRepairMinFps the per-joint test alone flags fast limbs; with the skeleton known,
  // its neighbours rule out most of them (kernels/pop_skeleton.hpp), and the detour test finds
  // the pops fast motion hides from the fit (kernels/pop_detour.hpp).
  const bool skeleton_test = !high_rate && std::size_t(J) == parents.size();
  c.repaired = mode == PopsMode::repair || (mode == PopsMode::automatic && high_rate);
  std::vector<int> found(std::size_t(J), 0);
  std::vector<float> repaired;
  std::vector<std::uint8_t> flagged;
  const StepAngles angles{step_angles, rotations.frames, J};
  c.segments = split_segments(
      rotations.frames, find_impossible_steps(angles, frame_time, MotionSplitParams{}, flipping));
  for (const Segment& seg : c.segments) {
    flagged.assign(std::size_t(seg.frames()) * std::size_t(J), 0);
    const std::size_t offset = std::size_t(seg.begin) * std::size_t(J) * 4;
    repaired.resize(std::size_t(seg.frames()) * std::size_t(J) * 4);
    PopRepairJob job;
    job.io.frame_time = frame_time;
    job.io.rotations = {rotations.data + offset, seg.frames(), J};
    job.io.filtered_rotations = {repaired.data(), seg.frames(), J};
    job.params = pop_params_at(frame_time);
    job.skip_joints = flipping;
    job.flagged_per_joint = found;
    job.flagged_samples = flagged;
    job.repair = c.repaired && !skeleton_test;
    run_joints_in_parallel(job);
    if (c.repaired)
      repair_between_flips(job.io.rotations, flipping, job.params, flagged, found, repaired);
    if (skeleton_test) {
      // A pop that fast motion hides from the fit still makes a detour (kernels/pop_detour.hpp).
      // With the classification's step angles.
      PopDetourJob detour;
      detour.rotations = {rotations.data + offset, seg.frames(), J};
      detour.skip = flipping;
      detour.flags = flagged;
      detour.threshold = pop_detour_threshold(frame_time);
      detour.steps = &angles;
      detour.step_offset = seg.begin;
      run_joints_in_parallel(detour);
      PopSkeletonJob skeleton;
      skeleton.rotations = {rotations.data + offset, seg.frames(), J};
      skeleton.parents = parents;
      skeleton.params = job.params;
      skeleton.skip = c.garbage;
      skeleton.flags = flagged;
      if (const Status s = skeleton.run(); !s.ok())
        throw std::runtime_error("pop repair: " + s.message());
      std::fill(found.begin(), found.end(), 0);
      for (std::size_t i = 0; i < flagged.size(); ++i) found[i % std::size_t(J)] += flagged[i];
      if (c.repaired) repair_flagged(skeleton.rotations, flagged, flipping, repaired);
    }
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
  return condition_rotations(settings.pops, clip.rotation_span(), clip.frame_time,
                             clip.skeleton->parents);
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
      {"handling",
       keep_garbage
           ? "kept (flipping joints filtered between their flips; by auto only in a noisy clip)"
           : "filtered like the others"},
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
                       : fmt::format("{} repaired (below 60 fps only in clips with many)", fixed));
  }
  return line + describe_garbage(g);
}

}  // namespace mocap::engine
