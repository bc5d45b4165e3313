// Tests for runtime/vt/scheduler.hpp: hand-built cases where the best operation is known (paper 000
// §5.1–5.2, §6), budgets and their counters, hysteresis, the overload LOD bias, and long random
// feedback sequences that keep the cache invariants and replay identically.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/vt/scheduler.hpp"
#include "test_random_operations.hpp"

using namespace btflod;

namespace {
struct Rig {
  VtSet set;
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Scheduler> sched;
  std::unique_ptr<VoteCounter> votes;

  Rig(uint32_t slots_x, uint32_t slots_y, SchedulerConfig cfg = {}, uint32_t textures = 1, uint32_t materials = 1) {
    for (uint32_t m = 0; m < materials; ++m) set.add_material(VtGeometry::make(256, 256), textures);  // L = 2
    auto c = TileCache::create(set, {slots_x, slots_y});
    cache = std::make_unique<TileCache>(std::move(c.value()));
    auto s = Scheduler::create(*cache, cfg);
    sched = std::make_unique<Scheduler>(std::move(s.value()));
    const auto layouts = vote_layouts(set);
    votes = std::make_unique<VoteCounter>(layouts);
  }
  void set_weight(uint32_t tex, uint32_t level, uint32_t x, uint32_t y, float w) {
    sched->set_weight(tex, set.levels_of(tex).index(level, x, y), Half(w).to_float());
  }
  const SchedulerCounters& frame(const std::vector<uint32_t>& words, uint64_t f) {
    votes->count(words);
    return sched->run_frame(*cache, *votes, f);
  }
  void check() const {
    std::string why;
    ASSERT_TRUE(cache->check_invariants(&why)) << why;
  }
};

void push(std::vector<uint32_t>& words, uint32_t material, uint32_t level, uint32_t x, uint32_t y, int n) {
  for (int i = 0; i < n; ++i) words.push_back(pack_feedback({material, level, x, y}));
}
}  // namespace

TEST(Scheduler, AddTakesTheHighestWeightTimesVotes) {
  SchedulerConfig cfg;
  cfg.budgets.requests_in_flight = 1;
  Rig rig(4, 4, cfg);
  rig.set_weight(0, 1, 0, 0, 0.1f);
  rig.set_weight(0, 1, 1, 0, 0.5f);
  std::vector<uint32_t> w;
  push(w, 0, 1, 0, 0, 20);  // P = 0.1 · 20 = 2
  push(w, 0, 1, 1, 0, 10);  // P = 0.5 · 10 = 5
  const SchedulerCounters& c = rig.frame(w, 0);
  EXPECT_EQ(c.adds, 1u);
  EXPECT_GE(c.request_budget_hits, 1u);  // the second add did not fit the request budget
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 1, 0}));
  EXPECT_FALSE(rig.cache->resident(TileId{0, 1, 0, 0}));
  rig.check();
}

TEST(Scheduler, VotesOnlyModeIgnoresWeights) {
  SchedulerConfig cfg;
  cfg.budgets.requests_in_flight = 1;
  cfg.mode = PriorityMode::votes_only;
  Rig rig(4, 4, cfg);
  rig.set_weight(0, 1, 0, 0, 0.1f);
  rig.set_weight(0, 1, 1, 0, 0.5f);
  std::vector<uint32_t> w;
  push(w, 0, 1, 0, 0, 20);
  push(w, 0, 1, 1, 0, 10);
  rig.frame(w, 0);
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 0, 0}));
  EXPECT_FALSE(rig.cache->resident(TileId{0, 1, 1, 0}));
}

TEST(Scheduler, OnlyTilesWithAResidentParentAreAdded) {
  Rig rig(4, 4);
  std::vector<uint32_t> w;
  push(w, 0, 2, 3, 3, 50);  // finest tile: its parent (1,1,1) is not resident yet
  EXPECT_EQ(rig.frame(w, 0).adds, 1u);
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 1, 1}));  // the ancestor chain is walked down
  EXPECT_FALSE(rig.cache->resident(TileId{0, 2, 3, 3}));
  EXPECT_EQ(rig.frame(w, 1).adds, 1u);
  EXPECT_TRUE(rig.cache->resident(TileId{0, 2, 3, 3}));
  EXPECT_EQ(rig.frame(w, 2).adds, 0u);  // nothing left worth adding: P = 0 elsewhere
  rig.check();
}

