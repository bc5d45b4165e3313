// Tests for runtime/vt/tile_cache.hpp: pinned roots, add/swap of paper 000 §5.1, page tables (eq. 3's
// lookup table) with deltas, and invariants after every operation of long random sequences.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/vt/scheduler.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "test_random_operations.hpp"

using namespace btflod;

namespace {
VtSet make_set() {
  VtSet set;
  set.add_material(VtGeometry::make(512, 512), 2);  // L = 3, 85 tiles each
  set.add_material(VtGeometry::make(300, 100), 1);  // non-square, L = 3
  return set;
}

#define EXPECT_INVARIANTS(cache)                        \
  do {                                                  \
    std::string why;                                    \
    ASSERT_TRUE((cache).check_invariants(&why)) << why; \
  } while (0)
}  // namespace

TEST(TileCache, RootsArePinnedAndCoverEverything) {
  const VtSet set = make_set();
  auto r = TileCache::create(set, {4, 4});
  ASSERT_TRUE(r.ok()) << r.error().message;
  TileCache& c = r.value();
  EXPECT_EQ(c.slot_count(), 16u);
  EXPECT_EQ(c.used_count(), 3u);
  EXPECT_EQ(c.free_count(), 13u);
  EXPECT_INVARIANTS(c);
  for (uint32_t t = 0; t < 3; ++t) {
    EXPECT_TRUE(c.resident(TileId{t, 0, 0, 0}));
    EXPECT_EQ(c.remove(TileId{t, 0, 0, 0}), Status::invalid_argument);
    for (uint32_t e : c.page_table(t)) EXPECT_EQ(e, pack_page_entry(c.slot_of(TileId{t, 0, 0, 0}), 0));
  }
  EXPECT_EQ(c.page_table(2).size(), 5u * 2u);
  EXPECT_EQ(c.deltas().size(), 3u);
  uint32_t x, y;
  c.slot_origin(5, x, y);
  EXPECT_EQ(x, 72u);
  EXPECT_EQ(y, 72u);
}

TEST(TileCache, TooFewSlotsForTheRootsIsAnError) {
  const VtSet set = make_set();
  auto r = TileCache::create(set, {2, 1});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().status, Status::insufficient_space);
}

TEST(TileCache, AddNeedsAResidentParentAndDropsCoveredAncestors) {
  const VtSet set = make_set();
  auto r = TileCache::create(set, {8, 8});
  ASSERT_TRUE(r.ok());
  TileCache& c = r.value();
  const TileId root{0, 0, 0, 0};
  // Grandchild without parent: refused, slot untouched.
  uint32_t s = c.reserve_slot();
  EXPECT_EQ(c.add(root.child(0).child(0), s, 1), Status::invalid_argument);
  EXPECT_EQ(c.release_slot(s), Status::success);
  // Three children: root still visible on the fourth quarter.
  for (uint32_t i = 0; i < 3; ++i) {
    uint32_t removed = 99;
    ASSERT_EQ(c.add(root.child(i), c.reserve_slot(), 1, &removed), Status::success);
    EXPECT_EQ(removed, 0u);
    EXPECT_INVARIANTS(c);
  }
  EXPECT_EQ(c.visible_entries(c.slot_of(root)), 16u);  // 8×8 finest tiles, one quarter
  // Level-2 tiles below child 0: all four → child 0 becomes hidden and is removed.
  const TileId c0 = root.child(0);
  for (uint32_t i = 0; i < 4; ++i) {
    uint32_t removed = 99;
    ASSERT_EQ(c.add(c0.child(i), c.reserve_slot(), 2, &removed), Status::success);
    EXPECT_EQ(removed, i == 3 ? 1u : 0u);
    EXPECT_INVARIANTS(c);
  }
  EXPECT_FALSE(c.resident(c0));
  // The root is never removed even when covered.
  ASSERT_EQ(c.add(root.child(3), c.reserve_slot(), 3), Status::success);
  EXPECT_TRUE(c.resident(root));
  EXPECT_EQ(c.visible_entries(c.slot_of(root)), 0u);
  EXPECT_INVARIANTS(c);
  // The page table names the deepest resident tile: finest tile (0,0) → level 2 tile (0,0).
  const uint32_t e = c.page_table(0)[0];
  EXPECT_EQ(unpack_page_entry_level(e), 2u);
  EXPECT_EQ(unpack_page_entry_slot(e), c.slot_of(c0.child(0)));
}

