#include "engine/run/job.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>

#include <chrono>
#include <numeric>
#include <optional>

#include "engine/clip/clip_checks.hpp"
#include "engine/clip/clip_conditioning.hpp"
#include "engine/clip/foot_stage.hpp"
#include "engine/clip/hinge_stage.hpp"
#include "engine/clip/motion_check.hpp"
#include "engine/clip/motion_guard.hpp"
#include "engine/run/automatic_tally.hpp"
#include "engine/run/pipeline.hpp"
#include "engine/run/progress.hpp"
#include "engine/run/stage_times.hpp"

namespace mocap::engine {
namespace {

// What the stages keep per clip.
struct ClipState {
  ResolvedSettings resolved;
  std::any prepared;  // the sink's form of the finished clip
  ClipConditioning conditioning;
  MotionMeasure before, after;  // what a viewer sees, as read and as written
  ClipFeet feet;                // with lock_feet: found on the input, locked on the output
  ReviewCapture review;         // with --report: the motion before and after, for the page
  ReviewEntry review_entry;     // and the page's entry, built from it in the finish stage
  std::optional<Kept> kept;     // with the guard: what the clip kept
  Clip raw;                     // with the guard: the clip as read, its last resort
  bool fell_back = false;       // with the guard: the clip kept is not the filter's output
};

// What this run does to the clip, kept with it in a library output.
void record_provenance(const ClipState& state, ClipProvenance& p) {
  const ResolvedSettings& r = state.resolved;
  p.method = r.unchanged ? "unchanged" : std::string(to_string(r.settings.method));
  // resolve_for_clip has replaced every automatic value with the clip's own.
  p.parameters_json = r.settings.to_json().dump();
  p.noise_sigma = r.noise_sigma;
  p.pop_stage = !state.conditioning.pops.empty();
  p.pops_repaired = state.conditioning.repaired;
  p.pops = state.conditioning.pop_samples;
}

}  // namespace

RunSummary run_job(const Job& job) {
  const auto start = std::chrono::steady_clock::now();
  RunSummary summary;
  summary.command = job.label;

  std::vector<std::size_t> selection = job.selection;
  if (selection.empty() && job.source->count() > 0) {
    selection.resize(job.source->count());
    std::iota(selection.begin(), selection.end(), std::size_t(0));
  }

  summary.threads =
      int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));

  Progress progress(job.label, selection.size(),
                    job.run.progress && !job.run.json && Progress::stderr_is_terminal());
  const FilterSettings& settings = job.filter;
  ConditioningTally tally;
  tally.mode = settings.pops;
  tally.keep_garbage = settings.keep_garbage_joints;
  AutomaticTally automatic;
  // Jitter and skating before and after: for filters (not the copy of --method none, nor the
  // transforms of `noise`, whose point is to change the motion).
  const bool measure = settings.method != Method::none && !job.transform;
  const bool guard = measure && settings.guard_motion;
  MotionTally motion;
  FeetTally feet;
  feet.lock = settings.lock_feet && settings.method != Method::none;
  // The foot lock's working memory, one per thread, reused across clips (lock_feet).
  tbb::enumerable_thread_specific<FootLockScratch> lock_scratch;
  StageTimes times;
  using Timed = StageTimes::Scope;
  PipelineStages stages;
  stages.count = selection.size();
  stages.read = [&](WorkItem& item) {
    const std::size_t index = selection[item.index];
    item.name = job.source->name(index);
    std::string error;
    const Timed timed(times, StageTimes::read);
    ClipSource::Loaded loaded;
    if (!job.source->load(index, loaded, &error)) return item.fail(error);
    item.context = std::move(loaded);
  };
  stages.split = [&](WorkItem& item) -> std::vector<Shard> {
    {
      const Timed timed(times, StageTimes::parse);
      std::string error;
      std::optional<Clip> clip =
          job.source->decode(selection[item.index],
                             std::move(std::any_cast<ClipSource::Loaded&>(item.context)), &error);
      item.context.reset();
      if (!clip) {
        item.fail(error);
        return {};
      }
      item.input = std::move(*clip);
    }
    {
      const Timed timed(times, StageTimes::check);
      if (std::string why = check_clip_values(item.input); !why.empty()) {
        item.fail(why);
        return {};
      }
      // Filters expect each joint's curve on one hemisphere (spec "Sign continuity"); a library
      // written by another tool may not be. Same rotations, so harmless for `none`.
      make_hemisphere_continuous(item.input.rotation_span());
    }
    // The clip as read, measured once the segments are known (after resolve), and the guard's
    // last resort.
    Clip raw;
    if (measure) raw = motion_copy(item.input);
    ReviewCapture review;
    if (job.review) {
      const Timed timed(times, StageTimes::review);
      review = begin_review(item.input);
    }
    ClipConditioning conditioning;
    {
      const Timed timed(times, StageTimes::condition);
      conditioning = condition_clip(settings, item.input);
    }
    ResolvedSettings resolved;
    {
      const Timed timed(times, StageTimes::resolve);
      resolved = resolve_for_clip(settings, item.input, conditioning.garbage, conditioning.facts());
    }
    MotionMeasure before;
    if (measure) {
      const Timed timed(times, StageTimes::metrics);
      before = measure_motion(raw, nullptr, resolved.segments);
    }
    if (!guard) raw = {};
    ClipState state{std::move(resolved), {}, std::move(conditioning),
                    std::move(before),   {}, {},
                    std::move(review),   {}, {},
                    std::move(raw)};
    if (settings.method != Method::none) record_provenance(state, item.input.provenance);
    // Contacts on the clip as it came (pops repaired): the filter is what makes feet slide.
    if (feet.lock) {
      const Timed timed(times, StageTimes::contacts);
      state.feet = detect_feet(item.input);
      ClipProvenance& p = item.input.provenance;
      p.feet = settings.method != Method::none;
      for (std::size_t leg = 0; leg < state.feet.legs.size(); ++leg)
        for (const ContactInterval& c : state.feet.contacts[leg])
          p.contacts.insert(p.contacts.end(), {state.feet.legs[leg].ankle, c.begin, c.end});
    }
    item.context = std::move(state);
    if (std::any_cast<ClipState&>(item.context).resolved.unchanged) {
      if (guard) {
        item.output = item.input;  // the guard's fallback needs the input
      } else {
        item.output = std::move(item.input);
        item.input = {};
      }
      return {};
    }
    item.output = item.input;  // skeleton, frame time, source; the shards overwrite the tensors
    return plan_shards(std::any_cast<ClipState&>(item.context).resolved.settings, item.input.frames,
                       item.input.joints());
  };
  stages.process = [&](WorkItem& item, const Shard& shard) {
    const auto& state = std::any_cast<const ClipState&>(item.context);
    const Timed timed(times, StageTimes::filter);
    if (const Status s = run_shard(state.resolved, item.input, item.output, shard); !s.ok())
      item.fail(s.message());
  };
  stages.finish = [&](WorkItem& item) {
    {
      // auto's hinges (engine/clip/hinge_stage.hpp), on the filtered clip.
      const auto& state = std::any_cast<const ClipState&>(item.context);
      const Timed timed(times, StageTimes::filter);
      if (const Status s =
              project_hinges_after_auto(settings, state.resolved, item.input, item.output);
          !s.ok())
        return item.fail("hinges: " + s.message());
    }
    // Free the input early, only the output goes on; the guard may fall back to it.
    if (!guard) item.input = {};
    if (guard || feet.lock) {
      // Lock and, with the guard, measure and fall back where the clip came out worse than it
      // went in (engine/clip/motion_guard.hpp). Without the guard its time is the lock's.
      auto& state = std::any_cast<ClipState&>(item.context);
      const Timed timed(times, guard ? StageTimes::guard : StageTimes::lock);
      MotionGuardJob g;
      g.input = guard ? &item.input : nullptr;
      g.raw = guard ? &state.raw : nullptr;
      g.before = guard ? &state.before : nullptr;
      g.guard = guard;
      g.segments = &state.resolved.segments;
      g.feet = feet.lock ? &state.feet : nullptr;
      g.lock_scratch = &lock_scratch.local();
      g.output = &item.output;
      if (const Status s = g.run(); !s.ok())
        return item.fail(guard ? s.message() : "foot lock: " + s.message());
      if (guard) {
        state.after = std::move(g.after);
        state.kept = g.kept;
        state.fell_back = g.fell_back();
        state.raw = {};
      }
      // A library output says per clip what it holds: the parameters ran, but the clip kept
      // something nearer its input.
      if (g.fell_back()) {
        ClipProvenance& p = item.output.provenance;
        nlohmann::json parameters = nlohmann::json::parse(p.parameters_json, nullptr, false);
        if (parameters.is_object()) {
          parameters["kept"] = std::string(to_string(g.kept));
          p.parameters_json = parameters.dump();
        }
      }
    }
    item.input = {};
    if (measure && !guard) {
      auto& state = std::any_cast<ClipState&>(item.context);
      const Timed timed(times, StageTimes::metrics);
      state.after = measure_motion(item.output, &state.before, state.resolved.segments);
    }
    if (job.review) {
      auto& state = std::any_cast<ClipState&>(item.context);
      const Timed timed(times, StageTimes::review);
      finish_review(state.review, item.output, state.conditioning.pop_samples);
    }
    if (job.transform) {
      if (const Status s = job.transform(item.output, selection[item.index]); !s.ok())
        return item.fail(s.message());
    }
    {
      std::string error;
      const Timed timed(times, StageTimes::prepare);
      if (!job.sink->prepare(item.output, std::any_cast<ClipState&>(item.context).prepared, &error))
        return item.fail(error);
    }
    if (job.review) {
      // The page's entry (JSON, base64) here, in parallel; the write stage numbers and writes it.
      auto& state = std::any_cast<ClipState&>(item.context);
      const Timed timed(times, StageTimes::review);
      state.review_entry =
          review_entry({item.name, &item.output, &state.resolved, &state.conditioning, &state.feet,
                        measure ? &state.before : nullptr, measure ? &state.after : nullptr},
                       std::move(state.review));
    }
  };
  stages.write = [&](WorkItem& item) {
    const std::size_t index = selection[item.index];
    if (item.error.empty()) {
      std::string error;
      auto& state = std::any_cast<ClipState&>(item.context);
      const Timed timed(times, StageTimes::write);
      if (!job.sink->write(job.source->clip_path(index), job.source->relative_path(index),
                           state.prepared, &error))
        item.fail(error);
    }
    if (item.error.empty()) {
      summary.add_clip(std::size_t(item.output.frames), std::size_t(item.output.joints()));
      const auto& state = std::any_cast<const ClipState&>(item.context);
      tally.add(item.name, item.output, state.conditioning);
      automatic.add(item.name, state.resolved);
      if (measure) {
        motion.add(item.name, state.before, state.after,
                   state.kept ? std::optional(to_string(*state.kept)) : std::nullopt,
                   state.fell_back);
      }
      if (feet.lock) feet.add(item.name, item.output, state.feet);
      if (job.review) {
        const Timed timed(times, StageTimes::review);
        job.review->add(std::move(std::any_cast<ClipState&>(item.context).review_entry));
      }
    } else {
      summary.failed.push_back({item.name, item.error});
      if (job.review) job.review->add_failure(item.name, item.error);
    }
    progress.advance(std::size_t(item.output.frames), !item.error.empty());
    item.output = {};
    item.context.reset();
  };
  PipelineOptions options;
  options.cancel = job.run.cancel;
  const std::size_t read = run_pipeline(stages, options);
  progress.finish();
  summary.interrupted = read < selection.size();
  if (settings.method != Method::none) {
    tally.write_to(summary.extra);
    feet.write_to(summary.extra);
  }
  automatic.write_to(summary.extra);
  motion.write_to(summary.extra);
  summary.extra["stages"] = times.to_json();
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace mocap::engine
