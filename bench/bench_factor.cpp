// FMF factorisation time (paper 000 §4) for UBO2003-sized materials (81 × 81 directions,
// 19,683 matrix rows) at rank 100: the blocked randomised SVD (SvdOptions defaults: sparse sign
// sketch, oversampling 50, adaptive power iterations (2…6), fused last pass) next to the exact
// Eigen BDCSVD baseline at 64×64, with truncation errors, the SVD's own error estimate and
// iteration count, and peak memory (VmHWM, reset before each run via /proc/self/clear_refs).
// BM_Fmf32CarPaint: the flat-spectrum case (measured car paint on the leather mesostructure,
// 32×32, rank 64), randomised defaults vs BDCSVD; skipped without the shared measured data.
//
// The 64×64 material is the synthesised cloth (offline/btf/synthesizer.hpp). The 256×256 material
// (19,683 × 65,536 floats = 5.2 GB) is that cloth tiled 4 × 4 with a small deterministic
// per-sample perturbation (synthesising 256×256 directly takes far longer than the
// factorisation); it runs only when BTFLOD_BENCH_LARGE=1, as it needs ~6 GB of RAM.
//
//   build-d/bench/bench_factor                      # 64×64: randomised vs BDCSVD
//   BTFLOD_BENCH_LARGE=1 build-d/bench/bench_factor --benchmark_filter=256
// This executable is built with the offline tools' flags (BTFLOD_OFFLINE_ARCH, default AUTO:
// -march=x86-64-v3 when the build machine runs it); the counter avx2_fma says which build ran.
// GFLOP/s counts the dense products only: 2·(2q)·m·n·k (sparse sketch: q ≥ 1) or, for the
// Gaussian sketch (BTFLOD_BENCH_ZETA=0), 2·(2q + 1)·m·n·k; k = rank + p, q = the iterations the
// adaptive rule ran (counter q_used; BTFLOD_BENCH_Q sets the minimum, BTFLOD_BENCH_QMAX the cap;
// BTFLOD_BENCH_BC the columns per block).
// Where the time goes (SvdReport timing fields): gather_share / product_share / small_share are
// the parts of the wall time spent gathering columns, in the block products and outside the
// passes (QR, small SVDs); gather_GB/s = bytes read per pass (m·n·4, counter GB_per_pass) × passes
// over the gather time per thread; product_GFLOP/s = GFLOP over the product time per thread ×
// threads. BM_GemmPeak runs first: the machine's float GEMM rate in the same run (every pool
// thread multiplies its own 2048 × 512 by 512 × 2048 matrices), through Eigen's GEMM or, when
// built with -DBTFLOD_WITH_OPENBLAS=ON, OpenBLAS's sgemm (counter openblas); every FMF run
// reports of_peak = GFLOP/s / that peak.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "btflod/offline/btf/measured_brdf.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/factor/fmf.hpp"

namespace {

using namespace btflod;

double vm_hwm_gb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::strtod(line.c_str() + 6, nullptr) / (1024.0 * 1024.0);
  return 0.0;
}
void reset_hwm() {
  std::ofstream f("/proc/self/clear_refs");
  f << "5";
}

const BtfFloat& cloth64() {
  static const BtfFloat btf = [] {
    SynthesisOptions so;
    return synthesize_material(SynthMaterial::cloth, 64, 64, 1, so).value();
  }();
  return btf;
}

// ‖A − U·(VΣ)ᵀ‖_F computed block by block (no m × n temporary), column sums in double (one
// float squaredNorm per 19,683 × 512 block was off by ~4·10⁻⁴ relative with the earlier float sum).
double fmf_error(const BtfFloat& btf, const Fmf& f) {
  const size_t m = btf.view_count() * btf.light_count() * 3, n = btf.texel_count(), bc = 512;
  using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::Map<const RowMat> u(f.u.data(), static_cast<Eigen::Index>(m), f.components);
  Eigen::Map<const RowMat> v(f.v.data(), static_cast<Eigen::Index>(n), f.components);
  double sum = 0.0;
  Eigen::MatrixXf a(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(bc));
  for (size_t t0 = 0; t0 < n; t0 += bc) {
    const size_t cnt = std::min(bc, n - t0);
    a.resize(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(cnt));
    gather_fmf_columns(btf, t0, cnt, a);
    a.noalias() -= u * v.middleRows(static_cast<Eigen::Index>(t0), static_cast<Eigen::Index>(cnt)).transpose();
    sum += a.colwise().squaredNorm().cast<double>().sum();  // float sums over 10⁷ values drift
  }
  return std::sqrt(sum);
}

struct Run {
  double seconds = 0.0, error = 0.0, peak_gb = 0.0;
};
double g_peak_gflops = 0.0;

