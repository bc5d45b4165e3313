// btflod — geometry of the tile hierarchy of one virtual texture, the FMF input of the sparse
// virtual texture path, and the set of virtual textures (several materials) that share a cache.
//
// Paper 000 §3: an M×N image is cut into tiles of T×T texels at levels l = 0 … L (0 = coarsest,
// one tile), where level l is the image down-sampled to ⌈M / 2^(L−l)⌉ × ⌈N / 2^(L−l)⌉ texels and
// L is the smallest level with max(M, N) ≤ T·2^L. Tiles sit on a grid aligned to the origin, so
// the parent of tile (x, y) at level l is (x >> 1, y >> 1) at level l − 1 for any M×N; tiles that
// would lie completely outside a non-square or non-power-of-two texture do not exist:
//   tiles_x(l) = ⌈M / (T·2^(L−l))⌉,  tiles_y(l) = ⌈N / (T·2^(L−l))⌉.
// Each stored tile carries B texels of border on each side ((T + 2B)² texels) so that bilinear
// filtering in the physical cache is seamless.
//
// Paper 000 §5 / §7: the C eigen-textures V'_c of an FMF material are packed four per RGBA texel,
// so a material gives ⌈C/4⌉ virtual textures that share the material's geometry (and its votes,
// "repeated in the spatial layout of the components").
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/core/allocator.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/lod/feedback.hpp"
#include "btflod/vt/tile_id.hpp"

namespace btflod {

inline constexpr uint32_t kDefaultTileSize = 64;    ///< T of paper 000 §7
inline constexpr uint32_t kDefaultTileBorder = 4;   ///< B: texels of padding per side (paper 000 §7)
inline constexpr uint32_t kComponentsPerTexel = 4;  ///< eigen-texture components per RGBA texel

/// Shape of the tile hierarchy of one M×N virtual texture. Plain value type; all queries are
/// constexpr-cheap, thread-safe and allocation-free.
struct VtGeometry {
  uint32_t width = 0;                     ///< M, finest-level texels
  uint32_t height = 0;                    ///< N, finest-level texels
  uint32_t tile_size = kDefaultTileSize;  ///< T
  uint32_t border = kDefaultTileBorder;   ///< B
  uint32_t finest_level = 0;              ///< L

  /// Geometry for an M×N texture. Precondition: width, height, tile_size > 0. L is the smallest
  /// level with max(M, N) ≤ T·2^L (paper 000 §3); L is capped at kMaxTileLevel (check valid()).
  static constexpr VtGeometry make(uint32_t width, uint32_t height, uint32_t tile_size = kDefaultTileSize,
                                   uint32_t border = kDefaultTileBorder) noexcept {
    VtGeometry g{width, height, tile_size, border, 0};
    const uint64_t largest = std::max(width, height);
    while (g.finest_level < kMaxTileLevel && (static_cast<uint64_t>(tile_size) << g.finest_level) < largest)
      ++g.finest_level;
    return g;
  }
  /// True when sizes are positive and the hierarchy fits the tile-id bit budget.
  constexpr bool valid() const noexcept {
    return width > 0 && height > 0 && tile_size > 0 && border < tile_size &&
           (static_cast<uint64_t>(tile_size) << finest_level) >= std::max(width, height);
  }
  /// L + 1.
  uint32_t level_count() const noexcept { return finest_level + 1; }
  /// Side of a stored tile including both borders: T + 2B.
  constexpr uint32_t stored_size() const noexcept { return tile_size + 2 * border; }
  /// Width of the level-l image in texels: ⌈M / 2^(L−l)⌉. Precondition: level ≤ L.
  constexpr uint32_t level_width(uint32_t level) const noexcept {
    const uint32_t s = finest_level - level;
    return static_cast<uint32_t>((static_cast<uint64_t>(width) + (1ull << s) - 1) >> s);
  }
  /// Height of the level-l image in texels: ⌈N / 2^(L−l)⌉. Precondition: level ≤ L.
  constexpr uint32_t level_height(uint32_t level) const noexcept {
    const uint32_t s = finest_level - level;
    return static_cast<uint32_t>((static_cast<uint64_t>(height) + (1ull << s) - 1) >> s);
  }
  /// Tiles per row at level l. Precondition: level ≤ L.
  constexpr uint32_t tiles_x(uint32_t level) const noexcept { return (level_width(level) + tile_size - 1) / tile_size; }
  /// Tiles per column at level l. Precondition: level ≤ L.
  constexpr uint32_t tiles_y(uint32_t level) const noexcept {
    return (level_height(level) + tile_size - 1) / tile_size;
  }
  /// Index of the first tile of level l in a flat per-texture array ordered coarse to fine,
  /// row-major inside a level. level may be L + 1 (gives tile_count()).
  constexpr uint32_t level_offset(uint32_t level) const noexcept {
    uint32_t off = 0;
    for (uint32_t l = 0; l < level; ++l) off += tiles_x(l) * tiles_y(l);
    return off;
  }
  /// Number of tiles over all levels.
  constexpr uint32_t tile_count() const noexcept { return level_offset(finest_level + 1); }
  /// True when the tile exists in this hierarchy (texture field not checked).
  constexpr bool contains(const TileId& t) const noexcept {
    return t.level <= finest_level && t.x < tiles_x(t.level) && t.y < tiles_y(t.level);
  }
};

/// Precomputed per-level offsets of a VtGeometry, for per-frame index arithmetic without loops.
struct VtLevelTable {
  VtGeometry geometry;
  uint32_t offset[kMaxTileLevel + 2] = {};
  uint32_t tiles_x[kMaxTileLevel + 1] = {};
  uint32_t tiles_y[kMaxTileLevel + 1] = {};

