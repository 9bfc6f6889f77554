#pragma once
// A flipping joint's flips as one rotation (kernels/joint_quality.hpp: steps within 0.5 rad of
// pi, an uncaptured joint whose Euler channels wrap). When a solver wraps the same channel each
// time, every flip is the same half-turn D, on one side:
//   q[t+1] = D q[t]  (left)   or   q[t+1] = q[t] D  (right),
// and every other flip turns back by D^-1, up to the motion of that one step: on the shared clips
// each of CMU 06_14's LThumb flips is D q with D within 0.06-0.2 rad of one half-turn about the
// parent's y axis (at 30 and 120 fps). Such a flip carries no information, so it can be taken out:
// on the frames after an odd number of flips, q' = D^-1 q (left) or q D^-1 (right) leaves one
// continuous curve, which the pop tests and the filters read across the flips as they read a
// captured joint's (piece by piece they saw pieces of one or two frames with no neighbours, and a
// pop on one of them was out of reach). D q' or q' D puts the flips back where the capture has
// them. The chart is taken only where the flips agree: D is the mean of the form (left or right)
// whose flips lie nearer their mean in sum (each flip's step with the step before it taken out,
// which stands in for the motion the flip's step also holds), and a flip is taken out only when it
// lies within kFlipChartTolerance of D (a flip the solver made otherwise stays a cut between
// pieces).
#include <cstdint>
#include <span>

#include "core/quaternion.hpp"

namespace mocap {

// How far (rad, geodesic) a flip may lie from the chart's D and still be taken out: above one
// step of real motion at 30 fps (the LThumb's flips lie within 0.06-0.2 rad of D), far below the
// flips' own pi.
inline constexpr double kFlipChartTolerance = 0.35;

struct FlipChart {
  Quat flip{1, 0, 0, 0};  // D, a unit quaternion
  bool left = true;       // the flip multiplies on the left (D q), else on the right (q D)
  bool found = false;     // false: no flips, or none within the tolerance of D

  // The rotation that takes q[t] to q[t+1] in the chart's form: q[t+1] q[t]^-1 or q[t]^-1 q[t+1].
  Quat step(Quat from, Quat to) const;
  // Whether the step from -> to is a flip the chart takes out: a step of at least kFlipStep
  // within the tolerance of D, or of D^-1 when `from` is itself flipped (the flip back).
  bool takes_out(Quat from, Quat to, bool flipped) const;
  Quat unflip(Quat q) const;  // D^-1 q or q D^-1
  Quat reflip(Quat q) const;  // D q or q D
};

// The chart of `curve`'s flips (steps of at least kFlipStep): found when at least half of them
// lie within kFlipChartTolerance of D.
FlipChart find_flip_chart(std::span<const Quat> curve);

// `curve` with the chart's flips taken out, in place: after each step the chart takes out, the
// samples are unflipped until the next; `flipped` (one per sample) says which. The result is
// made hemisphere-continuous (each sample on its predecessor's side), which changes no rotation.
void take_out_flips(const FlipChart& chart, std::span<Quat> curve, std::span<std::uint8_t> flipped);

}  // namespace mocap
