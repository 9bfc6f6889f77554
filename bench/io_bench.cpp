// Micro-benchmarks of the store's chunk codec (io/chunk_codec.hpp) on one chunk of the size the
// store writes (1,024 frames x 31 joints x 4 float32), in bytes per second.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "io/chunk_codec.hpp"

namespace mocap::io {
namespace {

std::vector<std::uint8_t> chunk_bytes() {
  std::mt19937_64 rng(11);
  std::normal_distribution<float> g(0.0f, 0.5f);
  std::vector<float> values(1024 * 31 * 4);
  for (float& v : values) v = g(rng);
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(values.data());
  return {bytes, bytes + values.size() * sizeof(float)};
}

volatile std::size_t stride = 4;

// Arg 0: the strided byte loop per plane that shuffle_bytes ran for every element size before
// its float32 path; 1: shuffle_bytes.
void BM_Shuffle(benchmark::State& state) {
  const std::vector<std::uint8_t> in = chunk_bytes();
  std::vector<std::uint8_t> out(in.size());
  const std::size_t n = in.size() / 4;
  for (auto _ : state) {
    if (state.range(0) == 0) {
      const std::size_t element = stride;  // read at run time, as the element size was
      for (std::size_t b = 0; b < element; ++b)
        for (std::size_t i = 0; i < n; ++i) out[b * n + i] = in[element * i + b];
    } else {
      shuffle_bytes(in, 4, out);
    }
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(state.iterations() * std::int64_t(in.size()));
}
BENCHMARK(BM_Shuffle)->ArgName("fast")->Arg(0)->Arg(1);

// Arg 0: HDF5's loop (fletcher32_reference); 1: fletcher32.
void BM_Fletcher32(benchmark::State& state) {
  const std::vector<std::uint8_t> in = chunk_bytes();
  for (auto _ : state)
    benchmark::DoNotOptimize(state.range(0) == 0 ? fletcher32_reference(in) : fletcher32(in));
  state.SetBytesProcessed(state.iterations() * std::int64_t(in.size()));
}
BENCHMARK(BM_Fletcher32)->ArgName("fast")->Arg(0)->Arg(1);

}  // namespace
}  // namespace mocap::io
