// btflod — the physical tile cache and the page tables (paper 000 §3, §5.1).
//
// The cache is a grid of S slots of (T + 2B)² texels, shaped by runtime/vt/cache_config.hpp's
// CacheConfig (the type the shaders and the runtime use too; default 16×16 slots of 72×72 in
// one layer). It knows nothing about the GPU: it does the bookkeeping (which tile lives in which
// slot, a free list) and keeps one page table per virtual texture with one entry per
// finest-level tile naming the level and slot of the best (deepest) resident tile covering it —
// the lookup table L of eq. 3. Every change to a page table is also reported as a small delta (a
// rectangle of entries set to one value), and every tile that entered or left a slot is reported
// in touched_tiles(), so the GPU page table can be brought up to date from this frame's
// operations alone (runtime/backend/page_table_writes.hpp) — no slot diff.
//
// The cache owns a copy of its VtSet and holds no pointer into another object: it can be moved
// freely (the scheduler takes the cache as an argument of each call).
//
// Pools (create_pools()): the slots may be split into up to kMaxCachePools pools, each a cache
// texture of its own CacheConfig (tile size, border, slot grid, format) with its own free list.
// Every material lives in one pool (add_material()'s `pool`), its tiles only in that pool's
// slots, and its tiles' size and border are the pool's. Slot ids are global: pool p owns
// [pool_first_slot(p), pool_first_slot(p) + pool_config(p).slot_count()); the GPU sees the
// pool-local slot (pool_local_slot(), what gpu_page_entry() packs into a page-table texel).
// One pool (create()) is the common case: local and global slots are then the same.
//
// Invariants (check_invariants() verifies them; tests call it after every operation):
//  * the root tile of every virtual texture is resident and pinned, hence every texel of every
//    virtual texture is covered by some resident tile;
//  * every page-table entry names the deepest resident tile that covers its finest tile;
//  * slots are either free (exactly once in the free list), reserved, or hold exactly one tile.
// All operations after create() are noexcept, allocation-free and deterministic (the free list
// hands out the lowest free slot first). Not thread-safe: one owner thread.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/allocator.hpp"
#include "btflod/core/result.hpp"
#include "btflod/runtime/vt/cache_config.hpp"
#include "btflod/runtime/vt/tile_id.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"

namespace btflod {

inline constexpr uint32_t kNoSlot = 0xffffffffu;

/// One page-table change: entries [x, x + width) × [y, y + height) (finest-level tile
/// coordinates) of virtual texture `texture` now hold `entry`.
struct PageTableDelta {
  uint32_t texture = 0;
  uint32_t x = 0;
  uint32_t y = 0;
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t entry = 0;
};

/// One texel of the GPU page table to overwrite (runtime/backend/backend.hpp describes the GPU side).
/// The GPU page table has one level per mip so the shader can blend two resident levels.
/// `tile` names the texel: layer tile.texture (virtual texture), tile (x, y) at paper level
/// tile.level; page_mip = material finest level − tile.level is the mip it lives in. entry =
/// pack_page_entry(slot, resident level) (runtime/vt/cache_config.hpp, what the shaders read) of
/// the tile the cache uses for it: itself or its deepest resident ancestor.
struct PageTableWrite {
  TileId tile;
  uint32_t page_mip = 0;
  uint32_t entry = 0;
};

/// The tile cache's configuration is the shared cache shape (runtime/vt/cache_config.hpp).
using TileCacheConfig = CacheConfig;

/// What one slot holds.
struct SlotInfo {
  TileId tile;               ///< tile.texture is the virtual texture
  uint32_t flat_index = 0;   ///< tile index within its virtual texture (VtLevelTable order)
  uint64_t added_frame = 0;  ///< frame of insertion (for hysteresis)
  enum class State : uint8_t { free, reserved, used } state = State::free;
};

class TileCache {
 public:
  /// An empty cache (assign the result of create()).
  TileCache() = default;

  /// Builds the bookkeeping for every virtual texture of `set` and makes every root tile
  /// resident (pinned) in slots 0 … (textures − 1). The slot grid is config.slots_x × slots_y ×
  /// cache_layers; the tile size and border are the set's (config() reports them), so every
  /// material must share one tile size and border. Returns insufficient_space when the cache
  /// has fewer slots than virtual textures, invalid_argument for an empty set, ≥ 2^24 slots or
  /// materials with different tile sizes or borders. Allocates, here and only here, through
  /// `allocator` (its callbacks, or operator new; a failing callback aborts: set-up memory is
  /// not optional, core/allocator.hpp); copies `set` (no pointer kept) with the same allocator.
  static Result<TileCache> create(const VtSet& set, const TileCacheConfig& config = {},
                                  const RuntimeAllocator& allocator = {}) {
    // The tile size and border: the first live material's, or the configuration's for an empty
    // reserved set; every other material must match them (create_pools checks).
    TileCacheConfig c = config;
    for (uint32_t m = 0; m < set.material_count(); ++m)
      if (set.material_live(m)) {
        c.tile_size = set.material(m).levels.geometry.tile_size;
        c.border = set.material(m).levels.geometry.border;
        break;
      }
    return create_pools(set, std::span<const CacheConfig>(&c, 1), allocator);
  }

