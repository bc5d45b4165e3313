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
#include "btflod/core/angular_row_order.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/range_list.hpp"
#include "btflod/core/value_transform.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/vt/tile_id.hpp"

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
  /// U': row-major, C columns; rows in `row_order`: (light · view_count + view) · 3 + colour
  /// (light-major, what shaders and backends read) or (view · light_count + light) · 3 + colour
  /// (view-major, offline/factor/fmf.hpp's order).
  std::vector<float> angular;
  uint32_t light_count = 0;
  uint32_t view_count = 0;
  /// The order of `angular`'s rows; containers record it (BsvtfMetadata::u_row_order).
  AngularRowOrder row_order = AngularRowOrder::light_major;
  /// The encoding U'·V'ᵀ approximates (core/value_transform.hpp): renderers decode the sum of
  /// eq. 5 with it. Linear unless the factorisation reduced the dynamic range.
  ValueTransform transform{};

  /// C, the number of eigen-texture components.
  uint32_t components() const noexcept { return static_cast<uint32_t>(textures.channels()); }
  /// Number of RGBA virtual textures for C components: ⌈C/4⌉.
  uint32_t virtual_texture_count() const noexcept {
    return (components() + kComponentsPerTexel - 1) / kComponentsPerTexel;
  }
  /// First of the C entries of U' for (light, view, colour), in either row order. Precondition:
  /// indices in range.
  const float* u_row(uint32_t light, uint32_t view, uint32_t colour) const noexcept {
    return angular.data() + angular_row(row_order, light, view, colour, light_count, view_count) * components();
  }
  /// U'(light, view, colour, c). Precondition: indices in range.
  float u(uint32_t light, uint32_t view, uint32_t colour, uint32_t c) const noexcept {
    return u_row(light, view, colour)[c];
  }
  /// True when the angular matrix has rows · C entries in a known order and the texture is non-empty.
  bool valid() const noexcept {
    return !textures.empty() && components() > 0 && light_count > 0 && view_count > 0 &&
           row_order != AngularRowOrder::unspecified &&
           angular.size() == static_cast<size_t>(light_count) * view_count * 3 * components();
  }
};

/// One material in a VtSet: its geometry and the range of virtual textures it owns. A removed
/// (or never used) material id has texture_count 0 and an empty hierarchy.
struct VtMaterial {
  VtLevelTable levels;
  uint32_t first_texture = 0;  ///< index of its first virtual texture in the set
  uint32_t texture_count = 0;  ///< ⌈C/4⌉
  uint32_t entry_base = 0;     ///< first of its texture_count · tile_count per-tile entries
  bool live = false;
};

inline constexpr uint32_t kNoMaterial = 0xffffffffu;

/// Room a VtSet (and the tile cache, scheduler and runtime built on it) reserves for materials
/// added and removed while running. Every id and range is handed out from it without
/// allocating; 0 everywhere: no reservation (the set grows as materials are added, set-up only).
struct VtCapacity {
  uint32_t materials = 0;     ///< material ids (the feedback word holds at most 1023)
  uint32_t textures = 0;      ///< virtual textures = page-table layers and U′ packets
  uint64_t tile_entries = 0;  ///< Σ over live materials of tile_count · texture_count
};

/// Every virtual texture that shares one tile cache, grouped by material, with the per-tile
/// values the scheduler needs (no texel data): w(i, l, l−1) of paper 000 eq. 8 and the mean
/// squared norm of the tile ‖T‖²_F / T² (§6), both stored as half as in §7.
///
/// Per-tile values live in one array of "entries": material m owns texture_count · tile_count
/// consecutive entries from material(m).entry_base (texture k's tiles from texture_offset()).
/// Without a reservation the set grows as materials are added (set-up, allocates through the
/// RuntimeAllocator given at construction or operator new). With reserve(VtCapacity) every
/// material id, texture range and entry range is handed out from the reserved room: then
/// add_material() and remove_material() allocate nothing, ids are the lowest free ones and
/// ranges first-fit, so a live material's ids never move.
class VtSet {
 public:
  /// An empty set allocating through operator new.
  VtSet() = default;
  /// An empty set allocating through `allocator`'s callbacks (a failing callback aborts).
  explicit VtSet(const RuntimeAllocator& allocator)
      : materials_(CallbackAllocator<VtMaterial>(allocator)),
        texture_material_(CallbackAllocator<uint32_t>(allocator)),
        weights_(CallbackAllocator<Half>(allocator)),
        energies_(CallbackAllocator<Half>(allocator)),
        free_textures_(allocator),
        free_entries_(allocator) {}
  /// A copy of `other` (with its reservation) allocating through `allocator`.
  VtSet(const VtSet& other, const RuntimeAllocator& allocator)
      : materials_(CallbackAllocator<VtMaterial>(allocator)),
        texture_material_(CallbackAllocator<uint32_t>(allocator)),
        weights_(CallbackAllocator<Half>(allocator)),
        energies_(CallbackAllocator<Half>(allocator)),
        free_textures_(other.free_textures_, allocator),
        free_entries_(other.free_entries_, allocator),
        fixed_(other.fixed_),
        live_materials_(other.live_materials_) {
    materials_.assign(other.materials_.begin(), other.materials_.end());
    texture_material_.assign(other.texture_material_.begin(), other.texture_material_.end());
    weights_.assign(other.weights_.begin(), other.weights_.end());
    energies_.assign(other.energies_.begin(), other.energies_.end());
  }