TEST(TileCache, SwapRemovesTwoAndNamesTheirCommonAncestor) {
  const VtSet set = make_set();
  auto r = TileCache::create(set, {8, 8});
  ASSERT_TRUE(r.ok());
  TileCache& c = r.value();
  const TileId root{1, 0, 0, 0};
  const TileId a = root.child(0), b = root.child(1);
  ASSERT_EQ(c.add(a, c.reserve_slot(), 1), Status::success);
  ASSERT_EQ(c.add(b, c.reserve_slot(), 1), Status::success);
  const TileId a2 = a.child(3), b2 = b.child(2);
  ASSERT_EQ(c.add(a2, c.reserve_slot(), 2), Status::success);
  ASSERT_EQ(c.add(b2, c.reserve_slot(), 2), Status::success);
  ASSERT_EQ(c.remove(a), Status::success);  // a2 and b2 now sit below the root only (and b)
  const uint32_t free_before = c.free_count();
  TileId anc;
  ASSERT_EQ(c.swap_remove(a2, b2, anc), Status::success);
  EXPECT_EQ(anc, root);  // deepest common ancestor below both levels
  EXPECT_EQ(c.free_count(), free_before + 2);
  EXPECT_INVARIANTS(c);
  EXPECT_EQ(TileCache::common_ancestor(a.child(0), a.child(3)), a);
  EXPECT_EQ(TileCache::common_ancestor(a.child(0).child(1), a.child(0)), a);  // below min level
  EXPECT_EQ(c.swap_remove(b, b, anc), Status::invalid_argument);
}

TEST(TileCache, LongRandomOperationSequencesKeepEveryInvariant) {
  const VtSet set = make_set();
  auto r = TileCache::create(set, {5, 5});  // 25 slots: full often
  ASSERT_TRUE(r.ok());
  TileCache& c = r.value();
  // Shadow page tables rebuilt from the deltas alone.
  std::vector<std::vector<uint32_t>> shadow(3);
  for (uint32_t t = 0; t < 3; ++t) shadow[t].assign(c.page_table(t).size(), 0);
  const auto apply_deltas = [&] {
    ASSERT_FALSE(c.deltas_overflowed());
    for (const PageTableDelta& d : c.deltas()) {
      const uint32_t w = set.levels_of(d.texture).tiles_x[set.levels_of(d.texture).finest_level()];
      for (uint32_t y = d.y; y < d.y + d.height; ++y)
        for (uint32_t x = d.x; x < d.x + d.width; ++x) shadow[d.texture][y * w + x] = d.entry;
    }
    c.clear_deltas();
  };
  apply_deltas();
  std::mt19937 rng(11);
  const auto pick = [&](uint32_t n) { return static_cast<uint32_t>(rng() % n); };
  uint32_t adds = 0, removes = 0, swaps = 0, inserts = 0;
  const uint64_t steps = test::random_operation_count(4000);
  for (uint64_t step = 0; step < steps; ++step) {
    const uint32_t tex = pick(3);
    const VtLevelTable& lv = set.levels_of(tex);
    const TileId t = lv.tile(tex, pick(lv.tile_count()));
    switch (pick(5)) {
      case 0: {  // add a child of a resident tile
        const SlotInfo& si = c.slot(pick(c.slot_count()));
        if (si.state != SlotInfo::State::used || si.tile.level == 3) break;
        const TileId ch = si.tile.child(pick(4));
        if (!set.levels_of(ch.texture).geometry.contains(ch) || c.resident(ch)) break;
        const uint32_t s = c.reserve_slot();
        if (s == kNoSlot) break;
        ASSERT_EQ(c.add(ch, s, step), Status::success);
        ++adds;
        break;
      }
      case 4: {  // add of a random tile (mostly refused: parent not resident)
        if (c.resident(t) || t.level == 0 || !c.resident(t.parent())) break;
        const uint32_t s = c.reserve_slot();
        if (s == kNoSlot) break;
        ASSERT_EQ(c.add(t, s, step), Status::success);
        ++adds;
        break;
      }
      case 1: {  // insert anywhere (the second half of a swap)
        if (c.resident(t)) break;
        const uint32_t s = c.reserve_slot();
        if (s == kNoSlot) break;
        ASSERT_EQ(c.insert(t, s, step), Status::success);
        ++inserts;
        break;
      }
      case 2:  // remove
        if (c.remove(t) == Status::success) ++removes;
        break;
      case 3: {  // swap two resident tiles
        const SlotInfo& sa = c.slot(pick(c.slot_count()));
        const SlotInfo& sb = c.slot(pick(c.slot_count()));
        if (sa.state != SlotInfo::State::used || sb.state != SlotInfo::State::used) break;
        const TileId t = sa.tile, u = sb.tile;
        TileId anc;
        if (c.swap_remove(t, u, anc) != Status::success) break;
        ++swaps;
        EXPECT_TRUE(anc.covers(t) && anc.covers(u));
        EXPECT_LT(anc.level, std::min(t.level, u.level));
        if (!c.resident(anc)) {
          ASSERT_EQ(c.insert(anc, c.reserve_slot(), step), Status::success);
        }
        break;
      }
    }
    EXPECT_INVARIANTS(c);
    apply_deltas();
    for (uint32_t x = 0; x < 3; ++x)
      ASSERT_EQ(shadow[x], std::vector<uint32_t>(c.page_table(x).begin(), c.page_table(x).end()));
  }
  EXPECT_GT(adds, 100u);
  EXPECT_GT(removes, 50u);
  EXPECT_GT(swaps, 20u);
  EXPECT_GT(inserts, 50u);
}

