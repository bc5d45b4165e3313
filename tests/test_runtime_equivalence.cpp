// The runtime (runtime/streamer.hpp) against the hand-assembled loop the samples used before it
// existed (TileCache + Scheduler driven by hand, page tables brought up to date by diffing
// every slot against the previous frame — the demo's former write_page_tables — and tiles
// decoded directly from the container): over the same feedback frames both give the same
// schedule, identical GPU page tables and identical images (the CPU reference backend's
// CpuCacheTexture sampling every texture on a grid of texture coordinates).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "test_runtime_helpers.hpp"

using namespace btflod;
using btflod_test::decode_direct;

namespace {

EigenTextures make_eigen(uint32_t size, uint32_t components, uint32_t seed) {
  EigenTextures e;
  btflod_test::fill_smooth_textures(e, size, components, seed, 0.09f, 0.05f, 0.0f);
  e.light_count = 2;
  e.view_count = 2;
  e.angular.assign(size_t{2} * 2 * 3 * components, 0.2f);
  return e;
}

std::vector<uint8_t> build(const EigenTextures& e) {
  BsvtfFromEigenOptions o;
  o.tile_size = 32;
  o.border = 4;
  o.light_directions = {0, 0, 1, 0.6f, 0, 0.8f};
  o.view_directions = {0, 0, 1, 0, 0.6f, 0.8f};
  return build_bsvtf_from_eigen_textures(e, o).value();
}

// Every texture sampled on a 48×48 grid through the cache's page table.
std::vector<float> image(const TileCache& cache, const CpuCacheTexture& tex) {
  std::vector<float> out;
  for (uint32_t t = 0; t < cache.set().texture_count(); ++t)
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 48; ++x) {
        float v[4];
        tex.sample(cache, t, (x + 0.5f) / 48.0f, (y + 0.5f) / 48.0f, v);
        out.insert(out.end(), v, v + 4);
      }
  return out;
}

}  // namespace

