// btflod — a block-compressed tile cache layout: two BC5 (RGTC2) planes per slot, each texel's
// four eigen-texture components under the slot's affine map (runtime/vt/cache_format.hpp), 2
// bytes a texel: a quarter of rgba16f, half of rgba8_affine.
//
// A tile is first quantised to unorm8 against its own per-component range, as rgba8_affine does
// (encode_cache_tile_unorm8: value = offset + scale · q / 255), then each component's 4 × 4
// blocks are coded as BC4 (RGTC1 UNORM): two 8-bit endpoints and sixteen 3-bit indices into the
// eight values between them. Components 0 and 1 form the first BC5 plane (a BC5 block is the BC4
// block of its red channel followed by that of its green channel), components 2 and 3 the
// second. The map is affine and the same over the slot, so filtering the decoded blocks and then
// applying the map equals filtering the mapped values, as for rgba8_affine.
//
// The encoder is the project's own: per block the endpoints start at the block's minimum and
// maximum and are refined by least squares over the chosen indices while the squared error
// falls; the six-value mode (explicit 0 and 255) is tried for blocks that reach either extreme.
// Debian's libsquish (1.15, kBc4) was measured against it on the demo materials' eigen-texture
// blocks (bench/bench_cache_bc5.cpp): 28 % more squared error per value, 1.3× faster; the
// project's encoder keeps the lower error. decode_bc4_block is the reference decoder of the
// format as the graphics APIs define it (D3D10 BC4_UNORM, OpenGL RGTC1): values are exact
// fractions of 255, not rounded to 8 bits.
//
// Everything here is noexcept and allocation-free: what a decode worker would run per tile.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "btflod/runtime/vt/cache_format.hpp"

