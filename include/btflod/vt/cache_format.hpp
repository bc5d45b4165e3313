// btflod — the texel formats of the physical tile cache (CacheConfig::format) and the encoder
// of the compact one.
//
// rgba16f keeps the decoded eigen-texture values as half floats, 8 bytes per texel.
// rgba8_affine keeps 4 bytes per texel: each slot stores its tile as unorm8 with one offset and
// one scale per component (CacheSlotMap), value = offset + scale · unorm, unorm = q / 255. The
// map is affine and the same over the whole slot, so the GPU's bilinear filter of the unorm
// texels followed by the map equals the bilinear filter of the mapped values: the shaders apply
// the map once, after the fetch (shader/glsl_generator.hpp's cache_sample). The map of each
// slot reaches the shaders through a small RGBA32F table (two texels per slot, see
// cache_slot_map_texel()), written when the slot's tile is uploaded.
//
// Quantisation error: at most scale / 510 per component and texel (half a step of 255), i.e.
// 1/510 of that component's range inside the tile. Eigen-textures are smooth inside a 72²
// tile, so the range of one tile is a fraction of the material's and the error is below what
// the tile codec already loses (docs/bsvtf_format.md, "Cache formats").
//
// Everything here is per-frame code: noexcept, no allocation, safe for any float input (NaN
// maps to the offset, values beyond the half range saturate at ±65504 as rgba16f would).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "btflod/core/half.hpp"
#include "btflod/vt/cache_config.hpp"

namespace btflod {

/// Per-slot affine map of an rgba8_affine cache slot: component c of a texel is
/// offset[c] + scale[c] · (q / 255). 32 bytes; the layout of the two RGBA32F texels of the
/// slot-map table (offset first, then scale).
struct CacheSlotMap {
  float offset[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  float scale[4] = {0.0f, 0.0f, 0.0f, 0.0f};
};
static_assert(sizeof(CacheSlotMap) == 32, "two RGBA32F texels");

/// Name of a cache format ("rgba16f", "rgba8_affine").
constexpr const char* cache_format_name(CacheFormat f) noexcept {
  return f == CacheFormat::rgba8_affine ? "rgba8_affine" : "rgba16f";
}

/// Where the two texels of slot `slot`'s map live in the slot-map table
/// (cache_slot_map_width() × cache_slot_map_height() RGBA32F texels): offset at (x, y), scale at
/// (x + 1, y), with x = 2 · column and y = layer · slots_y + row of the slot in the cache.
/// Precondition: slot < c.slot_count(). constexpr, noexcept.
struct CacheSlotMapTexel {
  uint32_t x = 0;
  uint32_t y = 0;
};
constexpr CacheSlotMapTexel cache_slot_map_texel(const CacheConfig& c, uint32_t slot) noexcept {
  const uint32_t per_layer = c.slots_x * c.slots_y;
  const uint32_t r = slot % per_layer;
  return CacheSlotMapTexel{2 * (r % c.slots_x), (slot / per_layer) * c.slots_y + r / c.slots_x};
}
/// Width and height of the slot-map table in texels.
constexpr uint32_t cache_slot_map_width(const CacheConfig& c) noexcept { return 2 * c.slots_x; }
constexpr uint32_t cache_slot_map_height(const CacheConfig& c) noexcept { return c.slots_y * c.cache_layers; }

/// Decodes one unorm8 value of component `c` through `map` (what the shaders compute after the
/// fetch). Precondition: c < 4. constexpr, noexcept.
constexpr float decode_cache_unorm8(const CacheSlotMap& map, uint32_t c, uint8_t q) noexcept {
  return map.offset[c] + map.scale[c] * (static_cast<float>(q) * (1.0f / 255.0f));
}

namespace detail {
inline float saturate_to_half_range(float v) noexcept {
  constexpr float kHalfMax = 65504.0f;
  return v != v ? v : std::clamp(v, -kHalfMax, kHalfMax);  // NaN kept for the caller
}
}  // namespace detail

/// Encodes one tile of RGBA values (`values`: texels · 4 floats, component-interleaved) into
/// `out` (texels · 4 bytes, same order) with the per-component range of the tile, and returns
/// the map that decodes it: offset = the component's minimum, scale = its range (0 for a
/// constant component, which then decodes exactly). Each byte is round((v − offset) / scale ·
/// 255). NaN counts as no value and encodes to 0; ±∞ and values beyond ±65504 saturate there.
/// Returns a zero map and writes nothing when out.size() < values.size() or values.size() is not
/// a multiple of 4. noexcept, no allocation, thread-safe.
inline CacheSlotMap encode_cache_tile_unorm8(std::span<const float> values, std::span<uint8_t> out) noexcept {
  CacheSlotMap map;
  if (values.size() % 4 != 0 || out.size() < values.size()) return map;
  float lo[4] = {INFINITY, INFINITY, INFINITY, INFINITY}, hi[4] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
  const size_t n = values.size() / 4;
  for (size_t i = 0; i < n; ++i)
    for (uint32_t c = 0; c < 4; ++c) {
      const float v = detail::saturate_to_half_range(values[i * 4 + c]);
      lo[c] = v < lo[c] ? v : lo[c];  // NaN compares false: ignored
      hi[c] = v > hi[c] ? v : hi[c];
    }
  float inv[4];
  for (uint32_t c = 0; c < 4; ++c) {
    if (!(lo[c] <= hi[c])) lo[c] = hi[c] = 0.0f;  // no finite value
    map.offset[c] = lo[c];
    map.scale[c] = hi[c] - lo[c];  // ≤ 131008: finite
    inv[c] = map.scale[c] > 0.0f ? 255.0f / map.scale[c] : 0.0f;
  }
  for (size_t i = 0; i < n; ++i)
    for (uint32_t c = 0; c < 4; ++c) {
      const float v = detail::saturate_to_half_range(values[i * 4 + c]);
      const float t = (v - lo[c]) * inv[c] + 0.5f;                    // NaN stays NaN
      const float q = t >= 0.0f ? (t <= 255.0f ? t : 255.0f) : 0.0f;  // NaN → 0
      out[i * 4 + c] = static_cast<uint8_t>(q);
    }
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