TEST(Scheduler, SwapsZeroCostLeavesWhenFullAndRespectsHysteresis) {
  Rig rig(3, 1);  // root + 2 slots
  std::vector<uint32_t> w1;
  push(w1, 0, 1, 0, 0, 10);
  push(w1, 0, 1, 1, 0, 10);
  EXPECT_EQ(rig.frame(w1, 0).adds, 2u);
  EXPECT_EQ(rig.cache->free_count(), 0u);
  std::vector<uint32_t> w2;
  push(w2, 0, 1, 0, 1, 10);
  push(w2, 0, 1, 1, 1, 10);
  // Same frame again: the tiles inserted in frame 0 may not be swapped out (hysteresis).
  const SchedulerCounters same = rig.frame(w2, 0);
  EXPECT_EQ(same.swaps, 0u);
  EXPECT_EQ(same.swaps_rejected, 1u);
  // Next frame: the old tiles have v = 0 → swap cost 0 < P: swap (their common ancestor is the
  // resident root, so two slots free up) and both adds.
  const SchedulerCounters next = rig.frame(w2, 1);
  EXPECT_EQ(next.swaps, 1u);
  EXPECT_EQ(next.adds, 2u);
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 0, 1}));
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 1, 1}));
  EXPECT_FALSE(rig.cache->resident(TileId{0, 1, 0, 0}));
  rig.check();
}

TEST(Scheduler, NoSwapWhenItsCostExceedsTheBestAddPriority) {
  Rig rig(3, 1);
  rig.set_weight(0, 1, 0, 0, 1.0f);
  rig.set_weight(0, 1, 1, 0, 1.0f);
  rig.set_weight(0, 1, 0, 1, 0.01f);
  std::vector<uint32_t> w;
  push(w, 0, 1, 0, 0, 10);
  push(w, 0, 1, 1, 0, 10);
  rig.frame(w, 0);
  push(w, 0, 1, 0, 1, 10);  // P = 0.1, cheapest swap costs 1·10 + 1·10 = 20
  const SchedulerCounters c = rig.frame(w, 5);
  EXPECT_EQ(c.swaps, 0u);
  EXPECT_EQ(c.adds, 0u);
  EXPECT_EQ(c.swaps_rejected, 1u);
  EXPECT_EQ(c.visible_missing, 1u);
  // Make the new tile valuable: now P = 100 · 10 > 20 → swap.
  rig.set_weight(0, 1, 0, 1, 100.0f);
  const SchedulerCounters d = rig.frame(w, 6);
  EXPECT_EQ(d.swaps, 1u);
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 0, 1}));
  rig.check();
}

TEST(Scheduler, SwapInsertsTheCommonAncestorWhenItIsNotResident) {
  Rig rig(7, 1);  // root + 6
  std::vector<uint32_t> w;
  for (uint32_t i = 0; i < 4; ++i) push(w, 0, 2, i & 1, i >> 1, 5);  // the 4 children of (1,0,0)
  rig.frame(w, 0);                                                   // adds (1,0,0)
  rig.frame(w, 1);  // adds its 4 children → (1,0,0) covered → removed
  EXPECT_FALSE(rig.cache->resident(TileId{0, 1, 0, 0}));
  EXPECT_EQ(rig.cache->used_count(), 5u);
  rig.check();
  // Fill the last two free slots with tiles elsewhere, then ask for something new.
  std::vector<uint32_t> w2;
  push(w2, 0, 1, 1, 1, 50);
  push(w2, 0, 1, 1, 0, 50);
  rig.frame(w2, 2);
  EXPECT_EQ(rig.cache->free_count(), 0u);
  std::vector<uint32_t> w3 = w2;
  push(w3, 0, 1, 0, 1, 60);
  const SchedulerCounters c = rig.frame(w3, 3);
  // The four level-2 leaves have no votes: the cheapest swap removes two of them and inserts
  // their parent (1,0,0) (not resident) → one slot for the parent, one for the add.
  EXPECT_EQ(c.swaps, 1u);
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 0, 0}));
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 0, 1}));
  rig.check();
}