// The float GEMM rate of the machine, now: every pool thread runs C += A·B (2048 × 512 · 512 ×
// 2048, the packed-panel regime of the SVD's products) until 1.5 s have passed.
void BM_GemmPeak(benchmark::State& state) {
  ThreadPool& pool = default_thread_pool();
  const unsigned threads = std::max(1u, pool.thread_count());
  constexpr Eigen::Index kM = 2048, kK = 512, kN = 2048;
  for (auto _ : state) {
    std::vector<double> flops(threads, 0.0);
    const auto t0 = std::chrono::steady_clock::now();
    pool.parallel_for(0, threads, 1, [&](size_t b, size_t e) {
      for (size_t t = b; t < e; ++t) {
        const Eigen::MatrixXf a = Eigen::MatrixXf::Random(kM, kK), bm = Eigen::MatrixXf::Random(kK, kN);
        Eigen::MatrixXf c = Eigen::MatrixXf::Zero(kM, kN);
        const auto start = std::chrono::steady_clock::now();
        while (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < 1.5) {
          c.noalias() += a * bm;
          flops[t] += 2.0 * kM * kK * kN;
        }
        benchmark::DoNotOptimize(c.data());
      }
    });
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    double f = 0.0;
    for (double x : flops) f += x;
    g_peak_gflops = f / s / 1e9;
  }
  state.counters["GFLOP/s"] = g_peak_gflops;
  state.counters["threads"] = threads;
#if defined(BTFLOD_WITH_OPENBLAS)
  state.counters["openblas"] = 1;
#else
  state.counters["openblas"] = 0;
#endif
}
Run g_randomized64, g_exact64, g_carpaint_randomized;

Run run_fmf(benchmark::State& state, const BtfFloat& btf, SvdMethod method, bool measure_error, int rank = 100) {
  Run r;
  FmfOptions o;
  o.components = rank;
  o.svd.method = method;
  // BTFLOD_BENCH_Q / BTFLOD_BENCH_P override the power iterations / oversampling (defaults of
  // SvdOptions otherwise), to chart the time/accuracy trade-off without rebuilding.
  if (const char* q = std::getenv("BTFLOD_BENCH_Q")) o.svd.power_iterations = std::atoi(q);
  if (const char* q = std::getenv("BTFLOD_BENCH_QMAX")) o.svd.max_power_iterations = std::atoi(q);
  if (const char* p = std::getenv("BTFLOD_BENCH_P")) o.svd.oversampling = std::atoi(p);
  if (const char* z = std::getenv("BTFLOD_BENCH_ZETA")) o.svd.sketch_nonzeros = std::atoi(z);
  if (const char* b = std::getenv("BTFLOD_BENCH_BC")) o.svd.block_columns = static_cast<size_t>(std::atoi(b));
  state.counters["block_columns"] = static_cast<double>(o.svd.block_columns);
  state.counters["q_min"] = o.svd.power_iterations;
  state.counters["p"] = o.svd.oversampling;
  state.counters["zeta"] = o.svd.sketch_nonzeros;
#if defined(__AVX2__) && defined(__FMA__)
  state.counters["avx2_fma"] = 1;
#else
  state.counters["avx2_fma"] = 0;
#endif
  SvdReport report;
  for (auto _ : state) {
    reset_hwm();
    const auto t0 = std::chrono::steady_clock::now();
    auto f = factorize_fmf(btf, o);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.peak_gb = vm_hwm_gb();
    if (!f) {
      state.SkipWithError(f.message().c_str());
      return r;
    }
    report = f->svd_report;
    if (measure_error) r.error = fmf_error(btf, *f);
  }
  const double input_gb = static_cast<double>(btf.size_bytes()) / (1024.0 * 1024.0 * 1024.0);
  state.counters["seconds"] = r.seconds;
  if (method == SvdMethod::randomized) {
    const double m = static_cast<double>(btf.view_count() * btf.light_count() * 3),
                 n = static_cast<double>(btf.texel_count());
    const double k = std::min({static_cast<double>(o.components + o.svd.oversampling), m, n});
    const int q = report.power_iterations;
    state.counters["q_used"] = q;
    state.counters["error_estimate"] = report.error_estimate;
    state.counters["predicted_ratio"] = report.predicted_ratio;
    const int products = q == 0 ? (o.svd.sketch_nonzeros > 0 ? 1 : 2) : 2 * q + (o.svd.sketch_nonzeros > 0 ? 0 : 1);
    const double gflop = 2.0 * products * m * n * k / 1e9;
    const double threads = std::max(1u, default_thread_pool().thread_count());
    state.counters["GFLOP"] = gflop;
    state.counters["GFLOP/s"] = gflop / r.seconds;
    if (g_peak_gflops > 0.0) state.counters["of_peak"] = gflop / r.seconds / g_peak_gflops;
    state.counters["passes"] = report.passes;
    state.counters["GB_per_pass"] = m * n * 4.0 / 1e9;
    const double wall = std::max(report.total_seconds, 1e-9);
    state.counters["gather_share"] = report.gather_seconds / threads / wall;
    state.counters["product_share"] = report.product_seconds / threads / wall;
    state.counters["small_share"] = (report.total_seconds - report.pass_seconds) / wall;
    if (report.gather_seconds > 0.0)
      state.counters["gather_GB/s"] = m * n * 4.0 * report.passes / 1e9 / (report.gather_seconds / threads);
    if (report.product_seconds > 0.0) state.counters["product_GFLOP/s"] = gflop / (report.product_seconds / threads);
  }
  state.counters["input_GB"] = input_gb;
  state.counters["peak_GB"] = r.peak_gb;
  state.counters["peak/input"] = r.peak_gb / input_gb;
  if (measure_error) state.counters["frob_error"] = r.error;
  state.counters["threads"] = default_thread_pool().thread_count();
  return r;
}

