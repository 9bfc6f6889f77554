// The `mocap_clean` Python module: the engine's filters, pop stage, noise estimate and models,
// metrics, forward kinematics and BVH reader/writer on numpy arrays. Every filter runs the
// per-clip path of `mocap-clean clean` (engine/run/job.cpp: value checks, sign continuity,
// conditioning, resolve_for_clip, plan_shards, run_shard), with its parameters parsed by the
// CLI's own option definitions (app/filter_options.cpp): same names, defaults, checks and
// messages, and the same bits.
#include <fmt/core.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "app/commands.hpp"
#include "app/filter_options.hpp"
#include "core/clip.hpp"
#include "core/quaternion.hpp"
#include "core/version.hpp"
#include "engine/clip/clip_checks.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "engine/clip/filter_settings.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/clip/hinge_stage.hpp"
#include "engine/clip/motion_check.hpp"
#include "engine/clip/motion_guard.hpp"
#include "engine/run/pipeline.hpp"
#include "engine/run/process_memory.hpp"
#include "io/bvh_reader.hpp"
#include "io/bvh_writer.hpp"
#include "kernels/forward_kinematics.hpp"
#include "kernels/joint_quality.hpp"
#include "kernels/metrics.hpp"
#include "kernels/noise_estimate.hpp"
#include "kernels/noise_model.hpp"
#include "kernels/position_metrics.hpp"
#include "python/arrays.hpp"

namespace mocap::python {
namespace {

using engine::FilterOptions;
using engine::FilterSettings;
using Options = std::vector<std::pair<std::string, std::string>>;

std::string number(double x) {
  return fmt::format("{}", x);  // shortest text that reads back to the same double
}

// The settings `mocap-clean clean --method=<method> --<name>=<value>...` would run, parsed and
// checked by the CLI's own option definitions; a bad value raises ValueError with the CLI's
// message ("--sigma-t: must be a number >= 0, got '-1'").
FilterSettings parse_settings(const std::string& method, const Options& options) {
  CLI::App app{"mocap_clean"};
  FilterOptions filter;
  filter.add_to(app, method);
  engine::RunOptions run;
  engine::add_run_options(app, run);
  std::vector<std::string> args;
  for (const auto& [name, value] : options)
    args.push_back(value.empty() ? "--" + name : "--" + name + "=" + value);
  std::reverse(args.begin(), args.end());  // CLI11 takes a vector of arguments last first
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    throw py::value_error(e.what());
  }
  FilterSettings settings = filter.settings();
  if (const Status s = settings.validate(); !s.ok()) throw py::value_error(s.message());
  return settings;
}

// A skeleton for bare arrays: J joints named by index, so that messages read "joint '3'", joint 0
// the root and the others its children (no legs: feet are not locked); every joint carries
// rotation channels, and position channels when translations are given (the
// engine filters the translations of joints with position channels).
std::shared_ptr<const Skeleton> array_skeleton(int joints, bool translated) {
  auto s = std::make_shared<Skeleton>();
  for (int j = 0; j < joints; ++j) {
    s->joint_names.push_back(std::to_string(j));
    // One root (the library and BVH checks refuse a second), the others its children.
    s->parents.push_back(j == 0 ? -1 : 0);
    s->offsets.push_back({});
    std::vector<Channel> channels;
    if (translated) channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
    for (Channel c : {Channel::Zrotation, Channel::Xrotation, Channel::Yrotation})
      channels.push_back(c);
    s->channels.push_back(channels);
    s->end_sites.push_back(std::nullopt);
  }
  return s;
}

void check_frame_time(double frame_time) {
  if (!(frame_time > 0) || !std::isfinite(frame_time))
    throw py::value_error("frame_time must be a finite number > 0 (seconds), got " +
                          number(frame_time));
}

// What the caller passed: a Motion, or bare arrays (then the answer is arrays too).
struct ClipInput {
  Clip clip;  // the engine's private copy: the clean path changes signs and repairs pops
  bool motion = false, translations = false, scalar_first = true, float64 = false;
};

ClipInput clip_input(py::handle data, py::handle translations, std::optional<double> frame_time,
                     bool scalar_first) {
  ClipInput in;
  in.scalar_first = scalar_first;
  if (py::isinstance<Clip>(data)) {
    if (!translations.is_none())
      throw py::value_error("translations come from the Motion; pass them only with arrays");
    if (frame_time)
      throw py::value_error("frame_time comes from the Motion; pass it only with arrays");
    in.motion = true;
    in.clip = data.cast<const Clip&>();
    return in;
  }
  int frames = 0, joints = 0;
  in.float64 = py::isinstance<py::array>(data) &&
               py::reinterpret_borrow<py::array>(data).dtype().is(py::dtype::of<double>());
  copy_into(data, 4, scalar_first, "rotations", in.clip.rotations, frames, joints);
  in.clip.frames = frames;
  in.translations = !translations.is_none();
  if (in.translations) {
    int f = 0, j = 0;
    copy_into(translations, 3, true, "translations", in.clip.translations, f, j);
    if (f != frames || j != joints)
      throw py::value_error(fmt::format(
          "translations must have the shape of rotations, (F, J, 3) = ({}, {}, 3), got ({}, {}, 3)",
          frames, joints, f, j));
  } else {
    in.clip.translations.assign(std::size_t(frames) * std::size_t(joints) * 3, 0.0f);
  }
  in.clip.frame_time = frame_time.value_or(1.0 / 120.0);
  check_frame_time(in.clip.frame_time);
  in.clip.skeleton = array_skeleton(joints, in.translations);
  return in;
}

struct Outcome {
  Clip output;
  engine::ResolvedSettings resolved;
  engine::ClipConditioning conditioning;
  std::optional<engine::Kept> kept;  // with the guard: what the clip kept
};

// The split and process stages of engine/run/job.cpp's run_job for one clip, with the shards run in
// parallel on `threads` workers (0: all cores). Called without the GIL.
Outcome run_clip(const FilterSettings& settings, Clip input, int threads) {
  Outcome out;
  const std::string prefix = input.source.empty() ? "" : input.source + ": ";
  if (std::string why = engine::check_clip_values(input); !why.empty())
    throw py::value_error(prefix + why);
  make_hemisphere_continuous(input.rotation_span());
  const bool guard = settings.guard_motion && settings.method != engine::Method::none;
  Clip raw;
  if (guard) raw = motion_copy(input);
  out.conditioning = engine::condition_clip(settings, input);
  out.resolved =
      engine::resolve_for_clip(settings, input, out.conditioning.garbage, out.conditioning.facts());
  engine::MotionMeasure before;
  if (guard) before = engine::measure_motion(raw, nullptr, out.resolved.segments);
  // As run_job: contacts on the conditioned input, locked after the filter (unchanged clips too).
  const bool lock = settings.lock_feet && settings.method != engine::Method::none;
  engine::ClipFeet feet;
  if (lock) feet = engine::detect_feet(input);
  auto finish = [&] {
    if (!guard && !lock) return;
    engine::MotionGuardJob g;
    g.input = guard ? &input : nullptr;
    g.raw = guard ? &raw : nullptr;
    g.before = guard ? &before : nullptr;
    g.guard = guard;
    g.segments = &out.resolved.segments;
    g.feet = lock ? &feet : nullptr;
    g.output = &out.output;
    if (const Status s = g.run(); !s.ok())
      throw py::value_error(prefix + (guard ? "" : "foot lock: ") + s.message());
    if (guard) out.kept = g.kept;
  };
  if (out.resolved.unchanged) {
    out.output = input;
    finish();
    return out;
  }
  out.output = input;
  const std::vector<engine::Shard> shards =
      engine::plan_shards(out.resolved.settings, input.frames, input.joints());
  std::vector<Status> status(shards.size());
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(std::size_t(0), shards.size(), [&](std::size_t i) {
      status[i] = engine::run_shard(out.resolved, input, out.output, shards[i]);
    });
  });
  for (const Status& s : status)
    if (!s.ok()) throw py::value_error(prefix + s.message());
  if (const Status s = engine::project_hinges_after_auto(settings, out.resolved, input, out.output);
      !s.ok())
    throw py::value_error(prefix + "hinges: " + s.message());
  finish();
  return out;
}