  /// Reserves room for materials added and removed later (see the class comment). Only on an
  /// empty set; invalid_argument otherwise or when a capacity is 0. Set-up (allocates).
  Status reserve(const VtCapacity& capacity) {
    if (!materials_.empty() || capacity.materials == 0 || capacity.textures == 0 || capacity.tile_entries == 0 ||
        capacity.tile_entries >= (1ull << 32))
      return Status::invalid_argument;
    materials_.assign(capacity.materials, VtMaterial{});
    texture_material_.assign(capacity.textures, kNoMaterial);
    weights_.assign(capacity.tile_entries, Half(1.0f));
    energies_.assign(capacity.tile_entries, Half(0.0f));
    free_textures_.reset(capacity.textures, capacity.materials);
    free_entries_.reset(capacity.tile_entries, capacity.materials);
    fixed_ = true;
    return Status::success;
  }
  /// What reserve(capacity) allocates, and what a copy of such a set (VtSet(const VtSet&,
  /// allocator)) holds. No allocation.
  static AllocationTally reserved_memory(const VtCapacity& capacity) noexcept {
    AllocationTally t;
    t.array<decltype(materials_)>(capacity.materials);
    t.array<decltype(texture_material_)>(capacity.textures);
    t.array<decltype(weights_)>(capacity.tile_entries);
    t.array<decltype(energies_)>(capacity.tile_entries);
    t += detail::RangeList::reserved_memory(capacity.materials);
    t += detail::RangeList::reserved_memory(capacity.materials);
    return t;
  }
  /// True after reserve(): add/remove allocate nothing.
  bool reserved() const noexcept { return fixed_; }

  /// Adds a material of `texture_count` virtual textures; weights start at 1 and energies at 0.
  /// Returns the material index, or kNoMaterial when the reservation has no free material id,
  /// no texture_count consecutive free textures or no free entry range large enough.
  /// Precondition: geometry.valid(), texture_count > 0. Spans from weights() / energies() taken
  /// before this call are invalidated when the set grows (no reservation). With a reservation
  /// noexcept in effect (no allocation).
  /// With a reservation, `wanted` may name the free id to take (kNoMaterial: the lowest free).
  uint32_t add_material(const VtGeometry& geometry, uint32_t texture_count, uint32_t wanted = kNoMaterial) {
    const VtLevelTable levels(geometry);
    const uint64_t entries = uint64_t{levels.tile_count()} * texture_count;
    uint32_t id = kNoMaterial;
    if (fixed_) {
      if (wanted != kNoMaterial) {
        if (wanted >= materials_.size() || materials_[wanted].live) return kNoMaterial;
        id = wanted;
      }
      for (uint32_t m = 0; m < materials_.size() && id == kNoMaterial; ++m)
        if (!materials_[m].live) id = m;
      if (id == kNoMaterial) return kNoMaterial;
    } else {  // grow: room at the end
      id = static_cast<uint32_t>(materials_.size());
      materials_.push_back(VtMaterial{});
      free_textures_.grow(texture_material_.size(), texture_count);
      texture_material_.resize(texture_material_.size() + texture_count, kNoMaterial);
      free_entries_.grow(weights_.size(), entries);
      weights_.resize(weights_.size() + entries, Half(1.0f));
      energies_.resize(energies_.size() + entries, Half(0.0f));
    }
    const uint64_t first = free_textures_.allocate(texture_count);
    if (first == ~0ull) return kNoMaterial;
    const uint64_t base = free_entries_.allocate(entries);
    if (base == ~0ull) {
      free_textures_.release(first, texture_count);
      return kNoMaterial;
    }
    VtMaterial& m = materials_[id];
    m = VtMaterial{levels, static_cast<uint32_t>(first), texture_count, static_cast<uint32_t>(base), true};
    for (uint32_t k = 0; k < texture_count; ++k) texture_material_[first + k] = id;
    std::fill(weights_.begin() + static_cast<ptrdiff_t>(base),
              weights_.begin() + static_cast<ptrdiff_t>(base + entries), Half(1.0f));
    std::fill(energies_.begin() + static_cast<ptrdiff_t>(base),
              energies_.begin() + static_cast<ptrdiff_t>(base + entries), Half(0.0f));
    ++live_materials_;
    return id;
  }
  /// Removes a material: its id, textures and entries become free (reused by later adds).
  /// invalid_argument for an id that is not live. noexcept, no allocation.
  Status remove_material(uint32_t id) noexcept {
    if (id >= materials_.size() || !materials_[id].live) return Status::invalid_argument;
    VtMaterial& m = materials_[id];
    for (uint32_t k = 0; k < m.texture_count; ++k) texture_material_[m.first_texture + k] = kNoMaterial;
    free_textures_.release(m.first_texture, m.texture_count);
    free_entries_.release(m.entry_base, uint64_t{m.levels.tile_count()} * m.texture_count);
    m = VtMaterial{};
    --live_materials_;
    return Status::success;
  }

