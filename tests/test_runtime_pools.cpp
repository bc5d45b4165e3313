// btflod-label: unit
// Tests for the Streamer's cache pools (StreamerConfig::pools, StreamerMaterial::pool;
// docs/vt.md "Cache pools"): materials of tile sizes 32 and 64 in one Streamer stream the same
// texels and page tables as two single-pool Streamers; pools of different formats (rgba16f and
// rgba8_affine) each get their own upload format; per-pool stats, GPU layout and memory report;
// nothing allocated per frame; and the failure classes (a pool that does not exist, a container
// whose tile size does not fit its pool or any pool, too many pools, too few slots in a pool).
#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "btflod/runtime/backend/streamer_outputs.hpp"
#include "btflod/runtime/streamer.hpp"
#include "btflod/runtime/vt/cache_format.hpp"
#include "test_counting_new.hpp"
#include "test_runtime_helpers.hpp"

using namespace btflod;
using namespace btflod_test;

namespace {

// The two pools of the mixed world: T = 32 and T = 64, both B = 4, room for every tile.
const CacheConfig kPool32{8, 8, 1u << 12, 32, 4, 1};
const CacheConfig kPool64{5, 5, 1u << 12, 64, 4, 1};

StreamerConfig roomy_config() {
  StreamerConfig c = small_config();
  c.scheduler.budgets.uploads_per_frame = 64;
  c.scheduler.budgets.requests_in_flight = 128;
  c.scheduler.budgets.tiles_decoding = 128;
  return c;
}

// Every finest tile of material m, voted under material id `id`.
std::vector<uint32_t> material_feedback(const Streamer& s, uint32_t m, uint32_t id) {
  std::vector<uint32_t> words;
  const VtLevelTable& lv = s.cache().set().material(m).levels;
  const uint32_t L = lv.finest_level();
  for (uint32_t y = 0; y < lv.tiles_y[L]; ++y)
    for (uint32_t x = 0; x < lv.tiles_x[L]; ++x) words.push_back(pack_feedback(FeedbackTile{id, L, x, y}));
  return words;
}

// The texels a GPU page-table texel of texture t (tile `flat`) leads to in engine e: the entry's
// level and the texels of the slot it names in the material's pool.
std::pair<uint32_t, const std::vector<uint16_t>*> resolve(const Streamer& s, const Engine& e, uint32_t t,
                                                          uint32_t flat) {
  const uint32_t entry = e.page_table[t][flat];
  const uint32_t pool = s.cache().texture_pool(t);
  return {unpack_page_entry_level(entry), &e.slots[s.cache().pool_first_slot(pool) + unpack_page_entry_slot(entry)]};
}

}  // namespace

