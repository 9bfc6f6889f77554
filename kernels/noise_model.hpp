#pragma once
// The noise models of ../shared/spec/filters.md, "Noise models (for evaluation)":
//   gaussian: q[t][j] := q[t][j] Exp(n),  n ~ N(0, sigma^2 I_3), i.i.d.
//   impulse:  with probability `rate` per joint-sample, q := q Exp(n), |n| uniform in
//             [min_angle, max_angle] rad about a uniformly random axis (pops from occlusion).
// Seeded and deterministic: std::mt19937_64 (fully specified by the standard) with explicit
// uniform and Box-Muller transforms, never std::*_distribution, whose output the standard leaves
// to the library. Samples are drawn frame by frame, joint by joint. Bits can still differ between
// platforms whose libm rounds log/cos/sin differently in the last place: exchange noisy files,
// not seeds, to compare implementations (as the spec says).
#include <cstdint>
#include <span>

#include "core/status.hpp"
#include "core/tensor.hpp"

namespace mocap {

struct GaussianNoise {
  double sigma = 0.03;  // rad, per tangent component
  std::uint64_t seed = 1;
  Status validate() const;  // sigma finite and >= 0
};

// Position noise of the spec's "Noise models": p[t][j] += n, n ~ N(0, sigma^2 I_3), on the joints
// with position channels (translated[j] != 0), sigma in the file's unit.
struct PositionNoise {
  double sigma = 0;  // file units
  std::uint64_t seed = 1;
  Status validate() const;  // sigma finite and >= 0
};
// The seed of a clip's position noise beside rotation noise of `seed` (noise --position-sigma,
// eval's +pos:F): its own stream, so the position draws do not repeat the rotation's.
inline std::uint64_t position_noise_seed(std::uint64_t seed) {
  return seed ^ 0x5bd1e995u;
}

struct ImpulseNoise {
  double rate = 0.01;                       // probability per joint-sample
  double min_angle = 0.3, max_angle = 1.0;  // rad
  std::uint64_t seed = 1;
  Status validate() const;  // rate in [0, 1], 0 <= min_angle <= max_angle <= pi
};

// In place, then the result is made hemisphere-continuous again. Parameters must validate().
void add_noise(const GaussianNoise& noise, RotationSpan rotations);
// Returns the number of popped samples.
int add_noise(const ImpulseNoise& noise, RotationSpan rotations);
void add_noise(const PositionNoise& noise, TranslationSpan translations,
               std::span<const std::uint8_t> translated);

}  // namespace mocap
