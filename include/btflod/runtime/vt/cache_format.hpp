// btflod — the texel formats of the physical tile cache (CacheConfig::format) and the encoder
// of the compact one.
//
// rgba16f keeps the decoded eigen-texture values as half floats, 8 bytes per texel.
// rgba8_affine keeps 4 bytes per texel: each slot stores its tile as unorm8 with one offset and
// one scale per component (CacheSlotMap), value = offset + scale · unorm, unorm = q / 255. The
// map is affine and the same over the whole slot, so the GPU's bilinear filter of the unorm
// texels followed by the map equals the bilinear filter of the mapped values: the shaders apply
// the map once, after the fetch (runtime/shader/glsl_generator.hpp's cache_sample). The map of each
// slot reaches the shaders through a small RGBA32UI table, one texel per slot holding the eight
// values as halves (pack_cache_slot_map, unpackHalf2x16 in the shader): one extra fetch per
// cache sample. The encoder picks offsets and scales that are halves (offset rounded down,
// scale up), so the packed map is exactly the map the bytes were quantised against.
//
// Quantisation error: at most scale / 510 per component and texel (half a step of 255); scale is
// the component's range inside the tile, widened by the half rounding of the offset (at most
// |offset| · 2^-11, the precision rgba16f itself stores such values with). Eigen-textures are
// smooth inside a 72² tile, so the range of one tile is a fraction of the material's
// (docs/bsvtf_format.md, "Cache formats", has the rendered error).
//
// Everything here is per-frame code: noexcept, no allocation, safe for any float input (NaN
// maps to the offset, values beyond ±32752 saturate there so that every range fits a half).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "btflod/core/half.hpp"
#include "btflod/runtime/vt/cache_config.hpp"