py::object json_to_python(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

// What the engine did to the clip: the method it ran (auto: the one it chose) and its resolved
// parameters, the estimated noise, pops and garbage joints.
py::dict describe(const Outcome& o) {
  const Clip& clip = o.output;
  py::dict info;
  info["method"] = std::string(engine::to_string(o.resolved.settings.method));
  info["parameters"] = json_to_python(o.resolved.settings.to_json());
  info["noise_sigma"] =
      o.resolved.noise_sigma >= 0 ? py::object(py::float_(o.resolved.noise_sigma)) : py::none();
  info["unchanged"] = o.resolved.unchanged;
  py::dict pops, garbage;
  for (std::size_t j = 0; j < o.conditioning.pops.size(); ++j)
    if (o.conditioning.pops[j] > 0)
      pops[py::str(clip.skeleton->joint_names[j])] = o.conditioning.pops[j];
  for (std::size_t j = 0; j < o.conditioning.garbage.size(); ++j)
    if (o.conditioning.garbage[j])
      garbage[py::str(clip.skeleton->joint_names[j])] =
          std::string(to_string(o.conditioning.joints[j].joint_class));
  info["pops"] = pops;
  info["pops_repaired"] = o.conditioning.repaired;
  info["garbage_joints"] = garbage;
  py::list segments;
  for (const Segment& s : o.resolved.segments) segments.append(py::make_tuple(s.begin, s.end));
  info["segments"] = segments;
  info["kept"] = o.kept ? py::object(py::str(std::string(engine::to_string(*o.kept)))) : py::none();
  return info;
}

// The options every filter shares, under the CLI's names (--translations is `translation_mode`
// here, since `translations` is the array).
struct Common {
  py::object translations;
  std::optional<double> frame_time;
  bool scalar_first;
  std::string boundary;
  std::optional<std::string> pops;
  std::string garbage_joints;
  std::optional<bool> split_impossible;  // None: the CLI's default (on with auto)
  std::string translation_mode;
  std::optional<std::string> feet, guard;  // None: the CLI's defaults (on with auto)
  int shard_joints, shard_frames, threads;
  bool return_info;
};

py::object run_filter(const std::string& method, py::handle data, Options options, const Common& c,
                      bool always_info = false) {
  options.emplace_back("boundary", c.boundary);
  if (c.pops) options.emplace_back("pops", *c.pops);
  options.emplace_back("garbage-joints", c.garbage_joints);
  if (c.split_impossible)
    options.emplace_back(*c.split_impossible ? "split-impossible" : "no-split-impossible", "");
  options.emplace_back("translations", c.translation_mode);
  if (c.feet) options.emplace_back("feet", *c.feet);
  if (c.guard) options.emplace_back("guard", *c.guard);
  options.emplace_back("shard-joints", std::to_string(c.shard_joints));
  options.emplace_back("shard-frames", std::to_string(c.shard_frames));
  options.emplace_back("threads", std::to_string(c.threads));
  const FilterSettings settings = parse_settings(method, options);
  ClipInput in = clip_input(data, c.translations, c.frame_time, c.scalar_first);
  Outcome outcome;
  {
    py::gil_scoped_release release;
    FilterSettings run = settings;
    if (!in.motion) {  // bare arrays have no legs, nor positions to measure
      run.lock_feet = false;
      run.guard_motion = false;
    }
    outcome = run_clip(run, std::move(in.clip), c.threads);
  }
  // Before the output is handed over (describe reads its skeleton).
  py::object info = always_info || c.return_info ? py::object(describe(outcome)) : py::none();
  py::object result;
  if (in.motion) {
    result = py::cast(std::make_shared<Clip>(std::move(outcome.output)));
  } else {
    const int F = outcome.output.frames, J = outcome.output.joints();
    py::array rotations =
        adopt(std::move(outcome.output.rotations), F, J, 4, in.scalar_first, in.float64);
    if (in.translations)
      result = py::make_tuple(
          rotations, adopt(std::move(outcome.output.translations), F, J, 3, true, in.float64));
    else
      result = rotations;
  }
  if (!info.is_none()) return py::make_tuple(result, info);
  return result;
}

// A writable float32 C-contiguous array the kernels can change in place, or a ValueError.
py::array_t<float> writable_float32(py::handle object) {
  if (!py::isinstance<py::array>(object)) throw py::type_error("inplace=True needs a numpy array");
  py::array a = py::reinterpret_borrow<py::array>(object);
  check_shape(a, 4, "rotations");
  if (!a.dtype().is(py::dtype::of<float>()) || !(a.flags() & py::array::c_style) || !a.writeable())
    throw py::value_error("inplace=True needs a writable C-contiguous float32 array");
  return py::reinterpret_borrow<py::array_t<float>>(a);
}

// Runs `fn(RotationSpan)` (without the GIL) on `rotations` in place (inplace: the caller's own
// float32 array, reordered to scalar-first and back around it if need be) or on a copy returned
// in the caller's order and precision.
template <class Fn>
py::array on_rotations(py::handle rotations, bool scalar_first, bool inplace, Fn&& fn) {
  if (inplace) {
    py::array_t<float> a = writable_float32(rotations);
    float* data = a.mutable_data();
    const int F = int(a.shape(0)), J = int(a.shape(1));
    std::string why;
    {
      py::gil_scoped_release release;
      const std::size_t n = std::size_t(F) * std::size_t(J);
      if (!scalar_first) to_scalar_first(data, n);
      why = check_rotation_values({data, F, J});
      if (why.empty()) fn(RotationSpan{data, F, J});
      if (!scalar_first) to_scalar_last(data, n);
    }
    if (!why.empty()) throw py::value_error(why);
    return a;
  }
  std::vector<float> values;
  int F = 0, J = 0;
  copy_into(rotations, 4, scalar_first, "rotations", values, F, J);
  const bool float64 =
      py::isinstance<py::array>(rotations) &&
      py::reinterpret_borrow<py::array>(rotations).dtype().is(py::dtype::of<double>());
  std::string why;
  {
    py::gil_scoped_release release;
    why = check_rotation_values({values.data(), F, J});
    if (why.empty()) fn(RotationSpan{values.data(), F, J});
  }
  if (!why.empty()) throw py::value_error(why);
  return adopt(std::move(values), F, J, 4, scalar_first, float64);
}

std::shared_ptr<Clip> make_motion(std::shared_ptr<Skeleton> skeleton, py::handle rotations,
                                  py::handle translations, double frame_time, bool scalar_first,
                                  const std::string& source) {
  auto clip = std::make_shared<Clip>();
  int F = 0, J = 0;
  copy_into(rotations, 4, scalar_first, "rotations", clip->rotations, F, J);
  if (J != skeleton->joint_count())
    throw py::value_error(
        fmt::format("rotations have {} joints, the skeleton {}", J, skeleton->joint_count()));
  clip->frames = F;
  if (translations.is_none()) {
    // The library contract: joints without position channels hold their offset.
    for (int t = 0; t < F; ++t)
      for (int j = 0; j < J; ++j) {
        const Vec3& o = skeleton->offsets[std::size_t(j)];
        for (double v : {o.x, o.y, o.z}) clip->translations.push_back(float(v));
      }
  } else {
    int f = 0, j = 0;
    copy_into(translations, 3, true, "translations", clip->translations, f, j);
    if (f != F || j != J)
      throw py::value_error(
          fmt::format("translations must have shape ({}, {}, 3), got ({}, {}, 3)", F, J, f, j));
  }
  check_frame_time(frame_time);
  clip->frame_time = frame_time;
  clip->source = source;
  clip->skeleton = std::move(skeleton);
  return clip;
}

py::array tensor_view(py::object self, std::vector<float>& values, int frames, int joints,
                      int channels) {
  static float empty = 0;  // numpy wants a pointer even for zero elements
  return py::array_t<float>({py::ssize_t(frames), py::ssize_t(joints), py::ssize_t(channels)},
                            values.empty() ? &empty : values.data(), self);
}

void assign_tensor(Clip& clip, std::vector<float>& target, py::handle value, int channels,
                   const char* what) {
  std::vector<float> values;
  int F = 0, J = 0;
  copy_into(value, channels, true, what, values, F, J);
  if (F != clip.frames || J != clip.joints())
    throw py::value_error(
        fmt::format("{} must keep the Motion's shape ({}, {}, {}), got ({}, {}, {})", what,
                    clip.frames, clip.joints(), channels, F, J, channels));
  // Copy into the existing buffer: arrays handed out earlier stay views of the Motion.
  std::copy(values.begin(), values.end(), target.begin());
}

#define MOCAP_COMMON_PARAMS                                                              \
  py::object translations, std::optional<double> frame_time, bool scalar_first,          \
      const std::string &boundary, std::optional<std::string> pops,                      \
      const std::string &garbage_joints, std::optional<bool> split_impossible,           \
      const std::string &translation_mode, std::optional<std::string> feet,              \
      std::optional<std::string> guard, int shard_joints, int shard_frames, int threads, \
      bool return_info
#define MOCAP_COMMON_VALUES                                                                   \
  Common {                                                                                    \
    translations, frame_time, scalar_first, boundary, pops, garbage_joints, split_impossible, \
        translation_mode, feet, guard, shard_joints, shard_frames, threads, return_info       \
  }
#define MOCAP_COMMON_ARGS                                                                 \
  py::arg("translations") = py::none(), py::arg("frame_time") = py::none(),               \
  py::arg("scalar_first") = true, py::arg("boundary") = d.word("boundary"),               \
  py::arg("pops") = py::none(), py::arg("garbage_joints") = d.garbage_joints,             \
  py::arg("split_impossible") = py::none(), py::arg("translation_mode") = d.translations, \
  py::arg("feet") = py::none(), py::arg("guard") = py::none(),                            \
  py::arg("shard_joints") = d.shard_joints, py::arg("shard_frames") = d.shard_frames,     \
  py::arg("threads") = run.threads, py::arg("return_info") = false

constexpr const char* kCommonDoc = R"(

data: a Motion (returns a new Motion), or rotations as an array (F, J, 4) of float32 or
    float64 (returns arrays of the same dtype; with ``translations`` a tuple
    (rotations, translations)).
translations: with an array ``data``, the (F, J, 3) translations, filtered as the position
    channels of every joint; None: rotations only.
frame_time: with an array ``data``, seconds per frame (default 1/120).
scalar_first: True: quaternions (w, x, y, z), the engine's order; False: (x, y, z, w), scipy's.
boundary: mirror | hold | extrapolate (--boundary).
pops: None (the CLI's default: off for a named method, auto for auto), auto | repair | detect |
    off (--pops).
garbage_joints: keep | filter (--garbage-joints).
split_impossible: filter the segments between impossible steps separately (--split-impossible,
    --no-split-impossible); None: the CLI's default (on with auto, off with a named method).
translation_mode: filter | keep (--translations).
feet: None (the CLI's default: lock with auto, off with a named method), lock | off (--feet):
    pin planted feet by two-bone IK after the filter. A Motion only (bare arrays have no legs).
guard: None (the CLI's default: on with auto), on | off (--guard): fall back where cleaning
    raised the joint positions' jitter or foot skating. A Motion only.
shard_joints, shard_frames: task sizes (--shard-joints, --shard-frames); no effect on the bits.
threads: worker threads, 0 = all cores (--threads); no effect on the bits.
return_info: also return a dict of what was done (method, parameters, noise_sigma, pops,
    garbage_joints, segments, unchanged, kept: what the guard kept, None without it):
    (result, info).

The GIL is released while the engine runs. Errors raise ValueError with the CLI's message.)";

std::string doc(const char* head) {
  return std::string(head) + kCommonDoc;
}

}  // namespace
}  // namespace mocap::python

using namespace mocap;
using namespace mocap::python;

PYBIND11_MODULE(mocap_clean, m) {
  // As mocap-clean does: freed blocks kept in the heap for the next call. With glibc's defaults
  // each call's clip tensors and working blocks (a few MB) are page-faulted and zero-filled
  // afresh: measured 13x slower for a 4,000-frame `gaussian` (README "Python"). A process-wide
  // setting; MOCAP_CLEAN_HOST_ALLOCATOR=1 in the environment leaves the host's as it is.
  if (const char* keep = std::getenv("MOCAP_CLEAN_HOST_ALLOCATOR");
      keep == nullptr || std::string_view(keep) != "1")
    mocap::engine::keep_freed_memory_for_reuse();
  m.doc() =
      "mocap-clean's engine on numpy arrays: the filters of ../shared/spec/filters.md (bof, nlpm, "
      "gaussian, butterworth, moving_mean, kalman, auto), the pop stage, garbage-joint "
      "classification, the noise estimate and models, metrics, forward kinematics and BVH I/O. "
      "Results are bit-identical to `mocap-clean clean` with the same parameters.";
  m.attr("__version__") = std::string(mocap::kVersion);

  py::class_<Skeleton, std::shared_ptr<Skeleton>>(
      m, "Skeleton", "A BVH hierarchy: joints in file order (parents before children).")
      .def(py::init([](std::vector<std::string> names, std::vector<int> parents,
                       py::array_t<double, py::array::c_style | py::array::forcecast> offsets,
                       std::vector<std::string> channels,
                       std::optional<std::vector<std::optional<std::array<double, 3>>>> end_sites) {
             auto s = std::make_shared<Skeleton>();
             const std::size_t J = names.size();
             if (offsets.ndim() != 2 || offsets.shape(1) != 3 || std::size_t(offsets.shape(0)) != J)
               throw py::value_error(fmt::format("offsets must have shape ({}, 3)", J));
             s->joint_names = std::move(names);
             s->parents = std::move(parents);
             for (std::size_t j = 0; j < J; ++j)
               s->offsets.push_back({offsets.at(j, 0), offsets.at(j, 1), offsets.at(j, 2)});
             for (const std::string& list : channels) {
               std::vector<Channel> parsed;
               std::size_t at = 0;
               while (at < list.size()) {
                 std::size_t end = list.find(' ', at);
                 if (end == std::string::npos) end = list.size();
                 if (end > at) {
                   const auto c = parse_channel(std::string_view(list).substr(at, end - at));
                   if (!c) throw py::value_error("unknown channel '" + list.substr(at, end - at) + "'");
                   parsed.push_back(*c);
                 }
                 at = end + 1;
               }
               s->channels.push_back(parsed);
             }
             if (end_sites) {
               for (const auto& e : *end_sites)
                 s->end_sites.push_back(e ? std::optional<Vec3>(Vec3{(*e)[0], (*e)[1], (*e)[2]})
                                          : std::nullopt);
             } else {
               s->end_sites.assign(J, std::nullopt);
             }
             if (std::string why = check_structure(*s); !why.empty()) throw py::value_error(why);
             return s;
           }),
           py::arg("joint_names"), py::arg("parents"), py::arg("offsets"), py::arg("channels"),
           py::arg("end_sites") = py::none(),
           "Skeleton(joint_names, parents, offsets, channels, end_sites=None): parents[j] = -1 for "
           "a root, offsets (J, 3), channels per joint as BVH lists ('Zrotation Xrotation "
           "Yrotation'), end_sites per joint None or an (x, y, z) offset.")
      .def_property_readonly(
          "joint_names", [](const Skeleton& s) { return s.joint_names; }, "Joint names, in file order.")
      .def_property_readonly(
          "parents", [](const Skeleton& s) { return s.parents; }, "Parent index per joint (-1: root).")
      .def_property_readonly(
          "offsets",
          [](const Skeleton& s) {
            py::array_t<double> a({py::ssize_t(s.offsets.size()), py::ssize_t(3)});
            for (std::size_t j = 0; j < s.offsets.size(); ++j) {
              a.mutable_at(j, 0) = s.offsets[j].x;
              a.mutable_at(j, 1) = s.offsets[j].y;
              a.mutable_at(j, 2) = s.offsets[j].z;
            }
            return a;
          },
          "OFFSET of each joint, (J, 3) float64 (a copy).")
      .def_property_readonly(
          "channels",
          [](const Skeleton& s) {
            std::vector<std::string> lists;
            for (int j = 0; j < s.joint_count(); ++j) lists.push_back(s.channel_list(j));
            return lists;
          },
          "BVH channel list of each joint, e.g. 'Zrotation Xrotation Yrotation'.")
      .def_property_readonly(
          "end_sites",
          [](const Skeleton& s) {
            py::list out;
            for (const auto& e : s.end_sites)
              out.append(e ? py::object(py::make_tuple(e->x, e->y, e->z)) : py::none());
            return out;
          },
          "Per joint: the offset of its End Site, or None.")
      .def_property_readonly(
          "translated_joints",
          [](const Skeleton& s) {
            std::vector<bool> out;
            for (int j = 0; j < s.joint_count(); ++j) out.push_back(s.has_translation(j));
            return out;
          },
          "Per joint: True when it carries position channels.")
      .def("__len__", &Skeleton::joint_count, "Number of joints.")
      .def("__repr__", [](const Skeleton& s) {
        return fmt::format("<mocap_clean.Skeleton: {} joints>", s.joint_count());
      });

  py::class_<Clip, std::shared_ptr<Clip>>(
      m, "Motion",
      "A clip: skeleton, rotations (F, J, 4) float32 wxyz, translations (F, J, 3) float32 (joints "
      "without position channels hold their offset), frame_time in seconds.")
      .def(py::init(&make_motion), py::arg("skeleton"), py::arg("rotations"),
           py::arg("translations") = py::none(), py::arg("frame_time") = 1.0 / 120.0,
           py::arg("scalar_first") = true, py::arg("source") = "",
           "Motion(skeleton, rotations, translations=None, frame_time=1/120, scalar_first=True, "
           "source=''): copies the arrays into float32 (wxyz). translations None: every joint "
           "holds its offset.")
      .def_property(
          "rotations",
          [](py::object self) {
            auto& c = self.cast<Clip&>();
            return tensor_view(self, c.rotations, c.frames, c.joints(), 4);
          },
          [](Clip& c, py::handle v) { assign_tensor(c, c.rotations, v, 4, "rotations"); },
          "Local joint rotations, (F, J, 4) float32 (w, x, y, z): a writable view of the Motion's "
          "own memory (no copy). Assigning copies values into it (the shape must stay).")
      .def_property(
          "translations",
          [](py::object self) {
            auto& c = self.cast<Clip&>();
            return tensor_view(self, c.translations, c.frames, c.joints(), 3);
          },
          [](Clip& c, py::handle v) { assign_tensor(c, c.translations, v, 3, "translations"); },
          "Local joint translations, (F, J, 3) float32: a writable view (no copy).")
      .def(
          "quaternions",
          [](const Clip& c, bool scalar_first) {
            std::vector<float> values = c.rotations;
            return adopt(std::move(values), c.frames, c.joints(), 4, scalar_first);
          },
          py::arg("scalar_first") = true,
          "A copy of the rotations, (w, x, y, z) or with scalar_first=False (x, y, z, w) for "
          "scipy.spatial.transform.Rotation.from_quat.")
      .def_property_readonly(
          "skeleton", [](const Clip& c) { return std::const_pointer_cast<Skeleton>(c.skeleton); },
          "The Skeleton (shared, read-only).")
      .def_property(
          "frame_time", [](const Clip& c) { return c.frame_time; },
          [](Clip& c, double t) {
            check_frame_time(t);
            c.frame_time = t;
          },
          "Seconds per frame.")
      .def_readwrite("source", &Clip::source, "Where the clip came from (names it in errors).")
      .def_property_readonly(
          "frames", [](const Clip& c) { return c.frames; }, "Number of frames F.")
      .def_property_readonly("joints", &Clip::joints, "Number of joints J.")
      .def(
          "copy", [](const Clip& c) { return std::make_shared<Clip>(c); },
          "A deep copy of the tensors (the skeleton is shared).")
      .def("__repr__", [](const Clip& c) {
        return fmt::format("<mocap_clean.Motion '{}': {} frames, {} joints, {:g} fps>", c.source,
                           c.frames, c.joints(), 1.0 / c.frame_time);
      });

  m.def(
      "read_bvh",
      [](const std::filesystem::path& path) {
        io::BvhReadResult r;
        {
          py::gil_scoped_release release;
          r = io::read_bvh(path, /*keep_source_angles=*/true);
        }
        if (r.error) {
          if (r.error->line == 0) throw std::runtime_error(r.error->what());
          throw py::value_error(r.error->what());
        }
        return std::make_shared<Clip>(std::move(*r.clip));
      },
      py::arg("path"),
      "Reads a BVH file into a Motion (Euler channels to unit quaternions, sign-continuous), as "
      "`mocap-clean import` does, keeping the file's own channel values so that write_bvh and "
      "format_bvh pick the Euler branch nearest them, as `mocap-clean clean` does. A malformed "
      "file raises ValueError 'path:line: message'; a file that cannot be read raises "
      "RuntimeError.");
  m.def(
      "parse_bvh",
      [](const std::string& text, const std::string& name) {
        io::BvhReadResult r = io::parse_bvh(text, name, /*keep_source_angles=*/true);
        if (r.error) throw py::value_error(r.error->what());
        return std::make_shared<Clip>(std::move(*r.clip));
      },
      py::arg("text"), py::arg("name") = "<string>",
      "Parses BVH text into a Motion (see read_bvh).");
  m.def(
      "format_bvh",
      [](const Clip& clip) {
        if (std::string why = io::check_clip_for_bvh(clip); !why.empty())
          throw py::value_error(why);
        return io::format_bvh(clip);
      },
      py::arg("motion"), "The BVH text of a Motion, exactly as `mocap-clean export` writes it.");
  m.def(
      "write_bvh",
      [](const Clip& clip, const std::filesystem::path& path) {
        if (std::string why = io::check_clip_for_bvh(clip); !why.empty())
          throw py::value_error(path.string() + ": " + why);
        std::string error;
        bool ok = false;
        {
          py::gil_scoped_release release;
          ok = io::write_bvh(clip, path, &error);
        }
        if (!ok) throw std::runtime_error(error);
      },
      py::arg("motion"), py::arg("path"),
      "Writes a Motion as BVH (each joint's own rotation order; written to path.tmp, then "
      "renamed), as `mocap-clean export` does. Raises ValueError for a Motion BVH cannot hold, "
      "RuntimeError when the file cannot be written.");

  const FilterOptions d;
  const engine::RunOptions run;

  m.def(
      "bof",
      [](py::object data, double sigma_t, double sigma_g, int window, int iterations,
         const std::string& kernel, double sigma_p, MOCAP_COMMON_PARAMS) {
        return run_filter("bof", data,
                          {{"sigma-t", number(sigma_t)},
                           {"sigma-g", number(sigma_g)},
                           {"window", std::to_string(window)},
                           {"iterations", std::to_string(iterations)},
                           {"kernel", kernel},
                           {"sigma-p", number(sigma_p)}},
                          MOCAP_COMMON_VALUES);
      },
      py::arg("data"), py::kw_only(), py::arg("sigma_t") = d.number("sigma-t"),
      py::arg("sigma_g") = d.number("sigma-g"), py::arg("window") = d.integer("window"),
      py::arg("iterations") = d.integer("iterations"), py::arg("kernel") = d.word("kernel"),
      py::arg("sigma_p") = d.number("sigma-p"), MOCAP_COMMON_ARGS,
      doc("Bilateral orientation filter (Courty 2008), `--method bof`.\n\n"
          "sigma_t: temporal width in frames, 0 = automatic from the noise (--sigma-t).\n"
          "sigma_g: range width in rad, full rotation angle, 0 = automatic (--sigma-g).\n"
          "window: half-width k in frames, 0 = ceil(3 sigma_t) (--window).\n"
          "iterations: passes of the filter on its own output (--iterations).\n"
          "kernel: gaussian | paper (--kernel).\n"
          "sigma_p: range width for translations, 0 = none (--sigma-p).")
          .c_str());

  m.def(
      "nlpm",
      [](py::object data, int search_radius, int patch_radius, double h, const std::string& space,
         py::object nlpm_range, MOCAP_COMMON_PARAMS) {
        std::string range = py::isinstance<py::str>(nlpm_range) ? nlpm_range.cast<std::string>()
                                                                : number(nlpm_range.cast<double>());
        return run_filter("nlpm", data,
                          {{"search-radius", std::to_string(search_radius)},
                           {"patch-radius", std::to_string(patch_radius)},
                           {"h", number(h)},
                           {"space", space},
                           {"nlpm-range", range}},
                          MOCAP_COMMON_VALUES);
      },
      py::arg("data"), py::kw_only(), py::arg("search_radius") = d.integer("search-radius"),
      py::arg("patch_radius") = d.integer("patch-radius"), py::arg("h") = d.number("h"),
      py::arg("space") = d.word("space"), py::arg("nlpm_range") = d.word("nlpm-range"),
      MOCAP_COMMON_ARGS,
      doc("Non-local pose means (Dean & Lewis 2017), `--method nlpm`.\n\n"
          "search_radius: K, 2K+1 poses searched (--search-radius).\n"
          "patch_radius: P, 2P+1 poses compared (--patch-radius).\n"
          "h: strength in rad, 0 = automatic from the estimated noise (--h).\n"
          "space: tangent | log (--space).\n"
          "nlpm_range: 'off', 'auto' or a width in rad (--nlpm-range).")
          .c_str());

  m.def(
      "gaussian",
      [](py::object data, double sigma_t, int window, MOCAP_COMMON_PARAMS) {
        return run_filter("gaussian", data,
                          {{"sigma-t", number(sigma_t)}, {"window", std::to_string(window)}},
                          MOCAP_COMMON_VALUES);
      },
      py::arg("data"), py::kw_only(), py::arg("sigma_t") = d.number("sigma-t"),
      py::arg("window") = d.integer("window"), MOCAP_COMMON_ARGS,
      doc("Gaussian linear filter (Lee-Shin construction), `--method gaussian`.\n\n"
          "sigma_t: width in frames (--sigma-t).\n"
          "window: half-width k, 0 = ceil(3 sigma_t) (--window).")
          .c_str());

  m.def(
      "butterworth",
      [](py::object data, int order, double cutoff, MOCAP_COMMON_PARAMS) {
        return run_filter("butterworth", data,
                          {{"order", std::to_string(order)}, {"cutoff", number(cutoff)}},
                          MOCAP_COMMON_VALUES);
      },
      py::arg("data"), py::kw_only(), py::arg("order") = d.integer("order"),
      py::arg("cutoff") = d.number("cutoff"), MOCAP_COMMON_ARGS,
      doc("Butterworth low-pass (Lee-Shin construction), `--method butterworth`.\n\n"
          "order: filter order n, 1..8 (--order).\n"
          "cutoff: single-pass -3 dB cut-off in Hz (--cutoff).")
          .c_str());

  m.def(
      "moving_mean",
      [](py::object data, int passes, MOCAP_COMMON_PARAMS) {
        return run_filter("moving-mean", data, {{"passes", std::to_string(passes)}},
                          MOCAP_COMMON_VALUES);
      },
      py::arg("data"), py::kw_only(), py::arg("passes") = d.integer("passes"), MOCAP_COMMON_ARGS,
      doc("Moving mean (Blender's Smooth Keys mask), `--method moving-mean`.\n\n"
          "passes: passes of the mask (--passes).")
          .c_str());

  m.def(
      "kalman",
      [](py::object data, double kalman_lambda, MOCAP_COMMON_PARAMS) {
        return run_filter("kalman", data, {{"kalman-lambda", number(kalman_lambda)}},
                          MOCAP_COMMON_VALUES);
      },
      py::arg("data"), py::kw_only(), py::arg("kalman_lambda") = d.number("kalman-lambda"),
      MOCAP_COMMON_ARGS,
      doc("Constant-velocity RTS smoother (Lee-Shin), `--method kalman`.\n\n"
          "kalman_lambda: process over measurement noise q/r, 0 = automatic (--kalman-lambda).")
          .c_str());

  m.def(
      "auto",
      [](py::object data, MOCAP_COMMON_PARAMS) {
        return run_filter("auto", data, {}, MOCAP_COMMON_VALUES, true);
      },
      py::arg("data"), py::kw_only(), MOCAP_COMMON_ARGS,
      doc("`--method auto`: the method and its parameters chosen per clip from its estimated "
          "noise (engine/clip/filter_settings.hpp, choose_automatic), with the pop stage on (pops "
          "None = auto). Always returns (result, info); info['method'] and info['parameters'] "
          "say what it chose.")
          .c_str());

  m.def(
      "filter",
      [](py::object data, const std::string& method, py::dict options, MOCAP_COMMON_PARAMS) {
        Options parsed;
        for (auto [key, value] : options) {
          std::string name = py::str(key);
          std::replace(name.begin(), name.end(), '_', '-');
          parsed.emplace_back(name, py::isinstance<py::float_>(value)
                                        ? number(value.cast<double>())
                                        : std::string(py::str(value)));
        }
        std::string m_name = method;
        std::replace(m_name.begin(), m_name.end(), '_', '-');
        return run_filter(m_name, data, parsed, MOCAP_COMMON_VALUES);
      },
      py::arg("data"), py::arg("method"), py::arg("options") = py::dict(), py::kw_only(),
      MOCAP_COMMON_ARGS,
      doc("Any method by name ('bof', 'nlpm', 'gaussian', 'butterworth', 'moving_mean', "
          "'kalman', 'auto', 'none') with a dict of the method's options under their CLI names "
          "('sigma_t' or 'sigma-t'), e.g. filter(m, 'bof', {'sigma_t': 2}).")
          .c_str());

  m.def(
      "repair_pops",
      [](py::object rotations, double frame_time, const std::string& mode, bool scalar_first,
         bool inplace) {
        const FilterSettings s = parse_settings("none", {{"pops", mode}});
        check_frame_time(frame_time);
        engine::ClipConditioning c;
        py::array out = on_rotations(rotations, scalar_first, inplace, [&](RotationSpan span) {
          make_hemisphere_continuous(span);
          c = engine::condition_rotations(s.pops, span, frame_time);
        });
        py::dict info;
        info["pops"] = c.pops;
        info["garbage"] = c.garbage;
        info["repaired"] = c.repaired;
        return py::make_tuple(out, info);
      },
      py::arg("rotations"), py::kw_only(), py::arg("frame_time") = 1.0 / 120.0,
      py::arg("mode") = "repair", py::arg("scalar_first") = true, py::arg("inplace") = false,
      "The engine's pop stage (engine/clip/clip_conditioning.hpp, condition_rotations): makes each "
      "joint's curve sign-continuous, classifies the joints and finds (mode 'detect') or repairs "
      "('repair'; 'auto': repair at 60 fps and more; below, without the skeleton this function "
      "does not take, only count, where clean repairs a clip with many pops from 20 fps) the pops "
      "of all but the flipping joints.\n"
      "Returns (rotations, info) with info['pops'] per joint, info['garbage'] per joint (1 = "
      "garbage) and info['repaired']. inplace=True changes the caller's writable C-contiguous "
      "float32 array itself (no copy) and returns it; otherwise a copy is changed.");

  m.def(
      "classify_joints",
      [](py::object rotations, bool scalar_first) {
        Borrowed b = borrow(rotations, 4, scalar_first, "rotations");
        std::vector<JointQuality> q;
        std::string why;
        {
          py::gil_scoped_release release;
          why = check_rotation_values(rotation_view(b));
          if (why.empty()) q = classify_joints(rotation_view(b));
        }
        if (!why.empty()) throw py::value_error(why);
        py::list out;
        for (const JointQuality& j : q) {
          py::dict entry;
          entry["class"] = std::string(to_string(j.joint_class));
          entry["garbage"] = is_garbage(j.joint_class);
          entry["median_step"] = j.median_step;
          entry["max_step"] = j.max_step;
          entry["near_pi_steps"] = j.near_pi_steps;
          entry["near_pi_fraction"] = j.near_pi_fraction;
          out.append(entry);
        }
        return out;
      },
      py::arg("rotations"), py::kw_only(), py::arg("scalar_first") = true,
      "Garbage-joint classification (kernels/joint_quality.hpp): per joint a dict with 'class' "
      "(moving, constant, rounding, flipping), 'garbage', 'median_step', 'max_step' (rad), "
      "'near_pi_steps', 'near_pi_fraction'. Reads a float32 C-contiguous wxyz array in place; NaN "
      "or non-unit quaternions raise ValueError.");

  m.def(
      "estimate_noise",
      [](py::object rotations, std::optional<std::vector<std::uint8_t>> skip_joints,
         bool scalar_first) {
        Borrowed b = borrow(rotations, 4, scalar_first, "rotations");
        std::vector<std::uint8_t> skip = skip_joints.value_or(std::vector<std::uint8_t>{});
        if (!skip.empty() && int(skip.size()) != b.joints)
          throw py::value_error(fmt::format(
              "skip_joints must have one entry per joint ({}), got {}", b.joints, skip.size()));
        NoiseEstimate e;
        std::string why;
        {
          py::gil_scoped_release release;
          why = check_rotation_values(rotation_view(b));
          if (why.empty()) e = estimate_noise(rotation_view(b), skip);
        }
        if (!why.empty()) throw py::value_error(why);
        return py::make_tuple(e.sigma, e.moving_joints);
      },
      py::arg("rotations"), py::kw_only(), py::arg("skip_joints") = py::none(),
      py::arg("scalar_first") = true,
      "The spec's noise level estimate (kernels/noise_estimate.hpp): (sigma_hat in rad per "
      "tangent component, number of moving joints). skip_joints: one flag per joint to leave "
      "out (e.g. the garbage joints). Reads a float32 C-contiguous wxyz array in place; NaN or "
      "non-unit quaternions raise ValueError.");

  const engine::NoiseCommand noise;
  m.def(
      "add_gaussian_noise",
      [](py::object rotations, double sigma, std::uint64_t seed, bool scalar_first, bool inplace) {
        const GaussianNoise model{sigma, seed};
        if (const Status s = model.validate(); !s.ok()) throw py::value_error(s.message());
        return on_rotations(rotations, scalar_first, inplace,
                            [&](RotationSpan span) { add_noise(model, span); });
      },
      py::arg("rotations"), py::kw_only(), py::arg("sigma") = noise.sigma,
      py::arg("seed") = std::uint64_t(noise.seed), py::arg("scalar_first") = true,
      py::arg("inplace") = false,
      "The spec's gaussian noise model, q := q Exp(n), n ~ N(0, sigma^2 I_3), seeded "
      "(kernels/noise_model.hpp). `seed` is the kernel's seed; `mocap-clean noise` derives one "
      "per clip from --seed and the clip's path. Returns the noisy rotations (a copy unless "
      "inplace=True).");
  m.def(
      "add_impulse_noise",
      [](py::object rotations, double rate, double min_angle, double max_angle, std::uint64_t seed,
         bool scalar_first, bool inplace) {
        const ImpulseNoise model{rate, min_angle, max_angle, seed};
        if (const Status s = model.validate(); !s.ok()) throw py::value_error(s.message());
        int popped = 0;
        py::array out = on_rotations(rotations, scalar_first, inplace,
                                     [&](RotationSpan span) { popped = add_noise(model, span); });
        return py::make_tuple(out, popped);
      },
      py::arg("rotations"), py::kw_only(), py::arg("rate") = noise.rate,
      py::arg("min_angle") = noise.min_angle, py::arg("max_angle") = noise.max_angle,
      py::arg("seed") = std::uint64_t(noise.seed), py::arg("scalar_first") = true,
      py::arg("inplace") = false,
      "The spec's impulse noise model (pops): with probability `rate` per joint-sample, q := q "
      "Exp(n), |n| uniform in [min_angle, max_angle] rad. Returns (rotations, popped samples).");

  auto metric = [](const char* name, double (*fn)(RotationView, RotationView)) {
    return [name, fn](py::object result, py::object truth, bool scalar_first) {
      Borrowed a = borrow(result, 4, scalar_first, "result");
      Borrowed b = borrow(truth, 4, scalar_first, "truth");
      if (a.frames != b.frames || a.joints != b.joints)
        throw py::value_error(
            fmt::format("{}: result ({}, {}, 4) and truth ({}, {}, 4) differ in shape", name,
                        a.frames, a.joints, b.frames, b.joints));
      py::gil_scoped_release release;
      return fn(rotation_view(a), rotation_view(b));
    };
  };
  m.def("rmse", metric("rmse", &rmse), py::arg("result"), py::arg("truth"), py::kw_only(),
        py::arg("scalar_first") = true,
        "Geodesic RMSE in rad of result against truth, sqrt(mean d(q, q')^2) over all samples "
        "(spec 'Metrics'). Reads float32 C-contiguous wxyz arrays in place.");
  m.def("psnr", metric("psnr", &psnr), py::arg("result"), py::arg("truth"), py::kw_only(),
        py::arg("scalar_first") = true,
        "PSNR in dB, 10 log10(pi^2 / MSE) (spec 'Metrics'); inf when identical.");
  m.def(
      "angular_speed",
      [](py::object rotations, int joint, double frame_time, bool scalar_first) {
        Borrowed b = borrow(rotations, 4, scalar_first, "rotations");
        if (joint < 0 || joint >= b.joints)
          throw py::value_error(fmt::format("joint must be in [0, {}), got {}", b.joints, joint));
        check_frame_time(frame_time);
        py::array_t<double> out(py::ssize_t(std::max(0, b.frames - 1)));
        std::span<double> span(out.mutable_data(), std::size_t(out.size()));
        py::gil_scoped_release release;
        angular_speed(rotation_view(b), frame_time, joint, span);
        return out;
      },
      py::arg("rotations"), py::arg("joint"), py::kw_only(), py::arg("frame_time") = 1.0 / 120.0,
      py::arg("scalar_first") = true,
      "|Log(q_t^-1 q_t+1)| / frame_time (rad/s) of one joint, F - 1 values.");

  // Position metrics (kernels/position_metrics.hpp) on positions from forward_kinematics.
  auto frame_range = [](int frames, int first, std::optional<int> last) {
    return FrameRange{first, last.value_or(frames)};
  };
  auto two_positions = [](py::object result, py::object truth, const char* name) {
    std::pair<Borrowed, Borrowed> p{borrow(result, 3, true, "result"),
                                    borrow(truth, 3, true, "truth")};
    if (p.first.frames != p.second.frames || p.first.joints != p.second.joints)
      throw py::value_error(
          fmt::format("{}: result ({}, {}, 3) and truth ({}, {}, 3) differ in shape", name,
                      p.first.frames, p.first.joints, p.second.frames, p.second.joints));
    return p;
  };
  m.def(
      "mpjpe",
      [=](py::object result, py::object truth, int first, std::optional<int> last) {
        auto [a, b] = two_positions(result, truth, "mpjpe");
        PositionSums sums;
        py::gil_scoped_release release;
        add_position_error(translation_view(a), translation_view(b),
                           frame_range(a.frames, first, last), sums);
        return sums.mpjpe();
      },
      py::arg("result"), py::arg("truth"), py::kw_only(), py::arg("first") = 0,
      py::arg("last") = py::none(),
      "Mean per-joint position error (spec 'Metrics'): mean over frames [first, last) and points "
      "of |P_r - P_g|, in the file's length unit, of two (F, N, 3) position arrays "
      "(forward_kinematics). NaN without samples.");
  m.def(
      "jitter",
      [=](py::object positions, int first, std::optional<int> last) {
        Borrowed a = borrow(positions, 3, true, "positions");
        PositionSums sums;
        py::gil_scoped_release release;
        add_jitter(translation_view(a), frame_range(a.frames, first, last), sums);
        return sums.jitter();
      },
      py::arg("positions"), py::kw_only(), py::arg("first") = 0, py::arg("last") = py::none(),
      "Jitter (spec 'Metrics'): RMS over frames and points of |P[t+1] - 2 P[t] + P[t-1]| (length "
      "unit per frame^2), second differences centred in [first, last).");
  m.def(
      "acceleration_error",
      [=](py::object result, py::object truth, int first, std::optional<int> last) {
        auto [a, b] = two_positions(result, truth, "acceleration_error");
        PositionSums sums;
        py::gil_scoped_release release;
        add_acceleration_error(translation_view(a), translation_view(b),
                               frame_range(a.frames, first, last), sums);
        return sums.accel_error();
      },
      py::arg("result"), py::arg("truth"), py::kw_only(), py::arg("first") = 0,
      py::arg("last") = py::none(),
      "Acceleration error (spec 'Metrics'): RMS of the difference of the second differences of "
      "result and truth positions (length unit per frame^2) over [first, last).");

  m.def(
      "forward_kinematics",
      [](const Clip& clip, bool end_sites) {
        const Skeleton& s = *clip.skeleton;
        const int F = clip.frames, J = clip.joints();
        const std::vector<std::uint8_t> translated = s.translated_mask();
        std::vector<JointSite> sites;
        if (end_sites)
          for (int j = 0; j < J; ++j)
            if (s.end_sites[std::size_t(j)]) sites.push_back({j, *s.end_sites[std::size_t(j)]});
        std::vector<float> positions(std::size_t(F) * std::size_t(J) * 3);
        std::vector<float> site_positions(std::size_t(F) * sites.size() * 3);
        ForwardKinematicsJob job;
        job.parents = s.parents;
        job.offsets = s.offsets;
        job.rotations = clip.rotation_view();
        job.translations = clip.translation_view();
        job.translated_joints = translated;
        job.sites = sites;
        job.positions = {positions.data(), F, J};
        job.site_positions = {site_positions.data(), F, int(sites.size())};
        Status status;
        {
          py::gil_scoped_release release;
          status = job.run();
        }
        if (!status.ok()) throw py::value_error(status.message());
        py::array p = adopt(std::move(positions), F, J, 3);
        if (!end_sites) return py::object(p);
        return py::object(
            py::make_tuple(p, adopt(std::move(site_positions), F, int(sites.size()), 3)));
      },
      py::arg("motion"), py::kw_only(), py::arg("end_sites") = false,
      "Global joint positions (F, J, 3) float32 of a Motion (BVH semantics: position channels "
      "replace a joint's offset). end_sites=True: (positions, site positions (F, S, 3)) for the "
      "S joints with an End Site, in joint order.");

  m.def(
      "make_continuous",
      [](py::object rotations, bool scalar_first, bool inplace) {
        return on_rotations(rotations, scalar_first, inplace,
                            [](RotationSpan span) { make_hemisphere_continuous(span); });
      },
      py::arg("rotations"), py::kw_only(), py::arg("scalar_first") = true,
      py::arg("inplace") = false,
      "Spec 'Sign continuity': q_t := -q_t where q_t . q_t-1 < 0, joint by joint (the filters "
      "do this to their own copy first).");

  m.def("_input_copies", &input_copies,
        "For tests: how many array inputs were converted into a private float32 copy since "
        "import (a C-contiguous float32 wxyz input is read in place and does not count).");
}
