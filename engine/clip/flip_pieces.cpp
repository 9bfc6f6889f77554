#include "engine/clip/flip_pieces.hpp"

#include <algorithm>
#include <cstring>

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
  const int first = io.frame_begin, stop = io.frame_stop();
  std::vector<float> scratch;
  for (const Segment& piece : flip_pieces(io.rotations, joint)) {
    const int begin = std::max(piece.begin, first), end = std::min(piece.end, stop);
    if (begin >= end || piece.frames() < kFlipPieceMinFrames) continue;
    const std::size_t row = std::size_t(piece.begin) * std::size_t(J);
    scratch.assign(std::size_t(piece.frames()) * std::size_t(J) * 4, 0.0f);
    MotionIO p;
    p.frame_time = io.frame_time;
    p.rotations = {io.rotations.data + row * 4, piece.frames(), J};
    p.filtered_rotations = {scratch.data(), piece.frames(), J};
    p.joint_begin = joint;
    p.joint_end = joint + 1;
    p.frame_begin = begin - piece.begin;
    p.frame_end = end - piece.begin;
    if (Status s = run_method(settings, p, distance_joints); !s) return s;
    for (int t = begin; t < end; ++t)
      std::memcpy(
          io.filtered_rotations.at(t, joint),
          scratch.data() + (std::size_t(t - piece.begin) * std::size_t(J) + std::size_t(joint)) * 4,
          4 * sizeof(float));
  }
  return {};
}

}  // namespace mocap::engine
