// btflod — materials that come and go on a running Streamer (runtime/streamer.hpp documents
// add_material() and remove_material()): the checks a container must pass, the tables a
// material fills in the room StreamerConfig::capacity reserved, and the two-step removal
// (at once: requests, slots, layers, votes; once its last job ended: its id and sources).
// Included by runtime/impl/streamer_impl.hpp; compiles alone too.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <vector>

#include "btflod/runtime/impl/streamer_impl.hpp"

namespace btflod {

StreamerCapacity streamer_capacity_for(std::span<const StreamerMaterial> candidates, uint32_t live_at_once) {
  StreamerCapacity cap;
  std::vector<uint32_t> textures, tiles, material_tiles;
  for (const StreamerMaterial& sm : candidates) {
    if (sm.directory == nullptr) continue;
    CacheConfig own;
    own.tile_size = sm.directory->metadata.tile_size;
    own.border = sm.directory->metadata.border;
    StreamerMaterial any_pool = sm;  // measured against a pool of its own shape
    any_pool.pool = kStreamerAnyPool;
    detail::StreamerMaterialNeeds n;
    if (detail::check_streamer_material(any_pool, std::span<const CacheConfig>(&own, 1), n, nullptr) != Status::success)
      continue;
    textures.push_back(n.textures);
    tiles.push_back(n.tiles);
    material_tiles.push_back(n.tiles / n.textures);
    cap.max_level_count = std::max(cap.max_level_count, n.level_count);
    cap.max_finest_tiles = std::max(cap.max_finest_tiles, n.finest_tiles);
    cap.max_tile_bytes = std::max(cap.max_tile_bytes, n.max_tile_bytes);
    cap.max_packet_bytes = std::max(cap.max_packet_bytes, n.max_packet_bytes);
    cap.max_u_rows = std::max(cap.max_u_rows, n.rows);
  }
  const size_t n = std::min<size_t>(live_at_once, textures.size());
  std::sort(textures.rbegin(), textures.rend());
  std::sort(tiles.rbegin(), tiles.rend());
  std::sort(material_tiles.rbegin(), material_tiles.rend());
  cap.materials = static_cast<uint32_t>(n);
  for (size_t i = 0; i < n; ++i)
    cap.textures += textures[i], cap.tiles += tiles[i], cap.material_tiles += material_tiles[i];
  return cap;
}

inline bool Streamer::Impl::stale(const detail::StreamerJob& job) const noexcept {
  const detail::StreamerMaterialState& ms = materials[job.material];
  return ms.life != detail::kMaterialLive || ms.generation != job.generation;
}

// A reading job of a removed material (or any, while quiescing): its reads not started yet
// are never started; the job ends (failed, cancelled: its work is asked for again later) with
// its last outstanding completion, or now if none is left.
inline void Streamer::Impl::abandon_reads(uint32_t j) noexcept {
  detail::StreamerJob& job = jobs[j];
  uint32_t unstarted = 0;
  if (job.kind == detail::kPacketJob) {
    unstarted = job.next_read == 0 ? 1 : 0;
    job.next_read = 1;
  } else {
    for (uint32_t i = job.next_read; i < job.chain; ++i) unstarted += job.chain_cached[i] ? 0 : 1;
    job.next_read = job.chain;
  }
  if (unstarted == 0) return;
  job.read_status.store(static_cast<uint8_t>(Status::cancelled), std::memory_order_relaxed);
  if (job.reads_pending.fetch_sub(unstarted, std::memory_order_acq_rel) == unstarted) {
    job.status = Status::cancelled;
    job.state.store(detail::kJobFailed, std::memory_order_release);
  }
}

// Evicts the oldest resident leaf tile (not a root, no resident descendant) of a pool: room
// for a new material's roots. Returns false when no tile can be evicted.
inline bool Streamer::Impl::evict_leaf(uint32_t pool) noexcept {
  uint32_t victim = kNoSlot;
  const uint32_t begin = cache.pool_first_slot(pool), end = begin + cache.pool_config(pool).slot_count();
  for (uint32_t s = begin; s < end; ++s) {
    const SlotInfo& si = cache.slot(s);
    if (si.state != SlotInfo::State::used || si.tile.level == 0 ||
        cache.resident_below_at(si.tile.texture, si.flat_index) != 0)
      continue;
    if (victim == kNoSlot || si.added_frame < cache.slot(victim).added_frame) victim = s;
  }
  return victim != kNoSlot && cache.remove(cache.slot(victim).tile) == Status::success;
}

inline Status Streamer::Impl::add_material(const StreamerMaterial& sm, uint32_t& id, bool queue_startup,
                                           const char** why) noexcept {
  id = kNoMaterial;
  const auto fail = [&](Status s, const char* text) {
    if (why != nullptr) *why = text;
    return s;
  };
  detail::StreamerMaterialNeeds needs;
  if (const Status s = detail::check_streamer_material(sm, std::span<const CacheConfig>(pools, pool_count), needs, why);
      s != Status::success)
    return s;
  const StreamerCapacity& cap = capacity;
  if (needs.level_count > cap.max_level_count || needs.finest_tiles > cap.max_finest_tiles)
    return fail(Status::insufficient_space,
                "the material's hierarchy is deeper or wider than the capacity's page table");
  if (needs.max_tile_bytes > cap.max_tile_bytes || needs.max_packet_bytes > cap.max_packet_bytes ||
      needs.rows > cap.max_u_rows)
    return fail(Status::insufficient_space, "a tile payload, U′ packet or U′ row count exceeds the capacity");
  uint32_t m = kNoMaterial;
  for (uint32_t i = 0; i < materials.size() && m == kNoMaterial; ++i)
    if (materials[i].life == detail::kMaterialFree) m = i;
  if (m == kNoMaterial) return fail(Status::insufficient_space, "no free material id (capacity.materials)");
  const VtSet& set = cache.set();
  if (set.largest_free_textures() < needs.textures || set.largest_free_entries() < needs.tiles ||
      votes.largest_free_tiles() < needs.tiles / needs.textures)
    return fail(Status::insufficient_space, "no run of free page-table layers or tile entries is large enough");
  while (cache.free_count(needs.pool) < needs.textures)
    if (!evict_leaf(needs.pool))
      return fail(Status::insufficient_space, "too few slots in its cache pool to pin the material's roots");
  uint32_t got = m;
  if (scheduler.add_material(cache, needs.geometry, needs.textures, got, needs.pool) != Status::success)
    return fail(Status::insufficient_space, "the cache has no room for the material");
  const VtMaterial& vm = set.material(m);
  const VtLevelTable& lv = vm.levels;
  if (votes.add_material(m, VoteLayout{lv.finest_level(), lv.tiles_x[lv.finest_level()],
                                       lv.tiles_y[lv.finest_level()]}) != Status::success) {
    scheduler.remove_material(cache, m);
    return fail(Status::insufficient_space, "the vote counter has no room for the material");
  }
  scheduler.set_material_enabled(m, false);  // its tiles are scheduled once it is ready
  const BsvtfMetadata& md = sm.directory->metadata;
  detail::StreamerMaterialState& ms = materials[m];
  const uint32_t generation = ms.generation + 1;
  ms = detail::StreamerMaterialState{};
  ms.generation = generation;
  ms.life = detail::kMaterialLive;
  ms.source = sm.source;
  ms.async_source = sm.async_source;
  ms.first_texture = vm.first_texture;
  ms.texture_count = vm.texture_count;
  ms.components = md.component_count;
  ms.tile_count = lv.tile_count();
  ms.record_base = vm.entry_base;
  ms.lights = static_cast<uint32_t>(md.light_directions.size() / 3);
  ms.views = static_cast<uint32_t>(md.view_directions.size() / 3);
  ms.channels = md.color_channels;
  ms.rows = md.u_rows;
  ms.row_order = needs.row_order;
  ms.packet_base = vm.first_texture;
  ms.pool = needs.pool;
  for (uint32_t k = 0; k < vm.texture_count; ++k) {
    const uint32_t t = vm.first_texture + k;
    texture_material[t] = m;
    texture_tile_base[t] = set.texture_offset(t);
    const BsvtfPacketEntry& p = sm.directory->packets[k];
    packet_records[t] = detail::TileRecord{p.offset, p.size, p.crc};
    packet_failures[t] = 0;
    startup_failed[t] = 0;
  }
  // Its tiles' records and scheduler values, from one pass over the directory (its entries in
  // the hierarchy are exactly its tiles: check_streamer_material counted them). The
  // scheduler's values go through half, as the container index stores them (§7).
  for (const BsvtfTileEntry& e : sm.directory->tiles) {
    if (e.id.texture >= vm.texture_count || !lv.geometry.contains(e.id)) continue;
    const uint32_t k = e.id.texture, i = lv.index(e.id);
    const size_t r = ms.record_base + size_t{k} * ms.tile_count + i;
    records[r] = detail::TileRecord{e.offset, e.size, e.crc};
    tile_failures[r] = 0;
    scheduler.set_tile_values(vm.first_texture + k, i, Half(e.weight).to_float(), Half(e.energy).to_float(), e.size);
  }
  scheduler.refresh_weight_bounds(m);
  // Its page-table texels, every level, go out in full (the layers may hold another material's
  // entries).
  for (uint32_t k = 0; k < vm.texture_count; ++k) {
    const uint32_t t = vm.first_texture + k;
    for (uint32_t i = 0; i < ms.tile_count; ++i) {
      mirror_texture[texture_tile_base[t] + i] = t;
      mirror[texture_tile_base[t] + i] = 0xffffffffu;
      queue_write(t, i, gpu_page_entry(cache, lv.tile(t, i)));
    }
  }
  scheduler.set_u_packet_bytes(m, sm.directory->packets[0].size);
  if (queue_startup) {
    for (uint32_t k = 0; k < vm.texture_count; ++k) push_startup((vm.first_texture + k) << 1);
    if (!config.scheduler.stream_u_columns)
      for (uint32_t k = 0; k < vm.texture_count; ++k) push_startup((vm.first_texture + k) << 1 | 1);
  }
  ++live_materials;
  ++materials_added;
  id = m;
  return Status::success;
}

inline Status Streamer::Impl::remove_material(uint32_t m) noexcept {
  if (m >= materials.size() || materials[m].life != detail::kMaterialLive) return Status::invalid_argument;
  detail::StreamerMaterialState& ms = materials[m];
  const uint32_t t0 = ms.first_texture, t1 = ms.first_texture + ms.texture_count;
  // Its jobs: work not started is dropped now; reading or running jobs end and are dropped
  // (update() sees them stale).
  for (uint32_t j = 0; j < jobs.size(); ++j) {
    detail::StreamerJob& job = jobs[j];
    if (job.material != m || job.generation != ms.generation) continue;
    uint8_t st = job.state.load(std::memory_order_acquire);
    if (st == detail::kJobFree || st == detail::kJobHanded) continue;
    if (job.request != kNoJob && job.request < job_of_request.size() && job_of_request[job.request] == j)
      job_of_request[job.request] = kNoJob;
    if (st == detail::kJobWaiting) {
      job.state.store(detail::kJobFree, std::memory_order_relaxed);
      continue;
    }
    if (st == detail::kJobRunnable &&
        job.state.compare_exchange_strong(st, detail::kJobFree, std::memory_order_acq_rel)) {
      drop_stale_pin(job);
      ++jobs_dropped;
    }
  }
  scheduler.remove_material(cache, m);  // cancels its requests, frees its slots and ids
  votes.remove_material(m);
  // Queued work of its textures.
  const auto mine = [&](uint32_t texture) { return texture >= t0 && texture < t1; };
  uint32_t kept = 0;
  for (uint32_t i = 0; i < startup_count; ++i) {
    const uint32_t item = startup[(startup_head + i) % startup.size()];
    if (!mine(item >> 1)) startup[(startup_head + kept++) % startup.size()] = item;
  }
  startup_count = kept;
  kept = 0;
  for (uint32_t i = 0; i < waiting_count; ++i)
    if (!mine(static_cast<uint32_t>(waiting_packets[i] >> 32))) waiting_packets[kept++] = waiting_packets[i];
  waiting_count = kept;
  kept = 0;
  for (uint32_t i = 0; i < held_count; ++i) {
    const detail::HeldWork h = held[i];
    if (!(h.packet ? h.texture == m : mine(h.texture))) held[kept++] = h;
  }
  held_count = kept;
  // Its page-table texels leave the write queue; its mirror is reset.
  size_t q_kept = 0;
  for (size_t i = 0; i < queue_count; ++i) {
    const uint32_t x = queue[(queue_head + i) % queue.size()];
    if (mine(mirror_texture[x])) {
      queued[x] = 0;
      continue;
    }
    queue[(queue_head + q_kept++) % queue.size()] = x;
  }
  queue_count = q_kept;
  for (uint32_t t = t0; t < t1; ++t) {
    for (uint32_t i = 0; i < ms.tile_count; ++i) {
      const uint32_t x = texture_tile_base[t] + i;
      mirror[x] = 0xffffffffu;
      if (tile_failures[ms.record_base + (t - t0) * ms.tile_count + i] >= config.failure.tile_attempts && i > 0)
        --tiles_unavailable;
    }
    texture_material[t] = kNoMaterial;
  }
  purge_cached(m);
  if (ms.failed) --materials_failed_now;
  ms.failed = ms.ready = false;
  ms.life = detail::kMaterialRemoving;
  ResidencyEvent removed{ResidencyEventKind::material_removed, m, TileId{t0, 0, 0, 0}, Status::success};
  removed.layers = t1 - t0;
  notice(removed);
  if (!material_busy(m)) release_material(m);  // nothing in flight: its id is free at once
  --live_materials;
  ++materials_removed_count;
  return Status::success;
}

// Forgets a material's payloads and unpinned decoded tiles (its id may be reused later).
inline void Streamer::Impl::purge_cached(uint32_t m) noexcept {
  for (uint32_t e = 0; e < decoded.size(); ++e)
    if (decoded[e].key != ~0ull && key_material(decoded[e].key) == m && decoded[e].pins == 0) decoded[e].key = ~0ull;
  payloads.erase_if([m](uint64_t key) { return key_material(key) == m; });
}

// Queues a material event for the next update()'s outputs (the oldest is dropped, and
// counted, in the unlikely case that more are waiting than the ring holds).
inline void Streamer::Impl::notice(const ResidencyEvent& e) noexcept {
  if (notices.size() == 0) return;
  if (notice_count == notices.size()) {
    notice_head = (notice_head + 1) % static_cast<uint32_t>(notices.size());
    --notice_count;
    ++dropped_events;
  }
  notices[(notice_head + notice_count) % notices.size()] = e;
  ++notice_count;
}

// True while a job launched for material m's current generation may still read or run.
inline bool Streamer::Impl::material_busy(uint32_t m) const noexcept {
  const detail::StreamerMaterialState& ms = materials[m];
  for (uint32_t j = 0; j < jobs.size(); ++j) {
    const detail::StreamerJob& job = jobs[j];
    const uint8_t st = job.state.load(std::memory_order_acquire);
    // Only jobs that may still read its source or run count: finished ones are dropped when
    // collected (their generation no longer matches, whatever the id names by then).
    if (job.material == m && job.generation == ms.generation &&
        (st == detail::kJobReading || st == detail::kJobRunnable || st == detail::kJobRunning))
      return true;
  }
  return false;
}

// A removed material with no job left: its id is free and its sources may go.
inline void Streamer::Impl::release_material(uint32_t m) noexcept {
  detail::StreamerMaterialState& ms = materials[m];
  purge_cached(m);  // entries pinned by its last jobs are free now
  notice(ResidencyEvent{ResidencyEventKind::material_released, m, TileId{ms.first_texture, 0, 0, 0}, Status::success});
  ms.life = detail::kMaterialFree;
  ms.source = nullptr;
  ms.async_source = nullptr;
}

// After a frame's jobs were collected: removed materials whose last job ended are released,
// then the waiting material events go out (what does not fit waits for the next frame).
inline void Streamer::Impl::announce_materials(StreamerOutputs& out) noexcept {
  for (uint32_t m = 0; m < materials.size(); ++m)
    if (materials[m].life == detail::kMaterialRemoving && !material_busy(m)) release_material(m);
  while (notice_count > 0 && out.event_count < out.events.size()) {
    out.events[out.event_count++] = notices[notice_head];
    notice_head = (notice_head + 1) % static_cast<uint32_t>(notices.size());
    --notice_count;
  }
}

}  // namespace btflod
