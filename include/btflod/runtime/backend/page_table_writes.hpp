// btflod — from runtime/vt/tile_cache.hpp's page table to the GPU page table of the generated shaders.
//
// TileCache keeps one entry per finest-level tile (the deepest resident tile covering it, eq. 3)
// and reports changes as rectangles of finest-level entries (PageTableDelta). The shaders read
// a page table with one mip per level (shader_config.hpp, VirtualTextureConfig): texel (x, y)
// of mip L − l holds the entry of tile (l, x, y) itself when resident, else of its deepest
// resident ancestor — so two resident levels can be blended (trilinear) — and mip 0 equals
// TileCache's table. These helpers turn deltas into per-level texel writes (PageTableWrite).
//
// What the shader needs (and what the helpers guarantee): the entry of every *resident* tile
// at its own level is exact, mip 0 is exact, and in every region whose finest entries changed
// all levels are exact. A tile that becomes resident or is removed while completely hidden by
// resident descendants (TileCache::add drops such ancestors) changes no finest entry, so
// TileCache reports no delta for it; TileCache::touched_tiles() names every such tile, and
// append_frame_page_table_writes() adds the own-level chain of each. Stale entries can then remain only on non-resident
// tiles whose region is covered by deeper resident tiles, and the shader never samples those: when the level-l1 entry
// is not at level l1 it takes the mip-0 entry whenever that one is deeper.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/runtime/vt/tile_cache.hpp"