  /// create() with the slots split into pools (see the file comment): pool p is a grid of
  /// pools[p].slot_count() slots of pools[p].tile_size + 2·border texels. The live materials of
  /// `set` go to pool material_pools[m] (pool 0 when material_pools is shorter), and their tile
  /// size and border must be that pool's. delta_capacity is pool 0's. Errors: invalid_argument
  /// for no pool, more than kMaxCachePools, an empty pool, ≥ 2^24 slots in all, a material in a
  /// pool that does not exist or whose tile size or border differs from its pool's, an empty
  /// unreserved set; insufficient_space when a pool has fewer slots than its materials have
  /// virtual textures. Allocates as create().
  static Result<TileCache> create_pools(const VtSet& set, std::span<const CacheConfig> pools,
                                        const RuntimeAllocator& allocator = {},
                                        std::span<const uint32_t> material_pools = {}) {
    if (pools.empty() || pools.size() > kMaxCachePools)
      return make_error(Status::invalid_argument, "tile cache: %zu pools (need 1 … %u)", pools.size(), kMaxCachePools);
    uint64_t slots = 0;
    for (const CacheConfig& p : pools) {
      const uint64_t n = static_cast<uint64_t>(p.slots_x) * p.slots_y * p.cache_layers;
      if (n == 0) return make_error(Status::invalid_argument, "tile cache: a pool without slots");
      slots += n;
    }
    const auto pool_of = [&](uint32_t m) { return m < material_pools.size() ? material_pools[m] : 0u; };
    uint32_t live_textures = 0;
    uint64_t pool_textures[kMaxCachePools] = {};
    for (uint32_t m = 0; m < set.material_count(); ++m) {
      if (!set.material_live(m)) continue;
      live_textures += set.material(m).texture_count;
      const uint32_t p = pool_of(m);
      if (p >= pools.size())
        return make_error(Status::invalid_argument, "tile cache: material %u names pool %u of %zu", m, p, pools.size());
      const VtGeometry& g = set.material(m).levels.geometry;
      if (g.tile_size != pools[p].tile_size || g.border != pools[p].border)
        return make_error(Status::invalid_argument,
                          "tile cache: material %u has tiles of %u texels with border %u, its pool %u holds %u with "
                          "%u (one pool holds one tile size)",
                          m, g.tile_size, g.border, p, pools[p].tile_size, pools[p].border);
      pool_textures[p] += set.material(m).texture_count;
    }
    if ((live_textures == 0 && !set.reserved()) || slots >= (1u << 24))
      return make_error(Status::invalid_argument, "tile cache: %u virtual textures, %llu slots (need > 0, < 2^24)",
                        live_textures, static_cast<unsigned long long>(slots));
    for (uint32_t p = 0; p < pools.size(); ++p)
      if (pools[p].slot_count() < pool_textures[p])
        return make_error(Status::insufficient_space,
                          "tile cache: %u slots of pool %u cannot pin the root tiles of %llu virtual textures",
                          pools[p].slot_count(), p, static_cast<unsigned long long>(pool_textures[p]));
    TileCache c{allocator, set};
    c.config_ = pools[0];
    c.pool_count_ = static_cast<uint32_t>(pools.size());
    c.slots_.assign(slots, SlotInfo{});
    c.visible_.assign(slots, 0);
    c.free_.assign(slots, 0);
    for (uint32_t p = 0, base = 0; p < pools.size(); ++p) {
      const uint32_t n = pools[p].slot_count();
      c.pools_[p] = pools[p];
      c.pool_base_[p] = base;
      c.pool_free_[p] = n;
      // Each pool's free list, descending: its lowest slot on top.
      for (uint32_t i = 0; i < n; ++i) c.free_[base + i] = base + n - 1 - i;
      base += n;
    }
    c.material_pool_.assign(set.material_count(), 0);
    for (uint32_t m = 0; m < set.material_count(); ++m)
      if (set.material_live(m)) c.material_pool_[m] = static_cast<uint8_t>(pool_of(m));
    c.textures_.assign(set.texture_count(), Texture{});
    c.slot_of_.assign(set.entry_count(), kNoSlot);
    c.resident_below_.assign(set.entry_count(), 0);
    c.page_table_.assign(set.entry_count(), pack_page_entry(kNoSlot & 0xffffffu, 0));
    c.deltas_.reserve(pools[0].delta_capacity);
    c.touched_.reserve(pools[0].delta_capacity);
    for (uint32_t m = 0; m < set.material_count(); ++m)
      if (set.material_live(m)) c.pin_roots(m);
    return c;
  }

