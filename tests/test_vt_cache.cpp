// Tests for vt/tile_cache.hpp: pinned roots, add/swap of paper 000 §5.1, page tables (eq. 3's
// lookup table) with deltas, and invariants after every operation of long random sequences.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "btflod/vt/tile_cache.hpp"

using namespace btflod;

namespace {
VtSet make_set() {
  VtSet set;
  set.add_material(VtGeometry::make(512, 512), 2);   // L = 3, 85 tiles each
  set.add_material(VtGeometry::make(300, 100), 1);   // non-square, L = 3
  return set;
}

#define EXPECT_INVARIANTS(cache)                     \
  do {                                               \
    std::string why;                                 \
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
    for (uint32_t e : c.page_table(t)) EXPECT_EQ(e, make_page_entry(0, c.slot_of(TileId{t, 0, 0, 0})));
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
  EXPECT_EQ(page_entry_level(e), 2u);
  EXPECT_EQ(page_entry_slot(e), c.slot_of(c0.child(0)));
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
  for (int step = 0; step < 4000; ++step) {
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
    for (uint32_t x = 0; x < 3; ++x) ASSERT_EQ(shadow[x], std::vector<uint32_t>(c.page_table(x).begin(), c.page_table(x).end()));
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
