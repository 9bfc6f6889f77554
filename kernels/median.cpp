#include "kernels/median.hpp"

#include <algorithm>
#include <array>
#include <memory>

#include "kernels/simd/select_simd.hpp"

namespace mocap {

double median_reference(std::vector<double>& values) {
  const std::size_t n = values.size(), mid = n / 2;
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(mid), values.end());
  const double upper = values[mid];
  if (n % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + std::ptrdiff_t(mid));
  return 0.5 * (lower + upper);
}

namespace {

// One round of Floyd and Rivest's select on from[0, count): a sorted sample brackets rank k (and
// k - 1 when `pair`) between two of its order statistics; one pass counts the values below the
// bracket and gathers those inside it into `to` (simd::gather_bracket). False when the bracket
// misses a wanted rank; else count and k become those of the gathered values.
bool select_round(const double* from, double* to, std::size_t& count, std::size_t& k, bool pair) {
  constexpr std::size_t kSample = 64, kHalfWidth = 10;
  std::array<double, kSample> sample;
  for (std::size_t i = 0; i < kSample; ++i) sample[i] = from[(2 * i + 1) * count / (2 * kSample)];
  std::sort(sample.begin(), sample.end());
  const double low = sample[kSample / 2 - kHalfWidth], high = sample[kSample / 2 + kHalfWidth];
  std::size_t below = 0;
  const std::size_t inside = simd::gather_bracket(from, count, low, high, to, below);
  if (below > (pair ? k - 1 : k) || k >= below + inside) return false;
  count = inside;
  k -= below;
  return true;
}

}  // namespace

// Floyd and Rivest's select (1975): a round (select_round) keeps about a third of the values,
// those between two order statistics of a sample that bracket the middle ranks; a second round
// runs on those when they are still many, and nth_element finishes on what is left. When a
// round's bracket misses a middle rank (improbable, or an adversarial order) nth_element runs on
// that round's input, which holds the wanted ranks, so the value is always exact (speed:
// docs/performance.md, mocap-microbench BM_Median).
double median(std::vector<double>& values) {
  constexpr std::size_t kMinSize = 512;
  const std::size_t n = values.size();
  if (n < kMinSize) return median_reference(values);
  const bool even = n % 2 == 0;  // the ranks n / 2 - 1 and n / 2 are wanted
  std::size_t count = n, k = n / 2;
  const auto buffer = std::make_unique_for_overwrite<double[]>(n);
  double* selected = buffer.get();
  if (!select_round(values.data(), selected, count, k, even)) return median_reference(values);
  // The second round gathers behind the first's values, which stay whole if it misses.
  if (count >= kMinSize && 2 * count <= n) {
    std::size_t count2 = count, k2 = k;
    if (select_round(selected, selected + count, count2, k2, even)) {
      selected += count;
      count = count2;
      k = k2;
    }
  }
  std::nth_element(selected, selected + k, selected + count);
  const double upper = selected[k];
  if (!even) return upper;
  const double lower = *std::max_element(selected, selected + k);  // k >= 1: n / 2 - 1 inside
  return 0.5 * (lower + upper);
}

}  // namespace mocap
