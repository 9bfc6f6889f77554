#include "engine/clip/motion_guard.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>

namespace mocap::engine {

namespace {

// The columns of the joints the lock may change (kernels/foot_lock.hpp: the legs' hip, knee and
// ankle rotations, their top ancestor's translation; kept here with margin: every joint of a
// leg and every ancestor of its hip, rotations and translations), so that the guard can take
// the lock back without copying the whole clip (the copy was 2 % of a one-thread `filter`).
struct LegColumns {
  std::vector<int> joints;
  std::vector<float> rotations, translations;  // [F][joints][4], [F][joints][3]

  LegColumns(const Clip& clip, std::span<const FootChain> legs) {
    const std::vector<int>& parents = clip.skeleton->parents;
    std::vector<std::uint8_t> mark(parents.size());
    for (const FootChain& leg : legs) {
      for (int j : {leg.hip, leg.knee, leg.ankle, leg.toe})
        if (j >= 0) mark[std::size_t(j)] = 1;
      for (int a = leg.hip; a >= 0; a = parents[std::size_t(a)]) mark[std::size_t(a)] = 1;
    }
    for (std::size_t j = 0; j < mark.size(); ++j)
      if (mark[j]) joints.push_back(int(j));
    const std::size_t J = parents.size(), K = joints.size(), F = std::size_t(clip.frames);
    rotations.resize(F * K * 4);
    translations.resize(F * K * 3);
    for (std::size_t t = 0; t < F; ++t)
      for (std::size_t k = 0; k < K; ++k) {
        const std::size_t from = t * J + std::size_t(joints[k]), to = t * K + k;
        std::copy_n(clip.rotations.begin() + std::ptrdiff_t(from * 4), 4,
                    rotations.begin() + std::ptrdiff_t(to * 4));
        std::copy_n(clip.translations.begin() + std::ptrdiff_t(from * 3), 3,
                    translations.begin() + std::ptrdiff_t(to * 3));
      }
  }

  void restore(Clip& clip) const {
    const std::size_t J = clip.skeleton->parents.size(), K = joints.size(),
                      F = std::size_t(clip.frames);
    for (std::size_t t = 0; t < F; ++t)
      for (std::size_t k = 0; k < K; ++k) {
        const std::size_t to = t * J + std::size_t(joints[k]), from = t * K + k;
        std::copy_n(rotations.begin() + std::ptrdiff_t(from * 4), 4,
                    clip.rotations.begin() + std::ptrdiff_t(to * 4));
        std::copy_n(translations.begin() + std::ptrdiff_t(from * 3), 3,
                    clip.translations.begin() + std::ptrdiff_t(to * 3));
      }
  }
};

}  // namespace

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
  return after.jitter > before.jitter || after.skating > before.skating * (1 + kMeasureRounding);
}

Status MotionGuardJob::validate() const {
  if (!segments || !output) return Status::error("motion guard: segments and output are required");
  if (guard && (!input || !before))
    return Status::error(
        "motion guard: the guard needs the input and the measure of the clip as "
        "read (before)");
  auto same = [&](const Clip& c) {
    return c.skeleton && c.skeleton == output->skeleton && c.frames == output->frames &&
           c.rotations.size() == output->rotations.size() &&
           c.translations.size() == output->translations.size();
  };
  if ((input && !same(*input)) || (raw && !same(*raw)))
    return Status::error("motion guard: the input and the output are not the same clip's");
  return {};
}

Status MotionGuardJob::run() {
  if (Status s = validate(); !s) return s;
  // The contacts as found, to lock another candidate or to take the lock back; only a guard
  // that may fall back needs them.
  const ClipFeet contacts = feet && guard ? *feet : ClipFeet{};
  auto lock = [&](Clip& clip) -> Status {
    *feet = contacts;
    return lock_feet_in_segments(*feet, clip, *segments, lock_scratch);
  };
  auto unlock = [&] {
    if (feet) *feet = contacts;
  };

  // The unlocked candidate's columns, in case it is needed.
  const LegColumns unlocked =
      feet && guard ? LegColumns(*output, feet->legs) : LegColumns(*output, {});
  kept = feet ? Kept::filtered_locked : Kept::filtered;
  if (feet)
    if (Status s = lock_feet_in_segments(*feet, *output, *segments, lock_scratch); !s) return s;
  if (before) after = measure_motion(*output, before, *segments);
  if (!guard) return {};
  // The bar a filtered candidate must clear: the clip as read, or the input when the pop stage
  // repaired samples and that raised nothing. Against the clip as read alone, a pop's jitter
  // hides whatever the filter adds to the motion around it.
  // `repaired`: the input's measure, taken once, where it is not the clip as read.
  std::optional<MotionMeasure> repaired;
  if (raw && (input->rotations != raw->rotations || input->translations != raw->translations))
    repaired = measure_motion(*input, before, *segments);
  const MotionMeasure& bar = repaired && !raises_motion(*repaired, *before) ? *repaired : *before;
  if (!raises_motion(after, bar)) return {};

  if (feet) {
    unlocked.restore(*output);
    MotionMeasure m = measure_motion(*output, before, *segments);
    if (!raises_motion(m, bar)) {
      unlock();
      kept = Kept::filtered;
      after = std::move(m);
      return {};
    }
    output->rotations = input->rotations;
    output->translations = input->translations;
    if (Status s = lock(*output); !s) return s;
    m = measure_motion(*output, before, *segments);
    if (!raises_motion(m, bar)) {
      kept = Kept::input_locked;
      after = std::move(m);
      return {};
    }
  }
  output->rotations = input->rotations;
  output->translations = input->translations;
  unlock();
  kept = Kept::input;
  // Measured already: the repaired input above, and an input the pop stage left as read is the
  // clip `before` measured (the same positions, segments and contacts).
  if (repaired)
    after = std::move(*repaired);
  else
    after = raw ? *before : measure_motion(*output, before, *segments);
  if (!raw || !raises_motion(after, *before)) return {};
  // The pop stage's repairs themselves raised jitter or skating: the clip as read.
  output->rotations = raw->rotations;
  output->translations = raw->translations;
  kept = Kept::as_read;
  after = *before;
  return {};
}

}  // namespace mocap::engine
