#pragma once
// `auto`'s last step on the filtered clip (kernels/hinge_projection.hpp): the joints that the
// filter's input shows to turn about one axis, up to its noise, are put back on their hinge's
// curve, segment by segment; only where the noise estimate is at most kAutoNoisePerIteration,
// where auto's bof runs one pass and leaves most of the noise: above, the filter's own passes
// take most of it out, and at 0.12 rad the projection took hips whose abduction is of the
// noise's size for hinges (joint position error 21.66 -> 23.18 mm at 120 fps,
// docs/automatic-parameters.md, "Hinges under noise"). One function for `clean`
// (engine/run/job.cpp) and eval (engine/eval/eval_run.cpp), so that eval scores what `clean`
// writes.
#include <cstdint>
#include <span>

#include "core/clip.hpp"
#include "core/status.hpp"
#include "core/tensor.hpp"
#include "engine/clip/filter_settings.hpp"
#include "kernels/motion_split.hpp"

namespace mocap::engine {

// `segments` empty: the whole clip. `sigmas`: one noise estimate per segment, or one for all.
// `skip` (empty, or one per joint): joints left as they are (the kept garbage joints).
Status project_hinges_in_segments(RotationView input, RotationSpan output,
                                  std::span<const Segment> segments, std::span<const double> sigmas,
                                  std::span<const std::uint8_t> skip);

// What `clean` and the Python module run after the filter: with `requested.method` automatic and
// a clip the resolution did not leave unchanged, the hinges of `input` (the filter's input) put
// back on their curves in `output`, with the clip's noise estimate, the kept joints left alone.
Status project_hinges_after_auto(const FilterSettings& requested, const ResolvedSettings& resolved,
                                 const Clip& input, Clip& output);

}  // namespace mocap::engine