TEST(Scheduler, BudgetsAreEnforcedAndCounted) {
  SchedulerConfig cfg;
  cfg.budgets.requests_in_flight = 4;
  cfg.budgets.tiles_decoding = 2;
  cfg.budgets.uploads_per_frame = 1;
  Rig rig(8, 8, cfg);
  std::vector<uint32_t> w;
  for (uint32_t y = 0; y < 2; ++y)
    for (uint32_t x = 0; x < 2; ++x) push(w, 0, 1, x, y, 3);
  push(w, 0, 0, 0, 0, 1);
  rig.votes->count(w);
  const auto req = rig.sched->plan(*rig.cache, *rig.votes, 0);
  ASSERT_EQ(req.size(), 4u);
  EXPECT_EQ(rig.sched->frame().visible_missing, 4u);
  EXPECT_EQ(rig.sched->requests_in_flight(), 4u);
  EXPECT_EQ(rig.sched->bytes_in_flight(), 4u * cfg.tile_bytes);
  // Everything in flight: the next plan issues nothing new (those tiles are already requested).
  EXPECT_EQ(rig.sched->plan(*rig.cache, *rig.votes, 1).size(), 0u);
  EXPECT_TRUE(rig.sched->begin_decode(req[0].id));
  EXPECT_TRUE(rig.sched->begin_decode(req[1].id));
  EXPECT_FALSE(rig.sched->begin_decode(req[2].id));
  EXPECT_EQ(rig.sched->frame().decoding_budget_hits, 1u);
  rig.sched->finish_decode(req[0].id);
  rig.sched->finish_decode(req[1].id);
  EXPECT_EQ(rig.sched->apply_uploads(*rig.cache), 1u);
  EXPECT_EQ(rig.sched->frame().upload_budget_hits, 1u);
  EXPECT_TRUE(rig.cache->resident(req[0].tile));
  EXPECT_FALSE(rig.cache->resident(req[1].tile));
  rig.check();
  EXPECT_EQ(rig.sched->apply_uploads(*rig.cache), 1u);
  EXPECT_TRUE(rig.cache->resident(req[1].tile));
  rig.sched->cancel(*rig.cache, req[3].id);
  EXPECT_EQ(rig.sched->requests_in_flight(), 1u);
  EXPECT_EQ(rig.cache->free_count() + rig.cache->used_count(), rig.cache->slot_count() - 1);  // req[2] reserved
  // Bytes budget: one tile's worth only.
  SchedulerConfig small;
  small.budgets.bytes_in_flight = small.tile_bytes;
  Rig r2(8, 8, small);
  r2.votes->count(w);
  EXPECT_EQ(r2.sched->plan(*r2.cache, *r2.votes, 0).size(), 1u);
  EXPECT_EQ(r2.sched->frame().byte_budget_hits, 1u);
}

TEST(Scheduler, UColumnPacketsArePrioritisedBySection6) {
  SchedulerConfig cfg;
  cfg.stream_u_columns = true;
  Rig rig(8, 8, cfg, 2);  // one material, two virtual textures (C = 8)
  // Root energies: texture 0 has 1, texture 1 has 0 (its eigen-textures are black).
  rig.sched->set_energy(0, 0, 1.0f);
  rig.sched->set_energy(1, 0, 0.0f);
  std::vector<uint32_t> w;
  push(w, 0, 1, 0, 0, 10);
  const SchedulerCounters& c0 = rig.frame(w, 0);
  // Nothing can be added before U' of texture 0: the packet goes first (priority 10·1 > 0).
  EXPECT_EQ(c0.u_requests, 1u);
  EXPECT_EQ(c0.adds, 0u);
  EXPECT_EQ(rig.sched->u_loaded(0), 1u);
  const SchedulerCounters& c1 = rig.frame(w, 1);
  EXPECT_EQ(c1.adds, 1u);  // tile of texture 0; texture 1's packet has priority 0 < P
  EXPECT_EQ(c1.u_requests, 0u);
  EXPECT_TRUE(rig.cache->resident(TileId{0, 1, 0, 0}));
  EXPECT_FALSE(rig.cache->resident(TileId{1, 1, 0, 0}));
  // Texture 1 gains energy: its packet (10 · 1000) outranks the next tile add.
  rig.sched->set_energy(1, 0, 1000.0f);
  std::vector<uint32_t> w2 = w;
  push(w2, 0, 2, 0, 0, 1);
  const SchedulerCounters& c2 = rig.frame(w2, 2);
  EXPECT_EQ(c2.u_requests, 1u);
  EXPECT_EQ(rig.sched->u_loaded(0), 2u);
  rig.check();
}

TEST(Scheduler, LodBiasRisesUnderOverloadAndFallsWhenCalm) {
  SchedulerConfig cfg;
  cfg.overload_missing_tiles = 0;
  cfg.overload_frames = 2;
  cfg.calm_frames = 3;
  cfg.max_lod_bias = 2;
  cfg.budgets.requests_in_flight = 1;
  Rig rig(2, 1, cfg);  // root + 1 slot: most visible tiles stay missing
  std::vector<uint32_t> busy;
  for (uint32_t y = 0; y < 4; ++y)
    for (uint32_t x = 0; x < 4; ++x) push(busy, 0, 2, x, y, 2);
  std::vector<uint32_t> bias;
  for (uint64_t f = 0; f < 6; ++f) {
    rig.frame(busy, f);
    bias.push_back(rig.sched->lod_bias());
  }
  EXPECT_EQ(bias, (std::vector<uint32_t>{0, 1, 1, 2, 2, 2}));
  const std::vector<uint32_t> none;
  bias.clear();
  for (uint64_t f = 6; f < 13; ++f) {
    rig.frame(none, f);
    bias.push_back(rig.sched->lod_bias());
  }
  EXPECT_EQ(bias, (std::vector<uint32_t>{2, 2, 1, 1, 1, 0, 0}));
}

