// Shared by the codec benchmarks (bench_codec, bench_codec_entropy): the coarser levels of an
// eigen-texture pyramid built from its finest level.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace btflod::bench {

/// Fills level[0 .. level.size() - 2] by 2 × 2 box filtering, each level from the next finer
/// one. Precondition: level.back() holds the finest level, finest_side² texels of `components`
/// values each (row-major, component fastest), finest_side divisible by 2^(level.size() - 1).
inline void box_filter_coarser_levels(std::vector<std::vector<float>>& level, uint32_t finest_side,
                                      uint32_t components) {
  const uint32_t levels = static_cast<uint32_t>(level.size());
  for (uint32_t l = levels - 1; l-- > 0;) {
    const uint32_t s = finest_side >> (levels - 1 - l), fs = s * 2;
    level[l].resize(size_t{s} * s * components);
    for (uint32_t y = 0; y < s; ++y)
      for (uint32_t x = 0; x < s; ++x)
        for (uint32_t k = 0; k < components; ++k) {
          auto at = [&](uint32_t xx, uint32_t yy) { return level[l + 1][(size_t{yy} * fs + xx) * components + k]; };
          level[l][(size_t{y} * s + x) * components + k] =
              0.25f * (at(2 * x, 2 * y) + at(2 * x + 1, 2 * y) + at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1));
        }
  }
}

}  // namespace btflod::bench
