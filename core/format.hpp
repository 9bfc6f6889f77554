#pragma once
// printf-style formatting into a std::string: the one formatting helper of the layers below the
// engine (core/, kernels/ and io/ stay free of fmt; the engine and the program use fmt).
#include <cstdio>
#include <string>

namespace mocap {

template <class... Args>
std::string format(const char* pattern, Args... args) {
  const int length = std::snprintf(nullptr, 0, pattern, args...);
  if (length <= 0) return {};
  std::string text(std::size_t(length), '\0');
  std::snprintf(text.data(), text.size() + 1, pattern, args...);
  return text;
}

}  // namespace mocap
