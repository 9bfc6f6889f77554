#pragma once
// Flipping joints between their flips. A flipping joint (kernels/joint_quality.hpp: an uncaptured
// joint whose Euler channels turn the rotation by about pi every few frames, CMU 06_14's LThumb)
// carries the same noise as its captured neighbours between flips, but a filter run across a
// flip smears the turn of pi over its neighbours. So each piece between two flips is filtered as a
// clip of its own (flip_piece_settings: its noise estimate comes from the other joints), and the
// flips stay where the capture has them: the joint comes out as smooth as its neighbours
// where it is smooth, and no flip is moved, added or removed (docs/pops.md).
// Where the flips are all one rotation (kernels/flip_chart.hpp), a piece runs across them, read
// with them taken out and written with them put back, so that pieces of one or two frames
// between flips have neighbours too.
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "core/status.hpp"
#include "core/tensor.hpp"
#include "engine/clip/filter_settings.hpp"
#include "kernels/flip_chart.hpp"
#include "kernels/motion_io.hpp"
#include "kernels/motion_split.hpp"

namespace mocap::engine {

// The frames [0, frames) of `rotations` between the joint's flips: cut after each step t -> t+1
// whose geodesic angle is at least kFlipStep.
std::vector<Segment> flip_pieces(RotationView rotations, int joint);

// A flipping joint's pieces with its flips' chart (kernels/flip_chart.hpp): cut only at the flips
// the chart does not take out, so that where the solver wrapped the same channel each time the
// joint is one piece, read with its flips taken out (load_piece) and written with them put back
// (put_back). Without a chart, flip_pieces.
struct ChartedPieces {
  std::vector<Segment> pieces;
  FlipChart chart;
};
ChartedPieces charted_flip_pieces(RotationView rotations, int joint);

// `joint`'s samples of `piece`, the chart's flips taken out (take_out_flips); `flipped` per sample.
void load_piece(RotationView rotations, int joint, const FlipChart& chart, Segment piece,
                std::vector<Quat>& curve, std::vector<std::uint8_t>& flipped);
// A sample of such a curve with its flip put back, on the hemisphere of `original`, the sample
// it replaces (without a chart, `q` itself).
Quat put_back(const FlipChart& chart, Quat q, bool flipped, Quat original);

// Pieces shorter than this stay as they came (a filter needs neighbours on both sides).
inline constexpr int kFlipPieceMinFrames = 3;

// The filter a flipping joint's pieces get. A named method: itself, `resolved` (what the clip's
// other joints ran with). --method auto: auto's bof for the clip's noise `sigma_hat`, whichever
// branch the other joints took, and no filter at all (the joint stays as it came) below
// kAutoCleanBelow: a low-pass rings on pieces a few frames long, and a capture with no noise has
// nothing to take out of them; bof's range weight keeps a piece's change within a few sigma_hat
// (docs/pops.md: what the other choices cost 06_14).
std::optional<FilterSettings> flip_piece_settings(const FilterSettings& asked,
                                                  const FilterSettings& resolved, double sigma_hat,
                                                  double frame_time);

// Writes `joint`'s rotations of io's frames [frame_begin, frame_stop()) from `settings`' filter
// run on each piece (charted_flip_pieces of io.rotations, its chart's flips taken out and put
// back) as a clip of its own; its translations and every other joint are left as they are.
// io.rotations is one segment of a clip (the pieces of a clip split at impossible steps lie inside
// its segments).
Status filter_between_flips(const FilterSettings& settings, const MotionIO& io, int joint,
                            std::span<const std::uint8_t> distance_joints);

}  // namespace mocap::engine
