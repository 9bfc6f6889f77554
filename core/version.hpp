#pragma once

namespace mocap {

inline constexpr const char* kVersion = "0.1.0";

}  // namespace mocap