  /// What create() allocates for a set reserved with `capacity` (VtSet::reserve) and `config`:
  /// the set's copy, the slot table, the per-entry and per-texture arrays and the delta
  /// buffers. No allocation.
  static AllocationTally memory_required(const VtCapacity& capacity, const TileCacheConfig& config) noexcept {
    return memory_required(capacity, std::span<const CacheConfig>(&config, 1));
  }
  /// What create_pools() allocates for a reserved set and these pools. No allocation.
  static AllocationTally memory_required(const VtCapacity& capacity, std::span<const CacheConfig> pools) noexcept {
    uint64_t slots = 0;
    for (const CacheConfig& p : pools) slots += static_cast<uint64_t>(p.slots_x) * p.slots_y * p.cache_layers;
    const CacheConfig config = pools.empty() ? CacheConfig{} : pools[0];
    AllocationTally t = VtSet::reserved_memory(capacity);
    t.array<decltype(slots_)>(slots);
    t.array<decltype(visible_)>(slots);
    t.array<decltype(free_)>(slots);
    t.array<decltype(material_pool_)>(capacity.materials);
    t.array<decltype(textures_)>(capacity.textures);
    t.array<decltype(slot_of_)>(capacity.tile_entries);
    t.array<decltype(resident_below_)>(capacity.tile_entries);
    t.array<decltype(page_table_)>(capacity.tile_entries);
    t.array<decltype(deltas_)>(config.delta_capacity);
    t.array<decltype(touched_)>(config.delta_capacity);
    return t;
  }

  /// Adds a material to a cache whose VtSet has a reservation (VtSet::reserve): takes a
  /// material id and ranges from the set (VtSet::add_material) and pins its root tiles in the
  /// lowest free slots of pool `pool`, reported like create()'s (deltas). `material`: in, the
  /// free id to take or kNoMaterial for the lowest free one; out, the id (kNoMaterial on
  /// failure). insufficient_space when fewer slots of the pool are free than it has virtual
  /// textures or the set has no room; invalid_argument without a reservation, for a pool that
  /// does not exist or for another tile size or border than the pool's. Other materials' tiles
  /// are not touched. noexcept, no allocation.
  Status add_material(const VtGeometry& geometry, uint32_t texture_count, uint32_t& material,
                      uint32_t pool = 0) noexcept {
    const uint32_t wanted = material;
    material = kNoMaterial;
    if (!set_.reserved() || !geometry.valid() || texture_count == 0 || pool >= pool_count_ ||
        geometry.tile_size != pools_[pool].tile_size || geometry.border != pools_[pool].border)
      return Status::invalid_argument;
    if (pool_free_[pool] < texture_count) return Status::insufficient_space;
    const uint32_t m = set_.add_material(geometry, texture_count, wanted);
    if (m == kNoMaterial) return Status::insufficient_space;
    material_pool_[m] = static_cast<uint8_t>(pool);
    const VtMaterial& vm = set_.material(m);
    const size_t entries = size_t{vm.levels.tile_count()} * texture_count;
    std::fill_n(slot_of_.begin() + vm.entry_base, entries, kNoSlot);
    std::fill_n(resident_below_.begin() + vm.entry_base, entries, 0u);
    pin_roots(m);
    material = m;
    return Status::success;
  }

  /// Removes a material: every tile of its virtual textures (roots included) leaves the cache
  /// and its slot becomes free; its page tables, deltas and touched tiles are dropped (the
  /// layers are free for the engine). Slots reserved for its tiles must have been released
  /// first (Scheduler::remove_material does). invalid_argument for a material that is not
  /// live. Other materials' tiles are not touched. noexcept, no allocation, O(its tiles + slots).
  Status remove_material(uint32_t material) noexcept {
    if (!set_.material_live(material)) return Status::invalid_argument;
    const VtMaterial vm = set_.material(material);
    const size_t entries = size_t{vm.levels.tile_count()} * vm.texture_count;
    for (size_t e = vm.entry_base; e < vm.entry_base + entries; ++e) {
      const uint32_t s = slot_of_[e];
      if (s == kNoSlot) continue;
      slot_of_[e] = kNoSlot;
      visible_[s] = 0;
      count_used(s, false);
      free_slot(s);
    }
    const uint32_t t0 = vm.first_texture, t1 = vm.first_texture + vm.texture_count;
    size_t o = 0;
    for (const PageTableDelta& d : deltas_)
      if (d.texture < t0 || d.texture >= t1) deltas_[o++] = d;
    deltas_.resize(o);  // shrinking: no allocation
    o = 0;
    for (const TileId& t : touched_)
      if (t.texture < t0 || t.texture >= t1) touched_[o++] = t;
    touched_.resize(o);
    return set_.remove_material(material);
  }

