// btflod-label: unit threads
// Tests for materials that come and go on a running Streamer (runtime/streamer.hpp
// add_material / remove_material, runtime/impl/streamer_materials.hpp): ten thousand random
// operations (adds, removes, frames with feedback naming live, removed and unknown materials,
// jobs run in any amount) keep the cache and page-table invariants after every one, with the
// engine's copy of the cache texels and page tables exact; ids and layers never move while a
// material lives; nothing allocates after create(); a removed material's slots, layers and
// votes are freed at once and its id only after its last job; reads outstanding at removal
// drain without a leak; adds that do not fit fail cleanly and change nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "btflod/runtime/streamer.hpp"
#include "test_counting_new.hpp"
#include "test_random_operations.hpp"
#include "test_runtime_helpers.hpp"

using namespace btflod;
using namespace btflod_test;

namespace {

// Five containers of different sizes and component counts (T = 32, B = 4).
World make_world(AsyncTileSource* async = nullptr) {
  World w;
  w.add(build(make_eigen(64, 4, 1)));
  w.add(build(make_eigen(96, 8, 2)));
  w.add(build(make_eigen(128, 5, 3)));
  w.add(build(make_eigen(64, 12, 4)));
  w.add(build(make_eigen(128, 8, 5)));
  w.finish(async);
  return w;
}

// Room for `live` of the world's materials at once, whichever they are.
StreamerCapacity capacity_for(const World& w, uint32_t live) {
  std::vector<StreamerMaterial> all = w.materials;
  return streamer_capacity_for(all, live);
}

// An engine that keeps per-layer page tables large enough for any material (layers are reused).
struct LiveEngine : StreamerOutputBuffers {
  std::vector<std::vector<uint16_t>> slots;
  std::vector<std::vector<uint32_t>> page_table;  // per layer, flat tile index
  std::vector<ResidencyEvent> events;
  LiveEngine(const Streamer& s, uint32_t layer_tiles) : StreamerOutputBuffers(s, 512, 64) {
    for (uint32_t slot = 0; slot < s.cache().slot_count(); ++slot) {
      const uint32_t stored = s.cache().pool_config(s.cache().pool_of_slot(slot)).padded_tile_size();
      slots.emplace_back(size_t{stored} * stored * 4, 0);
    }
    page_table.assign(s.gpu_layout().page_table_layers, std::vector<uint32_t>(layer_tiles, 0xffffffffu));
    events.reserve(1u << 16);
  }
  void apply(const Streamer& s, const StreamerOutputs& o) {
    for (size_t i = 0; i < o.tile_upload_count; ++i)
      std::copy(o.tile_uploads[i].texels.begin(), o.tile_uploads[i].texels.end(),
                slots[global_slot(s, o.tile_uploads[i])].begin());
    for (size_t i = 0; i < o.page_table_write_count; ++i) {
      const PageTableWrite& w = o.page_table_writes[i];
      page_table[w.tile.texture][s.cache().set().levels_of(w.tile.texture).index(w.tile)] = w.entry;
    }
    for (size_t i = 0; i < o.event_count && events.size() < events.capacity(); ++i) events.push_back(o.events[i]);
  }
};

// Every finest tile of every live material, words appended to `out` (capacity reserved).
void append_feedback(const Streamer& s, std::vector<uint32_t>& out) {
  for (uint32_t m = 0; m < s.material_count(); ++m) {
    if (!s.material_live(m)) continue;
    const VtLevelTable& lv = s.cache().set().material(m).levels;
    const uint32_t L = lv.finest_level();
    for (uint32_t y = 0; y < lv.tiles_y[L]; ++y)
      for (uint32_t x = 0; x < lv.tiles_x[L]; ++x) out.push_back(pack_feedback(FeedbackTile{m, L, x, y}));
  }
}

// `frames` frames whose feedback votes every finest tile of every live material, each followed
// by the jobs run here and `after()` (e.g. the engine's I/O completing reads).
template <class After>
void stream_frames(Streamer& s, LiveEngine& e, uint32_t frames, After&& after) {
  std::vector<uint32_t> fb;
  for (uint32_t f = 0; f < frames; ++f) {
    fb.clear();
    append_feedback(s, fb);
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update(fb, o), Status::success);
    e.apply(s, o);
    s.pump();
    after();
  }
}
void stream_frames(Streamer& s, LiveEngine& e, uint32_t frames) {
  stream_frames(s, e, frames, [] {});
}

