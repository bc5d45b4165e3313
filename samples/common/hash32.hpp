// btflod samples — a 32-bit integer hash for deterministic variation of synthetic data
// (btflod-replay's value noise, the benchmarks' per-tile weights).
#pragma once

#include <cstdint>

namespace btflod::samples {

/// The 32-bit integer hash "lowbias32" (xor-shift-multiply, two rounds): a well-mixed,
/// platform-independent function of x.
inline uint32_t hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

}  // namespace btflod::samples