  /// S, all slots (of every pool).
  uint32_t slot_count() const noexcept { return static_cast<uint32_t>(slots_.size()); }
  /// Slots in the free lists (not reserved, not used), over every pool.
  uint32_t free_count() const noexcept {
    uint32_t n = 0;
    for (uint32_t p = 0; p < pool_count_; ++p) n += pool_free_[p];
    return n;
  }
  /// Free slots of pool p (0 for a pool that does not exist).
  uint32_t free_count(uint32_t pool) const noexcept { return pool < pool_count_ ? pool_free_[pool] : 0; }
  /// Slots holding a tile, over every pool.
  uint32_t used_count() const noexcept { return used_; }
  /// Slots of pool p holding a tile (0 for a pool that does not exist).
  uint32_t used_count(uint32_t pool) const noexcept { return pool < pool_count_ ? pool_used_[pool] : 0; }
  /// The configuration given to create(), with tile_size and border set to the set's (with
  /// pools: pool 0's).
  const TileCacheConfig& config() const noexcept { return config_; }
  /// Pools (1 for create()).
  uint32_t pool_count() const noexcept { return pool_count_; }
  /// Shape of pool p. Precondition: p < pool_count().
  const CacheConfig& pool_config(uint32_t pool) const noexcept { return pools_[pool]; }
  /// First global slot of pool p. Precondition: p < pool_count().
  uint32_t pool_first_slot(uint32_t pool) const noexcept { return pool_base_[pool]; }
  /// Pool of global slot s (pool_count() for s ≥ slot_count()). O(pools).
  uint32_t pool_of_slot(uint32_t s) const noexcept {
    uint32_t p = 0;
    while (p + 1 < pool_count_ && s >= pool_base_[p + 1]) ++p;
    return s < slots_.size() ? p : pool_count_;
  }
  /// Slot s within its pool's cache texture (what the shaders address). Precondition: s < slot_count().
  uint32_t pool_local_slot(uint32_t s) const noexcept { return s - pool_base_[pool_of_slot(s)]; }
  /// Pool of material m (0 for an id the set does not know).
  uint32_t material_pool(uint32_t material) const noexcept {
    return material < material_pool_.size() ? material_pool_[material] : 0u;
  }
  /// Pool of virtual texture t's material (0 for a free texture). Precondition: t < set().texture_count().
  uint32_t texture_pool(uint32_t texture) const noexcept { return material_pool(set_.material_of(texture)); }
  /// The virtual textures this cache serves (the cache's own copy).
  const VtSet& set() const noexcept { return set_; }
  /// What slot s holds. Precondition: s < slot_count().
  const SlotInfo& slot(uint32_t s) const noexcept { return slots_[s]; }
  /// Finest-level page-table entries naming slot s (0 = the tile is hidden by its descendants).
  uint32_t visible_entries(uint32_t s) const noexcept { return visible_[s]; }
  /// Top-left texel of slot s inside its cache layer (the i' of eq. 3, border included; the
  /// layer is slot_placement(s).layer). Precondition: s < slot_count().
  void slot_origin(uint32_t s, uint32_t& x, uint32_t& y) const noexcept {
    const CacheSlotPlacement p = slot_placement(s);
    x = p.x;
    y = p.y;
  }
  /// Texel origin and layer of slot s in its pool's cache texture (runtime/vt/cache_config.hpp).
  /// Precondition: s < slot_count().
  CacheSlotPlacement slot_placement(uint32_t s) const noexcept {
    const uint32_t p = pool_of_slot(s);
    return cache_slot_placement(pools_[p], s - pool_base_[p]);
  }

  /// Slot holding the tile, or kNoSlot. Returns kNoSlot for ids outside the hierarchy. noexcept.
  uint32_t slot_of(const TileId& t) const noexcept {
    if (t.texture >= textures_.size()) return kNoSlot;
    const VtLevelTable& lv = set_.levels_of(t.texture);
    if (!lv.geometry.contains(t)) return kNoSlot;
    return slot_at(t.texture, lv.index(t));
  }
  /// Same by flat index. Precondition: texture and index in range.
  uint32_t slot_at(uint32_t texture, uint32_t flat_index) const noexcept {
    return slot_of_[textures_[texture].base + flat_index * textures_[texture].stride];
  }
  /// Slots of tile `flat_index` in every virtual texture of a material: texture_count entries
  /// (kNoSlot where not resident), contiguous, so the scheduler reads them in one cache line.
  /// Precondition: material and index in range.
  const uint32_t* material_slots(uint32_t material, uint32_t flat_index) const noexcept {
    const VtMaterial& m = set_.material(material);
    return slot_of_.data() + m.entry_base + static_cast<size_t>(flat_index) * m.texture_count;
  }
  /// True when t is in the cache (false for ids outside the hierarchy).
  bool resident(const TileId& t) const noexcept { return slot_of(t) != kNoSlot; }
  /// Resident strict descendants of a tile (0 = it is a leaf of the resident tree).
  /// Precondition: texture and index in range.
  uint32_t resident_below_at(uint32_t texture, uint32_t flat_index) const noexcept {
    return resident_below_[textures_[texture].base + flat_index * textures_[texture].stride];
  }
  /// Page table of a virtual texture: tiles_x(L) × tiles_y(L) entries, row-major.
  /// Empty for a texture of no live material.
  std::span<const uint32_t> page_table(uint32_t texture) const noexcept {
    return {page_table_.data() + textures_[texture].page, textures_[texture].page_entries};
  }