// The engine's cache texels and page tables against the Streamer's cache; `file_of` maps a
// live material id to its container.
void check_live_engine(const World& w, const Streamer& s, const LiveEngine& e,
                       const std::map<uint32_t, size_t>& file_of, bool texels) {
  const TileCache& c = s.cache();
  std::string why;
  ASSERT_TRUE(c.check_invariants(&why)) << why;
  if (texels)
    for (uint32_t slot = 0; slot < c.slot_count(); ++slot) {
      const SlotInfo& si = c.slot(slot);
      if (si.state != SlotInfo::State::used) continue;
      const uint32_t m = c.set().material_of(si.tile.texture);
      ASSERT_TRUE(s.material_live(m));
      if (!s.material_ready(m)) continue;  // roots still loading
      const size_t f = file_of.at(m);
      const TileId local{si.tile.texture - s.first_texture(m), si.tile.level, si.tile.x, si.tile.y};
      ASSERT_EQ(e.slots[slot], decode_direct(w.files[f], w.dirs[f], local)) << "slot " << slot;
    }
  // Page tables are compared once every change was handed out (writes queued or, after an
  // add that evicted tiles, cache changes the next update() publishes).
  if (s.pending_page_table_writes() != 0 || !c.deltas().empty() || !c.touched_tiles().empty()) return;
  for (uint32_t t = 0; t < c.set().texture_count(); ++t) {
    if (!c.set().texture_live(t)) continue;
    const VtLevelTable& lv = c.set().levels_of(t);
    for (uint32_t i = 0; i < lv.tile_count(); ++i) {
      const TileId id = lv.tile(t, i);
      if (c.resident(id) || id.level == lv.finest_level()) {
        ASSERT_EQ(e.page_table[t][i], gpu_page_entry(c, id));
      }
    }
  }
}

uint32_t largest_tile_count(const World& w) {
  uint32_t n = 0;
  for (const BsvtfDirectory& d : w.dirs) {
    const VtLevelTable lv(
        VtGeometry::make(d.metadata.width, d.metadata.height, d.metadata.tile_size, d.metadata.border));
    n = std::max(n, lv.tile_count());
  }
  return n;
}

size_t count(const std::vector<ResidencyEvent>& ev, ResidencyEventKind k, uint32_t m) {
  return static_cast<size_t>(
      std::count_if(ev.begin(), ev.end(), [&](const ResidencyEvent& e) { return e.kind == k && e.material == m; }));
}

}  // namespace

TEST(StreamerMaterials, CapacityForCoversTheLargestMaterialsLiveAtOnce) {
  World w = make_world();
  const StreamerCapacity one = capacity_for(w, 1), three = capacity_for(w, 3);
  EXPECT_EQ(one.materials, 1u);
  EXPECT_EQ(three.materials, 3u);
  EXPECT_EQ(one.textures, 3u);              // C = 12: three virtual textures
  EXPECT_EQ(three.textures, 3u + 2u + 2u);  // C = 12, 8, 8
  EXPECT_GT(three.tiles, one.tiles);
  EXPECT_EQ(one.max_level_count, three.max_level_count);
  EXPECT_EQ(one.max_tile_bytes, three.max_tile_bytes);
  // A Streamer created empty with that room takes any three.
  StreamerConfig cfg = small_config();
  cfg.capacity = three;
  auto s = Streamer::create({}, cfg);
  ASSERT_TRUE(s.ok()) << s.message();
  uint32_t ids[3];
  ASSERT_EQ(s->add_material(w.materials[1], ids[0]), Status::success);
  ASSERT_EQ(s->add_material(w.materials[3], ids[1]), Status::success);
  ASSERT_EQ(s->add_material(w.materials[4], ids[2]), Status::success);
  EXPECT_EQ(ids[0], 0u);
  EXPECT_EQ(ids[1], 1u);
  EXPECT_EQ(ids[2], 2u);
  uint32_t extra = 7;
  const char* why = nullptr;
  EXPECT_EQ(s->add_material(w.materials[0], extra, &why), Status::insufficient_space);
  EXPECT_EQ(extra, kNoMaterial);
  ASSERT_NE(why, nullptr);
  EXPECT_NE(std::string(why).find("material id"), std::string::npos) << why;
}

