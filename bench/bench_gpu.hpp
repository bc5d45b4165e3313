// Shared by the GPU benchmarks (bench_gpu_render, bench_gpu_spmm): the backend they draw with,
// one frame timed from begin_frame to wait_idle, and two kinds of frame timed interleaved so
// that load from other processes hits both alike.
#pragma once

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "gl_backend.hpp"
#include "vk_backend.hpp"

namespace btflod::bench {

/// The Vulkan (lavapipe on CI) or GL (llvmpipe) backend initialised with `config` and
/// `frames_in_flight`; null, with the reason in `error`, when either step fails.
inline std::unique_ptr<Backend> create_initialised_backend(bool vulkan, const ShaderConfig& config,
                                                           uint32_t frames_in_flight, std::string& error) {
  auto r = vulkan ? samples::create_vk_backend() : samples::create_gl_backend();
  if (!r) {
    error = r.message();
    return nullptr;
  }
  std::unique_ptr<Backend> backend = std::move(r.value());
  if (VoidResult v = backend->init(config, frames_in_flight); !v) {
    error = v.message();
    return nullptr;
  }
  return backend;
}

/// The scene of one API from `scenes` (one per API: [0] GL, [1] Vulkan), made by
/// make_scene(vulkan) on first use and kept for the process; null, with the benchmark marked
/// skipped, when its backend is unavailable. Scene has `backend` and `error` members.
template <class Scene, class MakeScene>
Scene* scene_or_skip(benchmark::State& state, Scene (&scenes)[2], bool vulkan, MakeScene&& make_scene) {
  Scene& s = scenes[vulkan ? 1 : 0];
  if (!s.backend && s.error.empty()) s = make_scene(vulkan);
  if (!s.backend) {
    state.SkipWithError(("backend unavailable: " + s.error).c_str());
    return nullptr;
  }
  return &s;
}

/// Milliseconds of one frame: begin_frame, `draw()`, end_frame and wait_idle (so the GPU work
/// is inside the time).
template <class Draw>
double time_frame_ms(Backend& backend, const FrameDesc& frame, Draw&& draw) {
  const auto t0 = std::chrono::steady_clock::now();
  backend.begin_frame(frame);
  draw();
  backend.end_frame();
  backend.wait_idle();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// The median of a benchmark's per-iteration figures (0 when there are none).
inline double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// The per-pair ratios num[i] / den[i] (e.g. t_fmf / t_bsvtf: the frame-rate ratio of BSVTF
/// over FMF). Precondition: num.size() <= den.size().
inline std::vector<double> per_pair_ratios(const std::vector<double>& num, const std::vector<double>& den) {
  std::vector<double> r;
  for (size_t i = 0; i < num.size(); ++i) r.push_back(num[i] / den[i]);
  return r;
}

/// Per-iteration milliseconds of the two kinds of frame of time_interleaved_pairs().
struct PairTimes {
  std::vector<double> a, b;
};

/// Times frames `a()` and `b()` (each returns its milliseconds) as one pair per benchmark
/// iteration, a first on even iterations and b first on odd ones, after two untimed warm-up
/// pairs (shader JIT, target (re)creation); `after_pair()` runs after each timed pair.
template <class A, class B, class AfterPair = void (*)()>
PairTimes time_interleaved_pairs(
    benchmark::State& state, A&& a, B&& b, AfterPair&& after_pair = [] {}) {
  for (int warm = 0; warm < 2; ++warm) a(), b();
  PairTimes t;
  for (auto _ : state) {
    const bool a_first = (t.a.size() & 1) == 0;
    const double first = a_first ? a() : b();
    const double second = a_first ? b() : a();
    after_pair();
    t.a.push_back(a_first ? first : second);
    t.b.push_back(a_first ? second : first);
  }
  return t;
}

}  // namespace btflod::bench
