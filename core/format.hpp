#pragma once
// printf-style formatting into a std::string: the one formatting helper of the layers below the
// engine (core/, kernels/ and io/ stay free of fmt; the engine and the program use fmt). Declared
// as printf-like, so -Wformat checks every pattern against its arguments at compile time.
#include <string>

namespace mocap {

[[gnu::format(printf, 1, 2)]] std::string format(const char* pattern, ...);

}  // namespace mocap
