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
    const uint64_t slots = static_cast<uint64_t>(config.slots_x) * config.slots_y * config.cache_layers;
    uint32_t live_textures = 0, first = kNoMaterial;
    for (uint32_t m = 0; m < set.material_count(); ++m)
      if (set.material_live(m)) {
        live_textures += set.material(m).texture_count;
        if (first == kNoMaterial) first = m;
      }
    if ((live_textures == 0 && !set.reserved()) || slots == 0 || slots >= (1u << 24))
      return make_error(Status::invalid_argument, "tile cache: %u virtual textures, %llu slots (need > 0, < 2^24)",
                        live_textures, static_cast<unsigned long long>(slots));
    if (slots < live_textures)
      return make_error(Status::insufficient_space,
                        "tile cache: %llu slots cannot pin the root tiles of %u virtual textures",
                        static_cast<unsigned long long>(slots), live_textures);
    // The tile size and border: the materials' (all equal), or the configuration's for an empty
    // reserved set.
    const VtGeometry g0 = first != kNoMaterial ? set.material(first).levels.geometry
                                               : VtGeometry{0, 0, config.tile_size, config.border, 0};
    for (uint32_t m = 0; m < set.material_count(); ++m) {
      if (!set.material_live(m)) continue;
      const VtGeometry& g = set.material(m).levels.geometry;
      if (g.tile_size != g0.tile_size || g.border != g0.border)
        return make_error(Status::invalid_argument,
                          "tile cache: material %u has tiles of %u texels with border %u, material %u of %u with %u "
                          "(one cache holds one tile size)",
                          m, g.tile_size, g.border, first, g0.tile_size, g0.border);
    }
    TileCache c{allocator, set};
    c.config_ = config;
    c.config_.tile_size = g0.tile_size;
    c.config_.border = g0.border;
    c.slots_.assign(slots, SlotInfo{});
    c.visible_.assign(slots, 0);
    c.free_.reserve(slots);
    for (uint64_t s = slots; s-- > 0;) c.free_.push_back(static_cast<uint32_t>(s));  // lowest slot on top
    c.textures_.assign(set.texture_count(), Texture{});
    c.slot_of_.assign(set.entry_count(), kNoSlot);
    c.resident_below_.assign(set.entry_count(), 0);
    c.page_table_.assign(set.entry_count(), pack_page_entry(kNoSlot & 0xffffffu, 0));
    c.deltas_.reserve(config.delta_capacity);
    c.touched_.reserve(config.delta_capacity);
    for (uint32_t m = 0; m < set.material_count(); ++m)
      if (set.material_live(m)) c.pin_roots(m);
    return c;
  }

  /// What create() allocates for a set reserved with `capacity` (VtSet::reserve) and `config`:
  /// the set's copy, the slot table, the per-entry and per-texture arrays and the delta
  /// buffers. No allocation.
  static AllocationTally memory_required(const VtCapacity& capacity, const TileCacheConfig& config) noexcept {
    const uint64_t slots = static_cast<uint64_t>(config.slots_x) * config.slots_y * config.cache_layers;
    AllocationTally t = VtSet::reserved_memory(capacity);
    t.array<decltype(slots_)>(slots);
    t.array<decltype(visible_)>(slots);
    t.array<decltype(free_)>(slots);
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
  /// lowest free slots, reported like create()'s (deltas). `material`: in, the free id to take
  /// or kNoMaterial for the lowest free one; out, the id (kNoMaterial on failure).
  /// insufficient_space when fewer slots are free than it has virtual textures or the set has
  /// no room; invalid_argument without a reservation or for another tile size or border.
  /// Other materials' tiles are not touched. noexcept, no allocation.
  Status add_material(const VtGeometry& geometry, uint32_t texture_count, uint32_t& material) noexcept {
    const uint32_t wanted = material;
    material = kNoMaterial;
    if (!set_.reserved() || !geometry.valid() || texture_count == 0 || geometry.tile_size != config_.tile_size ||
        geometry.border != config_.border)
      return Status::invalid_argument;
    if (free_.size() < texture_count) return Status::insufficient_space;
    const uint32_t m = set_.add_material(geometry, texture_count, wanted);
    if (m == kNoMaterial) return Status::insufficient_space;
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
      --used_;
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

  /// S, all slots.
  uint32_t slot_count() const noexcept { return static_cast<uint32_t>(slots_.size()); }
  /// Slots in the free list (not reserved, not used).
  uint32_t free_count() const noexcept { return static_cast<uint32_t>(free_.size()); }
  /// Slots holding a tile.
  uint32_t used_count() const noexcept { return used_; }
  /// The configuration given to create(), with tile_size and border set to the set's.
  const TileCacheConfig& config() const noexcept { return config_; }
  /// The virtual textures this cache serves (the cache's own copy).
  const VtSet& set() const noexcept { return set_; }
  /// What slot s holds. Precondition: s < slot_count().
  const SlotInfo& slot(uint32_t s) const noexcept { return slots_[s]; }
  /// Finest-level page-table entries naming slot s (0 = the tile is hidden by its descendants).
  uint32_t visible_entries(uint32_t s) const noexcept { return visible_[s]; }
  /// Top-left texel of slot s inside its cache layer (the i' of eq. 3, border included; the
  /// layer is slot_placement(s).layer). Precondition: s < slot_count().
  void slot_origin(uint32_t s, uint32_t& x, uint32_t& y) const noexcept {
    const CacheSlotPlacement p = cache_slot_placement(config_, s);
    x = p.x;
    y = p.y;
  }
  /// Texel origin and layer of slot s (runtime/vt/cache_config.hpp). Precondition: s < slot_count().
  CacheSlotPlacement slot_placement(uint32_t s) const noexcept { return cache_slot_placement(config_, s); }

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

  /// Takes the lowest free slot out of the free list (state reserved). Returns kNoSlot when full.
  uint32_t reserve_slot() noexcept {
    if (free_.empty()) return kNoSlot;
    const uint32_t s = free_.back();
    free_.pop_back();
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
  /// invalid_argument when t is outside the hierarchy, already resident, or s not reserved.
  Status insert(const TileId& t, uint32_t s, uint64_t frame) noexcept {
    if (t.texture >= textures_.size() || !set_.levels_of(t.texture).geometry.contains(t) || resident(t) ||
        s >= slots_.size() || slots_[s].state != SlotInfo::State::reserved)
      return Status::invalid_argument;
    const VtLevelTable& lv = set_.levels_of(t.texture);
    const uint32_t idx = lv.index(t);
    Texture& tx = textures_[t.texture];
    c_slot(tx, idx) = s;
    slots_[s] = SlotInfo{t, idx, frame, SlotInfo::State::used};
    ++used_;
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
    --used_;
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
    for (uint32_t s : free_) {
      if (s >= slots_.size() || in_free[s] || slots_[s].state != SlotInfo::State::free)
        return fail(format_message("free list entry %u bad", s));
      in_free[s] = 1;
    }
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
      const uint32_t slot = reserve_slot();
      // The root covers everything: set the whole table directly, then count visibility.
      c_slot(tx, 0) = slot;
      slots_[slot] = SlotInfo{TileId{t, 0, 0, 0}, 0, 0, SlotInfo::State::used};
      ++used_;
      std::fill_n(page_table_.begin() + tx.page, tx.page_entries, pack_page_entry(slot, 0));
      visible_[slot] = tx.page_entries;
      push_delta(PageTableDelta{t, 0, 0, lv.tiles_x[L], lv.tiles_y[L], pack_page_entry(slot, 0)});
    }
  }

  void free_slot(uint32_t s) noexcept {
    slots_[s] = SlotInfo{};
    // Keep the free list sorted descending so the lowest slot is handed out first (determinism
    // independent of the order of removals). Insertion is O(free) but only moves integers.
    auto it = std::lower_bound(free_.begin(), free_.end(), s, [](uint32_t a, uint32_t b) { return a > b; });
    free_.insert(it, s);  // capacity reserved at create(): no allocation
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
  Vec<uint32_t> free_;  // sorted descending; back() is the lowest free slot
  Vec<Texture> textures_;
  Vec<PageTableDelta> deltas_;
  Vec<TileId> touched_;
  bool deltas_overflowed_ = false;
  uint32_t used_ = 0;
};

}  // namespace btflod
