// SPMM (paper 003, offline/factor/spmm.hpp): fit time of a 64×64 material sampled at the UBO2003
// directions (81 × 81; the synthesised cloth of offline/btf/synthesizer.hpp), and evaluation time per
// sample next to FMF (paper 000, rank 16) on the same material in the same run. Evaluation
// samples are random texels and random (non-measured) upper-hemisphere directions; both
// representations interpolate through the same exact-grid interpolators (SPMM: analytic part
// at the exact directions + residual over 3 × 3 taps; FMF: 3 × 3 taps).
//
//   build-x/bench/bench_spmm                        # fit once at 64×64, then the eval pairs
//   BTFLOD_BENCH_SPMM_SIZE=32 build-x/bench/bench_spmm   # smaller material
// Counters: ns_per_sample, and on the SPMM rows ratio_vs_fmf = SPMM ns / FMF ns from the
// FMF row measured first in the same run.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "../samples/common/texel_direction_samples.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/spmm.hpp"

namespace {

using namespace btflod;

int material_size() {
  const char* s = std::getenv("BTFLOD_BENCH_SPMM_SIZE");
  return s ? std::max(4, std::atoi(s)) : 64;
}

const BtfFloat& material() {
  static const BtfFloat btf = [] {
    const int n = material_size();
    return synthesize_material(SynthMaterial::cloth, n, n, 1, SynthesisOptions{}).value();
  }();
  return btf;
}

// The factorisation `fit()` returns (a Result that must hold a value), its seconds in `seconds`.
template <class Fit>
auto timed_fit(double& seconds, Fit&& fit) {
  const auto t0 = std::chrono::steady_clock::now();
  auto r = fit().value();
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

double g_spmm_fit_s = 0.0;
const Spmm& spmm() {
  static const Spmm p = timed_fit(g_spmm_fit_s, [] { return factorize_spmm(material(), SpmmOptions{.clusters = 8}); });
  return p;
}
double g_fmf_fit_s = 0.0;
const Fmf& fmf() {
  static const Fmf f = timed_fit(g_fmf_fit_s, [] { return factorize_fmf(material(), FmfOptions{.components = 16}); });
  return f;
}

// Evaluation points of the evaluate() benchmarks (fixed seed).
const samples::TexelDirectionSamples& eval_samples() {
  static const auto s = samples::random_texel_direction_samples(material_size(), 4096, 0x853c49e6748fea9bull);
  return s;
}

const ExactGridInterpolator<ParabolicMap>& interp(bool light) {
  static const auto li = ExactGridInterpolator<ParabolicMap>::build(material().lights()).value();
  static const auto vi = ExactGridInterpolator<ParabolicMap>::build(material().views()).value();
  return light ? li : vi;
}

void BM_SpmmFit(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(spmm().clusters());
  state.counters["fit_s"] = g_spmm_fit_s;
  state.counters["mean_bf"] = spmm().mean_basis_per_texel();
  state.counters["ratio"] = spmm().compression_ratio();
  (void)fmf();
  state.counters["fmf_fit_s"] = g_fmf_fit_s;
  state.counters["fit_vs_fmf"] = g_spmm_fit_s / std::max(g_fmf_fit_s, 1e-9);
  std::printf("SPMM fit %dx%d UBO2003: %.2f s (FMF C=16: %.2f s), #BF %.2f\n", material_size(), material_size(),
              g_spmm_fit_s, g_fmf_fit_s, spmm().mean_basis_per_texel());
}
BENCHMARK(BM_SpmmFit)->Iterations(1)->Unit(benchmark::kSecond);

double g_fmf_ns = 0.0;
void BM_FmfEval(benchmark::State& state) {
  const samples::TexelDirectionSamples& s = eval_samples();
  const Fmf& f = fmf();
  size_t i = 0, count = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const size_t k = i++ & 4095;
    benchmark::DoNotOptimize(f.evaluate(s.x[k], s.y[k], interp(true).query(s.l[k]), interp(false).query(s.v[k])));
    ++count;
  }
  g_fmf_ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() /
             static_cast<double>(std::max<size_t>(count, 1));
  state.counters["ns_per_sample"] = g_fmf_ns;
}
BENCHMARK(BM_FmfEval);

// Arg: −2 = no residual, −1 = all N_PCA, k ≥ 0 = N_PCA = k.
void BM_SpmmEval(benchmark::State& state) {
  const samples::TexelDirectionSamples& s = eval_samples();
  const Spmm& p = spmm();
  const int arg = static_cast<int>(state.range(0));
  const SpmmEvalOptions o{.residual = arg != -2, .pca_components = arg < 0 ? -1 : arg};
  size_t i = 0, count = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const size_t k = i++ & 4095;
    benchmark::DoNotOptimize(p.evaluate(s.x[k], s.y[k], s.l[k], s.v[k], interp(true), interp(false), o));
    ++count;
  }
  const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() /
                    static_cast<double>(std::max<size_t>(count, 1));
  state.counters["ns_per_sample"] = ns;
  if (g_fmf_ns > 0.0) state.counters["ratio_vs_fmf"] = ns / g_fmf_ns;
}
BENCHMARK(BM_SpmmEval)->Arg(-2)->Arg(0)->Arg(2)->Arg(-1);

}  // namespace

BENCHMARK_MAIN();
