#pragma once
// printf-style formatting into a std::string for the kernels' error messages (kernels/ stays free
// of dependencies beyond the standard library and Highway).
#include <cstdio>
#include <string>

namespace mocap {

template <class... Args>
std::string format(const char* pattern, Args... args) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, pattern, args...);
  return buffer;
}

}  // namespace mocap
