// The SIMD kernels of core/simd.hpp, every ISA build the CPU runs next to the scalar twin, in the
// same run (compare the rows of one kernel; absolute times are machine- and load-dependent):
// the tile decoder's 4-channel inverse DCT (4×4 and 8×8 non-zero coefficients), half → float of
// 64 Ki values, float → half of one padded RGBA tile, and the run detection of a 1280×720
// feedback buffer. Each benchmark's argument is the SimdIsa value.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "bench_conversion.hpp"
#include "btflod/core/dct.hpp"
#include "btflod/core/simd.hpp"

namespace {

using btflod::SimdIsa;

const btflod::SimdKernels* kernels_or_skip(benchmark::State& state) {
  const auto* k = btflod::simd_kernels_for(static_cast<SimdIsa>(state.range(0)));
  if (k == nullptr)
    state.SkipWithError("this ISA build does not run on this CPU");
  else
    state.SetLabel(btflod::simd_isa_name(k->isa));
  return k;
}

void BM_TileIdctAdd4(benchmark::State& state) {
  const auto* k = kernels_or_skip(state);
  if (k == nullptr) return;
  const uint32_t n = static_cast<uint32_t>(state.range(1));
  std::mt19937 rng(1);
  btflod::TileCoefBlock b[4];
  for (auto& blk : b) {
    blk.rows = blk.cols = n;
    for (uint32_t v = 0; v < n; ++v)
      for (uint32_t u = 0; u < n; ++u) blk.coef[v * 8 + u] = static_cast<float>(rng() % 100) - 50.0f;
  }
  std::vector<float> dst(8 * 288, 0.0f);
  for (auto _ : state) {
    k->tile_idct_add4(b, dst.data(), 288);
    benchmark::DoNotOptimize(dst.data());
  }
}
BENCHMARK(BM_TileIdctAdd4)->ArgsProduct({{0, 1, 2}, {4, 8}});

void BM_HalfToFloat(benchmark::State& state) {
  const auto* k = kernels_or_skip(state);
  if (k == nullptr) return;
  std::mt19937 rng(2);
  std::vector<uint16_t> in(1 << 16);
  for (auto& h : in) h = static_cast<uint16_t>(rng() & 0x7bffu);
  btflod::bench::time_bulk_conversion<float>(
      state, in, [k](const auto& from, auto& to) { k->half_to_float(from.data(), to.data(), from.size()); });
}
BENCHMARK(BM_HalfToFloat)->Arg(0)->Arg(1)->Arg(2);

void BM_FloatToHalf(benchmark::State& state) {
  const auto* k = kernels_or_skip(state);
  if (k == nullptr) return;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> d(-4.0f, 4.0f);
  std::vector<float> in(72 * 72 * 4);
  for (auto& f : in) f = d(rng);
  btflod::bench::time_bulk_conversion<uint16_t>(
      state, in, [k](const auto& from, auto& to) { k->float_to_half(from.data(), to.data(), from.size()); });
}
BENCHMARK(BM_FloatToHalf)->Arg(0)->Arg(1)->Arg(2);

void BM_RunMarks(benchmark::State& state) {
  const auto* k = kernels_or_skip(state);
  if (k == nullptr) return;
  std::mt19937 rng(4);
  std::vector<uint32_t> words(1280 * 720 + 1);
  uint32_t w = 0;
  for (auto& x : words) {
    if (rng() % 12 == 0) w = static_cast<uint32_t>(rng());
    x = w;
  }
  std::vector<uint64_t> marks(words.size() / 64 + 1);
  for (auto _ : state) {
    k->run_marks(words.data() + 1, words.size() - 1, marks.data());
    benchmark::DoNotOptimize(marks.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(words.size() - 1));
}
BENCHMARK(BM_RunMarks)->Arg(0)->Arg(1)->Arg(2);

}  // namespace

BENCHMARK_MAIN();