  /// Takes the lowest free slot of pool `pool` out of its free list (state reserved). Returns
  /// kNoSlot when the pool is full or does not exist.
  uint32_t reserve_slot(uint32_t pool = 0) noexcept {
    if (pool >= pool_count_ || pool_free_[pool] == 0) return kNoSlot;
    const uint32_t s = free_[pool_base_[pool] + --pool_free_[pool]];
    slots_[s].state = SlotInfo::State::reserved;
    return s;
  }
  /// Returns a reserved slot to the free list. invalid_argument if it is not reserved.
  Status release_slot(uint32_t s) noexcept {
    if (s >= slots_.size() || slots_[s].state != SlotInfo::State::reserved) return Status::invalid_argument;
    free_slot(s);
    return Status::success;
  }

  /// Makes tile t resident in reserved slot s and updates the page table (no removals).
  /// invalid_argument when t is outside the hierarchy, already resident, s not reserved or not
  /// in the pool of t's material.
  Status insert(const TileId& t, uint32_t s, uint64_t frame) noexcept {
    if (t.texture >= textures_.size() || !set_.levels_of(t.texture).geometry.contains(t) || resident(t) ||
        s >= slots_.size() || slots_[s].state != SlotInfo::State::reserved ||
        pool_of_slot(s) != texture_pool(t.texture))
      return Status::invalid_argument;
    const VtLevelTable& lv = set_.levels_of(t.texture);
    const uint32_t idx = lv.index(t);
    Texture& tx = textures_[t.texture];
    c_slot(tx, idx) = s;
    slots_[s] = SlotInfo{t, idx, frame, SlotInfo::State::used};
    count_used(s, true);
    for (TileId a = t; a.level > 0;) {
      a = a.parent();
      ++below(tx, lv.index(a));
    }
    refresh(t, pack_page_entry(s, t.level));
    push_touched(t);
    return Status::success;
  }

  /// Paper 000 §5.1 `add`: inserts t (whose parent must be resident) into reserved slot s, then
  /// removes every ancestor that is now completely covered by resident descendants (root
  /// excepted). Returns the number of removed ancestors through `removed` (may be null).
  /// invalid_argument as insert(), or when the parent is not resident.
  Status add(const TileId& t, uint32_t s, uint64_t frame, uint32_t* removed = nullptr) noexcept {
    if (t.level == 0 || !resident(t.parent())) return Status::invalid_argument;
    const Status st = insert(t, s, frame);
    if (st != Status::success) return st;
    const uint32_t n = remove_hidden_ancestors(t);
    if (removed != nullptr) *removed = n;
    return Status::success;
  }

  /// Removes every resident, non-root, proper ancestor of t that shows on no page-table entry
  /// (the post-condition of `add`). Returns how many were removed. noexcept.
  uint32_t remove_hidden_ancestors(const TileId& t) noexcept {
    uint32_t n = 0;
    for (TileId a = t; a.level > 1;) {
      a = a.parent();
      const uint32_t s = slot_of(a);
      if (s != kNoSlot && visible_[s] == 0 && remove(a) == Status::success) ++n;
    }
    return n;
  }

  /// Removes a resident tile; its page-table entries fall back to the deepest resident
  /// ancestor (so coverage holds). invalid_argument for the root (pinned) or a non-resident tile.
  Status remove(const TileId& t) noexcept {
    const uint32_t s = slot_of(t);
    if (s == kNoSlot || t.level == 0) return Status::invalid_argument;
    const VtLevelTable& lv = set_.levels_of(t.texture);
    Texture& tx = textures_[t.texture];
    c_slot(tx, lv.index(t)) = kNoSlot;
    uint32_t best = kNoSlot;
    uint32_t best_level = 0;
    for (TileId a = t; a.level > 0;) {
      a = a.parent();
      const uint32_t ai = lv.index(a);
      --below(tx, ai);
      if (best == kNoSlot && c_slot(tx, ai) != kNoSlot) {
        best = c_slot(tx, ai);
        best_level = a.level;
      }
    }
    count_used(s, false);
    refresh(t, pack_page_entry(best, best_level));
    push_touched(t);
    free_slot(s);
    return Status::success;
  }

