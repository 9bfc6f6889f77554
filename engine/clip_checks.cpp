#include "engine/clip_checks.hpp"

#include <fmt/core.h>

#include <cmath>

namespace mocap::engine {

std::string check_clip_values(const io::Clip& clip) {
  const int J = clip.joints();
  auto joint_name = [&](int j) { return clip.skeleton->joint_names[j]; };
  for (int t = 0; t < clip.frames; ++t) {
    for (int j = 0; j < J; ++j) {
      const float* q = clip.rotation_view().at(t, j);
      const float* p = clip.translation_view().at(t, j);
      for (int c = 0; c < 4; ++c)
        if (!std::isfinite(q[c]))
          return fmt::format("{} in rotations at frame {}, joint '{}'",
                             std::isnan(q[c]) ? "NaN" : "infinity", t, joint_name(j));
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(p[c]))
          return fmt::format("{} in translations at frame {}, joint '{}'",
                             std::isnan(p[c]) ? "NaN" : "infinity", t, joint_name(j));
      const double norm = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] +
                                    double(q[2]) * q[2] + double(q[3]) * q[3]);
      if (std::abs(norm - 1.0) > 1e-3)
        return fmt::format(
            "rotation at frame {}, joint '{}' is not a unit quaternion (norm {:.6g})", t,
            joint_name(j), norm);
    }
  }
  return {};
}

}  // namespace mocap::engine
