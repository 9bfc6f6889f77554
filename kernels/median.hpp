#pragma once
// The median of a sample, as the spec's noise estimate takes it: of an even count, the mean of
// the two middle values.
#include <algorithm>
#include <cstddef>
#include <vector>

namespace mocap {

// Reorders `values` (non-empty).
inline double median(std::vector<double>& values) {
  const std::size_t n = values.size(), mid = n / 2;
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(mid), values.end());
  const double upper = values[mid];
  if (n % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + std::ptrdiff_t(mid));
  return 0.5 * (lower + upper);
}

}  // namespace mocap
