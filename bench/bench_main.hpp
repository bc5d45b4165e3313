// Shared by the benchmarks with a main() of their own (bench_codec, bench_scheduler): the options
// added for measuring the user's files, and Google Benchmark's start-up and run.
#pragma once

#include <benchmark/benchmark.h>

#include <string_view>
#include <vector>

namespace btflod::bench {

/// Appends the options that steady a measurement of the user's files (5 repetitions in random
/// interleaving, aggregates only), unless `args` already holds --benchmark_repetitions.
inline void add_steady_repetitions(std::vector<char*>& args) {
  for (const char* a : args)
    if (std::string_view(a).starts_with("--benchmark_repetitions")) return;
  static char reps[] = "--benchmark_repetitions=5";
  static char interleave[] = "--benchmark_enable_random_interleaving=true";
  static char aggregates[] = "--benchmark_report_aggregates_only=true";
  args.push_back(reps);
  args.push_back(interleave);
  args.push_back(aggregates);
}

/// Runs the registered benchmarks with Google Benchmark's options `args` (argv[0] first).
/// `before_run()` is called once the options are accepted (e.g. to print tables first). Returns
/// the process exit code: 1 when an option is not recognised, else 0.
template <class BeforeRun = void (*)()>
int run_benchmarks(
    std::vector<char*> args, BeforeRun&& before_run = [] {}) {
  int n = static_cast<int>(args.size());
  args.push_back(nullptr);
  benchmark::Initialize(&n, args.data());
  if (benchmark::ReportUnrecognizedArguments(n, args.data())) return 1;
  before_run();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace btflod::bench
