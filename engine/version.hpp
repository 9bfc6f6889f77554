#pragma once

namespace mocap::engine {

inline constexpr const char* kVersion = "0.1.0";

}  // namespace mocap::engine
