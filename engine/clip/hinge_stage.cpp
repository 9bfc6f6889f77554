#include "engine/clip/hinge_stage.hpp"

#include <fmt/format.h>

#include "kernels/hinge_projection.hpp"

namespace mocap::engine {

Status project_hinges_in_segments(RotationView input, RotationSpan output,
                                  std::span<const Segment> segments, std::span<const double> sigmas,
                                  std::span<const std::uint8_t> skip) {
  const Segment whole{0, input.frames};
  if (segments.empty()) segments = {&whole, 1};
  if (sigmas.size() != 1 && sigmas.size() != segments.size())
    return Status::error("hinge projection: one noise estimate per segment, or one for all");
  const std::size_t J = std::size_t(input.joints);
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const Segment& seg = segments[s];
    HingeProjectionJob job;
    job.input = {input.data + std::size_t(seg.begin) * J * 4, seg.frames(), input.joints};
    job.output = {output.data + std::size_t(seg.begin) * J * 4, seg.frames(), output.joints};
    job.skip = skip;
    job.noise_sigma = sigmas.size() == 1 ? sigmas[0] : sigmas[s];
    // Only where auto's bof runs one pass (header): above, the filter takes out most of the
    // noise itself, and a joint's secondary motion of the noise's size would pass for noise.
    if (job.noise_sigma > kAutoNoisePerIteration) continue;
    if (Status st = job.run(); !st)
      return Status::error(fmt::format("frames {}-{}: {}", seg.begin, seg.end, st.message()));
  }
  return {};
}

Status project_hinges_after_auto(const FilterSettings& requested, const ResolvedSettings& resolved,
                                 const Clip& input, Clip& output) {
  if (requested.method != Method::automatic || resolved.unchanged || input.frames == 0) return {};
  const double sigma = resolved.noise_sigma;
  return project_hinges_in_segments(input.rotation_view(), output.rotation_span(),
                                    resolved.segments, {&sigma, 1}, resolved.kept_joints);
}

}  // namespace mocap::engine
