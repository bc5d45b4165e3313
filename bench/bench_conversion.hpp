// Shared by the conversion benchmarks (bench_core_half, bench_core_simd): one bulk conversion of
// the same buffer per iteration.
#pragma once

#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

namespace btflod::bench {

/// Times `convert(in, out)` once per iteration into an output of in.size() values of type Out;
/// the items processed are the values converted.
template <class Out, class In, class Convert>
void time_bulk_conversion(benchmark::State& state, const std::vector<In>& in, Convert&& convert) {
  std::vector<Out> out(in.size());
  for (auto _ : state) {
    convert(in, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(in.size()));
}

}  // namespace btflod::bench