  VtLevelTable() = default;
  /// Precomputes offsets and tile counts of every level of g. Precondition: g.valid().
  explicit VtLevelTable(const VtGeometry& g) noexcept : geometry(g) {
    uint32_t off = 0;
    for (uint32_t l = 0; l <= g.finest_level; ++l) {
      offset[l] = off;
      tiles_x[l] = g.tiles_x(l);
      tiles_y[l] = g.tiles_y(l);
      off += tiles_x[l] * tiles_y[l];
    }
    offset[g.finest_level + 1] = off;
  }
  /// L.
  uint32_t finest_level() const noexcept { return geometry.finest_level; }
  /// Tiles over all levels.
  uint32_t tile_count() const noexcept { return offset[geometry.finest_level + 1]; }
  /// Flat index of tile (level, x, y). Precondition: the tile exists.
  uint32_t index(uint32_t level, uint32_t x, uint32_t y) const noexcept {
    return offset[level] + y * tiles_x[level] + x;
  }
  /// Flat index of t (texture field ignored). Precondition: the tile exists.
  uint32_t index(const TileId& t) const noexcept { return index(t.level, t.x, t.y); }
  /// Inverse of index(): the tile with flat index i of virtual texture `texture`.
  /// Precondition: i < tile_count(). O(L).
  TileId tile(uint32_t texture, uint32_t i) const noexcept {
    uint32_t l = 0;
    while (i >= offset[l + 1]) ++l;
    const uint32_t r = i - offset[l];
    return TileId{texture, l, r % tiles_x[l], r / tiles_x[l]};
  }
};

/// The input of the sparse-virtual-texture path: an FMF material B ≈ U'·V'ᵀ (paper 000 eq. 5)
/// from any factorisation. Σ is folded into the eigen-textures (V := VΣ).
struct EigenTextures {
  /// V': M×N texels with C channels; channel c is eigen-texture V'_c.
  Image<float> textures;
  /// U': row-major, rows = (light · view_count + view) · 3 + colour, columns = C.
  std::vector<float> angular;
  uint32_t light_count = 0;
  uint32_t view_count = 0;

  /// C, the number of eigen-texture components.
  uint32_t components() const noexcept { return static_cast<uint32_t>(textures.channels()); }
  /// Number of RGBA virtual textures for C components: ⌈C/4⌉.
  uint32_t virtual_texture_count() const noexcept {
    return (components() + kComponentsPerTexel - 1) / kComponentsPerTexel;
  }
  /// U'(row, c). Precondition: indices in range.
  float u(uint32_t light, uint32_t view, uint32_t colour, uint32_t c) const noexcept {
    return angular[(static_cast<size_t>(light * view_count + view) * 3 + colour) * components() + c];
  }
  /// True when the angular matrix has rows · C entries and the texture is non-empty.
  bool valid() const noexcept {
    return !textures.empty() && components() > 0 && light_count > 0 && view_count > 0 &&
           angular.size() == static_cast<size_t>(light_count) * view_count * 3 * components();
  }
};

/// One material in a VtSet: its geometry and the range of virtual textures it owns.
struct VtMaterial {
  VtLevelTable levels;
  uint32_t first_texture = 0;  ///< index of its first virtual texture in the set
  uint32_t texture_count = 0;  ///< ⌈C/4⌉
};

/// Every virtual texture that shares one tile cache, grouped by material, with the per-tile
/// values the scheduler needs (no texel data): w(i, l, l−1) of paper 000 eq. 8 and the mean
/// squared norm of the tile ‖T‖²_F / T² (§6), both stored as half as in §7.
/// Built at set-up (allocates, through the RuntimeAllocator given at construction or operator
/// new); read-only and thread-safe afterwards.
class VtSet {
 public:
  /// An empty set allocating through operator new.
  VtSet() = default;
  /// An empty set allocating through `allocator`'s callbacks (a failing callback aborts).
  explicit VtSet(const RuntimeAllocator& allocator)
      : materials_(CallbackAllocator<VtMaterial>(allocator)),
        texture_material_(CallbackAllocator<uint32_t>(allocator)),
        texture_offset_(CallbackAllocator<uint32_t>(allocator)),
        weights_(CallbackAllocator<Half>(allocator)),
        energies_(CallbackAllocator<Half>(allocator)) {}
  /// A copy of `other` allocating through `allocator`.
  VtSet(const VtSet& other, const RuntimeAllocator& allocator) : VtSet(allocator) {
    materials_.assign(other.materials_.begin(), other.materials_.end());
    texture_material_.assign(other.texture_material_.begin(), other.texture_material_.end());
    texture_offset_.assign(other.texture_offset_.begin(), other.texture_offset_.end());
    weights_.assign(other.weights_.begin(), other.weights_.end());
    energies_.assign(other.energies_.begin(), other.energies_.end());
  }

