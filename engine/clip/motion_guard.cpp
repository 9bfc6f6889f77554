#include "engine/clip/motion_guard.hpp"

#include <utility>

namespace mocap::engine {

std::string_view to_string(Kept kept) {
  switch (kept) {
    case Kept::filtered_locked:
      return "filter+lock";
    case Kept::filtered:
      return "filter";
    case Kept::input_locked:
      return "input+lock";
    case Kept::input:
      return "input";
    case Kept::as_read:
      return "as read";
  }
  return "?";
}

bool raises_motion(const MotionMeasure& after, const MotionMeasure& before) {
  return after.jitter > before.jitter || after.skating > before.skating;
}

Status MotionGuardJob::validate() const {
  if (!input || !before || !segments || !output)
    return Status::error("motion guard: input, before, segments and output are required");
  auto same = [&](const Clip& c) {
    return c.skeleton && c.skeleton == output->skeleton && c.frames == output->frames &&
           c.rotations.size() == output->rotations.size() &&
           c.translations.size() == output->translations.size();
  };
  if (!same(*input) || (raw && !same(*raw)))
    return Status::error("motion guard: the input and the output are not the same clip's");
  return {};
}

Status MotionGuardJob::run() {
  if (Status s = validate(); !s) return s;
  const ClipFeet contacts = feet ? *feet : ClipFeet{};
  auto lock = [&](Clip& clip) -> Status {
    *feet = contacts;
    return lock_feet_in_segments(*feet, clip, *segments, lock_scratch);
  };
  auto unlock = [&] {
    if (feet) *feet = contacts;
  };

  Clip filtered;  // the unlocked candidate, in case it is needed
  if (feet && guard) filtered = motion_copy(*output);
  kept = feet ? Kept::filtered_locked : Kept::filtered;
  if (feet)
    if (Status s = lock(*output); !s) return s;
  after = measure_motion(*output, before, *segments);
  if (!guard || !raises_motion(after, *before)) return {};

  if (feet) {
    MotionMeasure m = measure_motion(filtered, before, *segments);
    if (!raises_motion(m, *before)) {
      output->rotations = std::move(filtered.rotations);
      output->translations = std::move(filtered.translations);
      unlock();
      kept = Kept::filtered;
      after = std::move(m);
      return {};
    }
    output->rotations = input->rotations;
    output->translations = input->translations;
    if (Status s = lock(*output); !s) return s;
    m = measure_motion(*output, before, *segments);
    if (!raises_motion(m, *before)) {
      kept = Kept::input_locked;
      after = std::move(m);
      return {};
    }
  }
  output->rotations = input->rotations;
  output->translations = input->translations;
  unlock();
  kept = Kept::input;
  after = measure_motion(*output, before, *segments);
  if (!raw || !raises_motion(after, *before)) return {};
  // The pop stage's repairs themselves raised jitter or skating: the clip as read.
  output->rotations = raw->rotations;
  output->translations = raw->translations;
  kept = Kept::as_read;
  after = measure_motion(*output, before, *segments);
  return {};
}

}  // namespace mocap::engine
