#include "engine/clip/flip_pieces.hpp"

#include <algorithm>
#include <cstring>
#include <vector>

#include "core/quaternion.hpp"
#include "engine/clip/methods.hpp"
#include "kernels/joint_quality.hpp"

namespace mocap::engine {

std::vector<Segment> flip_pieces(RotationView rotations, int joint) {
  std::vector<Segment> pieces;
  if (rotations.frames <= 0) return pieces;
  int begin = 0;
  for (int t = 0; t + 1 < rotations.frames; ++t)
    if (geodesic(load_quat(rotations.at(t, joint)), load_quat(rotations.at(t + 1, joint))) >=
        kFlipStep) {
      pieces.push_back({begin, t + 1});
      begin = t + 1;
    }
  pieces.push_back({begin, rotations.frames});
  return pieces;
}

ChartedPieces charted_flip_pieces(RotationView rotations, int joint) {
  ChartedPieces c;
  std::vector<Quat> curve(std::size_t(std::max(rotations.frames, 0)));
  for (int t = 0; t < rotations.frames; ++t)
    curve[std::size_t(t)] = load_quat(rotations.at(t, joint));
  c.chart = find_flip_chart(curve);
  if (rotations.frames <= 0) return c;
  // As take_out_flips reads each piece: flipped after an odd number of the flips it takes out;
  // a flip it does not take out (every flip, without a chart: flip_pieces) starts a piece of its
  // own.
  int begin = 0;
  bool odd = false;
  for (std::size_t t = 0; t + 1 < curve.size(); ++t) {
    if (geodesic(curve[t], curve[t + 1]) < kFlipStep) continue;
    if (c.chart.takes_out(curve[t], curve[t + 1], odd)) {
      odd = !odd;
      continue;
    }
    c.pieces.push_back({begin, int(t) + 1});
    begin = int(t) + 1;
    odd = false;
  }
  c.pieces.push_back({begin, rotations.frames});
  return c;
}

void load_piece(RotationView rotations, int joint, const FlipChart& chart, Segment piece,
                std::vector<Quat>& curve, std::vector<std::uint8_t>& flipped) {
  const std::size_t n = std::size_t(piece.frames());
  curve.resize(n);
  flipped.assign(n, 0);
  for (std::size_t t = 0; t < n; ++t)
    curve[t] = load_quat(rotations.at(piece.begin + int(t), joint));
  if (chart.found) take_out_flips(chart, curve, flipped);
}

Quat put_back(const FlipChart& chart, Quat q, bool flipped, Quat original) {
  if (!chart.found) return q;  // load_piece took the samples as they came
  const Quat r = flipped ? chart.reflip(q) : q;
  return dot(r, original) < 0 ? negate(r) : r;
}

std::optional<FilterSettings> flip_piece_settings(const FilterSettings& asked,
                                                  const FilterSettings& resolved, double sigma_hat,
                                                  double frame_time) {
  if (asked.method != Method::automatic) return resolved;
  if (!(sigma_hat >= kAutoCleanBelow)) return std::nullopt;
  return choose_automatic(asked, sigma_hat, /*noisy_positions=*/false, frame_time);
}

Status filter_between_flips(const FilterSettings& settings, const MotionIO& io, int joint,
                            std::span<const std::uint8_t> distance_joints) {
  const int J = io.rotations.joints;
  const std::size_t columns = std::size_t(J) * 4;
  const int first = io.frame_begin, stop = io.frame_stop();
  const ChartedPieces charted = charted_flip_pieces(io.rotations, joint);
  std::vector<float> input, scratch;
  std::vector<Quat> curve;
  std::vector<std::uint8_t> flipped;
  for (const Segment& piece : charted.pieces) {
    const int begin = std::max(piece.begin, first), end = std::min(piece.end, stop);
    if (begin >= end || piece.frames() < kFlipPieceMinFrames) continue;
    const std::size_t frames = std::size_t(piece.frames());
    // The piece's rows as a clip of its own; with a chart, a copy whose joint column has its
    // flips taken out.
    const float* rows = io.rotations.data + std::size_t(piece.begin) * columns;
    load_piece(io.rotations, joint, charted.chart, piece, curve, flipped);
    if (charted.chart.found) {
      input.assign(rows, rows + frames * columns);
      for (std::size_t t = 0; t < frames; ++t)
        store_quat(curve[t], input.data() + t * columns + std::size_t(joint) * 4);
      rows = input.data();
    }
    scratch.assign(frames * columns, 0.0f);
    MotionIO p;
    p.frame_time = io.frame_time;
    p.rotations = {rows, piece.frames(), J};
    p.filtered_rotations = {scratch.data(), piece.frames(), J};
    p.joint_begin = joint;
    p.joint_end = joint + 1;
    p.frame_begin = begin - piece.begin;
    p.frame_end = end - piece.begin;
    if (Status s = run_method(settings, p, distance_joints); !s) return s;
    for (int t = begin; t < end; ++t) {
      const std::size_t k = std::size_t(t - piece.begin);
      const Quat out = load_quat(scratch.data() + k * columns + std::size_t(joint) * 4);
      store_quat(put_back(charted.chart, out, flipped[k], load_quat(io.rotations.at(t, joint))),
                 io.filtered_rotations.at(t, joint));
    }
  }
  return {};
}

}  // namespace mocap::engine
