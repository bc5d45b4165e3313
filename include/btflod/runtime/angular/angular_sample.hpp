// btflod — the common result of every angular interpolator: up to three measured-direction
// indices with non-negative weights that sum to 1. Canonical form (every interpolator returns
// it): the slots with non-zero weight come first and hold distinct indices; unused slots have
// weight 0 and repeat slot 0's index, so a consumer may always read all three, and code that
// sums or assigns weights by index counts each direction exactly once.
#pragma once

#include <array>
#include <cstdint>

namespace btflod {

struct AngularSample {
  std::array<uint32_t, 3> index{0, 0, 0};
  std::array<float, 3> weight{1.0f, 0.0f, 0.0f};
};

/// Puts a sample into the canonical form (file comment): weights of repeated indices are
/// merged into their first slot, zero-weight slots move to the end and repeat slot 0's index.
/// A sample whose weights are all zero becomes {index[0] ×3, {1, 0, 0}}. noexcept, no
/// allocation, thread-safe.
inline AngularSample canonical_angular_sample(AngularSample s) noexcept {
  AngularSample out;
  int n = 0;
  for (int k = 0; k < 3; ++k) {
    if (!(s.weight[k] > 0.0f)) continue;
    int j = 0;
    while (j < n && out.index[j] != s.index[k]) ++j;
    if (j < n) {
      out.weight[j] += s.weight[k];
    } else {
      out.index[n] = s.index[k];
      out.weight[n] = s.weight[k];
      ++n;
    }
  }
  if (n == 0) return AngularSample{{s.index[0], s.index[0], s.index[0]}, {1.0f, 0.0f, 0.0f}};
  for (int k = n; k < 3; ++k) {
    out.index[k] = out.index[0];
    out.weight[k] = 0.0f;
  }
  return out;
}

}  // namespace btflod
