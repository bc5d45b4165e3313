// Half-float bulk conversion: F16C path vs its scalar twin, in the same run. And the last step
// of a Streamer decode job per cache format (runtime/vt/cache_format.hpp): one padded tile to halves
// (rgba16f, float_to_half with the dispatched kernel) vs to unorm8 with its slot map
// (rgba8_affine, encode_cache_tile_unorm8).
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "bench_conversion.hpp"
#include "btflod/core/half.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"
#include "btflod/runtime/vt/cache_format.hpp"

namespace {

std::vector<float> random_floats(size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> d(-4.0f, 4.0f);
  std::vector<float> v(n);
  for (auto& f : v) f = d(rng);
  return v;
}

constexpr size_t kCount = 72 * 72 * 4;  // one padded RGBA tile

// kCount random values (as halves for the half → float direction), converted by `convert`.
template <class Convert>
void float_to_half_values(benchmark::State& state, Convert convert) {
  btflod::bench::time_bulk_conversion<uint16_t>(state, random_floats(kCount), convert);
}
template <class Convert>
void half_to_float_values(benchmark::State& state, Convert convert) {
  std::vector<uint16_t> in(kCount);
  btflod::float_to_half_scalar(random_floats(kCount), in);
  btflod::bench::time_bulk_conversion<float>(state, in, convert);
}

void BM_FloatToHalf_Scalar(benchmark::State& state) {
  float_to_half_values(state, [](const auto& in, auto& out) { btflod::float_to_half_scalar(in, out); });
}
BENCHMARK(BM_FloatToHalf_Scalar);

void BM_HalfToFloat_Scalar(benchmark::State& state) {
  half_to_float_values(state, [](const auto& in, auto& out) { btflod::half_to_float_scalar(in, out); });
}
BENCHMARK(BM_HalfToFloat_Scalar);

#if BTFLOD_HAS_X86_DISPATCH
void BM_FloatToHalf_F16C(benchmark::State& state) {
  if (!btflod::cpu_has_f16c()) return state.SkipWithError("no F16C on this CPU");
  float_to_half_values(state, [](const auto& in, auto& out) { btflod::float_to_half_f16c(in, out); });
}
BENCHMARK(BM_FloatToHalf_F16C);

void BM_HalfToFloat_F16C(benchmark::State& state) {
  if (!btflod::cpu_has_f16c()) return state.SkipWithError("no F16C on this CPU");
  half_to_float_values(state, [](const auto& in, auto& out) { btflod::half_to_float_f16c(in, out); });
}
BENCHMARK(BM_HalfToFloat_F16C);
#endif

void BM_CacheTile_Rgba16f(benchmark::State& state) {
  const auto in = random_floats(kCount);
  std::vector<uint16_t> out(kCount);
  for (auto _ : state) {
    btflod::float_to_half(in, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()));  // tiles
}
BENCHMARK(BM_CacheTile_Rgba16f);

void BM_CacheTile_Rgba8Affine(benchmark::State& state) {
  const auto in = random_floats(kCount);
  std::vector<uint8_t> out(kCount);
  for (auto _ : state) {
    const btflod::CacheSlotMap map = btflod::encode_cache_tile_unorm8(in, out);
    benchmark::DoNotOptimize(map);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()));  // tiles
}
BENCHMARK(BM_CacheTile_Rgba8Affine);

// The two-plane BC5 layout (runtime/vt/cache_bc5.hpp): the unorm8 quantisation above, then a BC4
// block per component and 4 × 4 texels. Smooth values, as eigen-texture tiles are (random ones
// would make every block span its whole range).
void BM_CacheTile_Bc5(benchmark::State& state) {
  const uint32_t side = 72;  // T = 64 with a 4-texel border, as kCount's tile
  std::vector<float> in(size_t{side} * side * 4);
  for (size_t i = 0; i < in.size(); ++i)
    in[i] = static_cast<float>(std::sin(0.05 * static_cast<double>(i / 4 % side)) *
                               std::cos(0.03 * static_cast<double>(i / 4 / side) + static_cast<double>(i % 4)));
  std::vector<uint8_t> scratch(in.size()), blocks(btflod::cache_bc5_tile_bytes(side));
  for (auto _ : state) {
    const btflod::CacheSlotMap map = btflod::encode_cache_tile_bc5(in, side, scratch, blocks);
    benchmark::DoNotOptimize(map);
    benchmark::DoNotOptimize(blocks.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()));  // tiles
}
BENCHMARK(BM_CacheTile_Bc5);

}  // namespace

BENCHMARK_MAIN();