  /// Paper 000 §5.1 `swap`, first half: removes resident tiles a and b (same virtual texture,
  /// neither the root) and returns in `ancestor` their deepest common ancestor at a level below
  /// both; the caller inserts it (insert()) once its data is there, into the slot freed here.
  /// Coverage holds meanwhile (the removed regions show a coarser resident ancestor).
  /// invalid_argument when a == b, textures differ, or either is not resident / is a root.
  Status swap_remove(const TileId& a, const TileId& b, TileId& ancestor) noexcept {
    if (a == b || a.texture != b.texture || a.level == 0 || b.level == 0 || !resident(a) || !resident(b))
      return Status::invalid_argument;
    ancestor = common_ancestor(a, b);
    remove(a);
    remove(b);
    return Status::success;
  }

  /// Deepest tile covering both a and b at a level below min(level a, level b) (same texture).
  static TileId common_ancestor(const TileId& a, const TileId& b) noexcept {
    uint32_t l = std::min(a.level, b.level);
    l = l > 0 ? l - 1 : 0;
    while (l > 0 && a.ancestor(l) != b.ancestor(l)) --l;
    return a.ancestor(l);
  }

  /// Page-table deltas since the last clear_deltas(), in order.
  std::span<const PageTableDelta> deltas() const noexcept { return deltas_; }
  /// True when more deltas happened than delta_capacity: upload whole tables instead.
  bool deltas_overflowed() const noexcept { return deltas_overflowed_; }
  /// Tiles that entered (insert, add) or left (remove, swap_remove, the ancestors add drops) a
  /// slot since the last clear_deltas(), in order; a tile may appear more than once. Together
  /// with deltas() they name every page-table texel that can have changed, at every level
  /// (runtime/backend/page_table_writes.hpp append_frame_page_table_writes). Overflow as deltas().
  std::span<const TileId> touched_tiles() const noexcept { return touched_; }
  /// Forgets the reported deltas and touched tiles (after the backend uploaded the page-table
  /// changes) and the overflow flag.
  void clear_deltas() noexcept {
    deltas_.clear();
    touched_.clear();
    deltas_overflowed_ = false;
  }

  /// Verifies every invariant listed at the top of this file by brute force (allocates; for
  /// tests and debugging). Returns true, or false with a description in *why.
  bool check_invariants(std::string* why = nullptr) const {
    const auto fail = [&](std::string msg) {
      if (why != nullptr) *why = std::move(msg);
      return false;
    };
    std::vector<uint32_t> visible(slots_.size(), 0);
    uint32_t used = 0;
    for (uint32_t s = 0; s < slots_.size(); ++s) {
      if (slots_[s].state != SlotInfo::State::used) continue;
      ++used;
      const SlotInfo& si = slots_[s];
      if (slot_of(si.tile) != s) return fail(format_message("slot %u: tile not mapped back", s));
    }
    if (used != used_) return fail(format_message("used count %u != %u", used_, used));
    std::vector<uint8_t> in_free(slots_.size(), 0);
    uint32_t used_in_pools = 0;
    for (uint32_t p = 0; p < pool_count_; ++p) {
      const uint32_t end = p + 1 < pool_count_ ? pool_base_[p + 1] : slot_count();
      uint32_t pool_used = 0;
      for (uint32_t s = pool_base_[p]; s < end; ++s) {
        if (slots_[s].state != SlotInfo::State::used) continue;
        ++pool_used;
        if (texture_pool(slots_[s].tile.texture) != p)
          return fail(
              format_message("slot %u of pool %u holds a tile of pool %u", s, p, texture_pool(slots_[s].tile.texture)));
      }
      if (pool_used != pool_used_[p])
        return fail(format_message("pool %u: used count %u != %u", p, pool_used_[p], pool_used));
      used_in_pools += pool_used;
      for (uint32_t i = 0; i < pool_free_[p]; ++i) {
        const uint32_t s = free_[pool_base_[p] + i];
        if (s < pool_base_[p] || s >= end || in_free[s] || slots_[s].state != SlotInfo::State::free ||
            (i > 0 && s >= free_[pool_base_[p] + i - 1]))
          return fail(format_message("free list entry %u of pool %u bad", s, p));
        in_free[s] = 1;
      }
    }
    if (used_in_pools != used_) return fail(format_message("pools' used counts %u != %u", used_in_pools, used_));
    for (uint32_t s = 0; s < slots_.size(); ++s)
      if (slots_[s].state == SlotInfo::State::free && !in_free[s]) return fail(format_message("slot %u lost", s));
    for (uint32_t t = 0; t < textures_.size(); ++t) {
      if (!set_.texture_live(t)) continue;
      const VtLevelTable& lv = set_.levels_of(t);
      const Texture& tx = textures_[t];
      if (c_slot(tx, 0) == kNoSlot) return fail(format_message("texture %u: root not resident", t));
      const uint32_t L = lv.finest_level();
      for (uint32_t i = 0; i < lv.tile_count(); ++i) {
        const TileId id = lv.tile(t, i);
        uint32_t below = 0;
        if (id.level < L)
          for (uint32_t j = lv.offset[id.level + 1]; j < lv.tile_count(); ++j)
            if (c_slot(tx, j) != kNoSlot && id.covers(lv.tile(t, j))) ++below;
        if (below != resident_below_[tx.base + i * tx.stride])
          return fail(format_message("texture %u tile %u: resident_below %u != %u", t, i,
                                     resident_below_[tx.base + i * tx.stride], below));
      }
      for (uint32_t y = 0; y < lv.tiles_y[L]; ++y)
        for (uint32_t x = 0; x < lv.tiles_x[L]; ++x) {
          TileId f{t, L, x, y};
          uint32_t want = kNoSlot, want_level = 0;
          for (uint32_t l = L + 1; l-- > 0;) {
            const uint32_t s = c_slot(tx, lv.index(f.ancestor(l)));
            if (s != kNoSlot) {
              want = s;
              want_level = l;
              break;
            }
          }
          if (want == kNoSlot) return fail(format_message("texture %u finest tile (%u,%u) uncovered", t, x, y));
          const uint32_t e = page_table_[tx.page + static_cast<size_t>(y) * lv.tiles_x[L] + x];
          if (e != pack_page_entry(want, want_level))
            return fail(format_message("texture %u entry (%u,%u) = level %u slot %u, expected level %u slot %u", t, x,
                                       y, unpack_page_entry_level(e), unpack_page_entry_slot(e), want_level, want));
          ++visible[want];
        }
    }
    for (uint32_t s = 0; s < slots_.size(); ++s)
      if (slots_[s].state == SlotInfo::State::used && !set_.texture_live(slots_[s].tile.texture))
        return fail(format_message("slot %u holds a tile of free texture %u", s, slots_[s].tile.texture));
    for (uint32_t s = 0; s < slots_.size(); ++s)
      if (visible[s] != visible_[s])
        return fail(format_message("slot %u: visible %u != %u", s, visible_[s], visible[s]));
    return true;
  }