TEST(Scheduler, RandomFeedbackKeepsInvariantsAndReplaysIdentically) {
  const auto run = [](std::vector<uint64_t>& log) {
    SchedulerConfig cfg;
    cfg.budgets.requests_in_flight = 6;
    cfg.budgets.uploads_per_frame = 4;
    Rig rig(5, 5, cfg, 2, 3);  // 3 materials × 2 textures, 25 slots
    std::mt19937 rng(99);
    const uint64_t frames = test::random_operation_count(250);
    for (uint64_t f = 0; f < frames; ++f) {
      std::vector<uint32_t> w;
      const uint32_t spots = 1 + rng() % 6;
      for (uint32_t s = 0; s < spots; ++s) {
        const uint32_t m = rng() % 3, l = rng() % 3;
        push(w, m, l, rng() % (1u << l), rng() % (1u << l), 1 + int(rng() % 40));
      }
      rig.votes->count(w, 1, rig.sched->lod_bias());
      const auto req = rig.sched->plan(*rig.cache, *rig.votes, f);
      for (const TileRequest& r : req) log.push_back(r.tile.key());
      // Deliver with a random latency: some requests complete now, some later.
      for (uint32_t id = 0; id < cfg.budgets.requests_in_flight; ++id)
        if (rng() % 2 && rig.sched->begin_decode(id)) rig.sched->finish_decode(id);
      rig.sched->apply_uploads(*rig.cache);
      std::string why;
      if (!rig.cache->check_invariants(&why)) {
        ADD_FAILURE() << "frame " << f << ": " << why;
        return;
      }
      log.push_back(0xffffffffffffull + rig.cache->used_count());
    }
    EXPECT_GT(rig.sched->total().swaps, 10u);
    EXPECT_GT(rig.sched->total().uploads, 100u);
  };
  std::vector<uint64_t> a, b;
  run(a);
  run(b);
  EXPECT_EQ(a, b);
}

