#include "engine/clip/clip_conditioning.hpp"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numeric>
#include <stdexcept>

#include "core/quaternion.hpp"
#include "engine/clip/flip_pieces.hpp"
#include "engine/run/run_summary.hpp"
#include "kernels/motion_split.hpp"
#include "kernels/pop_detour.hpp"
#include "kernels/pop_hinge.hpp"
#include "kernels/pop_repair.hpp"
#include "kernels/pop_screen.hpp"
#include "kernels/pop_skeleton.hpp"

namespace mocap::engine {

bool ClipConditioning::any_garbage() const {
  return std::any_of(garbage.begin(), garbage.end(), [](std::uint8_t g) { return g != 0; });
}

std::size_t ClipConditioning::pop_count() const {
  return std::accumulate(pops.begin(), pops.end(), std::size_t(0));
}

ClipFacts ClipConditioning::facts() const {
  if (joints.empty() || segments.empty()) return {};
  if (repaired && pop_count() > 0) {
    if (repaired_joints.empty()) return {};
    return {repaired_joints, &repaired_segments};
  }
  return {joints, &segments};
}

namespace {

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

// PopFindJob, PopDetourJob and PopHingeJob, sliced by their joint_begin and joint_end.
template <class Job>
void run_joints_in_parallel(const Job& job) {
  run_joints_in_parallel(job, job.rotations.joints, [](Job slice, int begin, int end) {
    slice.joint_begin = begin;
    slice.joint_end = end;
    return slice;
  });
}

// A segment's part of a clip's [F][J] sample flags.
std::span<std::uint8_t> segment_slice(std::span<std::uint8_t> clip_flags, const Segment& seg,
                                      int joints) {
  return clip_flags.subspan(std::size_t(seg.begin) * std::size_t(joints),
                            std::size_t(seg.frames()) * std::size_t(joints));
}

// The pop test on one segment's captured joints (all but the flipping ones), in three steps:
// find_pops on each joint's curve; the detour test, which adds flags (kernels/pop_detour.hpp);
// the skeleton test, which takes away those of coherent motion (kernels/pop_skeleton.hpp).
// Each writes `flags` ([F][J] of the segment).
struct SegmentPopTest {
  RotationView rotations;  // the segment
  double frame_time = 0;
  PopRepairParams params;             // pop_params_at(frame_time)
  const PopScreen* screen = nullptr;  // PopScreen(params), made once for the clip
  std::span<const int> parents;
  std::span<const std::uint8_t> flipping, garbage;  // one per joint
  const StepAngles* steps = nullptr;                // the classification's, of the whole clip
  int step_offset = 0;                              // the segment's first frame
  double strong_detour = 0;  // the skeleton test's (kernels/pop_skeleton.hpp)
  // With strong_detour: one per joint, the detour test's median detours, which the skeleton
  // test reads.
  std::span<double> median_detours;
  std::span<std::uint8_t> flags;