namespace {

// Ten thousand random adds, removes, frames and job runs on a Streamer created with the first
// two materials of w and room for three (cfg.capacity), checking the invariants and the
// engine's copies after every operation; at least ops / upload_divisor tiles must have streamed.
void random_adds_removes(World& w, const StreamerConfig& cfg, uint32_t upload_divisor) {
  auto created = Streamer::create(std::span<const StreamerMaterial>(w.materials.data(), 2), cfg);
  ASSERT_TRUE(created.ok()) << created.message();
  Streamer& s = *created;
  LiveEngine e(s, largest_tile_count(w));
  std::map<uint32_t, size_t> file_of{{0, 0}, {1, 1}};
  std::map<uint32_t, uint32_t> layer_of{{0, s.first_texture(0)}, {1, s.first_texture(1)}};
  std::vector<uint32_t> feedback;
  feedback.reserve(1u << 16);
  std::mt19937 rng(20261206);
  const uint32_t ops = static_cast<uint32_t>(btflod::test::random_operation_count(10000));
  uint64_t adds = 0, removes = 0, failed_adds = 0, frames = 0, stray_allocations = 0;
  std::vector<uint32_t> removed_ids;
  removed_ids.reserve(ops);
  for (uint32_t op = 0; op < ops; ++op) {
    const uint32_t kind = rng() % 100;
    uint64_t before = 0;
    if (kind < 70) {  // a frame: every live tile voted, plus words of removed and unknown ids
      feedback.clear();
      append_feedback(s, feedback);
      if (!removed_ids.empty()) {
        const uint32_t m = removed_ids[rng() % removed_ids.size()];
        if (!s.material_live(m)) feedback.push_back(pack_feedback(FeedbackTile{m, 0, 0, 0}));
      }
      feedback.push_back(pack_feedback(FeedbackTile{900, 0, 0, 0}));
      std::shuffle(feedback.begin(), feedback.end(), rng);
      feedback.resize(feedback.size() / (1 + rng() % 3));
      StreamerOutputs o = e.outputs();
      before = global_news();
      ASSERT_EQ(s.update(feedback, o), Status::success);
      stray_allocations += global_news() - before;
      e.apply(s, o);
      before = global_news();
      s.pump(rng() % 6);
      stray_allocations += global_news() - before;
      ++frames;
    } else if (kind < 80) {  // add one of the containers
      const size_t f = rng() % w.materials.size();
      uint32_t id = kNoMaterial;
      before = global_news();
      const Status st = s.add_material(w.materials[f], id);
      stray_allocations += global_news() - before;
      if (st == Status::success) {
        ASSERT_TRUE(s.material_live(id));
        ASSERT_EQ(file_of.count(id), 0u);
        file_of[id] = f;
        layer_of[id] = s.first_texture(id);
        ++adds;
      } else {
        ASSERT_EQ(st, Status::insufficient_space);
        ASSERT_EQ(id, kNoMaterial);
        ++failed_adds;
      }
    } else if (kind < 88) {  // remove a live material
      if (file_of.empty()) continue;
      auto it = file_of.begin();
      std::advance(it, rng() % file_of.size());
      const uint32_t id = it->first;
      before = global_news();
      ASSERT_EQ(s.remove_material(id), Status::success);
      stray_allocations += global_news() - before;
      ASSERT_FALSE(s.material_live(id));
      ASSERT_EQ(s.remove_material(id), Status::invalid_argument);
      file_of.erase(it);
      layer_of.erase(id);
      removed_ids.push_back(id);
      ++removes;
    } else {  // run some jobs
      before = global_news();
      s.pump(1 + rng() % 8);
      stray_allocations += global_news() - before;
    }
    for (const auto& [id, layer] : layer_of) ASSERT_EQ(s.first_texture(id), layer) << "material " << id << " moved";
    check_live_engine(w, s, e, file_of, op % 64 == 0);
    if (::testing::Test::HasFatalFailure()) return;
  }
  // Drain: the live materials settle, every removed one is released.
  stream_frames(s, e, 200);
  check_live_engine(w, s, e, file_of, true);
  EXPECT_EQ(stray_allocations, 0u) << "an operation allocated after create()";
  EXPECT_GT(adds, ops / 50);
  EXPECT_GT(removes, ops / 50);
  EXPECT_GT(s.scheduler().total().uploads, ops / upload_divisor);  // materials lived long enough to stream
  EXPECT_GT(failed_adds, 0u);                                      // the room for three was full at times
  const StreamerStats st = s.stats();
  EXPECT_EQ(st.materials_live, file_of.size());
  EXPECT_EQ(st.materials_removing, 0u);
  EXPECT_EQ(st.materials_added, adds + 2);
  EXPECT_EQ(st.materials_removed, removes);
  EXPECT_GT(st.feedback_rejected, 0u);  // removed and unknown ids
  // Every removal was announced once with its layers, then released once.
  for (uint32_t id = 0; id < s.material_count(); ++id) {
    const size_t removed = static_cast<size_t>(std::count(removed_ids.begin(), removed_ids.end(), id));
    if (e.events.size() == e.events.capacity()) break;
    EXPECT_EQ(count(e.events, ResidencyEventKind::material_removed, id), removed) << id;
    EXPECT_EQ(count(e.events, ResidencyEventKind::material_released, id), removed) << id;
  }
  for (uint32_t id = 0; id < s.material_count(); ++id)
    if (s.material_live(id)) {
      EXPECT_TRUE(s.material_ready(id)) << id;
    }
  // Per pool: its slots and live materials add up to the totals.
  uint32_t used = 0, live = 0;
  for (uint32_t p = 0; p < st.pool_count; ++p) {
    EXPECT_EQ(st.pools[p].slots_used, s.cache().used_count(p));
    used += st.pools[p].slots_used;
    live += st.pools[p].materials_live;
  }
  EXPECT_EQ(used, st.slots_used);
  EXPECT_EQ(live, st.materials_live);
  std::printf("%u operations: %llu frames, %llu adds (%llu refused), %llu removes, %llu tile uploads in the engine\n",
              ops, static_cast<unsigned long long>(frames), static_cast<unsigned long long>(adds),
              static_cast<unsigned long long>(failed_adds), static_cast<unsigned long long>(removes),
              static_cast<unsigned long long>(s.scheduler().total().uploads));
}

}  // namespace