// Materials of T = 32 (C = 6: two virtual textures) and T = 64 (C = 3) in one Streamer with two
// pools stream, for the same feedback, exactly the texels of a direct decode, and end with the
// same resident tiles and the same page-table texels (level and texels behind the slot) as two
// Streamers of one pool each.
TEST(RuntimePools, MixedTileSizesMatchTwoSingleStreamers) {
  World w;
  w.add(build(make_eigen(128, 6, 1)));                                    // T = 32: 4 × 4 finest tiles
  w.add(build(make_eigen(256, 3, 2), AngularRowOrder::light_major, 64));  // T = 64: 4 × 4 finest tiles
  w.finish();
  StreamerConfig mixed_cfg = roomy_config();
  const CacheConfig pools[] = {kPool32, kPool64};
  mixed_cfg.pools = pools;
  auto mixed_r = Streamer::create(w.materials, mixed_cfg);
  ASSERT_TRUE(mixed_r.ok()) << mixed_r.message();
  Streamer mixed = std::move(mixed_r.value());
  EXPECT_EQ(mixed.pool_count(), 2u);
  EXPECT_EQ(mixed.material_pool(0), 0u);  // the first pool whose tile size fits
  EXPECT_EQ(mixed.material_pool(1), 1u);
  EXPECT_EQ(mixed.pool_config(1).tile_size, 64u);
  Streamer single[2];
  for (uint32_t m = 0; m < 2; ++m) {
    StreamerConfig c = roomy_config();
    c.cache = pools[m];
    auto r = Streamer::create(std::span<const StreamerMaterial>(&w.materials[m], 1), c);
    ASSERT_TRUE(r.ok()) << r.message();
    single[m] = std::move(r.value());
  }
  Engine em(mixed);
  Engine es[2] = {Engine(single[0]), Engine(single[1])};
  std::vector<uint32_t> fb_mixed = material_feedback(mixed, 0, 0), fb_single[2];
  for (uint32_t word : material_feedback(mixed, 1, 1)) fb_mixed.push_back(word);
  for (uint32_t m = 0; m < 2; ++m) fb_single[m] = material_feedback(single[m], 0, 0);
  uint64_t mixed_uploads[2] = {}, stray_allocations = 0;
  for (int frame = 0; frame < 40; ++frame) {
    StreamerOutputs o = em.outputs();
    const uint64_t before = global_news();
    ASSERT_EQ(mixed.update(fb_mixed, o), Status::success);
    mixed.pump();
    stray_allocations += global_news() - before;
    // Every upload: its material's pool, a slot of that pool, the tile's exact texels.
    for (size_t i = 0; i < o.tile_upload_count; ++i) {
      const StreamerTileUpload& u = o.tile_uploads[i];
      const uint32_t m = mixed.cache().set().material_of(u.tile.texture);
      ASSERT_EQ(u.pool, m);
      ASSERT_LT(u.slot, pools[m].slot_count());
      const TileId local{u.tile.texture - mixed.first_texture(m), u.tile.level, u.tile.x, u.tile.y};
      ASSERT_EQ(std::vector<uint16_t>(u.texels.begin(), u.texels.end()), decode_direct(w.files[m], w.dirs[m], local));
      ++mixed_uploads[m];
    }
    em.apply(mixed, o);
    for (uint32_t m = 0; m < 2; ++m) {
      StreamerOutputs os;
      ASSERT_EQ(es[m].frame(single[m], fb_single[m], os), Status::success);
      single[m].pump();
    }
  }
  EXPECT_EQ(stray_allocations, 0u) << "update() or a job allocated";
  check_engine(w, mixed, em);
  EXPECT_GT(mixed_uploads[0], 30u);
  EXPECT_GT(mixed_uploads[1], 15u);
  // Same residency and the same page-table texels as the single-pool Streamers.
  for (uint32_t m = 0; m < 2; ++m) {
    ASSERT_TRUE(mixed.material_ready(m));
    for (uint32_t k = 0; k < mixed.texture_count(m); ++k) {
      const uint32_t tm = mixed.first_texture(m) + k, ts = single[m].first_texture(0) + k;
      const VtLevelTable& lv = mixed.cache().set().levels_of(tm);
      ASSERT_EQ(lv.tile_count(), single[m].cache().set().levels_of(ts).tile_count());
      for (uint32_t i = 0; i < lv.tile_count(); ++i) {
        const TileId a = lv.tile(tm, i), b = lv.tile(ts, i);
        ASSERT_EQ(mixed.cache().resident(a), single[m].cache().resident(b)) << "material " << m << " tile " << i;
        const auto ra = resolve(mixed, em, tm, i), rb = resolve(single[m], es[m], ts, i);
        ASSERT_EQ(ra.first, rb.first) << "material " << m << " tile " << i;
        ASSERT_FALSE(ra.second->empty());
        ASSERT_EQ(*ra.second, *rb.second) << "material " << m << " tile " << i;
      }
    }
  }
  // Stats and layout per pool.
  const StreamerStats st = mixed.stats();
  ASSERT_EQ(st.pool_count, 2u);
  for (uint32_t p = 0; p < 2; ++p) {
    EXPECT_EQ(st.pools[p].slots, pools[p].slot_count());
    EXPECT_EQ(st.pools[p].slots_used, mixed.cache().used_count(p));
    EXPECT_EQ(st.pools[p].slots_used, single[p].stats().slots_used);
    EXPECT_EQ(st.pools[p].materials_live, 1u);
    EXPECT_EQ(st.pools[p].resident_bytes,
              uint64_t{st.pools[p].slots_used} * pools[p].padded_tile_size() * pools[p].padded_tile_size() * 8);
    EXPECT_EQ(st.pools[p].texture_bytes, pools[p].cache_bytes());
  }
  EXPECT_EQ(st.slots, pools[0].slot_count() + pools[1].slot_count());
  EXPECT_EQ(st.slots_used, st.pools[0].slots_used + st.pools[1].slots_used);
  const StreamerGpuLayout g = mixed.gpu_layout();
  ASSERT_EQ(g.pool_count, 2u);
  EXPECT_EQ(g.pools[1].cache_width, 5u * 72u);
  EXPECT_EQ(g.pools[1].cache_height, 5u * 72u);
  EXPECT_EQ(g.pools[1].slots, 25u);
  EXPECT_EQ(g.pools[0].cache_width, 8u * 40u);
  EXPECT_EQ(g.cache_width, g.pools[0].cache_width);
  EXPECT_EQ(g.page_table_layers, 3u);
  // The memory report counts both pools (a decoder set per pool) and equals what is held.
  auto req = Streamer::memory_required(w.materials, mixed_cfg);
  ASSERT_TRUE(req.ok()) << req.message();
  EXPECT_EQ(req->total, st.memory.total);
  EXPECT_EQ(req->decoders, st.memory.decoders);
  EXPECT_EQ(req->tile_cache, st.memory.tile_cache);
  EXPECT_GT(st.memory.decoders, single[0].stats().memory.decoders);
}

