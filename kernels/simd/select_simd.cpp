// gather_bracket's vector path (select_simd.hpp), compiled once per Highway target.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "kernels/simd/select_simd.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <bit>
#include <cstddef>
#include <cstdint>

#include "hwy/highway.h"
#include "kernels/simd/select_simd.hpp"

HWY_BEFORE_NAMESPACE();
namespace mocap::simd::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

#if HWY_TARGET == HWY_AVX2
// AVX2 has no compress instruction, and Highway 1.0's CompressStore rebuilds its lookup table on
// the stack at every call under GCC 12 (measured: 2.7x slower than the scalar loop). So: the
// 32-bit lane permutation that packs the kept doubles of each 4-bit mask to the front, once.
struct CompressTable {
  alignas(32) std::int32_t index[16][8];
  constexpr CompressTable() : index{} {
    for (int mask = 0; mask < 16; ++mask) {
      int next = 0;
      for (int lane = 0; lane < 4; ++lane)
        if (mask & (1 << lane)) {
          index[mask][2 * next] = 2 * lane;
          index[mask][2 * next + 1] = 2 * lane + 1;
          ++next;
        }
      for (int k = 2 * next; k < 8; ++k) index[mask][k] = k;  // the rest: anything in range
    }
  }
};
constexpr CompressTable kCompress{};
#endif

std::size_t GatherBracket(const double* from, std::size_t count, double low, double high,
                          double* to, std::size_t& below) {
  std::size_t under = 0, inside = 0, i = 0;
  // A whole vector is written at to + inside, and inside <= i: within [0, count).
#if HWY_TARGET == HWY_AVX2
  const __m256d vlow = _mm256_set1_pd(low), vhigh = _mm256_set1_pd(high);
  for (; i + 4 <= count; i += 4) {
    const __m256d x = _mm256_loadu_pd(from + i);
    const int less = _mm256_movemask_pd(_mm256_cmp_pd(x, vlow, _CMP_LT_OQ));
    const int kept = _mm256_movemask_pd(
        _mm256_and_pd(_mm256_cmp_pd(x, vlow, _CMP_GE_OQ), _mm256_cmp_pd(x, vhigh, _CMP_LE_OQ)));
    const __m256i index =
        _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompress.index[kept]));
    _mm256_storeu_pd(to + inside,
                     _mm256_castps_pd(_mm256_permutevar8x32_ps(_mm256_castpd_ps(x), index)));
    under += std::size_t(std::popcount(unsigned(less)));
    inside += std::size_t(std::popcount(unsigned(kept)));
  }
#else
  const hn::ScalableTag<double> d;
  const std::size_t lanes = hn::Lanes(d);
  const auto vlow = hn::Set(d, low), vhigh = hn::Set(d, high);
  for (; i + lanes <= count; i += lanes) {
    const auto x = hn::LoadU(d, from + i);
    under += hn::CountTrue(d, hn::Lt(x, vlow));
    inside += hn::CompressStore(x, hn::And(hn::Ge(x, vlow), hn::Le(x, vhigh)), d, to + inside);
  }
#endif
  for (; i < count; ++i) {
    const double x = from[i];
    under += x < low;
    to[inside] = x;  // kept only when inside
    inside += (x >= low) & (x <= high);
  }
  below = under;
  return inside;
}

}  // namespace mocap::simd::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mocap::simd {

HWY_EXPORT(GatherBracket);

std::size_t gather_bracket(const double* from, std::size_t count, double low, double high,
                           double* to, std::size_t& below) {
  return HWY_DYNAMIC_DISPATCH(GatherBracket)(from, count, low, high, to, below);
}

}  // namespace mocap::simd
#endif  // HWY_ONCE