TEST(RuntimeEquivalence, SamePageTablesAndImagesAsTheHandAssembledLoop) {
  std::vector<std::vector<uint8_t>> files{build(make_eigen(128, 6, 1)), build(make_eigen(128, 4, 2))};
  std::vector<BsvtfDirectory> dirs{read_bsvtf(files[0]).value(), read_bsvtf(files[1]).value()};
  MemorySource s0{std::span<const uint8_t>(files[0])}, s1{std::span<const uint8_t>(files[1])};
  const StreamerMaterial mats[2] = {{&dirs[0], &s0, nullptr}, {&dirs[1], &s1, nullptr}};
  StreamerConfig cfg;
  cfg.cache = CacheConfig{4, 4, 1u << 12, 32, 4, 1};  // 16 slots for 3 textures × 21 tiles: swaps
  cfg.scheduler.budgets.uploads_per_frame = 4;
  cfg.scheduler.budgets.requests_in_flight = 8;
  cfg.vote_window_frames = 1;
  Streamer rt = std::move(Streamer::create(mats, cfg).value());

  // --- the hand-assembled loop, as the demo had it ---
  VtSet set;
  for (const auto& d : dirs) {
    const BsvtfMetadata& md = d.metadata;
    const uint32_t m =
        set.add_material(VtGeometry::make(md.width, md.height, md.tile_size, md.border), md.texture_count());
    for (const BsvtfTileEntry& e : d.tiles) {
      const uint32_t t = set.material(m).first_texture + e.id.texture;
      set.weights(t)[set.levels_of(t).index(e.id)] = Half(e.weight);
      set.energies(t)[set.levels_of(t).index(e.id)] = Half(e.energy);
    }
  }
  TileCache cache = std::move(TileCache::create(set, cfg.cache).value());
  Scheduler sched = std::move(Scheduler::create(cache, cfg.scheduler).value());
  for (uint32_t m = 0; m < 2; ++m)
    for (const BsvtfTileEntry& e : dirs[m].tiles) {
      const uint32_t t = set.material(m).first_texture + e.id.texture;
      sched.set_tile_bytes(t, set.levels_of(t).index(e.id), e.size);
    }
  VoteCounter votes(vote_layouts(set));
  CpuCacheTexture old_tex(cache), new_tex(rt.cache());
  std::vector<std::vector<uint16_t>> staging(cfg.scheduler.budgets.requests_in_flight);
  std::vector<TileId> slot_tiles(cache.slot_count());
  std::vector<uint8_t> slot_used(cache.slot_count(), 0);
  std::vector<std::vector<uint32_t>> old_gpu(set.texture_count()), new_gpu(set.texture_count());
  for (uint32_t t = 0; t < set.texture_count(); ++t) {
    old_gpu[t].assign(set.levels_of(t).tile_count(), 0);
    new_gpu[t].assign(set.levels_of(t).tile_count(), 0);
  }
  std::vector<PageTableWrite> writes;
  const auto old_page_tables = [&](bool full) {  // the demo's slot diff
    writes.clear();
    if (full) {
      for (uint32_t t = 0; t < set.texture_count(); ++t) append_full_page_table_writes(cache, t, writes);
    } else {
      append_page_table_writes(cache, cache.deltas(), writes);
      for (uint32_t s = 0; s < cache.slot_count(); ++s) {
        const SlotInfo& si = cache.slot(s);
        const bool used = si.state == SlotInfo::State::used;
        if (used == (slot_used[s] != 0) && (!used || si.tile == slot_tiles[s])) continue;
        if (slot_used[s]) append_tile_chain_writes(cache, slot_tiles[s], writes);
        if (used) append_tile_chain_writes(cache, si.tile, writes);
      }
    }
    for (uint32_t s = 0; s < cache.slot_count(); ++s) {
      slot_used[s] = cache.slot(s).state == SlotInfo::State::used;
      slot_tiles[s] = cache.slot(s).tile;
    }
    cache.clear_deltas();
    for (const PageTableWrite& w : writes)
      old_gpu[w.tile.texture][set.levels_of(w.tile.texture).index(w.tile)] = w.entry;
  };
  old_page_tables(true);
  for (uint32_t t = 0; t < set.texture_count(); ++t) {  // roots, loaded up front
    const uint32_t m = set.material_of(t);
    old_tex.upload(cache, cache.slot_of(TileId{t, 0, 0, 0}),
                   decode_direct(files[m], dirs[m], TileId{t - set.material(m).first_texture, 0, 0, 0}));
  }

  std::vector<StreamerTileUpload> tiles(rt.tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(rt.packet_uploads_bound());
  std::vector<PageTableWrite> rt_writes(1u << 14);
  std::vector<ResidencyEvent> events(64);
  std::mt19937 rng(9);
  uint32_t compared_frames = 0;
  for (uint64_t f = 1; f <= 150; ++f) {
    std::vector<uint32_t> fb;
    for (int k = 0; k < 10; ++k) {
      const uint32_t m = rng() % 2, level = rng() % 3, side = 1u << level;
      fb.push_back(pack_feedback(
          FeedbackTile{m, level, static_cast<uint32_t>(rng() % side), static_cast<uint32_t>(rng() % side)}));
    }
    // Runtime: one call.
    StreamerOutputs o{tiles, packets, rt_writes, events};
    ASSERT_EQ(rt.update(fb, o), Status::success);
    ASSERT_EQ(rt.pending_page_table_writes(), 0u);
    for (size_t i = 0; i < o.tile_upload_count; ++i)
      new_tex.upload(rt.cache(), o.tile_uploads[i].slot, o.tile_uploads[i].texels);
    for (size_t i = 0; i < o.page_table_write_count; ++i) {
      const PageTableWrite& w = o.page_table_writes[i];
      new_gpu[w.tile.texture][set.levels_of(w.tile.texture).index(w.tile)] = w.entry;
    }
    rt.pump();
    // Hand-assembled: uploads of last frame's decodes, votes, plan, decode, page tables.
    sched.apply_uploads(cache, [&](const TileRequest& q) { old_tex.upload(cache, q.slot, staging[q.id]); });
    votes.accumulate(fb, 1, sched.lod_bias());
    // The runtime schedules a material's tiles once it is ready (its roots verified and uploaded).
    for (uint32_t m = 0; m < 2; ++m) sched.set_material_enabled(m, rt.material_ready(m));
    for (const TileRequest& q : sched.plan(cache, votes, f)) {
      const uint32_t m = set.material_of(q.tile.texture);
      staging[q.id] = decode_direct(
          files[m], dirs[m], TileId{q.tile.texture - set.material(m).first_texture, q.tile.level, q.tile.x, q.tile.y});
      if (sched.begin_decode(q.id)) sched.finish_decode(q.id);
    }
    old_page_tables(false);
    // Same cache state, same GPU page tables (where the shader reads: resident tiles and the
    // finest level), same images.
    for (uint32_t s = 0; s < cache.slot_count(); ++s)
      ASSERT_EQ(cache.slot(s).tile, rt.cache().slot(s).tile) << "frame " << f;
    for (uint32_t t = 0; t < set.texture_count(); ++t)
      for (uint32_t i = 0; i < set.levels_of(t).tile_count(); ++i) {
        const TileId id = set.levels_of(t).tile(t, i);
        if (cache.resident(id) || id.level == set.levels_of(t).finest_level()) {
          ASSERT_EQ(old_gpu[t][i], new_gpu[t][i]) << "frame " << f << " texture " << t << " tile " << i;
        }
      }
    if (rt.material_ready(0) && rt.material_ready(1)) {
      ASSERT_EQ(image(cache, old_tex), image(rt.cache(), new_tex)) << "frame " << f;
      ++compared_frames;
    }
  }
  EXPECT_GT(compared_frames, 100u);
  EXPECT_GT(sched.total().swaps, 10u);
}
