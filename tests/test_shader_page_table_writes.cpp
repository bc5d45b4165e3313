// runtime/backend/page_table_writes.hpp: TileCache's finest-level deltas plus the chain writes of each
// operated tile, turned into per-level GPU page-table writes and applied incrementally, give
// the shader the same tile as a page table recomputed from scratch, for every finest tile and
// every desired level; resident tiles' own entries and mip 0 (= TileCache's table, eq. 3) are
// exact.
#include <gtest/gtest.h>

#include <vector>

#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"

using namespace btflod;

namespace {

struct Mirror {  // CPU copy of the GPU page table: [texture][mip] side² entries
  uint32_t side_log2 = 0;
  std::vector<std::vector<std::vector<uint32_t>>> mips;
  Mirror(uint32_t textures, uint32_t finest) : side_log2(finest), mips(textures) {
    for (auto& t : mips) {
      t.resize(finest + 1);
      for (uint32_t m = 0; m <= finest; ++m) t[m].assign(size_t{1} << (2 * (finest - m)), 0xdeadbeefu);
    }
  }
  void apply(std::span<const PageTableWrite> writes) {
    ASSERT_EQ(check_page_table_writes(writes, static_cast<uint32_t>(mips.size()), side_log2), Status::success);
    for (const PageTableWrite& w : writes) {
      const uint32_t side = 1u << (side_log2 - w.page_mip);
      mips[w.tile.texture][w.page_mip][w.tile.y * side + w.tile.x] = w.entry;
    }
  }
};

}  // namespace

TEST(ShaderPageTableWrites, IncrementalWritesMatchRecomputationUnderRandomAddRemove) {
  VtSet set;
  set.add_material(VtGeometry::make(256, 192, 64, 4), 2);  // L = 2, 4×3 finest tiles, 2 textures
  set.add_material(VtGeometry::make(128, 128, 64, 4), 1);  // L = 1
  auto cache_r = TileCache::create(set, TileCacheConfig{6, 6, 1u << 12});
  ASSERT_TRUE(cache_r.ok()) << cache_r.message();
  TileCache& cache = *cache_r;
  Mirror mirror(set.texture_count(), 2);
  std::vector<PageTableWrite> writes;
  for (uint32_t t = 0; t < set.texture_count(); ++t) append_full_page_table_writes(cache, t, writes);
  mirror.apply(writes);
  cache.clear_deltas();

  uint32_t rng = 99;
  auto next = [&rng](uint32_t n) {
    rng = rng * 1664525u + 1013904223u;
    return (rng >> 8) % n;
  };
  size_t total_writes = 0;
  uint32_t hidden_dropped = 0, removed = 0;
  for (int step = 0; step < 400; ++step) {
    const uint32_t tex = next(set.texture_count());
    const VtLevelTable& lv = set.levels_of(tex);
    const uint32_t flat = next(lv.tile_count());
    const TileId t = lv.tile(tex, flat);
    if (cache.resident(t)) {
      if (t.level == 0 || cache.resident_below_at(tex, flat) != 0) continue;
      ASSERT_EQ(cache.remove(t), Status::success);
      ++removed;
    } else if (t.level > 0 && cache.resident(t.parent())) {
      const uint32_t s = cache.reserve_slot();
      if (s == kNoSlot) continue;
      uint32_t dropped = 0;
      ASSERT_EQ(cache.add(t, s, static_cast<uint64_t>(step), &dropped), Status::success);
      hidden_dropped += dropped;
    } else {
      continue;
    }
    ASSERT_FALSE(cache.deltas_overflowed());
    writes.clear();
    const size_t bound = page_table_writes_bound(cache, cache.deltas());
    writes.reserve(bound);
    append_page_table_writes(cache, cache.deltas(), writes);
    EXPECT_LE(writes.size(), bound);
    append_tile_chain_writes(cache, t, writes);
    total_writes += writes.size();
    mirror.apply(writes);
    cache.clear_deltas();
    for (uint32_t x = 0; x < set.texture_count(); ++x) {
      const VtLevelTable& l = set.levels_of(x);
      const uint32_t L = l.finest_level();
      auto mirror_at = [&](uint32_t level, uint32_t tx, uint32_t ty) {
        return mirror.mips[x][L - level][ty * (1u << (2 - (L - level))) + tx];
      };
      for (uint32_t level = 0; level <= L; ++level)
        for (uint32_t ty = 0; ty < l.tiles_y[level]; ++ty)
          for (uint32_t tx = 0; tx < l.tiles_x[level]; ++tx) {
            const TileId id{x, level, tx, ty};
            if (cache.resident(id)) {
              ASSERT_EQ(mirror_at(level, tx, ty), pack_page_entry(cache.slot_of(id), level))
                  << "step " << step << ": resident tile's own entry, texture " << x << " level " << level;
            }
          }
      for (uint32_t fy = 0; fy < l.tiles_y[L]; ++fy)
        for (uint32_t fx = 0; fx < l.tiles_x[L]; ++fx) {
          const uint32_t ef = mirror_at(L, fx, fy);
          ASSERT_EQ(ef, cache.page_table(x)[fy * l.tiles_x[L] + fx]) << "mip 0 = TileCache table";
          for (uint32_t level = 0; level <= L; ++level) {
            // what btflod_vt_fetch samples for desired level `level` at this finest tile
            const TileId id = TileId{x, L, fx, fy}.ancestor(level);
            auto pick = [&](uint32_t e1) {
              if (unpack_page_entry_level(e1) == level) return e1;
              return unpack_page_entry_level(ef) > unpack_page_entry_level(e1) ? ef : e1;
            };
            const uint32_t truth_f = gpu_page_entry(cache, TileId{x, L, fx, fy});
            const uint32_t e_truth = gpu_page_entry(cache, id);
            const uint32_t truth =
                unpack_page_entry_level(e_truth) == level
                    ? e_truth
                    : (unpack_page_entry_level(truth_f) > unpack_page_entry_level(e_truth) ? truth_f : e_truth);
            ASSERT_EQ(pick(mirror_at(level, id.x, id.y)), truth)
                << "step " << step << " texture " << x << " finest tile " << fx << "," << fy << " level " << level;
          }
        }
    }
  }
  EXPECT_GT(hidden_dropped, 0u) << "the walk must exercise TileCache::add dropping hidden ancestors";
  EXPECT_GT(removed, 10u);
  EXPECT_GT(total_writes, 100u);
  EXPECT_GT(cache.used_count(), set.texture_count()) << "the random walk must have added tiles";
}

TEST(ShaderPageTableWrites, EntryEncodingMatchesTileCache) {
  EXPECT_EQ(pack_page_entry(1234, 5), pack_page_entry(1234, 5));
  EXPECT_EQ(unpack_page_entry_slot(pack_page_entry(77, 3)), unpack_page_entry_slot(pack_page_entry(77, 3)));
  EXPECT_EQ(unpack_page_entry_level(pack_page_entry(77, 3)), 3u);
}
