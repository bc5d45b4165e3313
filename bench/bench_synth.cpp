// Synthesis time of procedural UBO2003 materials (81 × 81 directions) at 64×64 and 256×256
// texels, next to an in-run baseline: the same size with a flat height field (no ray marching:
// shading and memory traffic only). The 256×256 runs stream each view to a checksum instead of
// holding the 5 GB float table. Threads: BTFLOD_THREADS or all cores.
//
//   build-b/bench/bench_synth --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstdio>

#include "btflod/offline/btf/synthesizer.hpp"

namespace {

using namespace btflod;

Mesostructure bench_meso(int kind, int size) {
  if (kind < 0) return make_flat_mesostructure(size, size, glm::vec3(0.5f), 0.5f, 0.04f);
  return make_mesostructure(static_cast<SynthMaterial>(kind), size, size, 1).value();
}

// range(0): texture size; range(1): material (−1 = flat baseline); range(2): interreflection.
void BM_SynthUbo2003(benchmark::State& state) {
  const int size = static_cast<int>(state.range(0));
  const int kind = static_cast<int>(state.range(1));
  const Mesostructure meso = bench_meso(kind, size);
  SynthesisOptions opts;
  opts.interreflection = state.range(2) != 0;
  double checksum = 0.0;
  for (auto _ : state) {
    auto done = synthesize_btf_views(meso, opts, [&](size_t, std::span<const float> block) {
      checksum += block[block.size() / 2];
      return true;
    });
    if (!done) state.SkipWithError(done.message().c_str());
  }
  benchmark::DoNotOptimize(checksum);
  const double samples = static_cast<double>(size) * size * 81.0 * 81.0;
  state.counters["Msamples/s"] =
      benchmark::Counter(samples * static_cast<double>(state.iterations()) / 1e6, benchmark::Counter::kIsRate);
  state.counters["threads"] = default_thread_pool().thread_count();
  state.SetLabel(kind < 0 ? "flat baseline" : material_name(static_cast<SynthMaterial>(kind)));
}

BENCHMARK(BM_SynthUbo2003)
    ->ArgNames({"size", "material", "interrefl"})
    ->Args({64, -1, 0})
    ->Args({64, 0, 0})
    ->Args({64, 1, 0})
    ->Args({64, 2, 0})
    ->Args({64, 3, 0})
    ->Args({64, 1, 1})
    ->Args({256, -1, 0})
    ->Args({256, 1, 0})
    ->Args({256, 1, 1})
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