namespace btflod {

/// Bytes of one BC4 block (4 × 4 texels of one component) and of one BC5 block (two components).
inline constexpr size_t kBc4BlockBytes = 8;
inline constexpr size_t kBc5BlockBytes = 16;

/// Bytes of a slot of `side` × `side` texels in the two-plane BC5 layout: side² · 2.
/// Precondition: side is a multiple of 4.
constexpr size_t cache_bc5_tile_bytes(uint32_t side) noexcept { return size_t{side} * side * 2; }

/// The eight palette values of a BC4 block in units of 1/255 (the reference decoder's values ×
/// 255): e0 > e1 interpolates six values between them; otherwise four, then 0 and 255. noexcept.
inline void bc4_palette(uint8_t e0, uint8_t e1, float palette[8]) noexcept {
  const float a = e0, b = e1;
  palette[0] = a;
  palette[1] = b;
  if (e0 > e1) {
    for (int k = 2; k < 8; ++k) palette[k] = (static_cast<float>(8 - k) * a + static_cast<float>(k - 1) * b) / 7.0f;
  } else {
    for (int k = 2; k < 6; ++k) palette[k] = (static_cast<float>(6 - k) * a + static_cast<float>(k - 1) * b) / 5.0f;
    palette[6] = 0.0f;
    palette[7] = 255.0f;
  }
}

/// Reference decoder: the 16 values of a BC4 block (row-major within the block) in [0, 1], as
/// BC4_UNORM / RGTC1 sampling returns them. noexcept, safe for any 8 bytes.
inline void decode_bc4_block(const uint8_t block[8], float out[16]) noexcept {
  float palette[8];
  bc4_palette(block[0], block[1], palette);
  uint64_t bits = 0;
  for (int i = 0; i < 6; ++i) bits |= static_cast<uint64_t>(block[2 + i]) << (8 * i);
  for (int t = 0; t < 16; ++t) out[t] = palette[(bits >> (3 * t)) & 7u] / 255.0f;
}

namespace detail {

// The indices of the nearest palette entry for each value and the block's squared error (in
// units of 1/255).
inline float bc4_assign(const uint8_t values[16], uint8_t e0, uint8_t e1, uint8_t index[16]) noexcept {
  float palette[8];
  bc4_palette(e0, e1, palette);
  float total = 0.0f;
  for (int t = 0; t < 16; ++t) {
    const float v = values[t];
    int best = 0;
    float best_d = (v - palette[0]) * (v - palette[0]);
    for (int k = 1; k < 8; ++k) {
      const float d = (v - palette[k]) * (v - palette[k]);
      if (d < best_d) best_d = d, best = k;
    }
    index[t] = static_cast<uint8_t>(best);
    total += best_d;
  }
  return total;
}

// Weight of e0 in palette entry k of the eight-value mode (e1's is 1 − that).
constexpr float bc4_weight8(int k) noexcept { return k == 0 ? 1.0f : k == 1 ? 0.0f : static_cast<float>(8 - k) / 7.0f; }

inline void bc4_write(uint8_t e0, uint8_t e1, const uint8_t index[16], uint8_t out[8]) noexcept {
  out[0] = e0;
  out[1] = e1;
  uint64_t bits = 0;
  for (int t = 0; t < 16; ++t) bits |= static_cast<uint64_t>(index[t] & 7u) << (3 * t);
  for (int i = 0; i < 6; ++i) out[2 + i] = static_cast<uint8_t>(bits >> (8 * i));
}

inline uint8_t bc4_round(float x) noexcept { return static_cast<uint8_t>(std::clamp(std::lround(x), 0L, 255L)); }

}  // namespace detail

/// Encodes 16 unorm8 values (row-major within the 4 × 4 block) as one BC4 block. Returns the
/// block's squared error in units of 1/255 (0 when every value is representable). Deterministic,
/// noexcept, no allocation.
inline float encode_bc4_block(const uint8_t values[16], uint8_t out[8]) noexcept {
  uint8_t lo = 255, hi = 0;
  for (int t = 0; t < 16; ++t) lo = std::min(lo, values[t]), hi = std::max(hi, values[t]);
  uint8_t index[16];
  if (lo == hi) {  // flat: six-value mode with e0 = e1, every index 0
    for (int t = 0; t < 16; ++t) index[t] = 0;
    detail::bc4_write(lo, lo, index, out);
    return 0.0f;
  }
  // Eight-value mode from the extremes, refined by least squares over the assigned indices
  // (the endpoints that minimise Σ (w_t e0 + (1 − w_t) e1 − v_t)² for fixed weights).
  uint8_t e0 = hi, e1 = lo;
  float best = detail::bc4_assign(values, e0, e1, index);
  for (int iteration = 0; iteration < 4 && best > 0.0f; ++iteration) {
    double saa = 0, sab = 0, sbb = 0, sav = 0, sbv = 0;
    for (int t = 0; t < 16; ++t) {
      const double w = detail::bc4_weight8(index[t]), u = 1.0 - w, v = values[t];
      saa += w * w, sab += w * u, sbb += u * u, sav += w * v, sbv += u * v;
    }
    const double det = saa * sbb - sab * sab;
    if (std::fabs(det) < 1e-9) break;
    uint8_t n0 = detail::bc4_round(static_cast<float>((sav * sbb - sbv * sab) / det));
    uint8_t n1 = detail::bc4_round(static_cast<float>((sbv * saa - sav * sab) / det));
    if (n0 == n1) break;
    if (n0 < n1) std::swap(n0, n1);  // keep the eight-value mode (e0 > e1)
    if (n0 == e0 && n1 == e1) break;
    uint8_t trial[16];
    const float err = detail::bc4_assign(values, n0, n1, trial);
    if (!(err < best)) break;
    best = err, e0 = n0, e1 = n1;
    for (int t = 0; t < 16; ++t) index[t] = trial[t];
  }
  // Six-value mode for blocks that reach 0 or 255: the extremes are exact there, the rest
  // interpolated between the block's inner minimum and maximum.
  if (lo == 0 || hi == 255) {
    uint8_t in_lo = 255, in_hi = 0;
    for (int t = 0; t < 16; ++t)
      if (values[t] != 0 && values[t] != 255) in_lo = std::min(in_lo, values[t]), in_hi = std::max(in_hi, values[t]);
    if (in_lo > in_hi) in_lo = in_hi = lo == 0 ? hi : lo;  // only 0s and 255s
    uint8_t trial[16];
    const float err = detail::bc4_assign(values, in_lo, in_hi, trial);  // e0 <= e1: six-value mode
    if (err < best) {
      best = err, e0 = in_lo, e1 = in_hi;
      for (int t = 0; t < 16; ++t) index[t] = trial[t];
    }
  }
  detail::bc4_write(e0, e1, index, out);
  return best;
}

/// Encodes a decoded tile (`values`: side² texels × 4 components, row-major) into the two-plane
/// BC5 layout `blocks` (cache_bc5_tile_bytes(side) bytes: plane p holds components 2p and 2p + 1,
/// block (bx, by) of plane p at ((p · n + by) · n + bx) · 16 with n = side / 4). Returns the
/// slot's map (encode_cache_tile_unorm8's, the same for both planes); `scratch` holds the unorm8
/// texels (side² · 4 bytes). Returns a zero map and writes nothing when a size does not fit.
/// noexcept, no allocation.
inline CacheSlotMap encode_cache_tile_bc5(std::span<const float> values, uint32_t side, std::span<uint8_t> scratch,
                                          std::span<uint8_t> blocks) noexcept {
  const size_t texels = size_t{side} * side;
  if (side == 0 || side % 4 != 0 || values.size() != texels * 4 || scratch.size() < texels * 4 ||
      blocks.size() < cache_bc5_tile_bytes(side))
    return CacheSlotMap{};
  const CacheSlotMap map = encode_cache_tile_unorm8(values, scratch);
  const uint32_t n = side / 4;
  for (uint32_t plane = 0; plane < 2; ++plane)
    for (uint32_t by = 0; by < n; ++by)
      for (uint32_t bx = 0; bx < n; ++bx) {
        uint8_t* block = blocks.data() + ((size_t{plane} * n + by) * n + bx) * kBc5BlockBytes;
        for (uint32_t half = 0; half < 2; ++half) {
          const uint32_t c = 2 * plane + half;
          uint8_t v[16];
          for (uint32_t y = 0; y < 4; ++y)
            for (uint32_t x = 0; x < 4; ++x) v[y * 4 + x] = scratch[((size_t{by} * 4 + y) * side + bx * 4 + x) * 4 + c];
          encode_bc4_block(v, block + half * kBc4BlockBytes);
        }
      }
  return map;
}

/// Reference decoder of the two-plane BC5 layout: side² texels × 4 mapped values (offset + scale
/// · decoded unorm), what the GPU's fetch followed by the shaders' map returns at texel centres.
/// Writes nothing when a size does not fit. noexcept, no allocation.
inline void decode_cache_tile_bc5(std::span<const uint8_t> blocks, uint32_t side, const CacheSlotMap& map,
                                  std::span<float> values) noexcept {
  const size_t texels = size_t{side} * side;
  if (side == 0 || side % 4 != 0 || values.size() != texels * 4 || blocks.size() < cache_bc5_tile_bytes(side)) return;
  const uint32_t n = side / 4;
  for (uint32_t plane = 0; plane < 2; ++plane)
    for (uint32_t by = 0; by < n; ++by)
      for (uint32_t bx = 0; bx < n; ++bx) {
        const uint8_t* block = blocks.data() + ((size_t{plane} * n + by) * n + bx) * kBc5BlockBytes;
        for (uint32_t half = 0; half < 2; ++half) {
          const uint32_t c = 2 * plane + half;
          float v[16];
          decode_bc4_block(block + half * kBc4BlockBytes, v);
          for (uint32_t y = 0; y < 4; ++y)
            for (uint32_t x = 0; x < 4; ++x)
              values[((size_t{by} * 4 + y) * side + bx * 4 + x) * 4 + c] = map.offset[c] + map.scale[c] * v[y * 4 + x];
        }
      }
}

}  // namespace btflod
