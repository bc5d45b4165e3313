// btflod samples — random evaluation points for timing a representation's evaluate(): texels
// and upper-hemisphere directions from a fixed seed (btflod-convert spmm_table, bench_spmm).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

namespace btflod::samples {

/// Sample i is texel (x[i], y[i]) with light direction l[i] and view direction v[i].
struct TexelDirectionSamples {
  std::vector<int> x, y;
  std::vector<glm::vec3> l, v;
};

/// `count` samples of a size × size material: texels uniform over it, directions uniform in
/// cos(theta) over [0.05, 1] and in azimuth, all drawn from a 64-bit LCG started at `seed`, so
/// a seed gives the same samples on every platform. Precondition: size > 0.
inline TexelDirectionSamples random_texel_direction_samples(int size, size_t count, uint64_t seed) {
  uint64_t state = seed;
  auto next = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<float>((state >> 40) & 0xffffff) / 16777216.0f;
  };
  auto hemi = [&] {
    const float mu = 0.05f + 0.95f * next(), ph = 6.2831853f * next(), st = std::sqrt(1.0f - mu * mu);
    return glm::vec3(st * std::cos(ph), st * std::sin(ph), mu);
  };
  TexelDirectionSamples s;
  for (size_t i = 0; i < count; ++i) {
    s.x.push_back(static_cast<int>(next() * static_cast<float>(size)) % size);
    s.y.push_back(static_cast<int>(next() * static_cast<float>(size)) % size);
    s.l.push_back(hemi());
    s.v.push_back(hemi());
  }
  return s;
}

}  // namespace btflod::samples
