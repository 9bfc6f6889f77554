#include "io/clip_validation.hpp"

#include <cmath>
#include <limits>
#include <span>

#include "core/format.hpp"
#include "io/library_format.hpp"

namespace mocap::io {

namespace {

std::string at(const Clip& clip, int frame, int joint) {
  return "frame " + std::to_string(frame + 1) + ", joint '" +
         clip.skeleton->joint_names[std::size_t(joint)] + "'";
}

// Whether every value is finite and every rotation's norm surely within 1e-3 of 1, the usual
// case, in a branch-free pass in floats that vectorizes; the per-sample loop then only runs to
// name what is wrong. The squared norm is held to a band well inside the limit's, (1 -+
// 0.75e-3)^2, so that float rounding (a few 1e-7) cannot accept a rotation the exact test
// refuses; one outside the band is left to that test. A NaN or an infinity fails the band.
bool surely_valid(std::span<const float> rotations, std::span<const float> translations) {
  constexpr float kLow = 0.9985006f, kHigh = 1.0015006f;
  constexpr float kMax = std::numeric_limits<float>::max();
  int ok = 1;
  const float* q = rotations.data();
  for (std::size_t s = 0, samples = rotations.size() / 4; s < samples; ++s, q += 4) {
    const float norm2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
    ok &= int(norm2 >= kLow) & int(norm2 <= kHigh);
  }
  for (std::size_t i = 0; i < translations.size(); ++i)
    ok &= int(translations[i] >= -kMax) & int(translations[i] <= kMax);
  return ok != 0;
}

}  // namespace

std::string validate_clip(const Clip& clip) {
  if (std::string problem = check_clip(clip); !problem.empty()) return problem;
  const int joints = clip.joints();
  if (std::int64_t(clip.frames) * joints > kMaxClipJointFrames)
    return std::to_string(clip.frames) + " frames x " + std::to_string(joints) +
           " joints exceed the " + std::to_string(kMaxClipJointFrames) +
           " joint-frames one clip may hold";
  if (clip.frames > 0 && clip.skeleton->channel_count() == 0)
    return "the skeleton has no channels, yet the clip has " + std::to_string(clip.frames) +
           " frames (BVH could not hold them)";
  if (surely_valid(clip.rotations, clip.translations)) return {};
  const RotationView rotations = clip.rotation_view();
  const TranslationView translations = clip.translation_view();
  for (int t = 0; t < clip.frames; ++t) {
    for (int j = 0; j < joints; ++j) {
      const float* q = rotations.at(t, j);
      const float* p = translations.at(t, j);
      for (int c = 0; c < 4; ++c)
        if (!std::isfinite(q[c]))
          return std::string(std::isnan(q[c]) ? "NaN" : "infinity") + " in rotations at " +
                 at(clip, t, j);
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(p[c]))
          return std::string(std::isnan(p[c]) ? "NaN" : "infinity") + " in translations at " +
                 at(clip, t, j);
      const double norm = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] +
                                    double(q[2]) * q[2] + double(q[3]) * q[3]);
      if (std::abs(norm - 1.0) > 1e-3) {
        return "rotation at " + at(clip, t, j) + " is not a unit quaternion (norm " +
               format("%.6g", norm) + ")";
      }
    }
  }
  return {};
}

}  // namespace mocap::io
