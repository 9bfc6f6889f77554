#include "kernels/noise_model.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "core/format.hpp"
#include "core/quaternion.hpp"

namespace mocap {
namespace {

// Uniform in [0, 1) from the top 53 bits: every double of the form k / 2^53.
double uniform(std::mt19937_64& rng) {
  return double(rng() >> 11) * 0x1.0p-53;
}

// Standard normal deviates by Box-Muller, two per pair of uniforms.
class NormalSource {
 public:
  explicit NormalSource(std::uint64_t seed) : rng_(seed) {}
  double next() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - uniform(rng_);  // (0, 1]: log stays finite
    const double u2 = uniform(rng_);
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double phase = 2.0 * kPi * u2;
    spare_ = radius * std::sin(phase);
    has_spare_ = true;
    return radius * std::cos(phase);
  }

 private:
  std::mt19937_64 rng_;
  double spare_ = 0;
  bool has_spare_ = false;
};

// Applies q := q Exp(n) to one stored sample.
void perturb(float* sample, Vec3 n) {
  store_quat(load_quat(sample) * exp(n), sample);
}

}  // namespace

Status GaussianNoise::validate() const {
  if (!(sigma >= 0) || !std::isfinite(sigma))
    return Status::error("gaussian noise sigma must be a finite angle >= 0 rad, got " +
                         format("%g", sigma));
  return {};
}

Status ImpulseNoise::validate() const {
  if (!(rate >= 0 && rate <= 1))
    return Status::error("impulse noise rate must be in [0, 1], got " + format("%g", rate));
  if (!(min_angle >= 0 && min_angle <= max_angle && max_angle <= kPi))
    return Status::error(
        "impulse noise angles must satisfy 0 <= min_angle <= max_angle <= pi, got [" +
        format("%g", min_angle) + ", " + format("%g", max_angle) + "]");
  return {};
}

void add_noise(const GaussianNoise& noise, RotationSpan rotations) {
  NormalSource normal(noise.seed);
  for (int t = 0; t < rotations.frames; ++t)
    for (int j = 0; j < rotations.joints; ++j) {
      const double x = normal.next(), y = normal.next(), z = normal.next();
      perturb(rotations.at(t, j), noise.sigma * Vec3{x, y, z});
    }
  make_hemisphere_continuous(rotations);
}

Status PositionNoise::validate() const {
  if (!std::isfinite(sigma) || sigma < 0)
    return Status::error("position noise sigma must be finite and >= 0");
  return {};
}

void add_noise(const PositionNoise& noise, TranslationSpan translations,
               std::span<const std::uint8_t> translated) {
  NormalSource normal(noise.seed);
  for (int t = 0; t < translations.frames; ++t)
    for (int j = 0; j < translations.joints; ++j) {
      if (std::size_t(j) >= translated.size() || translated[std::size_t(j)] == 0) continue;
      float* p = translations.at(t, j);
      for (int c = 0; c < 3; ++c) p[c] = float(p[c] + noise.sigma * normal.next());
    }
}

int add_noise(const ImpulseNoise& noise, RotationSpan rotations) {
  std::mt19937_64 rng(noise.seed);
  int popped = 0;
  for (int t = 0; t < rotations.frames; ++t)
    for (int j = 0; j < rotations.joints; ++j) {
      if (!(uniform(rng) < noise.rate)) continue;
      const double angle = noise.min_angle + (noise.max_angle - noise.min_angle) * uniform(rng);
      // Uniform axis on the sphere: z uniform in [-1, 1], azimuth uniform (Archimedes).
      const double z = 2.0 * uniform(rng) - 1.0;
      const double azimuth = 2.0 * kPi * uniform(rng);
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      perturb(rotations.at(t, j), angle * Vec3{r * std::cos(azimuth), r * std::sin(azimuth), z});
      ++popped;
    }
  make_hemisphere_continuous(rotations);
  return popped;
}

}  // namespace mocap