 private:
  template <class T>
  using Vec = std::vector<T, CallbackAllocator<T>>;  // every array through the creator's callbacks

  struct Texture {              // where a virtual texture's tiles live in the arrays below
    uint32_t base = 0;          // slot_of_ / resident_below_ [base + flat · stride]
    uint32_t stride = 1;        // virtual textures of the material (tile-major layout)
    uint32_t page = 0;          // page_table_ [page + y · tiles_x(L) + x]
    uint32_t page_entries = 0;  // finest-level tiles (0: a free texture)
  };

  TileCache(const RuntimeAllocator& al, const VtSet& set)
      : set_(set, al),
        slot_of_(CallbackAllocator<uint32_t>(al)),
        resident_below_(CallbackAllocator<uint32_t>(al)),
        page_table_(CallbackAllocator<uint32_t>(al)),
        slots_(CallbackAllocator<SlotInfo>(al)),
        visible_(CallbackAllocator<uint32_t>(al)),
        free_(CallbackAllocator<uint32_t>(al)),
        material_pool_(CallbackAllocator<uint8_t>(al)),
        textures_(CallbackAllocator<Texture>(al)),
        deltas_(CallbackAllocator<PageTableDelta>(al)),
        touched_(CallbackAllocator<TileId>(al)) {}

  // Sets up a live material's textures and makes their roots resident in the lowest free
  // slots (the caller checked there are enough).
  void pin_roots(uint32_t m) noexcept {
    const VtMaterial& vm = set_.material(m);
    const VtLevelTable& lv = vm.levels;
    const uint32_t L = lv.finest_level();
    for (uint32_t k = 0; k < vm.texture_count; ++k) {
      const uint32_t t = vm.first_texture + k;
      Texture& tx = textures_[t];
      tx.base = vm.entry_base + k;
      tx.stride = vm.texture_count;
      tx.page = set_.texture_offset(t);
      tx.page_entries = lv.tiles_x[L] * lv.tiles_y[L];
      const uint32_t slot = reserve_slot(material_pool_[m]);
      // The root covers everything: set the whole table directly, then count visibility.
      c_slot(tx, 0) = slot;
      slots_[slot] = SlotInfo{TileId{t, 0, 0, 0}, 0, 0, SlotInfo::State::used};
      count_used(slot, true);
      std::fill_n(page_table_.begin() + tx.page, tx.page_entries, pack_page_entry(slot, 0));
      visible_[slot] = tx.page_entries;
      push_delta(PageTableDelta{t, 0, 0, lv.tiles_x[L], lv.tiles_y[L], pack_page_entry(slot, 0)});
    }
  }

