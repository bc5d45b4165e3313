// btflod — the one description of the physical tile cache, shared by the tile cache
// (runtime/vt/tile_cache.hpp), the scheduler, the runtime (runtime/streamer.hpp) and the shader
// generator (runtime/shader/shader_config.hpp's VirtualTextureConfig derives from it), so the slot
// grid the bookkeeping hands out is the grid the shaders address.
//
// The cache is a 2D-array texture of `cache_layers` layers, each slots_x × slots_y slots of
// (tile_size + 2·border)² texels (paper 000 §7: T = 64, B = 4). Slot s lives in layer
// s / (slots_x·slots_y), column (s mod slots_x·slots_y) mod slots_x, row
// (s mod slots_x·slots_y) / slots_x.
#pragma once

#include <cstdint>

namespace btflod {

/// Page-table entry (paper 000 §3 lookup table L: level l' and cache position i'), the one
/// encoding the tile cache writes and the shaders read. One R32UI texel: bits [23..0] cache
/// slot, bits [31..24] resident level l' (paper numbering, 0 = coarsest).
inline constexpr uint32_t kPageEntrySlotBits = 24;
inline constexpr uint32_t kPageEntrySlotMask = (1u << kPageEntrySlotBits) - 1u;
constexpr uint32_t pack_page_entry(uint32_t slot, uint32_t resident_level) noexcept {
  return (resident_level << kPageEntrySlotBits) | (slot & kPageEntrySlotMask);
}
constexpr uint32_t unpack_page_entry_slot(uint32_t entry) noexcept { return entry & kPageEntrySlotMask; }
constexpr uint32_t unpack_page_entry_level(uint32_t entry) noexcept { return entry >> kPageEntrySlotBits; }

/// Most cache pools one TileCache (and one Streamer) keeps: each pool is a cache texture of its
/// own shape and format (CacheConfig), with its own slots and free list (docs/vt.md, "Cache
/// pools"). A fixed bound so the per-pool tables live inside the objects (nothing allocated).
inline constexpr uint32_t kMaxCachePools = 8;

/// Texel format of the physical tile cache (runtime/vt/cache_format.hpp).
enum class CacheFormat : uint8_t {
  rgba16f = 0,       ///< the decoded values as half floats: 8 bytes per texel
  rgba8_affine = 1,  ///< unorm8 with a per-slot, per-component offset and scale: 4 bytes per texel + 16 per slot
  /// rgba8_affine's map over two BC5 (RGTC2) planes (runtime/vt/cache_bc5.hpp): 2 bytes per texel + 16 per
  /// slot; the slot side T + 2B must be a multiple of 4 (whole 4 × 4 blocks per slot).
  bc5_affine = 2,
};

/// True for the formats that keep a per-slot affine map (CacheSlotMap) in a slot-map table.
constexpr bool cache_format_has_slot_map(CacheFormat f) noexcept {
  return f == CacheFormat::rgba8_affine || f == CacheFormat::bc5_affine;
}

/// Shape of the physical tile cache. Plain value type, constexpr queries, no allocation.
/// The first three members keep the order of the former TileCacheConfig, so `{slots_x,
/// slots_y}` and `{slots_x, slots_y, delta_capacity}` initialisers keep their meaning.
struct CacheConfig {
  uint32_t slots_x = 16;  ///< slots per cache row
  uint32_t slots_y = 16;  ///< slot rows per cache layer
  /// Page-table deltas the tile cache keeps between clear_deltas() calls (runtime/vt/tile_cache.hpp);
  /// beyond it the backend must upload whole page tables. Not used by the shaders.
  uint32_t delta_capacity = 1u << 16;
  uint32_t tile_size = 64;                    ///< T, texels per tile side without border
  uint32_t border = 4;                        ///< B, texels of border on each side (≥ 1 for bilinear)
  uint32_t cache_layers = 1;                  ///< layers of the cache array texture
  CacheFormat format = CacheFormat::rgba16f;  ///< texel format of the cache texture

  /// T + 2B: side of one slot in texels.
  constexpr uint32_t padded_tile_size() const noexcept { return tile_size + 2 * border; }
  /// Slots over all layers.
  constexpr uint32_t slot_count() const noexcept { return slots_x * slots_y * cache_layers; }
  /// Width of one cache layer in texels.
  constexpr uint32_t cache_width() const noexcept { return slots_x * padded_tile_size(); }
  /// Height of one cache layer in texels.
  constexpr uint32_t cache_height() const noexcept { return slots_y * padded_tile_size(); }
  /// Bytes of one cache texel in `format` (bc5_affine: a 16-byte block holds two components of
  /// 4 × 4 texels, in two planes).
  constexpr uint32_t texel_bytes() const noexcept {
    return format == CacheFormat::rgba8_affine ? 4 : format == CacheFormat::bc5_affine ? 2 : 8;
  }
  /// Bytes of the cache texture in `format` (what a GPU backend allocates).
  constexpr uint64_t cache_bytes() const noexcept {
    return static_cast<uint64_t>(cache_width()) * cache_height() * cache_layers * texel_bytes();
  }
  /// Bytes of the per-slot map table (RGBA32UI, one texel per slot; rgba8_affine and bc5_affine,
  /// else 0).
  constexpr uint64_t slot_map_bytes() const noexcept {
    return cache_format_has_slot_map(format) ? static_cast<uint64_t>(slot_count()) * 16 : 0;
  }
  /// True when the slot side suits the format: a multiple of 4 for bc5_affine (a slot is whole
  /// BC5 blocks), any side for the others.
  constexpr bool slot_side_fits_format() const noexcept {
    return format != CacheFormat::bc5_affine || padded_tile_size() % 4 == 0;
  }
  /// True when every size is positive, the border is smaller than the tile, the slot count
  /// fits the 24-bit slot field of a page-table entry, the format is known and the slot side
  /// suits it (slot_side_fits_format).
  constexpr bool valid() const noexcept {
    const uint64_t slots = static_cast<uint64_t>(slots_x) * slots_y * cache_layers;
    return slots_x > 0 && slots_y > 0 && cache_layers > 0 && tile_size > 0 && border < tile_size && slots > 0 &&
           slots < (1u << 24) &&
           (format == CacheFormat::rgba16f || format == CacheFormat::rgba8_affine ||
            format == CacheFormat::bc5_affine) &&
           slot_side_fits_format();
  }
};

/// Texel origin (top-left of the padded slot, border included) and layer of a cache slot.
struct CacheSlotPlacement {
  uint32_t x = 0;
  uint32_t y = 0;
  uint32_t layer = 0;
};

/// Where slot `slot` lives in the cache texture. Precondition: slot < config.slot_count().
constexpr CacheSlotPlacement cache_slot_placement(const CacheConfig& c, uint32_t slot) noexcept {
  const uint32_t per_layer = c.slots_x * c.slots_y;
  const uint32_t r = slot % per_layer;
  return CacheSlotPlacement{(r % c.slots_x) * c.padded_tile_size(), (r / c.slots_x) * c.padded_tile_size(),
                            slot / per_layer};
}

}  // namespace btflod