// An rgba16f pool and an rgba8_affine pool of the same tile size: each material's uploads come
// in its pool's format — half texels for one, the encoder's unorm8 bytes and map of the directly
// decoded tile for the other — and the forwarded batches never mix pools.
TEST(RuntimePools, PoolsOfDifferentFormatsUploadInTheirOwnFormat) {
  World w;
  w.add(build(make_eigen(96, 8, 3)));
  w.add(build(make_eigen(64, 4, 4)));
  w.finish();
  w.materials[0].pool = 1;  // rgba8_affine
  w.materials[1].pool = 0;  // rgba16f
  StreamerConfig cfg = small_config();
  CacheConfig wide{8, 8, 1u << 12, 32, 4, 1}, compact = wide;
  compact.format = CacheFormat::rgba8_affine;
  const CacheConfig pools[] = {wide, compact};
  cfg.pools = pools;
  auto r = Streamer::create(w.materials, cfg);
  ASSERT_TRUE(r.ok()) << r.message();
  Streamer s = std::move(r.value());
  EXPECT_EQ(s.material_pool(0), 1u);
  EXPECT_EQ(s.material_pool(1), 0u);
  StreamerOutputBuffers buf(s, 4096, 64);
  const std::vector<uint32_t> fb = full_feedback(s);
  uint64_t checked[2] = {}, batches = 0;
  for (int frame = 0; frame < 40; ++frame) {
    StreamerOutputs o = buf.outputs();
    ASSERT_EQ(s.update(fb, o), Status::success);
    for (size_t i = 0; i < o.tile_upload_count; ++i) {
      const StreamerTileUpload& u = o.tile_uploads[i];
      const uint32_t m = s.cache().set().material_of(u.tile.texture);
      ASSERT_EQ(u.pool, s.material_pool(m));
      const TileId local{u.tile.texture - s.first_texture(m), u.tile.level, u.tile.x, u.tile.y};
      const std::vector<float> ref = decode_direct_floats(w.files[m], w.dirs[m], local);
      if (u.pool == 0) {
        ASSERT_TRUE(u.unorm8.empty());
        ASSERT_EQ(std::vector<uint16_t>(u.texels.begin(), u.texels.end()), decode_direct(w.files[m], w.dirs[m], local));
      } else {
        ASSERT_TRUE(u.texels.empty());
        std::vector<uint8_t> q(ref.size());
        const CacheSlotMap map = encode_cache_tile_unorm8(ref, q);
        ASSERT_EQ(std::vector<uint8_t>(u.unorm8.begin(), u.unorm8.end()), q);
        for (int c = 0; c < 4; ++c) {
          ASSERT_EQ(u.map.offset[c], map.offset[c]);
          ASSERT_EQ(u.map.scale[c], map.scale[c]);
        }
      }
      ++checked[u.pool];
    }
    ASSERT_EQ(forward_streamer_outputs(
                  o,
                  [&](std::span<const TileUpload> tiles) {
                    ++batches;
                    for (const TileUpload& t : tiles) {
                      EXPECT_EQ(t.pool, tiles[0].pool);
                      EXPECT_EQ(check_tile_upload(t, pools[t.pool]), Status::success);
                    }
                    return Status::success;
                  },
                  [](std::span<const PageTableWrite>) { return Status::success; }),
              Status::success);
    s.pump();
  }
  EXPECT_GE(checked[0], 5u);  // material 1: its root and 4 finest tiles
  EXPECT_GT(checked[1], 20u);
  EXPECT_GT(batches, 0u);
  const StreamerStats st = s.stats();
  const uint32_t side = compact.padded_tile_size();
  EXPECT_EQ(st.pools[1].resident_bytes, uint64_t{st.pools[1].slots_used} * (side * side * 4 + 16));
  EXPECT_EQ(st.pools[1].texture_bytes, compact.cache_bytes() + compact.slot_map_bytes());
  std::string why;
  EXPECT_TRUE(s.cache().check_invariants(&why)) << why;
}