TEST(StreamerMaterials, RandomAddsRemovesAndFramesKeepEveryInvariant) {
  World w = make_world();
  StreamerConfig cfg = small_config();
  cfg.capacity = capacity_for(w, 3);
  cfg.vote_window_frames = 4;
  random_adds_removes(w, cfg, 2);
}

// The same across three cache pools: T = 32 containers go to pool 0 unless they name the small
// pool 2 (whose adds must evict its own tiles), T = 64 ones to pool 1 (the first that fits).
// check_invariants() also checks that every slot holds a tile of its own pool.
TEST(StreamerMaterials, RandomAddsRemovesAcrossPoolsKeepEveryInvariant) {
  World w;
  w.add(build(make_eigen(64, 4, 1)));
  w.add(build(make_eigen(256, 4, 6), AngularRowOrder::light_major, 64));
  w.add(build(make_eigen(128, 5, 3)));
  w.add(build(make_eigen(128, 8, 7), AngularRowOrder::light_major, 64));
  w.add(build(make_eigen(96, 8, 2)));
  w.finish();
  w.materials[2].pool = 2;
  w.materials[4].pool = 2;
  StreamerConfig cfg = small_config();
  const CacheConfig pools[] = {CacheConfig{6, 6, 1u << 12, 32, 4, 1}, CacheConfig{4, 3, 1u << 12, 64, 4, 1},
                               CacheConfig{3, 3, 1u << 12, 32, 4, 1}};
  cfg.pools = pools;
  cfg.capacity = capacity_for(w, 3);
  cfg.vote_window_frames = 4;
  random_adds_removes(w, cfg, 4);  // fewer tiles: T = 64 materials have a quarter as many
}

