// btflod — tile identifiers: (virtual texture, level, x, y) packed into one 64-bit key.
//
// Levels follow paper 000 §3: level 0 is the coarsest (one tile covers the whole virtual
// texture), level L the finest; at level l the texture is 2^l × 2^l tiles (for square
// textures; see vt/ for the general layout). GPU mip numbers are mip = L − level.
//
// Bit layout of the key (most significant first):
//   [63..40] virtual texture (24 bits, < 16,777,216 virtual textures)
//   [39..32] level           (8 bits; levels ≤ kMaxTileLevel)
//   [31..16] tile y          (16 bits)
//   [15..0]  tile x          (16 bits)
// so sorting keys sorts by texture, then coarse-to-fine, then row-major.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>  // declares std::hash (as <functional> does) without <functional>'s weight

namespace btflod {

inline constexpr uint32_t kMaxVirtualTextures = 1u << 24;
inline constexpr uint32_t kMaxTileLevel = 15;  ///< 2^15 tiles per side at the finest level

struct TileId {
  uint32_t texture = 0;  ///< virtual texture index, < kMaxVirtualTextures
  uint32_t level = 0;    ///< paper 000 level, 0 = coarsest
  uint32_t x = 0;        ///< tile column at this level
  uint32_t y = 0;        ///< tile row at this level

  /// True when every field fits its bit budget and x, y < 2^level.
  constexpr bool valid() const noexcept {
    return texture < kMaxVirtualTextures && level <= kMaxTileLevel && x < (1u << level) && y < (1u << level);
  }
  constexpr uint64_t key() const noexcept {
    return (static_cast<uint64_t>(texture) << 40) | (static_cast<uint64_t>(level & 0xffu) << 32) |
           (static_cast<uint64_t>(y & 0xffffu) << 16) | static_cast<uint64_t>(x & 0xffffu);
  }
  static constexpr TileId from_key(uint64_t key) noexcept {
    return TileId{static_cast<uint32_t>(key >> 40), static_cast<uint32_t>((key >> 32) & 0xffu),
                  static_cast<uint32_t>(key & 0xffffu), static_cast<uint32_t>((key >> 16) & 0xffffu)};
  }
  /// The parent one level coarser. Precondition: level > 0.
  constexpr TileId parent() const noexcept { return TileId{texture, level - 1, x >> 1, y >> 1}; }
  /// Child i (0..3: x bit = i & 1, y bit = i >> 1) one level finer.
  constexpr TileId child(uint32_t i) const noexcept {
    return TileId{texture, level + 1, (x << 1) | (i & 1u), (y << 1) | (i >> 1)};
  }
  /// The ancestor at a coarser level. Precondition: ancestor_level <= level.
  constexpr TileId ancestor(uint32_t ancestor_level) const noexcept {
    const uint32_t shift = level - ancestor_level;
    return TileId{texture, ancestor_level, x >> shift, y >> shift};
  }
  /// True when `other` is this tile or lies below it in the hierarchy.
  constexpr bool covers(const TileId& other) const noexcept {
    return other.texture == texture && other.level >= level && other.ancestor(level) == *this;
  }
  friend constexpr bool operator==(const TileId&, const TileId&) = default;
};

/// GPU mip number of a paper-000 level for a hierarchy whose finest level is finest_level.
constexpr uint32_t mip_from_level(uint32_t level, uint32_t finest_level) noexcept { return finest_level - level; }
/// Paper-000 level of a GPU mip number.
constexpr uint32_t level_from_mip(uint32_t mip, uint32_t finest_level) noexcept { return finest_level - mip; }

}  // namespace btflod

/// Hash of a tile id (its key, mixed): TileId can key unordered containers.
template <>
struct std::hash<btflod::TileId> {
  size_t operator()(const btflod::TileId& t) const noexcept {
    const uint64_t k = t.key() * 0x9e3779b97f4a7c15ull;
    return static_cast<size_t>(k ^ (k >> 32));
  }
};