  /// Adds a material of `texture_count` virtual textures; weights start at 1 and energies at 0.
  /// Returns the material index. Precondition: geometry.valid(), texture_count > 0.
  /// Spans from weights() / energies() taken before this call are invalidated.
  uint32_t add_material(const VtGeometry& geometry, uint32_t texture_count) {
    VtMaterial m;
    m.levels = VtLevelTable(geometry);
    m.first_texture = static_cast<uint32_t>(texture_material_.size());
    m.texture_count = texture_count;
    for (uint32_t k = 0; k < texture_count; ++k) {
      texture_material_.push_back(static_cast<uint32_t>(materials_.size()));
      texture_offset_.push_back(static_cast<uint32_t>(weights_.size()));
      weights_.insert(weights_.end(), m.levels.tile_count(), Half(1.0f));
      energies_.insert(energies_.end(), m.levels.tile_count(), Half(0.0f));
    }
    materials_.push_back(m);
    return static_cast<uint32_t>(materials_.size() - 1);
  }
  /// Materials added so far.
  uint32_t material_count() const noexcept { return static_cast<uint32_t>(materials_.size()); }
  /// Virtual textures over all materials (indices are stable).
  uint32_t texture_count() const noexcept { return static_cast<uint32_t>(texture_material_.size()); }
  /// Material m. Precondition: m < material_count().
  const VtMaterial& material(uint32_t m) const noexcept { return materials_[m]; }
  /// Material owning a virtual texture. Precondition: texture < texture_count().
  uint32_t material_of(uint32_t texture) const noexcept { return texture_material_[texture]; }
  /// Hierarchy of a virtual texture (its material's). Precondition: texture in range.
  const VtLevelTable& levels_of(uint32_t texture) const noexcept {
    return materials_[texture_material_[texture]].levels;
  }
  /// w(i, l, l−1) per tile (flat index), paper 000 eq. 8. For the root: mean squared norm.
  std::span<Half> weights(uint32_t texture) noexcept {
    return {weights_.data() + texture_offset_[texture], tiles(texture)};
  }
  /// Read-only w per tile. Precondition: texture in range.
  std::span<const Half> weights(uint32_t texture) const noexcept {
    return {weights_.data() + texture_offset_[texture], tiles(texture)};
  }
  /// ‖T‖²_F / T² per tile (flat index), paper 000 §6.
  std::span<Half> energies(uint32_t texture) noexcept {
    return {energies_.data() + texture_offset_[texture], tiles(texture)};
  }
  /// Read-only ‖T‖²_F / T² per tile. Precondition: texture in range.
  std::span<const Half> energies(uint32_t texture) const noexcept {
    return {energies_.data() + texture_offset_[texture], tiles(texture)};
  }

 private:
  size_t tiles(uint32_t texture) const noexcept { return levels_of(texture).tile_count(); }
  std::vector<VtMaterial, CallbackAllocator<VtMaterial>> materials_;
  std::vector<uint32_t, CallbackAllocator<uint32_t>> texture_material_;
  std::vector<uint32_t, CallbackAllocator<uint32_t>> texture_offset_;  // per texture: first tile in weights_
  std::vector<Half, CallbackAllocator<Half>> weights_;                 // every texture's tiles, in order
  std::vector<Half, CallbackAllocator<Half>> energies_;
};

/// The shape a VoteCounter needs for one material, one entry per material of the set, in order.
/// Allocates (set-up only).
inline std::vector<VoteLayout> vote_layouts(const VtSet& set) {
  std::vector<VoteLayout> out;
  for (uint32_t m = 0; m < set.material_count(); ++m) {
    const VtLevelTable& lv = set.material(m).levels;
    out.push_back(VoteLayout{lv.finest_level(), lv.tiles_x[lv.finest_level()], lv.tiles_y[lv.finest_level()]});
  }
  return out;
}

}  // namespace btflod