// Each failure class gives a clear error and creates nothing (create) or changes nothing (add).
TEST(RuntimePools, MissingPoolsAndTileSizesThatDoNotFitAreRefused) {
  World w;
  w.add(build(make_eigen(64, 4, 1)));                                     // T = 32
  w.add(build(make_eigen(128, 4, 2), AngularRowOrder::light_major, 64));  // T = 64
  w.add(build(make_eigen(64, 4, 3), AngularRowOrder::light_major, 16));   // T = 16: no pool
  w.finish();
  StreamerConfig cfg = small_config();
  const CacheConfig pools[] = {kPool32, kPool64};
  cfg.pools = pools;
  const auto refused = [&](std::vector<StreamerMaterial> ms, const StreamerConfig& c, Status status, const char* text) {
    auto r = Streamer::create(ms, c);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status(), status);
    EXPECT_NE(r.message().find(text), std::string::npos) << r.message();
  };
  StreamerMaterial missing = w.materials[0];
  missing.pool = 2;
  refused({missing}, cfg, Status::invalid_argument, "cache pool that does not exist");
  StreamerMaterial wrong = w.materials[1];  // T = 64 in the T = 32 pool
  wrong.pool = 0;
  refused({wrong}, cfg, Status::invalid_argument, "differs from its cache pool");
  refused({w.materials[2]}, cfg, Status::invalid_argument, "no cache pool has the container's tile size");
  CacheConfig nine[kMaxCachePools + 1];
  for (CacheConfig& c : nine) c = kPool32;
  StreamerConfig too_many = cfg;
  too_many.pools = nine;
  refused({w.materials[0]}, too_many, Status::invalid_argument, "cache pools, at most");
  const CacheConfig tiny[] = {kPool32, CacheConfig{1, 1, 1u << 12, 64, 4, 1}};
  StreamerConfig small_pool = cfg;
  small_pool.pools = tiny;
  World w2;
  w2.add(build(make_eigen(128, 8, 2), AngularRowOrder::light_major, 64));  // two virtual textures
  w2.finish();
  refused({w2.materials[0]}, small_pool, Status::insufficient_space, "slots of pool 1");
  const CacheConfig bad[] = {kPool32, CacheConfig{0, 1, 1u << 12, 64, 4, 1}};
  StreamerConfig bad_pool = cfg;
  bad_pool.pools = bad;
  refused({w.materials[0]}, bad_pool, Status::invalid_argument, "pool 1");
  // The same on a live Streamer: add_material refuses and changes nothing.
  cfg.capacity = streamer_capacity_for(w.materials, 3);
  auto r = Streamer::create(std::span<const StreamerMaterial>(w.materials.data(), 1), cfg);
  ASSERT_TRUE(r.ok()) << r.message();
  Streamer& s = *r;
  const StreamerStats before = s.stats();
  uint32_t id = 5;
  const char* why = nullptr;
  EXPECT_EQ(s.add_material(missing, id, &why), Status::invalid_argument);
  EXPECT_EQ(id, kNoMaterial);
  ASSERT_NE(why, nullptr);
  EXPECT_NE(std::string(why).find("does not exist"), std::string::npos) << why;
  EXPECT_EQ(s.add_material(wrong, id, &why), Status::invalid_argument);
  EXPECT_NE(std::string(why).find("its cache pool"), std::string::npos) << why;
  EXPECT_EQ(s.add_material(w.materials[2], id, &why), Status::invalid_argument);
  EXPECT_NE(std::string(why).find("no cache pool"), std::string::npos) << why;
  EXPECT_EQ(s.live_material_count(), 1u);
  EXPECT_EQ(s.stats().slots_used, before.slots_used);
  // And the one that fits goes to the T = 64 pool.
  ASSERT_EQ(s.add_material(w.materials[1], id, &why), Status::success);
  EXPECT_EQ(s.material_pool(id), 1u);
  EXPECT_EQ(s.stats().pools[1].slots_used, 1u);
  EXPECT_EQ(s.stats().pools[1].materials_live, 1u);
}
