#include "engine/clip/clip_checks.hpp"

#include "io/clip_validation.hpp"

namespace mocap::engine {

std::string check_clip_values(const Clip& clip) {
  return io::validate_clip(clip);
}

}  // namespace mocap::engine