namespace btflod {

/// GPU page-table entry of tile t: pack_page_entry(slot, level) of t when resident, else of its
/// deepest resident ancestor (the root is pinned, so one exists). The slot is the one within
/// the cache texture of the material's pool (TileCache::pool_local_slot; the global slot with
/// one pool). Returns pack_page_entry(0, 0) for a tile outside the hierarchy. noexcept, no
/// allocation, O(level).
inline uint32_t gpu_page_entry(const TileCache& cache, TileId t) noexcept {
  for (;;) {
    const uint32_t s = cache.slot_of(t);
    if (s != kNoSlot) return pack_page_entry(cache.pool_local_slot(s), t.level);
    if (t.level == 0) return pack_page_entry(0, 0);
    t = t.parent();
  }
}

/// Upper bound of the writes append_page_table_writes() emits for `deltas` (reserve this to
/// keep the per-frame call allocation-free). noexcept.
inline size_t page_table_writes_bound(const TileCache& cache, std::span<const PageTableDelta> deltas) noexcept {
  size_t n = 0;
  for (const PageTableDelta& d : deltas) {
    if (d.texture >= cache.set().texture_count() || d.width == 0 || d.height == 0) continue;
    const uint32_t L = cache.set().levels_of(d.texture).finest_level();
    for (uint32_t l = 0; l <= L; ++l) {
      const uint32_t s = L - l;
      n += static_cast<size_t>(((d.x + d.width - 1) >> s) - (d.x >> s) + 1) *
           (((d.y + d.height - 1) >> s) - (d.y >> s) + 1);
    }
  }
  return n;
}

namespace detail {
/// Calls sink(const PageTableWrite&) for every tile of every level over the rectangle of finest
/// entries of delta `d` (nothing for an unknown texture or an empty rectangle). noexcept if sink
/// is; no allocation.
template <class Sink>
void for_each_delta_page_table_write(const TileCache& cache, const PageTableDelta& d, Sink&& sink) {
  if (d.texture >= cache.set().texture_count() || d.width == 0 || d.height == 0) return;
  const VtLevelTable& lv = cache.set().levels_of(d.texture);
  const uint32_t L = lv.finest_level();
  for (uint32_t l = 0; l <= L; ++l) {
    const uint32_t s = L - l;
    const uint32_t x1 = std::min((d.x + d.width - 1) >> s, lv.tiles_x[l] - 1);
    const uint32_t y1 = std::min((d.y + d.height - 1) >> s, lv.tiles_y[l] - 1);
    for (uint32_t y = d.y >> s; y <= y1; ++y)
      for (uint32_t x = d.x >> s; x <= x1; ++x) {
        const TileId t{d.texture, l, x, y};
        sink(PageTableWrite{t, s, gpu_page_entry(cache, t)});
      }
  }
}

/// Calls sink(const PageTableWrite&) for the own-level entry of tile t and of each of its
/// ancestors (nothing for an unknown texture or a level beyond the finest). noexcept if sink is;
/// no allocation.
template <class Sink>
void for_each_tile_chain_write(const TileCache& cache, TileId t, Sink&& sink) {
  if (t.texture >= cache.set().texture_count()) return;
  const uint32_t L = cache.set().levels_of(t.texture).finest_level();
  if (t.level > L) return;
  for (;;) {
    sink(PageTableWrite{t, L - t.level, gpu_page_entry(cache, t)});
    if (t.level == 0) return;
    t = t.parent();
  }
}

/// The delta covering every finest entry of texture `texture` with level table `lv`.
inline PageTableDelta whole_table_delta(uint32_t texture, const VtLevelTable& lv) noexcept {
  return PageTableDelta{texture, 0, 0, lv.tiles_x[lv.finest_level()], lv.tiles_y[lv.finest_level()], 0};
}
}  // namespace detail

/// Appends the per-level writes that bring the GPU page table in line with the cache after
/// `deltas` (TileCache::deltas()): for every level, every tile over each delta's rectangle
/// gets gpu_page_entry(). Call after the cache operations of the frame (entries are read from
/// the cache's current state). Deltas naming unknown textures or empty rectangles are skipped.
/// Allocation-free when `out` has page_table_writes_bound() spare capacity. Not thread-safe
/// with respect to the cache.
inline void append_page_table_writes(const TileCache& cache, std::span<const PageTableDelta> deltas,
                                     std::vector<PageTableWrite>& out) {
  for (const PageTableDelta& d : deltas)
    detail::for_each_delta_page_table_write(cache, d, [&](const PageTableWrite& w) { out.push_back(w); });
}

/// Appends the own-level writes of tile t and of each of its ancestors (at most L + 1 writes).
/// Call after every TileCache operation on t (insert, add — which may drop hidden ancestors —,
/// remove, swap_remove for both tiles), together with append_page_table_writes() for the
/// deltas. Allocation-free with L + 1 spare capacity in `out`.
inline void append_tile_chain_writes(const TileCache& cache, TileId t, std::vector<PageTableWrite>& out) {
  detail::for_each_tile_chain_write(cache, t, [&](const PageTableWrite& w) { out.push_back(w); });
}

/// Appends writes for every tile of every level of one virtual texture (initial upload, or
/// after TileCache::deltas_overflowed()). Allocates as needed.
inline void append_full_page_table_writes(const TileCache& cache, uint32_t texture, std::vector<PageTableWrite>& out) {
  if (texture >= cache.set().texture_count()) return;
  const PageTableDelta all = detail::whole_table_delta(texture, cache.set().levels_of(texture));
  append_page_table_writes(cache, {&all, 1}, out);
}

/// Calls sink(const PageTableWrite&) for every texel this frame's cache operations can have
/// changed: the per-level writes of every delta (append_page_table_writes) and the own-level
/// chain of every tile in cache.touched_tiles() (inserted, added, removed, swapped out, or an
/// ancestor an add dropped). Derived from the operations alone — no slot diff. A texel may be
/// named more than once (the last call holds the current value). When the cache's deltas
/// overflowed, calls sink for every texel of every table instead. Call before
/// TileCache::clear_deltas(). noexcept if sink is; no allocation.
template <class Sink>
void for_each_frame_page_table_write(const TileCache& cache, Sink&& sink) {
  const VtSet& set = cache.set();
  if (cache.deltas_overflowed()) {
    for (uint32_t t = 0; t < set.texture_count(); ++t)
      detail::for_each_delta_page_table_write(cache, detail::whole_table_delta(t, set.levels_of(t)), sink);
    return;
  }
  for (const PageTableDelta& d : cache.deltas()) detail::for_each_delta_page_table_write(cache, d, sink);
  for (TileId t : cache.touched_tiles()) detail::for_each_tile_chain_write(cache, t, sink);
}

/// Upper bound of the writes append_frame_page_table_writes() emits now (every table when the
/// deltas overflowed). noexcept.
inline size_t frame_page_table_writes_bound(const TileCache& cache) noexcept {
  const VtSet& set = cache.set();
  size_t n = 0;
  if (cache.deltas_overflowed()) {
    for (uint32_t t = 0; t < set.texture_count(); ++t) n += set.levels_of(t).tile_count();
    return n;
  }
  n = page_table_writes_bound(cache, cache.deltas());
  for (const TileId& t : cache.touched_tiles())
    if (t.texture < set.texture_count()) n += set.levels_of(t.texture).finest_level() + 1;
  return n;
}

/// Appends the writes of for_each_frame_page_table_write() to `out`: everything the GPU page
/// table needs after this frame's cache operations. Allocation-free when `out` has
/// frame_page_table_writes_bound() spare capacity.
inline void append_frame_page_table_writes(const TileCache& cache, std::vector<PageTableWrite>& out) {
  for_each_frame_page_table_write(cache, [&](const PageTableWrite& w) { out.push_back(w); });
}

}  // namespace btflod
