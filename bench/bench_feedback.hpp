// Shared by the scheduler and runtime benchmarks: the synthetic moving-camera feedback they
// replay, the per-tile weights they give the materials, and the in-run baseline (thread CPU
// time of one plain read of the feedback buffer).
#pragma once

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <vector>

#include "../samples/common/hash32.hpp"
#include "btflod/runtime/lod/feedback.hpp"

namespace btflod::bench {

/// Pre-generated feedback frames, cycled by the benchmarks.
inline constexpr int kFeedbackFrames = 8;

/// The samples' 32-bit integer hash (deterministic per-tile variation of the weights w).
using samples::hash32;

/// Tile weight w of flat tile `flat` of virtual texture `texture`, component group k of its
/// material: later components matter less (SVD ordering), w varies per tile.
inline float bench_tile_weight(uint32_t texture, uint32_t flat, uint32_t k) {
  return (0.5f + static_cast<float>(hash32(texture * 7919u + flat) & 0xffu) / 256.0f) /
         static_cast<float>((k + 1) * (k + 1));
}

/// kFeedbackFrames frames of width × height feedback words imitating a camera moving over a
/// grid of `materials` materials of 2048² texels with finest level L: each material occupies a
/// screen cell, texels per pixel grow smoothly with the row (distance: levels L … L−4), and the
/// texture coordinates scroll a little every frame so tiles keep entering and leaving.
inline std::vector<std::vector<uint32_t>> make_feedback(uint32_t materials, uint32_t width, uint32_t height,
                                                        uint32_t L) {
  std::vector<std::vector<uint32_t>> frames(kFeedbackFrames);
  const uint32_t cells = static_cast<uint32_t>(std::ceil(std::sqrt(static_cast<double>(materials))));
  for (int f = 0; f < kFeedbackFrames; ++f) {
    auto& words = frames[static_cast<size_t>(f)];
    words.resize(static_cast<size_t>(width) * height);
    for (uint32_t y = 0; y < height; ++y)
      for (uint32_t x = 0; x < width; ++x) {
        const uint32_t cx = x * cells / width, cy = y * cells / height;
        const uint32_t m = cy * cells + cx;
        if (m >= materials) {
          words[static_cast<size_t>(y) * width + x] = kFeedbackNone;
          continue;
        }
        // Cell-local texel coordinates: near rows show ~1 texel per pixel, far rows up to 8
        // (the texture repeats over the surface, as on the paper's tori); coordinates scroll a
        // little every frame and each cell starts at its own offset.
        const double ly = (y - cy * height / cells) / double(height / cells);  // 0 … 1 inside the cell
        const double rho = std::ldexp(1.0, static_cast<int>(cy * 4 / cells)) * (1.0 + 1.5 * ly);
        const double texels = 2048.0;
        const double u = std::fmod(((x - cx * width / cells) * rho + 37.0 * m + 11.0 * f) / texels, 1.0);
        const double v = std::fmod(((y - cy * height / cells) * rho + 53.0 * m) / texels, 1.0);
        const uint32_t level = L - std::min<uint32_t>(L, static_cast<uint32_t>(std::ceil(std::log2(rho) - 1e-9)));
        const uint32_t n = 1u << level;
        words[static_cast<size_t>(y) * width + x] =
            pack_feedback({m, level, std::min(n - 1, uint32_t(u * n)), std::min(n - 1, uint32_t(v * n))});
      }
  }
  return frames;
}

/// Thread CPU time in ns: the machine is shared, so wall time would charge other processes to us.
inline double cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

/// The baseline: read the buffer once (sum of its words), mean thread CPU time over 200 reads.
inline double read_once_ns(const std::vector<uint32_t>& words) {
  const int reads = 200;
  const double t0 = cpu_ns();
  for (int r = 0; r < reads; ++r) {
    uint64_t sum = 0;
    for (uint32_t w : words) sum += w;
    benchmark::DoNotOptimize(sum);
  }
  return (cpu_ns() - t0) / reads;
}

}  // namespace btflod::bench