TEST(TileCache, DeltaOverflowIsReportedNotAllocated) {
  const VtSet set = make_set();
  TileCacheConfig cfg{8, 8, 2};
  auto r = TileCache::create(set, cfg);
  ASSERT_TRUE(r.ok());
  TileCache& c = r.value();
  EXPECT_TRUE(c.deltas_overflowed());  // 3 roots > capacity 2
  EXPECT_EQ(c.deltas().size(), 2u);
  c.clear_deltas();
  EXPECT_FALSE(c.deltas_overflowed());
}

namespace {
// The entry the shader samples at tile t for finest tile f below it (btflod_vt_fetch's rule):
// t's own entry when it names t's level, else the deeper of it and f's.
template <class Table>
uint32_t sampled_entry(const Table& table, const TileId& t, const TileId& f) {
  const uint32_t e = table(t);
  if (unpack_page_entry_level(e) == t.level) return e;
  const uint32_t ef = table(f);
  return unpack_page_entry_level(ef) > unpack_page_entry_level(e) ? ef : e;
}

// Applies this frame's writes (derived from the cache's operations only) to a GPU mirror and
// checks it against a from-scratch rebuild as far as the shader can tell.
void apply_and_check(const TileCache& c, std::vector<std::vector<uint32_t>>& gpu) {
  for_each_frame_page_table_write(c, [&](const PageTableWrite& w) {
    const VtLevelTable& lv = c.set().levels_of(w.tile.texture);
    ASSERT_EQ(w.page_mip, lv.finest_level() - w.tile.level);
    gpu[w.tile.texture][lv.index(w.tile)] = w.entry;
  });
  for (uint32_t t = 0; t < c.set().texture_count(); ++t) {
    const VtLevelTable& lv = c.set().levels_of(t);
    const uint32_t L = lv.finest_level();
    const auto mirror = [&](const TileId& id) { return gpu[t][lv.index(id)]; };
    const auto rebuild = [&](const TileId& id) { return gpu_page_entry(c, id); };
    for (uint32_t i = 0; i < lv.tile_count(); ++i) {
      const TileId id = lv.tile(t, i);
      if (c.resident(id) || id.level == L) {
        ASSERT_EQ(mirror(id), rebuild(id))
            << "texture " << t << " level " << id.level << " tile " << id.x << "," << id.y;
        continue;
      }
      const uint32_t side = 1u << (L - id.level);
      for (uint32_t y = id.y * side; y < std::min((id.y + 1) * side, lv.tiles_y[L]); ++y)
        for (uint32_t x = id.x * side; x < std::min((id.x + 1) * side, lv.tiles_x[L]); ++x) {
          const TileId f{t, L, x, y};
          ASSERT_EQ(sampled_entry(mirror, id, f), sampled_entry(rebuild, id, f));
        }
    }
  }
}
}  // namespace

