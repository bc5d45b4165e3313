// btflod — synthetic BTFs of known rank plus noise, the ground truth for factorisation tests
// and benchmarks (the Eckart–Young optimum of such a matrix is known from its construction).
#pragma once

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"

namespace btflod {

/// A small direction set of `rings` rings (θ = 0 … 70°) with `per_ring` directions each
/// (one at the pole), for tests that need a handful of directions.
inline DirectionSet small_direction_set(int rings, int per_ring, const char* name = "small") {
  std::vector<std::pair<float, float>> tp;
  tp.emplace_back(0.0f, 0.0f);
  for (int r = 1; r < rings; ++r)
    for (int k = 0; k < per_ring; ++k)
      tp.emplace_back(degrees_to_radians(70.0f * static_cast<float>(r) / static_cast<float>(rings - 1)),
                      degrees_to_radians(360.0f * static_cast<float>(k) / static_cast<float>(per_ring)));
  return DirectionSet::from_radians(name, tp);
}

/// Fills a BTF with Σ_{k<rank} decay^k · a_k(l, v, c) · b_k(x) + noise·N(0, 1) + offset, where
/// a_k and b_k are smooth-ish deterministic pseudo-random patterns (seeded). Positive offset
/// keeps values mostly positive like real reflectance. Deterministic for a given seed.
inline BtfFloat make_low_rank_btf(int width, int height, DirectionSet views, DirectionSet lights, int rank, float decay,
                                  float noise, uint64_t seed = 1, float offset = 0.5f) {
  BtfFloat btf(width, height, std::move(views), std::move(lights));
  detail::NormalGenerator gen(seed);
  const size_t nvl = btf.view_count() * btf.light_count();
  const size_t n = btf.texel_count();
  std::vector<float> a(static_cast<size_t>(rank) * nvl * 3), b(static_cast<size_t>(rank) * n);
  for (auto& x : a) x = static_cast<float>(gen.next());
  for (auto& x : b) x = static_cast<float>(gen.next());
  auto data = btf.samples();
  for (size_t i = 0; i < nvl; ++i)
    for (size_t t = 0; t < n; ++t)
      for (size_t c = 0; c < 3; ++c) {
        double s = offset;
        double scale = 0.1;
        for (int k = 0; k < rank; ++k, scale *= decay)
          s += scale * a[(static_cast<size_t>(k) * nvl + i) * 3 + c] * b[static_cast<size_t>(k) * n + t];
        if (noise > 0.0f) s += noise * gen.next();
        data[(i * n + t) * 3 + c] = static_cast<float>(s);
      }
  return btf;
}

}  // namespace btflod