  void free_slot(uint32_t s) noexcept {
    slots_[s] = SlotInfo{};
    // Keep the pool's free list sorted descending so its lowest slot is handed out first
    // (determinism independent of the order of removals). Insertion is O(free) but only moves
    // integers, within the pool's region of free_ (sized at create(): no allocation).
    const uint32_t p = pool_of_slot(s);
    uint32_t* begin = free_.data() + pool_base_[p];
    uint32_t* end = begin + pool_free_[p];
    uint32_t* it = std::lower_bound(begin, end, s, [](uint32_t a, uint32_t b) { return a > b; });
    std::copy_backward(it, end, end + 1);
    *it = s;
    ++pool_free_[p];
  }
  void count_used(uint32_t s, bool more) noexcept {
    const uint32_t p = pool_of_slot(s);
    if (more) {
      ++used_;
      ++pool_used_[p];
    } else {
      --used_;
      --pool_used_[p];
    }
  }

  void push_delta(const PageTableDelta& d) noexcept {
    if (deltas_.size() < config_.delta_capacity)
      deltas_.push_back(d);
    else
      deltas_overflowed_ = true;
  }
  void push_touched(const TileId& t) noexcept {
    if (touched_.size() < config_.delta_capacity)
      touched_.push_back(t);
    else
      deltas_overflowed_ = true;
  }

  // Rewrites the page-table entries under tile t: below t, `best` applies unless a deeper
  // resident tile takes over. Descends only into subtrees that hold resident tiles.
  void refresh(const TileId& t, uint32_t best) noexcept {
    const VtLevelTable& lv = set_.levels_of(t.texture);
    Texture& tx = textures_[t.texture];
    const uint32_t idx = lv.index(t);
    if (c_slot(tx, idx) != kNoSlot) best = pack_page_entry(c_slot(tx, idx), t.level);
    const uint32_t L = lv.finest_level();
    if (t.level == L || below(tx, idx) == 0) {
      const uint32_t shift = L - t.level;
      const uint32_t x0 = t.x << shift, y0 = t.y << shift;
      const uint32_t x1 = std::min(x0 + (1u << shift), lv.tiles_x[L]);
      const uint32_t y1 = std::min(y0 + (1u << shift), lv.tiles_y[L]);
      bool changed = false;
      for (uint32_t y = y0; y < y1; ++y) {
        uint32_t* row = page_table_.data() + tx.page + static_cast<size_t>(y) * lv.tiles_x[L];
        for (uint32_t x = x0; x < x1; ++x) {
          if (row[x] == best) continue;
          const uint32_t old_slot = unpack_page_entry_slot(row[x]);
          if (old_slot < visible_.size()) --visible_[old_slot];
          ++visible_[unpack_page_entry_slot(best)];
          row[x] = best;
          changed = true;
        }
      }
      if (changed) push_delta(PageTableDelta{t.texture, x0, y0, x1 - x0, y1 - y0, best});
      return;
    }
    for (uint32_t i = 0; i < 4; ++i) {
      const TileId c = t.child(i);
      if (c.x < lv.tiles_x[c.level] && c.y < lv.tiles_y[c.level]) refresh(c, best);
    }
  }

  uint32_t& below(const Texture& tx, uint32_t flat) noexcept { return resident_below_[tx.base + flat * tx.stride]; }
  uint32_t& c_slot(const Texture& tx, uint32_t flat) noexcept { return slot_of_[tx.base + flat * tx.stride]; }
  uint32_t c_slot(const Texture& tx, uint32_t flat) const noexcept { return slot_of_[tx.base + flat * tx.stride]; }

  VtSet set_;
  Vec<uint32_t> slot_of_;         // per entry, tile-major per material: [entry_base + flat · K + k]
  Vec<uint32_t> resident_below_;  // per entry (same layout): resident strict descendants
  Vec<uint32_t> page_table_;      // per entry, texture-major: VtSet::texture_offset(t) + finest tile
  TileCacheConfig config_;
  Vec<SlotInfo> slots_;
  Vec<uint32_t> visible_;
  Vec<uint32_t> free_;  // per pool, [pool_base_, + pool_free_): sorted descending, the last is the lowest free slot
  Vec<uint8_t> material_pool_;  // per material id: its pool
  CacheConfig pools_[kMaxCachePools] = {};
  uint32_t pool_base_[kMaxCachePools] = {};
  uint32_t pool_free_[kMaxCachePools] = {};
  uint32_t pool_used_[kMaxCachePools] = {};
  uint32_t pool_count_ = 1;
  Vec<Texture> textures_;
  Vec<PageTableDelta> deltas_;
  Vec<TileId> touched_;
  bool deltas_overflowed_ = false;
  uint32_t used_ = 0;
};

}  // namespace btflod