  /// Material ids (live or not): the reservation, or the materials added so far.
  uint32_t material_count() const noexcept { return static_cast<uint32_t>(materials_.size()); }
  /// Live materials.
  uint32_t live_material_count() const noexcept { return live_materials_; }
  /// Virtual texture ids (live or not). Indices of live textures are stable.
  uint32_t texture_count() const noexcept { return static_cast<uint32_t>(texture_material_.size()); }
  /// Size of the per-tile entry arrays (the reservation, or every material's tiles).
  uint32_t entry_count() const noexcept { return static_cast<uint32_t>(weights_.size()); }
  /// True when material m exists now.
  bool material_live(uint32_t m) const noexcept { return m < materials_.size() && materials_[m].live; }
  /// True when virtual texture t belongs to a live material.
  bool texture_live(uint32_t t) const noexcept {
    return t < texture_material_.size() && texture_material_[t] != kNoMaterial;
  }
  /// Material m (an empty one, texture_count 0, when not live). Precondition: m < material_count().
  const VtMaterial& material(uint32_t m) const noexcept { return materials_[m]; }
  /// Material owning a virtual texture (kNoMaterial for a free one). Precondition: texture < texture_count().
  uint32_t material_of(uint32_t texture) const noexcept { return texture_material_[texture]; }
  /// Hierarchy of a virtual texture (its material's; an empty one, 0 tiles, for a free texture).
  const VtLevelTable& levels_of(uint32_t texture) const noexcept {
    const uint32_t m = texture_material_[texture];
    return m != kNoMaterial ? materials_[m].levels : none_.levels;
  }
  /// First entry of a live virtual texture's tiles in the per-tile arrays (texture-major:
  /// entry_base + k · tile_count). Precondition: texture_live(texture).
  uint32_t texture_offset(uint32_t texture) const noexcept {
    const VtMaterial& m = materials_[texture_material_[texture]];
    return m.entry_base + (texture - m.first_texture) * m.levels.tile_count();
  }
  /// w(i, l, l−1) per tile (flat index), paper 000 eq. 8. For the root: mean squared norm.
  std::span<Half> weights(uint32_t texture) noexcept {
    return {weights_.data() + texture_offset(texture), tiles(texture)};
  }
  /// Read-only w per tile. Precondition: texture_live(texture).
  std::span<const Half> weights(uint32_t texture) const noexcept {
    return {weights_.data() + texture_offset(texture), tiles(texture)};
  }
  /// ‖T‖²_F / T² per tile (flat index), paper 000 §6.
  std::span<Half> energies(uint32_t texture) noexcept {
    return {energies_.data() + texture_offset(texture), tiles(texture)};
  }
  /// Read-only ‖T‖²_F / T² per tile. Precondition: texture_live(texture).
  std::span<const Half> energies(uint32_t texture) const noexcept {
    return {energies_.data() + texture_offset(texture), tiles(texture)};
  }
  /// The largest number of consecutive free textures / entries (what one add can still take).
  uint64_t largest_free_textures() const noexcept { return free_textures_.largest(); }
  uint64_t largest_free_entries() const noexcept { return free_entries_.largest(); }

 private:
  size_t tiles(uint32_t texture) const noexcept { return levels_of(texture).tile_count(); }
  std::vector<VtMaterial, CallbackAllocator<VtMaterial>> materials_;
  std::vector<uint32_t, CallbackAllocator<uint32_t>> texture_material_;  // kNoMaterial: free
  std::vector<Half, CallbackAllocator<Half>> weights_;                   // per entry
  std::vector<Half, CallbackAllocator<Half>> energies_;
  detail::RangeList free_textures_;
  detail::RangeList free_entries_;
  bool fixed_ = false;
  uint32_t live_materials_ = 0;
  VtMaterial none_;
};

/// The shape a VoteCounter needs for one material, one entry per material of the set, in order.
/// Allocates (set-up only).
inline std::vector<VoteLayout> vote_layouts(const VtSet& set) {
  std::vector<VoteLayout> out;
  for (uint32_t m = 0; m < set.material_count(); ++m) {
    const VtLevelTable& lv = set.material(m).levels;  // (an empty layout for a free id)
    out.push_back(VoteLayout{lv.finest_level(), lv.tiles_x[lv.finest_level()], lv.tiles_y[lv.finest_level()]});
  }
  return out;
}

}  // namespace btflod