TEST(StreamerMaterials, RemovalFreesSlotsLayersAndVotesAndLeavesOthersAlone) {
  World w = make_world();
  StreamerConfig cfg = small_config();
  cfg.cache = CacheConfig{16, 16, 1u << 12, 32, 4, 1};  // room for everything: nothing is evicted
  cfg.capacity = capacity_for(w, 3);
  auto created = Streamer::create(std::span<const StreamerMaterial>(w.materials.data() + 1, 2), cfg);
  ASSERT_TRUE(created.ok()) << created.message();
  Streamer& s = *created;
  LiveEngine e(s, largest_tile_count(w));
  std::vector<uint32_t> fb;
  append_feedback(s, fb);
  for (int f = 0; f < 60; ++f) {
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update(fb, o), Status::success);
    e.apply(s, o);
    s.pump();
  }
  ASSERT_TRUE(s.material_ready(0) && s.material_ready(1));
  // Material 1's resident tiles, to check they are untouched by material 0's removal.
  std::vector<std::pair<uint32_t, TileId>> others;
  for (uint32_t slot = 0; slot < s.cache().slot_count(); ++slot)
    if (s.cache().slot(slot).state == SlotInfo::State::used &&
        s.cache().set().material_of(s.cache().slot(slot).tile.texture) == 1)
      others.emplace_back(slot, s.cache().slot(slot).tile);
  const uint32_t used_before = s.stats().slots_used;
  uint32_t mine = 0;
  for (uint32_t slot = 0; slot < s.cache().slot_count(); ++slot)
    mine += s.cache().slot(slot).state == SlotInfo::State::used &&
            s.cache().set().material_of(s.cache().slot(slot).tile.texture) == 0;
  ASSERT_GT(mine, s.texture_count(0));  // more than its roots
  const uint32_t layer = s.first_texture(0), layers = s.texture_count(0);
  const uint64_t rejected_before = s.stats().feedback_rejected;
  ASSERT_EQ(s.remove_material(0), Status::success);
  EXPECT_EQ(s.stats().slots_used, used_before - mine);
  for (const auto& [slot, tile] : others) EXPECT_EQ(s.cache().slot(slot).tile, tile);
  StreamerOutputs o = e.outputs();
  ASSERT_EQ(s.update(fb, o), Status::success);  // fb still names material 0
  e.apply(s, o);
  EXPECT_GT(s.stats().feedback_rejected, rejected_before);
  EXPECT_EQ(o.tile_upload_count, 0u);  // nothing new was wanted
  ASSERT_EQ(count(e.events, ResidencyEventKind::material_removed, 0), 1u);
  for (const ResidencyEvent& ev : e.events)
    if (ev.kind == ResidencyEventKind::material_removed) {
      EXPECT_EQ(ev.tile.texture, layer);
      EXPECT_EQ(ev.layers, layers);
    }
  EXPECT_EQ(count(e.events, ResidencyEventKind::material_released, 0), 1u);  // no job was left
  for (const auto& [slot, tile] : others) EXPECT_EQ(s.cache().slot(slot).tile, tile);
  // The id and the layers are reused by the next add of a material that fits them.
  uint32_t id = kNoMaterial;
  ASSERT_EQ(s.add_material(w.materials[1], id), Status::success);
  EXPECT_EQ(id, 0u);
  EXPECT_EQ(s.first_texture(id), layer);
  stream_frames(s, e, 60);
  EXPECT_TRUE(s.material_ready(0));
  check_live_engine(w, s, e, {{0, 1}, {1, 2}}, true);
}