namespace {
// A fixed view over one material of the Rig (L = 2, 4×4 finest tiles): a 64×64 full-resolution
// feedback image, read decimated 4×4 with the rotating sample position of feedback_sample_offset
// (one pixel per block per frame). 15/16 of the pixels show the four finest tiles of one
// quadrant (near the camera), 1/16 are scattered over the twelve others (far away, about 21
// pixels each: about 1.3 samples per decimated frame, often none) — as in a perspective view.
std::vector<uint32_t> fixed_view_words(uint64_t frame, uint32_t view) {
  constexpr uint32_t kSize = 64, kD = 4;
  uint32_t dx = 0, dy = 0;
  feedback_sample_offset(frame, kD, dx, dy);
  std::vector<uint32_t> out;
  for (uint32_t y = dy; y < kSize; y += kD)
    for (uint32_t x = dx; x < kSize; x += kD) {
      uint32_t h = (x * 73856093u) ^ (y * 19349663u) ^ (view * 83492791u);
      h ^= h >> 13;
      h *= 0x5bd1e995u;
      h ^= h >> 15;
      const uint32_t qx = view & 1, qy = (view >> 1) & 1;  // the near quadrant
      uint32_t tx, ty;
      if (h % 16 != 0) {
        tx = 2 * qx + ((h >> 4) & 1), ty = 2 * qy + ((h >> 5) & 1);
      } else {
        uint32_t k = (h >> 8) % 12;  // the k-th finest tile outside the near quadrant
        for (tx = 0, ty = 0;; ++tx) {
          if (tx == 4) tx = 0, ++ty;
          if ((tx >> 1) == qx && (ty >> 1) == qy) continue;
          if (k-- == 0) break;
        }
      }
      out.push_back(pack_feedback({0, 2, tx, ty}));
    }
  return out;
}

struct SettleRun {
  std::vector<uint32_t> swaps;  // per frame
  std::vector<uint64_t> log;    // requests and resident sets, for the replay check
  uint32_t used = 0, slots = 0;
};

// Full cache (16 slots for 21 wanted tiles: root, 4 at level 1, the 4 near tiles and 7 of the 12
// far ones, which compete at nearly equal priority), data delivered the frame it is requested. The
// camera shows view 1 for the first `cut` frames, then holds view 2 (so the cache must change).
SettleRun run_fixed_view(bool accumulate, uint64_t frames, uint64_t cut) {
  SchedulerConfig cfg;
  cfg.budgets.requests_in_flight = 8;
  cfg.budgets.uploads_per_frame = 8;
  Rig rig(4, 4, cfg);
  for (uint32_t y = 0; y < 4; ++y)  // distinct weights, as a real pyramid has
    for (uint32_t x = 0; x < 4; ++x) rig.set_weight(0, 2, x, y, 0.2f + 0.05f * static_cast<float>(x + 4 * y));
  for (uint32_t y = 0; y < 2; ++y)
    for (uint32_t x = 0; x < 2; ++x) rig.set_weight(0, 1, x, y, 0.6f + 0.1f * static_cast<float>(x + 2 * y));
  VoteCounter window(vote_layouts(rig.set), VoteWindowConfig{16, 0});  // 16 = one 4×4 rotation cycle
  SettleRun r;
  for (uint64_t f = 0; f < frames; ++f) {
    const std::vector<uint32_t> words = fixed_view_words(f, f < cut ? 0 : 3);
    if (accumulate)
      window.accumulate(words, 1);
    else
      rig.votes->count(words, 16);  // one frame, each word standing for its 4×4 block
    const auto req = rig.sched->plan(*rig.cache, accumulate ? window : *rig.votes, f);
    r.swaps.push_back(rig.sched->frame().swaps);
    for (const TileRequest& q : req) r.log.push_back(q.tile.key());
    for (uint32_t id = 0; id < cfg.budgets.requests_in_flight; ++id)
      if (rig.sched->begin_decode(id)) rig.sched->finish_decode(id);
    rig.sched->apply_uploads(*rig.cache);
    for (uint32_t s = 0; s < rig.cache->slot_count(); ++s) r.log.push_back(rig.cache->slot(s).tile.key());
    std::string why;
    EXPECT_TRUE(rig.cache->check_invariants(&why)) << why;
  }
  r.used = rig.cache->used_count();
  r.slots = rig.cache->slot_count();
  return r;
}
}  // namespace

// Rotating decimated feedback at a fixed view with a full cache: one frame's votes differ from
// frame to frame and keep the scheduler swapping; the votes accumulated over the rotation cycle
// (VoteCounter::accumulate, 16 frames) are constant once the window is full, so the swaps stop
// within a bounded number of frames. Both replay bit-identically.
TEST(Scheduler, RotatingFeedbackSettlesWithVoteAccumulationOnly) {
  // View 2 from frame 32: its window is full from frame 47; a few more plans to finish the swaps.
  constexpr uint64_t kFrames = 160, kCut = 32, kSettledFrom = 80;
  const SettleRun acc = run_fixed_view(true, kFrames, kCut);
  const SettleRun raw = run_fixed_view(false, kFrames, kCut);
  uint32_t acc_late = 0, raw_late = 0, acc_after_cut = 0;
  int last_acc_swap = -1;
  for (uint64_t f = 0; f < kFrames; ++f) {
    if (f >= kCut) acc_after_cut += acc.swaps[f];
    if (acc.swaps[f]) last_acc_swap = static_cast<int>(f);
    if (f >= kSettledFrom) acc_late += acc.swaps[f], raw_late += raw.swaps[f];
  }
  std::printf(
      "swaps after the view change: accumulated %u (last at frame %d); from frame %llu on: accumulated %u, "
      "single-frame %u\n",
      acc_after_cut, last_acc_swap, static_cast<unsigned long long>(kSettledFrom), acc_late, raw_late);
  EXPECT_EQ(acc.used, acc.slots);  // the cache is full: the swaps decide
  EXPECT_GT(acc_after_cut, 0u);    // the new view did make it swap
  EXPECT_EQ(acc_late, 0u) << "accumulated votes: swaps after frame " << kSettledFrom;
  EXPECT_LT(last_acc_swap, static_cast<int>(kCut + 16 + 8));  // within the window + a few plans
  EXPECT_GE(raw_late, 20u) << "single-frame votes should keep swapping at a fixed view";
  // Replays: the same inputs give the same requests and resident sets.
  EXPECT_EQ(run_fixed_view(true, kFrames, kCut).log, acc.log);
  EXPECT_EQ(run_fixed_view(false, kFrames, kCut).log, raw.log);
}