// The GPU page table kept up to date from TileCache::deltas() and touched_tiles() alone (what
// the runtime does, no slot diff) equals a rebuild after every frame of a scheduler run with
// swaps and hidden-ancestor removals. Fails when an operation does not report a tile it touched.
TEST(TileCache, FrameWritesFromReportedOperationsMatchARebuild) {
  VtSet set = make_set();
  auto r = TileCache::create(set, {4, 4});  // 16 slots for 3 textures: swaps every frame
  ASSERT_TRUE(r.ok());
  TileCache c = std::move(r.value());
  auto s = Scheduler::create(c);
  ASSERT_TRUE(s.ok());
  Scheduler sched = std::move(s.value());
  std::vector<std::vector<uint32_t>> gpu(3);
  for (uint32_t t = 0; t < 3; ++t) gpu[t].assign(set.levels_of(t).tile_count(), 0xffffffffu);
  for (uint32_t t = 0; t < 3; ++t)  // initial upload: every texel
    for (uint32_t i = 0; i < set.levels_of(t).tile_count(); ++i)
      gpu[t][i] = gpu_page_entry(c, set.levels_of(t).tile(t, i));
  c.clear_deltas();
  VoteCounter votes(vote_layouts(set));
  std::mt19937 rng(5);
  uint64_t swaps = 0, removed = 0;
  for (uint64_t f = 0; f < 300; ++f) {
    std::vector<uint32_t> words;
    for (int k = 0; k < 24; ++k) {
      const uint32_t m = rng() % 2, level = rng() % 4, side = 1u << level;
      words.push_back(
          pack_feedback(FeedbackTile{m, level, static_cast<uint32_t>(rng() % side),
                                     static_cast<uint32_t>(rng() % (m == 1 ? std::max(1u, side / 2) : side))}));
    }
    votes.count(words);
    sched.run_frame(c, votes, f);
    swaps += sched.frame().swaps;
    removed += sched.frame().ancestors_removed;
    EXPECT_INVARIANTS(c);
    ASSERT_FALSE(c.deltas_overflowed());
    apply_and_check(c, gpu);
    c.clear_deltas();
  }
  EXPECT_GT(swaps, 20u);
  EXPECT_GT(removed, 5u);
}

// The cache owns its VtSet and the scheduler keeps no pointer to the cache: both survive being
// moved after create(), and the set they were built from may be gone.
TEST(TileCache, CacheAndSchedulerAreSafeToMove) {
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Scheduler> sched;
  {
    VtSet set = make_set();
    TileCache a = std::move(TileCache::create(set, {6, 6}).value());
    Scheduler sa = std::move(Scheduler::create(a).value());
    TileCache b = std::move(a);
    Scheduler sb = std::move(sa);
    cache = std::make_unique<TileCache>(std::move(b));
    sched = std::make_unique<Scheduler>(std::move(sb));
    set = VtSet{};  // the original set is gone
  }
  VoteCounter votes(vote_layouts(cache->set()));
  for (uint64_t f = 0; f < 20; ++f) {
    const uint32_t w[] = {pack_feedback(FeedbackTile{0, 3, static_cast<uint32_t>(f % 8), 1}),
                          pack_feedback(FeedbackTile{1, 2, 1, 0})};
    votes.count(w);
    sched->run_frame(*cache, votes, f);
    EXPECT_INVARIANTS(*cache);
  }
  EXPECT_GT(sched->total().uploads, 5u);
  EXPECT_EQ(cache->config().tile_size, 64u);  // taken from the set
}