TEST(StreamerMaterials, ReadsOutstandingAtRemovalDrainBeforeTheIdIsReleased) {
  World w = make_world();
  QueueSource io0, io2;  // the engine's I/O, one queue per file
  io0.files = io2.files = &w.files;
  io0.file = 0;
  io2.file = 2;
  io0.refuse_next = io2.refuse_next = false;
  const StreamerMaterial first{&w.dirs[0], nullptr, &io0}, second{&w.dirs[2], nullptr, &io2};
  StreamerConfig cfg = small_config();
  cfg.capacity = capacity_for(w, 2);
  auto created = Streamer::create(std::span<const StreamerMaterial>(&first, 1), cfg);
  ASSERT_TRUE(created.ok()) << created.message();
  Streamer& s = *created;
  LiveEngine e(s, largest_tile_count(w));
  std::vector<uint32_t> fb;
  append_feedback(s, fb);
  StreamerOutputs o = e.outputs();
  ASSERT_EQ(s.update(fb, o), Status::success);  // the roots' and packets' reads start
  e.apply(s, o);
  ASSERT_FALSE(io0.reads.empty());
  ASSERT_EQ(s.remove_material(0), Status::success);
  o = e.outputs();
  ASSERT_EQ(s.update(fb, o), Status::success);
  e.apply(s, o);
  EXPECT_EQ(count(e.events, ResidencyEventKind::material_removed, 0), 1u);
  EXPECT_EQ(count(e.events, ResidencyEventKind::material_released, 0), 0u) << "reads are still outstanding";
  EXPECT_EQ(s.stats().materials_removing, 1u);
  // The id is not reused while its reads are outstanding.
  uint32_t id = kNoMaterial;
  ASSERT_EQ(s.add_material(second, id), Status::success);
  EXPECT_EQ(id, 1u);
  io0.complete_all(s);  // the removed material's reads complete; its jobs are dropped
  for (int f = 0; f < 40 && count(e.events, ResidencyEventKind::material_released, 0) == 0; ++f) {
    o = e.outputs();
    ASSERT_EQ(s.update({}, o), Status::success);
    e.apply(s, o);
    s.pump();
    io0.complete_all(s);
    io2.complete_all(s);
  }
  EXPECT_EQ(count(e.events, ResidencyEventKind::material_released, 0), 1u);
  EXPECT_EQ(s.stats().materials_removing, 0u);
  EXPECT_GT(s.stats().jobs_dropped, 0u);
  EXPECT_TRUE(io0.reads.empty());
  // The new material streams normally; a Streamer destroyed now leaks nothing (ASan).
  stream_frames(s, e, 60, [&] { io2.complete_all(s); });
  EXPECT_TRUE(s.material_ready(1));
  EXPECT_EQ(s.stats().tile_failures + s.stats().packet_failures, 0u);
  check_live_engine(w, s, e, {{1, 2}}, true);
}

TEST(StreamerMaterials, AddsThatDoNotFitFailCleanly) {
  World w = make_world();
  StreamerConfig cfg = small_config();
  cfg.capacity = capacity_for(w, 1);
  cfg.capacity.max_tile_bytes = 0;  // derived from material 0 alone below
  cfg.capacity.max_level_count = 0;
  cfg.capacity.max_finest_tiles = 0;
  auto created = Streamer::create(std::span<const StreamerMaterial>(w.materials.data(), 1), cfg);
  ASSERT_TRUE(created.ok()) << created.message();
  Streamer& s = *created;
  uint32_t id = 5;
  const char* why = nullptr;
  // Material 0 is 64² (two levels); material 2 is 128² (three): a deeper page table than reserved.
  EXPECT_EQ(s.add_material(w.materials[2], id, &why), Status::insufficient_space);
  EXPECT_EQ(id, kNoMaterial);
  ASSERT_NE(why, nullptr);
  StreamerMaterial bad = w.materials[0];
  bad.source = nullptr;
  EXPECT_EQ(s.add_material(bad, id), Status::invalid_argument);
  EXPECT_EQ(s.remove_material(3), Status::invalid_argument);
  EXPECT_EQ(s.remove_material(1000), Status::invalid_argument);
  EXPECT_EQ(s.stats().materials_live, 1u);
  std::string invariants;
  EXPECT_TRUE(s.cache().check_invariants(&invariants)) << invariants;
  // A capacity below create()'s materials is refused with a message.
  StreamerConfig small = small_config();
  small.capacity.textures = 1;
  auto refused = Streamer::create(std::span<const StreamerMaterial>(w.materials.data() + 1, 1), small);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("capacity"), std::string::npos) << refused.message();
}

namespace {

// The engine's I/O for the threaded test: reads queued by the update thread, completed by an
// I/O thread in random order (one queue for every file, each read knows its file).
struct ThreadedIo {
  struct Read {
    const std::vector<uint8_t>* file;
    uint64_t offset;
    std::span<uint8_t> out;
    uint64_t ticket;
  };
  std::mutex mutex;
  std::vector<Read> reads;
  struct Source final : AsyncTileSource {
    ThreadedIo* io = nullptr;
    const std::vector<uint8_t>* file = nullptr;
    bool start_read(uint64_t offset, std::span<uint8_t> out, uint64_t ticket) noexcept override {
      std::lock_guard<std::mutex> lock(io->mutex);
      io->reads.push_back(Read{file, offset, out, ticket});
      return true;
    }
  };
  // Completes one read (a random one); false when none is queued.
  bool complete_one(Streamer& s, std::mt19937& rng) {
    Read r;
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (reads.empty()) return false;
      const size_t i = rng() % reads.size();
      r = reads[i];
      reads[i] = reads.back();
      reads.pop_back();
    }
    std::memcpy(r.out.data(), r.file->data() + r.offset, r.out.size());
    s.complete_read(r.ticket, Status::success);
    return true;
  }
  void complete_all_for_test(Streamer& s) {
    std::mt19937 rng(1);
    while (complete_one(s, rng)) {
    }
  }
};

}  // namespace

