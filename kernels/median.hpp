#pragma once
// The median of a sample, as the spec's noise estimate takes it: of an even count, the mean of
// the two middle values.
#include <cstddef>
#include <vector>

namespace mocap {

// Reorders `values` (non-empty, no NaN). An exact order statistic whatever the algorithm, so
// the fast path returns the reference's value bit for bit (tests/kernels/median_test.cpp).
double median(std::vector<double>& values);

// The plain version: std::nth_element over the whole sample.
double median_reference(std::vector<double>& values);

}  // namespace mocap
