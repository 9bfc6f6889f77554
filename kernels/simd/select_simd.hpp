#pragma once
// The gathering pass of the median's select (kernels/median.cpp), with Highway dynamic dispatch:
// comparisons and copies only, so the result is the scalar loop's to the bit, in the same order
// (tests/kernels/median_test.cpp compares the median with nth_element's on every path).
#include <cstddef>

namespace mocap::simd {

// Copies the values of from[0, count) that lie in [low, high] to `to`, in order, and returns how
// many; `below` receives how many are < low. `to` may be `from` itself or lie behind it: it gets
// written in whole vectors up to to[count - 1] at most.
std::size_t gather_bracket(const double* from, std::size_t count, double low, double high,
                           double* to, std::size_t& below);

}  // namespace mocap::simd