TEST(TileCache, MaterialsWithDifferentTileSizesAreRefused) {
  VtSet set;
  set.add_material(VtGeometry::make(256, 256, 64, 4), 1);
  set.add_material(VtGeometry::make(256, 256, 32, 4), 1);
  const auto r = TileCache::create(set, {4, 4});
  EXPECT_EQ(r.status(), Status::invalid_argument);
  EXPECT_NE(r.message().find("one pool holds one tile size"), std::string::npos);
}

// Two pools of different tile sizes in one cache: each material's tiles only in its pool's
// slots (global ids pool_first_slot(p) …), pool-local slots in the GPU entries, free lists and
// eviction per pool, every invariant after each step of a random sequence.
TEST(TileCache, PoolsKeepEachMaterialInItsOwnSlots) {
  VtSet set;
  set.add_material(VtGeometry::make(256, 256, 64, 4), 1);  // L = 2, pool 1
  set.add_material(VtGeometry::make(128, 128, 32, 4), 2);  // L = 2, pool 0
  const CacheConfig pools[] = {CacheConfig{3, 2, 1u << 12, 32, 4, 1}, CacheConfig{2, 2, 1u << 12, 64, 4, 1}};
  const uint32_t material_pools[] = {1, 0};
  // A material whose tile size is not its pool's is refused; so is a pool that does not exist.
  const uint32_t swapped[] = {0, 1};
  EXPECT_EQ(TileCache::create_pools(set, pools, {}, swapped).status(), Status::invalid_argument);
  const uint32_t missing[] = {2, 0};
  EXPECT_EQ(TileCache::create_pools(set, pools, {}, missing).status(), Status::invalid_argument);
  auto r = TileCache::create_pools(set, pools, {}, material_pools);
  ASSERT_TRUE(r.ok()) << r.message();
  TileCache& c = r.value();
  EXPECT_EQ(c.pool_count(), 2u);
  EXPECT_EQ(c.slot_count(), 10u);
  EXPECT_EQ(c.pool_first_slot(1), 6u);
  EXPECT_EQ(c.used_count(0), 2u);  // material 1's two roots
  EXPECT_EQ(c.used_count(1), 1u);  // material 0's root
  EXPECT_EQ(c.slot_of(TileId{0, 0, 0, 0}), 6u);
  EXPECT_EQ(gpu_page_entry(c, TileId{0, 0, 0, 0}), pack_page_entry(0, 0));  // first slot of pool 1's texture
  EXPECT_EQ(c.slot_placement(7).x, 72u);                                    // pool 1: 72-texel slots
  EXPECT_EQ(c.slot_placement(1).x, 40u);                                    // pool 0: 40-texel slots
  EXPECT_INVARIANTS(c);
  std::mt19937 rng(5);
  uint32_t inserted[2] = {};
  for (int op = 0; op < 4000; ++op) {
    const uint32_t t = rng() % 3;
    const uint32_t pool = c.texture_pool(t);
    const VtLevelTable& lv = c.set().levels_of(t);
    const TileId tile = lv.tile(t, 1 + rng() % (lv.tile_count() - 1));
    if (c.resident(tile)) {
      ASSERT_EQ(c.remove(tile), Status::success);
    } else if (c.resident(tile.parent())) {
      const uint32_t s = c.reserve_slot(pool);
      if (s == kNoSlot) {
        EXPECT_EQ(c.free_count(pool), 0u);
        continue;
      }
      ASSERT_EQ(c.pool_of_slot(s), pool);
      // A slot of the other pool cannot take the tile.
      const uint32_t other = c.reserve_slot(1 - pool);
      if (other != kNoSlot) {
        EXPECT_EQ(c.insert(tile, other, 0), Status::invalid_argument);
        ASSERT_EQ(c.release_slot(other), Status::success);
      }
      ASSERT_EQ(c.add(tile, s, 0), Status::success);
      ++inserted[pool];
      EXPECT_EQ(unpack_page_entry_slot(gpu_page_entry(c, tile)), c.pool_local_slot(s));
      EXPECT_LT(c.pool_local_slot(s), pools[pool].slot_count());
    }
    EXPECT_INVARIANTS(c);
  }
  EXPECT_GT(inserted[0], 100u);
  EXPECT_GT(inserted[1], 100u);
}