namespace btflod {

/// Per-slot affine map of an rgba8_affine cache slot: component c of a texel is
/// offset[c] + scale[c] · (q / 255). The encoder makes every value 0 or a normal half
/// (pack_cache_slot_map stores them so; the shaders widen them exactly).
struct CacheSlotMap {
  float offset[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  float scale[4] = {0.0f, 0.0f, 0.0f, 0.0f};
};

/// Name of a cache format ("rgba16f", "rgba8_affine", "bc5_affine").
constexpr const char* cache_format_name(CacheFormat f) noexcept {
  return f == CacheFormat::rgba8_affine ? "rgba8_affine" : f == CacheFormat::bc5_affine ? "bc5_affine" : "rgba16f";
}

/// The slot-map table texel of a slot: one RGBA32UI texel, (half offset0 | half offset1 << 16,
/// offset2 | offset3 << 16, scale0 | scale1 << 16, scale2 | scale3 << 16), what GLSL's
/// unpackHalf2x16 (HLSL f16tof32 of the low and high halves) reads. Values that are not halves
/// are rounded to the nearest. constexpr, noexcept.
constexpr std::array<uint32_t, 4> pack_cache_slot_map(const CacheSlotMap& m) noexcept {
  const auto pair = [](float lo, float hi) {
    return uint32_t{float_to_half_bits(lo)} | (uint32_t{float_to_half_bits(hi)} << 16);
  };
  return {pair(m.offset[0], m.offset[1]), pair(m.offset[2], m.offset[3]), pair(m.scale[0], m.scale[1]),
          pair(m.scale[2], m.scale[3])};
}

/// Where slot `slot`'s map lives in the slot-map table (cache_slot_map_width() ×
/// cache_slot_map_height() RGBA32UI texels): x = column, y = layer · slots_y + row of the slot
/// in the cache. Precondition: slot < c.slot_count(). constexpr, noexcept.
struct CacheSlotMapTexel {
  uint32_t x = 0;
  uint32_t y = 0;
};
constexpr CacheSlotMapTexel cache_slot_map_texel(const CacheConfig& c, uint32_t slot) noexcept {
  const uint32_t per_layer = c.slots_x * c.slots_y;
  const uint32_t r = slot % per_layer;
  return CacheSlotMapTexel{r % c.slots_x, (slot / per_layer) * c.slots_y + r / c.slots_x};
}
/// Width and height of the slot-map table in texels.
constexpr uint32_t cache_slot_map_width(const CacheConfig& c) noexcept { return c.slots_x; }
constexpr uint32_t cache_slot_map_height(const CacheConfig& c) noexcept { return c.slots_y * c.cache_layers; }

/// Decodes one unorm8 value of component `c` through `map` (what the shaders compute after the
/// fetch). Precondition: c < 4. constexpr, noexcept.
constexpr float decode_cache_unorm8(const CacheSlotMap& map, uint32_t c, uint8_t q) noexcept {
  return map.offset[c] + map.scale[c] * (static_cast<float>(q) * (1.0f / 255.0f));
}

namespace detail {
// Values the rgba8_affine encoder keeps: NaN stays (ignored by the caller), the rest clamped to
// ±32752 so that any range fits a half (32752 and 65504 are halves).
inline float saturate_for_unorm8_map(float v) noexcept {
  constexpr float kLimit = 32752.0f;
  return v != v ? v : std::clamp(v, -kLimit, kLimit);
}
// Map values are 0 or normal halves (|v| ≥ 2^-14): the shaders widen them with integer
// operations and one multiply, which a GPU that flushes denormals would get wrong for half
// subnormals.
inline constexpr float kSmallestNormalHalf = 6.103515625e-05f;  // 2^-14
// The largest such value ≤ x (x finite, |x| ≤ 65504).
inline float map_half_at_or_below(float x) noexcept {
  if (x >= 0.0f && x < kSmallestNormalHalf) return 0.0f;
  if (x < 0.0f && x > -kSmallestNormalHalf) return -kSmallestNormalHalf;
  uint16_t h = float_to_half_bits(x);
  if (half_bits_to_float(h) > x) h = (h & 0x8000u) ? static_cast<uint16_t>(h + 1u) : static_cast<uint16_t>(h - 1u);
  return half_bits_to_float(h);
}
// The smallest such value ≥ x (0 ≤ x ≤ 65504).
inline float map_half_at_or_above(float x) noexcept {
  if (x <= 0.0f) return 0.0f;
  if (x < kSmallestNormalHalf) return kSmallestNormalHalf;
  uint16_t h = float_to_half_bits(x);
  if (half_bits_to_float(h) < x) ++h;
  return half_bits_to_float(h);
}
}  // namespace detail

/// Encodes one tile of RGBA values (`values`: texels · 4 floats, component-interleaved) into
/// `out` (texels · 4 bytes, same order) with the per-component range of the tile, and returns
/// the map that decodes it: offset = the component's minimum rounded down to a half, scale =
/// the rest of its range rounded up to a half (0 for a constant half value, which then decodes
/// exactly); both are 0 or normal halves (magnitudes below 2^-14 go to 0 or ±2^-14). Each byte is round((v − offset) /
/// scale · 255). NaN counts as no value and encodes to 0; ±∞ and values beyond ±32752 saturate there. Returns a zero
/// map and writes nothing when out.size() < values.size() or values.size() is not a multiple of 4. noexcept, no
/// allocation, thread-safe.
inline CacheSlotMap encode_cache_tile_unorm8(std::span<const float> values, std::span<uint8_t> out) noexcept {
  CacheSlotMap map;
  if (values.size() % 4 != 0 || out.size() < values.size()) return map;
  // Both passes run over blocks of 16 values (4 texels) with per-lane constants, a shape the
  // compiler vectorises; NaN drops out of the comparisons (a < b ? a : b keeps b).
  constexpr size_t kBlock = 16;
  const size_t n = values.size(), blocks = n / kBlock;
  const float* v = values.data();
  float lo16[kBlock], hi16[kBlock];
  for (size_t j = 0; j < kBlock; ++j) lo16[j] = INFINITY, hi16[j] = -INFINITY;
  for (size_t b = 0; b < blocks; ++b)
    for (size_t j = 0; j < kBlock; ++j) {
      const float x = v[b * kBlock + j];
      lo16[j] = x < lo16[j] ? x : lo16[j];
      hi16[j] = x > hi16[j] ? x : hi16[j];
    }
  for (size_t k = blocks * kBlock; k < n; ++k) {
    const float x = v[k];
    lo16[k % 4] = x < lo16[k % 4] ? x : lo16[k % 4];
    hi16[k % 4] = x > hi16[k % 4] ? x : hi16[k % 4];
  }
  float off16[kBlock], inv16[kBlock];
  for (uint32_t c = 0; c < 4; ++c) {
    float lo = lo16[c], hi = hi16[c];
    for (size_t j = c + 4; j < kBlock; j += 4) lo = lo16[j] < lo ? lo16[j] : lo, hi = hi16[j] > hi ? hi16[j] : hi;
    if (!(lo <= hi)) lo = hi = 0.0f;                                                     // no value that is not NaN
    lo = detail::saturate_for_unorm8_map(lo), hi = detail::saturate_for_unorm8_map(hi);  // ±∞ too
    map.offset[c] = detail::map_half_at_or_below(lo);
    map.scale[c] = detail::map_half_at_or_above(hi - map.offset[c]);  // ≤ 65504: a half
    const float inv = map.scale[c] > 0.0f ? 255.0f / map.scale[c] : 0.0f;
    for (size_t j = c; j < kBlock; j += 4) off16[j] = map.offset[c], inv16[j] = inv;
  }
  // q = round((x − offset) / scale · 255) clamped to [0, 255]; NaN → 0, ±∞ → 255 or 0.
  const auto quantise = [](float x, float off, float inv) {
    float t = (x - off) * inv + 0.5f;
    t = t > 0.0f ? t : 0.0f;  // NaN → 0
    t = t < 255.0f ? t : 255.0f;
    return static_cast<uint8_t>(static_cast<int32_t>(t));
  };
  uint8_t* o = out.data();
  for (size_t b = 0; b < blocks; ++b) {
    // Through local copies: bytes written through `o` may alias the floats (uint8_t is a character
    // type), which would keep the compiler from vectorising a loop that writes `o` directly.
    float x[kBlock];
    uint8_t q[kBlock];
    std::memcpy(x, v + b * kBlock, sizeof x);
    for (size_t j = 0; j < kBlock; ++j) q[j] = quantise(x[j], off16[j], inv16[j]);
    std::memcpy(o + b * kBlock, q, sizeof q);
  }
  for (size_t k = blocks * kBlock; k < n; ++k) o[k] = quantise(v[k], off16[k % 4], inv16[k % 4]);
  return map;
}

/// encode_cache_tile_unorm8() of a tile given as half bits (what Streamer::update hands out in
/// an rgba16f configuration, or TilePyramid::tile() holds): for a renderer that receives half
/// tiles and keeps an rgba8_affine cache. `scratch` holds at least texels · 4 floats. Returns a
/// zero map and writes nothing on a size mismatch. noexcept, no allocation.
inline CacheSlotMap encode_cache_tile_unorm8(std::span<const uint16_t> halves, std::span<float> scratch,
                                             std::span<uint8_t> out) noexcept {
  if (scratch.size() < halves.size()) return CacheSlotMap{};
  half_to_float(halves, scratch.first(halves.size()));
  return encode_cache_tile_unorm8(std::span<const float>(scratch.data(), halves.size()), out);
}

}  // namespace btflod
