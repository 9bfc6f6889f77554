// kernels/median.hpp: the fast select against the plain nth_element, bit for bit, on the samples
// that reach each of its paths (small, one or two rounds, a round's bracket missed) and on ties.
#include "kernels/median.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace mocap {
namespace {

// The median by sorting a copy: the definition.
double sorted_median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void expect_same(const std::vector<double>& values) {
  std::vector<double> fast = values, plain = values;
  const double a = median(fast), b = median_reference(plain);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(a), std::bit_cast<std::uint64_t>(b))
      << "n " << values.size() << ": " << a << " vs " << b;
  EXPECT_EQ(a, sorted_median(values));
  std::sort(fast.begin(), fast.end());
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(fast, sorted) << "a reordering of the sample";
}

TEST(Median, TheFastSelectEqualsTheReferenceOnRandomSamples) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> gauss;
  std::uniform_int_distribution<int> size(1, 5000);
  for (int trial = 0; trial < 400; ++trial) {
    std::vector<double> v(std::size_t(size(rng)));
    for (double& x : v) x = trial % 2 ? std::abs(gauss(rng)) : gauss(rng) * 1e-3;
    if (trial % 5 == 0)  // ties: a few distinct values
      for (double& x : v) x = std::round(x * 4) / 4;
    expect_same(v);
  }
}

TEST(Median, OrdersThatDefeatTheSampleStillGiveTheExactMedian) {
  const std::size_t n = 4000;
  std::vector<double> ascending(n), descending(n), constant(n, 0.125), sawtooth(n), even(n + 1);
  for (std::size_t i = 0; i < n; ++i) {
    ascending[i] = double(i);
    descending[i] = double(n - i);
    sawtooth[i] = double(i % 64);
  }
  for (std::size_t i = 0; i <= n; ++i) even[i] = i < n / 2 ? -1.0 : double(i);
  // The sample's positions all hold one value and the rest another: the bracket is a single
  // value that misses the middle rank.
  std::vector<double> trap(n, 1.0);
  for (std::size_t i = 0; i < 64; ++i) trap[(2 * i + 1) * n / 128] = 0.0;
  std::vector<double> zeros_first(n, 5.0);
  std::fill(zeros_first.begin(), zeros_first.begin() + n / 2, 0.0);
  for (const auto& v : {ascending, descending, constant, sawtooth, even, trap, zeros_first})
    expect_same(v);
  // Orders whose first round brackets well but whose gathered values (kept in order) may defeat
  // the second round's sample: sorted blocks, and a sawtooth under a shuffled-looking ramp.
  for (const std::size_t size : {1600u, 6000u, 6001u, 20000u})
    for (const std::size_t period : {3u, 64u, 97u, 512u}) {
      std::vector<double> blocks(size), ramp(size);
      for (std::size_t i = 0; i < size; ++i) {
        blocks[i] = double((i % period) * (size / period) + i / period);
        ramp[i] = double(i % period) + (i * 7919 % size) * 1e-6;
      }
      expect_same(blocks);
      expect_same(ramp);
    }
}

}  // namespace
}  // namespace mocap