  void find() const {
    PopFindJob job;
    job.params = params;
    job.screen_weights = screen;
    job.rotations = rotations;
    job.skip = flipping;
    job.flags = flags;
    run_joints_in_parallel(job);
  }
  // A pop that fast motion hides from the fit still makes a detour; with the classification's
  // step angles.
  void detour() const {
    PopDetourJob job;
    job.rotations = rotations;
    job.skip = flipping;
    job.flags = flags;
    job.threshold = pop_detour_threshold(frame_time);
    // NaN for the joints the job skips: the skeleton test measures those itself.
    std::fill(median_detours.begin(), median_detours.end(), std::nan(""));
    job.median_detours = median_detours;
    job.steps = steps;
    job.step_offset = step_offset;
    run_joints_in_parallel(job);
  }
  // The detour test's flags where `known` ([F][J] of the segment) has none.
  void new_detours(std::span<const std::uint8_t> known) const {
    detour();
    for (std::size_t i = 0; i < flags.size(); ++i)
      if (known[i]) flags[i] = 0;
  }
  void skeleton(int pop_group = kPopGroup) const {
    PopSkeletonJob job;
    job.pop_group = pop_group;
    job.strong_detour = strong_detour;
    job.median_detours = median_detours;
    job.rotations = rotations;
    job.parents = parents;
    job.params = params;
    job.skip = garbage;
    job.flags = flags;
    if (const Status s = job.run(); !s.ok()) throw std::runtime_error("pop repair: " + s.message());
  }
};

// Flipping joints' pops, found between the joint's flips (clip/flip_pieces.hpp): to the test over
// the whole curve every flip is a pop, inside a piece the joint moves as captured joints do; where
// the flips are one rotation (kernels/flip_chart.hpp) a piece runs across them, read with them
// taken out. Sets their flags in `flags` ([F][J] of the segment `rotations`) and returns each
// joint's pieces: a flipping joint's charted pieces, the whole segment for a captured joint.
std::vector<ChartedPieces> find_pops_between_flips(RotationView rotations,
                                                   std::span<const std::uint8_t> flipping,
                                                   const PopRepairParams& params,
                                                   std::span<std::uint8_t> flags) {
  const int J = rotations.joints;
  std::vector<ChartedPieces> pieces(std::size_t(J), {{{0, rotations.frames}}, {}});
  std::vector<Quat> curve;
  std::vector<std::uint8_t> flipped, piece_flags;
  for (int j = 0; j < J; ++j) {
    if (!flipping[std::size_t(j)]) continue;
    ChartedPieces& charted = pieces[std::size_t(j)];
    charted = charted_flip_pieces(rotations, j);
    for (const Segment& piece : charted.pieces) {
      if (piece.frames() < kPopRepairMinFrames) continue;
      load_piece(rotations, j, charted.chart, piece, curve, flipped);
      piece_flags.assign(curve.size(), 0);
      if (find_pops(curve, params, piece_flags) == 0) continue;
      for (std::size_t t = 0; t < curve.size(); ++t)
        if (piece_flags[t])
          flags[(std::size_t(piece.begin) + t) * std::size_t(J) + std::size_t(j)] = 1;
    }
  }
  return pieces;
}

// Repairs the flagged runs of one segment in place (repair_pops): a captured joint's over its
// whole curve, a flipping joint's piece by piece, its chart's flips taken out and put back:
// `pieces` as find_pops_between_flips returned them. Joints are parallel tasks; each reads and
// writes only its own joint's samples, and reads a curve before it writes any of it.
void repair_segment(RotationSpan rotations, std::span<const std::uint8_t> flags,
                    const std::vector<ChartedPieces>& pieces) {
  const int J = rotations.joints;
  const RotationView view{rotations.data, rotations.frames, J};
  tbb::parallel_for(tbb::blocked_range<int>(0, J, 1), [&](const auto& range) {
    std::vector<Quat> curve, fixed;
    std::vector<std::uint8_t> flipped, piece_flags;
    for (int j = range.begin(); j < range.end(); ++j) {
      const ChartedPieces& charted = pieces[std::size_t(j)];
      for (const Segment& piece : charted.pieces) {
        const std::size_t n = std::size_t(piece.frames());
        piece_flags.resize(n);
        bool any = false;
        for (std::size_t t = 0; t < n; ++t) {
          piece_flags[t] = flags[(std::size_t(piece.begin) + t) * std::size_t(J) + std::size_t(j)];
          any = any || piece_flags[t];
        }
        if (!any) continue;
        load_piece(view, j, charted.chart, piece, curve, flipped);
        fixed.resize(n);
        repair_pops(curve, piece_flags, fixed);
        for (std::size_t t = 0; t < n; ++t)
          if (piece_flags[t]) {
            const int frame = piece.begin + int(t);
            store_quat(put_back(charted.chart, fixed[t], flipped[t], load_quat(view.at(frame, j))),
                       rotations.at(frame, j));
          }
      }
    }
  });
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
  const int F = rotations.frames, J = rotations.joints;
  const bool high_rate = frame_time > 0 && 1.0 / frame_time >= kPopsRepairMinFps;
  const RotationView view{rotations.data, F, J};
  // Joint by joint in parallel tasks, like the pop stage below (each writes its own entry).
  // The step angles the classification measures are kept for the impossible-step test below.
  c.joints.resize(std::size_t(J));
  const std::size_t steps = std::size_t(std::max(F - 1, 0));
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

  // Constant and rounding-only joints are tested too (a pop on a still joint is the easiest to
  // tell); a flipping joint is all pops to the test over its whole curve: where the stage
  // repairs, it is tested between its flips instead (it has no skeleton neighbours to ask: it is
  // garbage).
  const std::vector<std::uint8_t> flipping = flipping_joints(c.joints);
  // Below kPopsRepairMinFps the per-joint test alone flags fast limbs; with the skeleton known,
  // its neighbours rule out most of them (kernels/pop_skeleton.hpp), and the detour test finds
  // the pops fast motion hides from the fit (kernels/pop_detour.hpp).
  const bool skeleton_test = !high_rate && std::size_t(J) == parents.size();
  const StepAngles angles{step_angles, F, J};
  // The classification's median steps are the split's noise floors' medians (the same angles).
  c.segments = split_segments(F, find_impossible_steps(angles, frame_time, MotionSplitParams{},
                                                       flipping, median_steps(c.joints)));
  // The captured joints' flags of every segment ([F][J] of the clip), first: below
  // kPopsRepairMinFps auto repairs only a clip whose flags are many.
  std::vector<std::uint8_t> flags(std::size_t(F) * std::size_t(J), 0);
  const PopRepairParams params = pop_params_at(frame_time);
  const PopScreen screen(params);  // once per clip: each joint's task would make its own
  const auto segment_rotations = [&](const Segment& seg) {
    return RotationSpan{rotations.data + std::size_t(seg.begin) * std::size_t(J) * 4, seg.frames(),
                        J};
  };
  std::vector<double> median_detours(high_rate ? 0 : std::size_t(J));
  const auto segment_test = [&](const Segment& seg, std::vector<std::uint8_t>& clip_flags) {
    const RotationSpan part = segment_rotations(seg);
    SegmentPopTest test;
    test.rotations = {part.data, part.frames, J};
    test.frame_time = frame_time;
    test.params = params;
    test.screen = &screen;
    test.parents = parents;
    test.flipping = flipping;
    test.garbage = c.garbage;
    test.steps = &angles;
    test.step_offset = seg.begin;
    // Below kPopsRepairMinFps, where the skeleton test judges every flag (measured there only:
    // docs/pops.md, "Strong detours").
    if (!high_rate) {
      test.strong_detour = kPopStrongDetour;
      test.median_detours = median_detours;
    }
    test.flags = segment_slice(clip_flags, seg, J);
    return test;
  };
  for (const Segment& seg : c.segments) {
    const SegmentPopTest test = segment_test(seg, flags);
    test.find();
    if (skeleton_test) {
      test.detour();
      test.skeleton();
    }
  }
  // A hinge joint's pops (kernels/pop_hinge.hpp), over the whole clip: at any frame rate, and on
  // a frame that is a segment of its own.
  std::vector<Hinge> hinges(static_cast<std::size_t>(J));
  PopHingeJob hinge_test;
  hinge_test.rotations = view;
  hinge_test.skip = flipping;
  hinge_test.flags = flags;
  hinge_test.hinges = hinges;
  run_joints_in_parallel(hinge_test);
  // A clip with pops (kManyPopsFlagged, filter_settings.hpp). Below kPopsRepairMinFps auto
  // repairs it from kAutoRepairMinFps up (the low-rate test needs the skeleton). At
  // kPopsRepairMinFps and above, the detour test adds the pops that a fast joint's fit error hid,
  // each of its flags kept only where the skeleton test, with every flagged neighbour counting
  // (pop_group 0), finds no neighbour moving with it: a capture's own jitter moves a foot and its
  // toe together. A clip without pops keeps the per-joint test alone (docs/pops.md,
  // "Many pops").
  const double samples = double(F) * double(J);
  const bool many_pops =
      samples > 0 &&
      double(std::count(flags.begin(), flags.end(), std::uint8_t{1})) >= kManyPopsFlagged * samples;
  if (high_rate && many_pops && std::size_t(J) == parents.size()) {
    // Only the new flags ask the skeleton (with pop_group 0 a sample's verdict reads no other
    // flag, so the per-joint test's flags need not be there).
    std::vector<std::uint8_t> detours(flags.size(), 0);
    for (const Segment& seg : c.segments) {
      const SegmentPopTest test = segment_test(seg, detours);
      test.new_detours(segment_slice(flags, seg, J));
      test.skeleton(0);
    }
    for (std::size_t i = 0; i < flags.size(); ++i) flags[i] |= detours[i];
  }
  c.repaired =
      mode == PopsMode::repair ||
      (mode == PopsMode::automatic &&
       (high_rate || (skeleton_test && many_pops && 1.0 / frame_time >= kAutoRepairMinFps)));
  if (c.repaired)
    for (const Segment& seg : c.segments) {
      const RotationSpan part = segment_rotations(seg);
      const std::span<std::uint8_t> part_flags = segment_slice(flags, seg, J);
      repair_segment(
          part, part_flags,
          find_pops_between_flips({part.data, part.frames, J}, flipping, params, part_flags));
    }
  // A flagged sample of a hinge that the segment's repair could not reach (a segment of one
  // frame) is put back on the hinge's curve.
  if (c.repaired)
    for (std::size_t i = 0; i < flags.size(); ++i) {
      const Hinge& hinge = hinges[i % std::size_t(J)];
      if (!flags[i] || !hinge.found) continue;
      float* const sample = rotations.data + i * 4;
      const Quat q = load_quat(sample);
      if (hinge_distance(hinge, q) > hinge_test.tolerance)
        store_quat(project_onto_hinge(hinge, q), sample);
    }
  for (std::size_t i = 0; i < flags.size(); ++i)
    if (flags[i]) {
      ++c.pops[i % std::size_t(J)];
      c.pop_samples.push_back(std::int32_t(i / std::size_t(J)));
      c.pop_samples.push_back(std::int32_t(i % std::size_t(J)));
    }
  if (c.repaired && c.pop_count() > 0) {
    // The repair wrote only flagged samples: the other joints' classes and step angles are
    // those of the same samples (the same bits); the changed joints are classified again, and
    // the segments found again from the angles (as motion_segments would, on the rotations).
    c.repaired_joints = c.joints;
    tbb::parallel_for(tbb::blocked_range<int>(0, J, 1), [&](const auto& range) {
      for (int j = range.begin(); j < range.end(); ++j)
        if (c.pops[std::size_t(j)] > 0)
          c.repaired_joints[std::size_t(j)] = classify_joint(
              view, j, std::span<double>(step_angles).subspan(std::size_t(j) * steps, steps));
    });
    c.repaired_segments =
        split_segments(F, find_impossible_steps(angles, frame_time, MotionSplitParams{},
                                                flipping_joints(c.repaired_joints),
                                                median_steps(c.repaired_joints)));
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