void BM_Fmf64Randomized(benchmark::State& state) {
  g_randomized64 = run_fmf(state, cloth64(), SvdMethod::randomized, true);
}
void BM_Fmf64ExactBdcsvd(benchmark::State& state) {
  g_exact64 = run_fmf(state, cloth64(), SvdMethod::exact, true);
  if (g_randomized64.seconds > 0.0) {
    state.counters["speedup_of_randomized"] = g_exact64.seconds / g_randomized64.seconds;
    state.counters["error_ratio_randomized"] = g_randomized64.error / g_exact64.error;
  }
}

const BtfFloat* carpaint32() {
  static const BtfFloat btf = []() -> BtfFloat {
    auto brdf = read_mbsdf(std::string(BTFLOD_SHARED_DIR) + "/data/measured/carpaint_red.mbsdf");
    if (!brdf) return {};
    SynthesisOptions so;
    so.measured_brdf = &*brdf;
    auto b = synthesize_material(SynthMaterial::leather, 32, 32, 1, so);
    return b ? std::move(*b) : BtfFloat{};
  }();
  return btf.empty() ? nullptr : &btf;
}
void BM_Fmf32CarPaintRandomized(benchmark::State& state) {
  if (!carpaint32()) {
    for (auto _ : state) {
    }
    state.SkipWithError("no measured car paint (BTFLOD_SHARED_DIR/data/measured)");
    return;
  }
  g_carpaint_randomized = run_fmf(state, *carpaint32(), SvdMethod::randomized, true, 64);
}
void BM_Fmf32CarPaintExactBdcsvd(benchmark::State& state) {
  if (!carpaint32()) {
    for (auto _ : state) {
    }
    state.SkipWithError("no measured car paint (BTFLOD_SHARED_DIR/data/measured)");
    return;
  }
  const Run e = run_fmf(state, *carpaint32(), SvdMethod::exact, true, 64);
  if (g_carpaint_randomized.seconds > 0.0) {
    state.counters["speedup_of_randomized"] = e.seconds / g_carpaint_randomized.seconds;
    state.counters["error_ratio_randomized"] = g_carpaint_randomized.error / e.error;
  }
}

void BM_Fmf256Randomized(benchmark::State& state) {
  const char* env = std::getenv("BTFLOD_BENCH_LARGE");
  if (!env || std::string(env) != "1") {
    for (auto _ : state) {
    }
    state.SkipWithError("set BTFLOD_BENCH_LARGE=1 to run the 5.2 GB 256x256 case");
    return;
  }
  BtfFloat big(256, 256, cloth64().views(), cloth64().lights());
  {
    const auto& small = cloth64();
    for (size_t v = 0; v < big.view_count(); ++v)
      for (size_t l = 0; l < big.light_count(); ++l)
        for (int y = 0; y < 256; ++y)
          for (int x = 0; x < 256; ++x)
            for (int c = 0; c < 3; ++c) {
              const uint32_t h = (static_cast<uint32_t>(x) * 73856093u) ^ (static_cast<uint32_t>(y) * 19349663u) ^
                                 (static_cast<uint32_t>(v) * 83492791u + static_cast<uint32_t>(l) * 2654435761u +
                                  static_cast<uint32_t>(c));
              big.at(x, y, v, l, c) = small.value(x & 63, y & 63, v, l, c) *
                                      (1.0f + 0.02f * (static_cast<float>(h % 1024) / 1024.0f - 0.5f));
            }
  }
  run_fmf(state, big, SvdMethod::randomized, false);
}

BENCHMARK(BM_GemmPeak)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_Fmf64Randomized)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_Fmf64ExactBdcsvd)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_Fmf32CarPaintRandomized)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_Fmf32CarPaintExactBdcsvd)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_Fmf256Randomized)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (g_randomized64.seconds > 0.0 && g_exact64.seconds > 0.0)
    std::printf("64x64 rank 100: randomised %.2f s vs BDCSVD %.2f s (%.1fx faster); error %.6g vs %.6g (ratio %.5f)\n",
                g_randomized64.seconds, g_exact64.seconds, g_exact64.seconds / g_randomized64.seconds,
                g_randomized64.error, g_exact64.error, g_randomized64.error / g_exact64.error);
  return 0;
}