// Four engine workers run jobs and an I/O thread completes reads out of order while the update
// thread adds and removes materials: ThreadSanitizer checks that removal never races a job.
TEST(StreamerMaterials, AddAndRemoveWithEngineWorkersAndAnIoThread) {
  World w = make_world();
  ThreadedIo io;
  std::vector<ThreadedIo::Source> sources(w.files.size());
  std::vector<StreamerMaterial> materials;
  for (size_t f = 0; f < w.files.size(); ++f) {
    sources[f].io = &io;
    sources[f].file = &w.files[f];
  }
  for (size_t f = 0; f < w.files.size(); ++f) materials.push_back(StreamerMaterial{&w.dirs[f], nullptr, &sources[f]});
  StreamerConfig cfg = small_config();
  cfg.capacity = streamer_capacity_for(materials, 3);
  cfg.decode_workers = 4;
  auto created = Streamer::create(std::span<const StreamerMaterial>(materials.data(), 2), cfg);
  ASSERT_TRUE(created.ok()) << created.message();
  Streamer& s = *created;
  LiveEngine e(s, largest_tile_count(w));
  std::map<uint32_t, size_t> file_of{{0, 0}, {1, 1}};
  std::atomic<bool> stop{false};
  std::vector<std::thread> workers;
  for (int t = 0; t < 4; ++t)
    workers.emplace_back([&] {
      while (!stop.load(std::memory_order_relaxed)) {
        const uint32_t j = s.acquire_job();
        if (j == Streamer::kNoJob)
          std::this_thread::sleep_for(std::chrono::microseconds(50));
        else
          s.run_job(j);
      }
    });
  std::thread io_thread([&] {
    std::mt19937 rng(7);
    while (!stop.load(std::memory_order_relaxed))
      if (!io.complete_one(s, rng)) std::this_thread::sleep_for(std::chrono::microseconds(50));
  });
  std::mt19937 rng(11);
  std::vector<uint32_t> fb;
  fb.reserve(1u << 14);
  uint32_t adds = 0, removes = 0;
  std::map<std::string, uint32_t> refused;  // why adds were refused
  for (uint32_t frame = 0; frame < 3000; ++frame) {
    const uint32_t r = rng() % 100;
    if (r < 4 && !file_of.empty()) {
      auto it = file_of.begin();
      std::advance(it, rng() % file_of.size());
      ASSERT_EQ(s.remove_material(it->first), Status::success);
      file_of.erase(it);
      ++removes;
    } else if (r < 9) {
      const size_t f = rng() % w.files.size();
      uint32_t id = kNoMaterial;
      const char* why = "";
      if (s.add_material(materials[f], id, &why) == Status::success) {
        file_of[id] = f;
        ++adds;
      } else {
        ++refused[why];
      }
    }
    fb.clear();
    append_feedback(s, fb);
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update(fb, o), Status::success);
    e.apply(s, o);
    if (frame % 100 == 0) check_live_engine(w, s, e, file_of, true);
    std::this_thread::sleep_for(std::chrono::microseconds(100));  // the rest of the engine's frame
    if (HasFatalFailure()) break;
  }
  // Drain: no new work, every read completed, every job ended; then the threads stop.
  s.quiesce();
  for (int f = 0; f < 100000 && !s.idle(); ++f) {
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update({}, o), Status::success);
    e.apply(s, o);
    std::this_thread::yield();
  }
  stop = true;
  for (std::thread& t : workers) t.join();
  io_thread.join();
  EXPECT_TRUE(s.idle());
  EXPECT_GT(adds, 10u);  // (an add waits for a free id: removed materials keep theirs until drained)
  EXPECT_GT(removes, 10u);
  for (const auto& [why, n] : refused) std::printf("add refused %u times: %s\n", n, why.c_str());
  EXPECT_EQ(s.stats().tile_failures + s.stats().packet_failures, 0u);
  s.resume();
  stream_frames(s, e, 100, [&] { io.complete_all_for_test(s); });  // settle on this thread
  check_live_engine(w, s, e, file_of, true);
}
