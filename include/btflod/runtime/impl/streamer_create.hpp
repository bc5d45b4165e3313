// btflod — Streamer::create() (every buffer sized and allocated through the engine's
// callbacks, the memory report measured on the way) and the Streamer's accessors. Included by
// runtime/streamer.hpp; compiles alone too.
#pragma once

#include <algorithm>
#include <new>
#include <utility>

#include "btflod/runtime/impl/streamer_impl.hpp"

namespace btflod {

struct Streamer::Room {
  StreamerCapacity need;      // what the materials given need
  StreamerCapacity capacity;  // need, raised to config.capacity where that reserves more
};

Result<Streamer::Room> Streamer::resolve_room(std::span<const StreamerMaterial> materials,
                                              const StreamerConfig& config) {
  const std::span<const CacheConfig> pools = detail::streamer_pools(config);
  if (pools.size() > kMaxCachePools)
    return make_error(Status::invalid_argument, "streamer: %zu cache pools, at most %u", pools.size(), kMaxCachePools);
  uint64_t all_slots = 0;
  for (size_t p = 0; p < pools.size(); ++p) {
    const CacheConfig& c = pools[p];
    if (!c.slot_side_fits_format())
      return make_error(Status::invalid_argument,
                        "streamer: pool %zu: a %s cache needs a slot side T+2B that is a multiple of 4 (whole BC5 "
                        "blocks), found %u+2·%u = %u",
                        p, cache_format_name(c.format), c.tile_size, c.border, c.padded_tile_size());
    if (!c.valid())
      return make_error(Status::invalid_argument,
                        "streamer: pool %zu: cache of %u×%u×%u slots of %u+2·%u texels is not valid", p, c.slots_x,
                        c.slots_y, c.cache_layers, c.tile_size, c.border);
    all_slots += c.slot_count();
  }
  if (all_slots >= (1u << 24))
    return make_error(Status::invalid_argument, "streamer: %llu cache slots over all pools, at most 2^24 − 1",
                      static_cast<unsigned long long>(all_slots));
  if (config.packet_jobs == 0 || config.root_jobs == 0 || config.decode_workers == 0 ||
      config.u_row_order == AngularRowOrder::unspecified)
    return make_error(Status::invalid_argument,
                      "streamer: packet_jobs, root_jobs and decode_workers must be > 0 and u_row_order specified");
  const StreamerFailurePolicy& fp = config.failure;
  if (fp.tile_attempts == 0 || fp.startup_attempts == 0 || fp.packet_attempts == 0)
    return make_error(Status::invalid_argument, "streamer: failure policy attempts must be ≥ 1");
  // What create()'s materials need; the capacity is that unless the config reserves more.
  StreamerCapacity need;
  uint64_t tiles_needed = 0;
  uint64_t pool_textures[kMaxCachePools] = {};
  for (size_t m = 0; m < materials.size(); ++m) {
    detail::StreamerMaterialNeeds n;
    const char* why = "";
    if (const Status s = detail::check_streamer_material(materials[m], pools, n, &why); s != Status::success)
      return make_error(s, "streamer: material %zu (%s, pool %d): %s", m,
                        materials[m].directory != nullptr ? materials[m].directory->metadata.material_name.c_str() : "",
                        materials[m].pool == kStreamerAnyPool ? -1 : static_cast<int>(materials[m].pool), why);
    pool_textures[n.pool] += n.textures;
    need.textures += n.textures;
    tiles_needed += n.tiles;
    need.material_tiles += n.tiles / n.textures;
    need.max_level_count = std::max(need.max_level_count, n.level_count);
    need.max_finest_tiles = std::max(need.max_finest_tiles, n.finest_tiles);
    need.max_tile_bytes = std::max(need.max_tile_bytes, n.max_tile_bytes);
    need.max_packet_bytes = std::max(need.max_packet_bytes, n.max_packet_bytes);
    need.max_u_rows = std::max(need.max_u_rows, n.rows);
  }
  need.materials = static_cast<uint32_t>(std::min<size_t>(materials.size(), UINT32_MAX));
  if (tiles_needed >= (1ull << 31)) return make_error(Status::invalid_argument, "streamer: too many tiles");
  need.tiles = static_cast<uint32_t>(tiles_needed);
  StreamerCapacity cap = config.capacity;
  const auto resolve = [](uint32_t& field, uint32_t needed) {
    if (field == 0) field = needed;
    return field >= needed;
  };
  if (cap.material_tiles == 0) cap.material_tiles = cap.tiles == 0 ? need.material_tiles : cap.tiles;
  if (!resolve(cap.materials, need.materials) || !resolve(cap.textures, need.textures) ||
      !resolve(cap.tiles, need.tiles) || !resolve(cap.material_tiles, need.material_tiles) ||
      !resolve(cap.max_level_count, need.max_level_count) || !resolve(cap.max_finest_tiles, need.max_finest_tiles) ||
      !resolve(cap.max_tile_bytes, need.max_tile_bytes) || !resolve(cap.max_packet_bytes, need.max_packet_bytes) ||
      !resolve(cap.max_u_rows, need.max_u_rows))
    return make_error(Status::invalid_argument, "streamer: the capacity is below what the %zu materials given need",
                      materials.size());
  if (cap.materials == 0)
    return make_error(Status::invalid_argument,
                      "streamer: no materials and no capacity for any (StreamerConfig::capacity)");
  if (cap.materials > kFeedbackMaxMaterials)
    return make_error(Status::invalid_argument, "streamer: %u materials, the feedback word holds at most %u",
                      cap.materials, kFeedbackMaxMaterials);
  if (cap.textures == 0 || cap.tiles == 0 || cap.max_level_count == 0 || cap.max_level_count > kMaxTileLevel + 1)
    return make_error(Status::invalid_argument,
                      "streamer: a capacity without materials needs textures, tiles and max_level_count (≤ %u)",
                      kMaxTileLevel + 1);
  for (size_t p = 0; p < pools.size(); ++p)
    if (pools[p].slot_count() < pool_textures[p])
      return make_error(Status::insufficient_space,
                        "streamer: %u cache slots of pool %zu cannot pin the roots of its %llu virtual textures",
                        pools[p].slot_count(), p, static_cast<unsigned long long>(pool_textures[p]));
  return Room{need, cap};
}

Result<Streamer> Streamer::create(std::span<const StreamerMaterial> materials, const StreamerConfig& config) {
  auto room = resolve_room(materials, config);
  if (!room) return room.error();
  const StreamerCapacity need = room.value().need, cap = room.value().capacity;
  // Every allocation goes through a ledger over the engine's callbacks (StreamerStats::memory).
  void* ledger_memory =
      config.allocator.allocate_bytes(sizeof(detail::AllocationLedger), alignof(detail::AllocationLedger));
  if (ledger_memory == nullptr) return make_error(Status::insufficient_space, "streamer: allocator failed");
  detail::AllocationLedger* ledger = ::new (ledger_memory) detail::AllocationLedger{config.allocator};
  struct LedgerGuard {  // frees the ledger unless the Streamer took it
    detail::AllocationLedger* ledger;
    ~LedgerGuard() {
      if (ledger == nullptr) return;
      const RuntimeAllocator inner = ledger->inner;
      ledger->~AllocationLedger();
      inner.deallocate_bytes(ledger, sizeof(detail::AllocationLedger), alignof(detail::AllocationLedger));
    }
  } ledger_guard{ledger};
  Streamer out;  // destroyed before the guard on every error path
  const RuntimeAllocator al = ledger->counting();
  // An empty set with the reserved room: the materials are added below, as add_material() would.
  VtSet set(al);
  set.reserve(VtCapacity{cap.materials, cap.textures, cap.tiles});
  const uint64_t set_bytes = ledger->live, set_allocations = ledger->count;  // a create() temporary
  StreamerMemory memory;
  uint64_t mark = ledger->live;
  const std::span<const CacheConfig> pools = detail::streamer_pools(config);
  auto cache = TileCache::create_pools(set, pools, al);
  if (!cache) return cache.error();
  memory.tile_cache = ledger->live - mark;
  mark = ledger->live;
  auto sched = Scheduler::create(cache.value(), config.scheduler, al);
  if (!sched) return sched.error();
  memory.scheduler = ledger->live - mark;
  mark = ledger->live;
  VoteCounter votes(std::span<const VoteLayout>(), VoteWindowConfig{std::max(1u, config.vote_window_frames), 0}, al,
                    VoteCapacity{cap.materials, cap.material_tiles});
  memory.votes = ledger->live - mark;

  void* mem = al.allocate_bytes(sizeof(Impl), alignof(Impl));
  if (mem == nullptr) return make_error(Status::insufficient_space, "streamer: allocator failed");
  Impl* im = ::new (mem) Impl(std::move(cache.value()), std::move(sched.value()), std::move(votes));
  out.impl_ = im;
  im->ledger = std::exchange(ledger_guard.ledger, nullptr);
  im->allocator = al;
  im->config = config;
  im->config.pools = {};  // the caller's array is not kept: the pools are copied
  im->config.cache = pools[0];
  im->pool_count = static_cast<uint32_t>(pools.size());
  for (uint32_t p = 0; p < im->pool_count; ++p) {
    im->pools[p] = pools[p];
    im->layouts[p] = TileLayout{pools[p].tile_size, pools[p].border, 4};
    im->max_samples = std::max(im->max_samples, im->layouts[p].sample_count());
  }
  im->capacity = cap;
  mark = ledger->live;
  im->payloads = PayloadCache(PayloadCacheConfig{config.payload_cache_bytes, 4096, 512}, al);
  if (im->payloads.allocation_failed())
    return make_error(Status::insufficient_space, "streamer: allocating the payload cache failed");
  memory.payload_cache = ledger->live - mark;
  const auto fail = [&](const char* what) {
    return make_error(Status::insufficient_space, "streamer: allocating %s failed", what);
  };
  // Tables sized by the capacity: per material id, per tile entry (the VtSet's layout), per
  // virtual texture (page-table layer).
  if (!im->materials.allocate(al, cap.materials) || !im->records.allocate(al, cap.tiles) ||
      !im->texture_material.allocate(al, cap.textures) || !im->packet_records.allocate(al, cap.textures))
    return fail("material tables");
  std::fill(im->texture_material.data(), im->texture_material.data() + cap.textures, kNoMaterial);
  // Jobs: one per request in flight plus one per upload of a frame (a job whose texels were
  // handed out is reused only after the next update), root jobs, packet jobs.
  im->tile_jobs = config.scheduler.budgets.requests_in_flight + config.scheduler.budgets.uploads_per_frame;
  im->root_jobs = config.root_jobs;
  im->packet_jobs = config.packet_jobs;
  const uint32_t tile_like = im->tile_jobs + im->root_jobs;
  const uint32_t nj = tile_like + im->packet_jobs;
  im->chain_bytes = static_cast<size_t>(cap.max_level_count) * cap.max_tile_bytes;
  im->packet_bytes = cap.max_packet_bytes;
  im->max_rows = cap.max_u_rows;
  const size_t max_packet = cap.max_packet_bytes, max_rows = cap.max_u_rows;
  const size_t samples = im->max_samples;  // every job buffer fits a tile of any pool
  mark = ledger->live;
  if (!im->jobs.allocate(al, nj) ||
      !im->job_bytes.allocate(al, tile_like * im->chain_bytes + size_t{im->packet_jobs} * max_packet) ||
      !im->job_floats.allocate(al, size_t{tile_like} * samples * 2) ||
      !im->job_halves.allocate(al, size_t{tile_like} * samples + size_t{im->packet_jobs} * max_rows * 4) ||
      !im->job_of_request.allocate(al, config.scheduler.budgets.requests_in_flight) ||
      !im->waiting_packets.allocate(al, config.scheduler.budgets.requests_in_flight))
    return fail("job buffers");
  for (uint32_t j = 0; j < nj; ++j) {
    detail::StreamerJob& job = im->jobs[j];
    if (j < tile_like) {
      job.bytes = im->job_bytes.data() + size_t{j} * im->chain_bytes;
      job.parent = im->job_floats.data() + size_t{j} * samples * 2;
      job.out = job.parent + samples;
      job.halves = im->job_halves.data() + size_t{j} * samples;
    } else {
      const uint32_t p = j - tile_like;
      job.kind = detail::kPacketJob;
      job.bytes = im->job_bytes.data() + size_t{tile_like} * im->chain_bytes + size_t{p} * max_packet;
      job.halves = im->job_halves.data() + size_t{tile_like} * samples + size_t{p} * max_rows * 4;
    }
  }
  std::fill(im->job_of_request.data(), im->job_of_request.data() + im->job_of_request.size(), kNoJob);
  memory.job_buffers = ledger->live - mark;
  // One tile decoder per worker the engine declares (not per job), per pool: a decoder is
  // built for one tile layout.
  mark = ledger->live;
  const size_t decoders = size_t{config.decode_workers} * im->pool_count;
  if (!im->decoder_storage.allocate(al, decoders * sizeof(TileDecoder) + alignof(TileDecoder)) ||
      !im->decoder_busy.allocate(al, decoders))
    return fail("tile decoders");
  for (uint32_t d = 0; d < decoders; ++d) {
    ::new (static_cast<void*>(im->decoder(d)))
        TileDecoder(im->layouts[d / config.decode_workers], config.inflate_backend, al);
    ++im->decoder_count;
  }
  memory.decoders = ledger->live - mark;
  mark = ledger->live;
  if (!im->decoded.allocate(al, config.decoded_cache_tiles) ||
      !im->decoded_floats.allocate(al, size_t{config.decoded_cache_tiles} * samples))
    return fail("decoded cache");
  for (uint32_t e = 0; e < config.decoded_cache_tiles; ++e)
    im->decoded[e].samples = im->decoded_floats.data() + size_t{e} * samples;
  memory.decoded_cache = ledger->live - mark;
  // Failure bookkeeping, the start-up queue (each root and packet at most once) and the GPU
  // page-table mirror with its write queue (one entry per tile of every level).
  if (!im->tile_failures.allocate(al, cap.tiles) || !im->packet_failures.allocate(al, cap.textures) ||
      !im->startup_failed.allocate(al, cap.textures) || !im->held.allocate(al, config.failure.held_tiles_capacity))
    return fail("failure tables");
  if (!im->startup.allocate(al, size_t{cap.textures} * 2)) return fail("start-up queue");
  if (!im->notices.allocate(al, size_t{cap.materials} * 2 + 2)) return fail("material events");
  if (!im->texture_tile_base.allocate(al, cap.textures) || !im->mirror.allocate(al, cap.tiles) ||
      !im->queued.allocate(al, cap.tiles) || !im->queue.allocate(al, cap.tiles) ||
      !im->mirror_texture.allocate(al, cap.tiles))
    return fail("page-table mirror");
  // create()'s materials, as add_material() adds them (ids 0 … n − 1, layers in order), then
  // the start-up queue: every root, then every U′ packet unless the scheduler streams them (§6).
  for (size_t m = 0; m < materials.size(); ++m) {
    uint32_t id = kNoMaterial;
    const char* why = "";
    if (const Status s = im->add_material(materials[m], id, false, &why); s != Status::success)
      return make_error(s, "streamer: material %zu: %s", m, why);
  }
  for (uint32_t t = 0; t < need.textures; ++t) im->push_startup(t << 1);
  if (!config.scheduler.stream_u_columns)
    for (uint32_t t = 0; t < need.textures; ++t) im->push_startup(t << 1 | 1);
  im->cache.clear_deltas();  // the mirror queued every texel already
  // What is left: the Streamer object, the material, tile and packet tables, the page-table
  // mirror and queues (the create() temporaries are released when it returns: not counted).
  memory.total = ledger->live - set_bytes + sizeof(detail::AllocationLedger);
  memory.allocations = ledger->count - set_allocations + 1;  // the ledger itself: one more
  memory.tables = memory.total - memory.tile_cache - memory.scheduler - memory.votes - memory.payload_cache -
                  memory.job_buffers - memory.decoders - memory.decoded_cache;
  im->memory = memory;
  return out;
}

StreamerMemory Streamer::memory_for(const StreamerConfig& config, const StreamerCapacity& cap) noexcept {
  // The arrays create() allocates, in the same sizes (tests/test_runtime_memory.cpp checks that
  // every category equals what a created Streamer reports).
  const VtCapacity set{cap.materials, cap.textures, cap.tiles};
  const std::span<const CacheConfig> pools = detail::streamer_pools(config);
  const AllocationTally cache = TileCache::memory_required(set, pools);
  uint32_t all_slots = 0;
  uint64_t samples = 0;
  for (const CacheConfig& p : pools) {
    all_slots += p.slot_count();
    samples = std::max<uint64_t>(samples, TileLayout{p.tile_size, p.border, 4}.sample_count());
  }
  const AllocationTally sched = Scheduler::memory_required(set, all_slots, config.scheduler);
  const AllocationTally votes = VoteCounter::memory_required(
      VoteCapacity{cap.materials, cap.material_tiles}, VoteWindowConfig{std::max(1u, config.vote_window_frames), 0});
  const AllocationTally payloads =
      PayloadCache::memory_required(PayloadCacheConfig{config.payload_cache_bytes, 4096, 512});
  const uint64_t requests = config.scheduler.budgets.requests_in_flight;
  const uint64_t tile_like = requests + config.scheduler.budgets.uploads_per_frame + config.root_jobs;
  const uint64_t packet_jobs = config.packet_jobs;
  const uint64_t chain_bytes = uint64_t{cap.max_level_count} * cap.max_tile_bytes;
  AllocationTally jobs;
  jobs.array<decltype(Impl::jobs)>(tile_like + packet_jobs);
  jobs.array<decltype(Impl::job_bytes)>(tile_like * chain_bytes + packet_jobs * cap.max_packet_bytes);
  jobs.array<decltype(Impl::job_floats)>(tile_like * samples * 2);
  jobs.array<decltype(Impl::job_halves)>(tile_like * samples + packet_jobs * cap.max_u_rows * 4);
  jobs.array<decltype(Impl::job_of_request)>(requests);
  jobs.array<decltype(Impl::waiting_packets)>(requests);
  AllocationTally decoders;
  const uint64_t decoder_count = uint64_t{config.decode_workers} * pools.size();
  decoders.array<decltype(Impl::decoder_storage)>(decoder_count * sizeof(TileDecoder) + alignof(TileDecoder));
  decoders.array<decltype(Impl::decoder_busy)>(decoder_count);
  for (const CacheConfig& p : pools) {
    const AllocationTally one_decoder =
        TileDecoder::memory_required(TileLayout{p.tile_size, p.border, 4}, config.inflate_backend);
    for (uint32_t d = 0; d < config.decode_workers; ++d) decoders += one_decoder;
  }
  AllocationTally decoded;
  decoded.array<decltype(Impl::decoded)>(config.decoded_cache_tiles);
  decoded.array<decltype(Impl::decoded_floats)>(uint64_t{config.decoded_cache_tiles} * samples);
  AllocationTally tables;
  tables.block(sizeof(detail::AllocationLedger));
  tables.block(sizeof(Impl));
  tables.array<decltype(Impl::materials)>(cap.materials);
  tables.array<decltype(Impl::records)>(cap.tiles);
  tables.array<decltype(Impl::texture_material)>(cap.textures);
  tables.array<decltype(Impl::packet_records)>(cap.textures);
  tables.array<decltype(Impl::tile_failures)>(cap.tiles);
  tables.array<decltype(Impl::packet_failures)>(cap.textures);
  tables.array<decltype(Impl::startup_failed)>(cap.textures);
  tables.array<decltype(Impl::held)>(config.failure.held_tiles_capacity);
  tables.array<decltype(Impl::startup)>(uint64_t{cap.textures} * 2);
  tables.array<decltype(Impl::notices)>(uint64_t{cap.materials} * 2 + 2);
  tables.array<decltype(Impl::texture_tile_base)>(cap.textures);
  tables.array<decltype(Impl::mirror)>(cap.tiles);
  tables.array<decltype(Impl::queued)>(cap.tiles);
  tables.array<decltype(Impl::queue)>(cap.tiles);
  tables.array<decltype(Impl::mirror_texture)>(cap.tiles);
  // Each category and its tally; total and allocations sum all of them.
  struct Category {
    uint64_t StreamerMemory::*bytes;
    const AllocationTally* tally;
  };
  const Category categories[] = {
      {&StreamerMemory::tile_cache, &cache},      {&StreamerMemory::scheduler, &sched},
      {&StreamerMemory::votes, &votes},           {&StreamerMemory::payload_cache, &payloads},
      {&StreamerMemory::job_buffers, &jobs},      {&StreamerMemory::decoders, &decoders},
      {&StreamerMemory::decoded_cache, &decoded}, {&StreamerMemory::tables, &tables}};
  StreamerMemory m;
  AllocationTally all;
  for (const Category& c : categories) {
    m.*c.bytes = c.tally->bytes;
    all += *c.tally;
  }
  m.total = all.bytes;
  m.allocations = all.allocations;
  return m;
}

Result<StreamerMemory> Streamer::memory_required(std::span<const StreamerMaterial> materials,
                                                 const StreamerConfig& config) {
  auto room = resolve_room(materials, config);
  if (!room) return room.error();
  return memory_for(config, room.value().capacity);
}

void Streamer::destroy() noexcept {
  if (impl_ == nullptr) return;
  const RuntimeAllocator al = impl_->allocator;
  detail::AllocationLedger* ledger = impl_->ledger;
  impl_->~Impl();
  al.deallocate_bytes(impl_, sizeof(Impl), alignof(Impl));
  impl_ = nullptr;
  if (ledger == nullptr) return;
  const RuntimeAllocator inner = ledger->inner;
  ledger->~AllocationLedger();
  inner.deallocate_bytes(ledger, sizeof(detail::AllocationLedger), alignof(detail::AllocationLedger));
}

Status Streamer::update(std::span<const uint32_t> feedback, StreamerOutputs& out) noexcept {
  return impl_ != nullptr ? impl_->update(feedback, out) : Status::invalid_argument;
}
size_t Streamer::tile_uploads_bound() const noexcept { return impl_->tile_uploads_bound(); }
size_t Streamer::packet_uploads_bound() const noexcept { return impl_->packet_uploads_bound(); }
uint32_t Streamer::acquire_job() noexcept { return impl_->acquire_job(); }
void Streamer::run_job(uint32_t job) noexcept { impl_->run_job(job); }
uint32_t Streamer::pump(uint32_t max_jobs) noexcept {
  uint32_t n = 0;
  while (n < max_jobs) {
    const uint32_t j = impl_->acquire_job();
    if (j == kNoJob) break;
    impl_->run_job(j);
    ++n;
  }
  return n;
}
StreamerJobQueue& Streamer::jobs() noexcept { return *impl_; }
bool Streamer::claim_job(uint32_t job) noexcept { return impl_->claim_job(job); }
uint32_t Streamer::complete_read(uint64_t ticket, Status status) noexcept {
  return impl_->complete_read(ticket, status);
}
void Streamer::quiesce() noexcept { impl_->quiescing = true; }
void Streamer::resume() noexcept { impl_->quiescing = false; }
bool Streamer::idle() const noexcept {
  for (uint32_t j = 0; j < impl_->jobs.size(); ++j) {
    const uint8_t s = impl_->jobs[j].state.load(std::memory_order_acquire);
    if (s == detail::kJobReading || s == detail::kJobRunnable || s == detail::kJobRunning) return false;
  }
  return true;
}
Status Streamer::add_material(const StreamerMaterial& material, uint32_t& id, const char** why) noexcept {
  return impl_->add_material(material, id, true, why);
}
Status Streamer::remove_material(uint32_t id) noexcept { return impl_->remove_material(id); }
bool Streamer::material_live(uint32_t id) const noexcept {
  return id < impl_->materials.size() && impl_->materials[id].life == detail::kMaterialLive;
}
uint32_t Streamer::live_material_count() const noexcept { return impl_->live_materials; }
bool Streamer::material_failed(uint32_t m) const noexcept {
  return m < impl_->materials.size() && impl_->materials[m].failed;
}
Status Streamer::retry_material(uint32_t m) noexcept { return impl_->retry_material(m); }
StreamerStats Streamer::stats() const noexcept {
  const Impl& im = *impl_;
  StreamerStats st;
  st.memory = im.memory;
  st.frame = im.frame;
  st.slots = im.cache.slot_count();
  st.slots_used = im.cache.used_count();
  st.pool_count = im.pool_count;
  for (uint32_t p = 0; p < im.pool_count; ++p) {
    const CacheConfig& c = im.pools[p];
    StreamerPoolStats& ps = st.pools[p];
    ps.slots = c.slot_count();
    ps.slots_used = im.cache.used_count(p);
    // One slot: (T + 2B)² texels in the pool's format, and its slot-map texel (affine formats).
    const uint64_t slot_bytes = uint64_t{c.padded_tile_size()} * c.padded_tile_size() * c.texel_bytes() +
                                (cache_format_has_slot_map(c.format) ? 16 : 0);
    ps.resident_bytes = slot_bytes * ps.slots_used;
    ps.texture_bytes = c.cache_bytes() + c.slot_map_bytes();
  }
  for (uint32_t m = 0; m < im.materials.size(); ++m) {
    st.materials_ready += im.materials[m].ready ? 1u : 0u;
    st.materials_removing += im.materials[m].life == detail::kMaterialRemoving ? 1u : 0u;
    if (im.materials[m].life == detail::kMaterialLive) ++st.pools[im.materials[m].pool].materials_live;
  }
  st.materials_live = im.live_materials;
  st.jobs_dropped = im.jobs_dropped;
  st.materials_added = im.materials_added;
  st.materials_removed = im.materials_removed_count;
  st.materials_failed = im.materials_failed_now;
  for (uint32_t j = 0; j < im.jobs.size(); ++j) {
    const uint8_t s = im.jobs[j].state.load(std::memory_order_relaxed);
    st.jobs_reading += s == detail::kJobReading;
    st.jobs_runnable += s == detail::kJobRunnable;
    st.jobs_running += s == detail::kJobRunning;
    st.jobs_waiting_retry += s == detail::kJobWaiting;
  }
  st.tiles_backing_off = 0;
  for (uint32_t i = 0; i < im.held_count; ++i) st.tiles_backing_off += im.held[i].packet ? 0u : 1u;
  st.tiles_unavailable = im.tiles_unavailable;
  st.tile_failures = im.tile_failure_count;
  st.packet_failures = im.packet_failure_count;
  st.retries = im.retry_count;
  st.cancelled = im.cancelled_count;
  st.feedback_ignored = im.feedback_ignored;
  st.feedback_rejected = im.votes.rejected();
  st.bytes_read = im.bytes_read.load(std::memory_order_relaxed);
  st.decoded_levels_skipped = im.decoded_levels_skipped;
  st.events_dropped = im.dropped_events;
  st.decoder_busy = im.decoder_busy_hits.load(std::memory_order_relaxed);
  return st;
}
StreamerGpuLayout Streamer::gpu_layout() const noexcept {
  const Impl& im = *impl_;
  StreamerGpuLayout g;
  g.pool_count = im.pool_count;
  for (uint32_t p = 0; p < im.pool_count; ++p) {
    const CacheConfig& c = im.pools[p];
    g.pools[p] = StreamerPoolLayout{c, c.cache_width(), c.cache_height(), c.cache_layers, c.slot_count()};
  }
  g.cache_width = g.pools[0].cache_width;
  g.cache_height = g.pools[0].cache_height;
  g.cache_layers = g.pools[0].cache_layers;
  // Sized by the capacity, so materials added later fit the same resources.
  g.page_table_layers = g.u_packets = im.capacity.textures;
  g.page_table_width = g.page_table_height = 0;
  g.page_table_levels = im.capacity.max_level_count;
  g.u_rows = im.capacity.max_u_rows;
  // The finest level of the deepest material is at most max_finest_tiles wide; the live
  // materials' actual extents (never more).
  const VtSet& set = im.cache.set();
  for (uint32_t m = 0; m < set.material_count(); ++m) {
    if (!set.material_live(m)) continue;
    const VtLevelTable& lv = set.material(m).levels;
    g.page_table_width = std::max(g.page_table_width, lv.tiles_x[lv.finest_level()]);
    g.page_table_height = std::max(g.page_table_height, lv.tiles_y[lv.finest_level()]);
  }
  g.page_table_width = std::max(g.page_table_width, im.capacity.max_finest_tiles);
  g.page_table_height = std::max(g.page_table_height, im.capacity.max_finest_tiles);
  return g;
}
uint32_t Streamer::pool_count() const noexcept { return impl_->pool_count; }
const CacheConfig& Streamer::pool_config(uint32_t pool) const noexcept { return impl_->pools[pool]; }
uint32_t Streamer::material_pool(uint32_t m) const noexcept { return material_live(m) ? impl_->materials[m].pool : 0; }
const TileCache& Streamer::cache() const noexcept { return impl_->cache; }
const Scheduler& Streamer::scheduler() const noexcept { return impl_->scheduler; }
const VoteCounter& Streamer::votes() const noexcept { return impl_->votes; }
uint32_t Streamer::material_count() const noexcept { return static_cast<uint32_t>(impl_->materials.size()); }
uint32_t Streamer::first_texture(uint32_t m) const noexcept {
  return material_live(m) ? impl_->materials[m].first_texture : 0;
}
uint32_t Streamer::texture_count(uint32_t m) const noexcept {
  return material_live(m) ? impl_->materials[m].texture_count : 0;
}
uint32_t Streamer::component_count(uint32_t m) const noexcept {
  return material_live(m) ? impl_->materials[m].components : 0;
}
bool Streamer::material_ready(uint32_t m) const noexcept {
  return m < impl_->materials.size() && impl_->materials[m].ready;
}
size_t Streamer::pending_page_table_writes() const noexcept { return impl_->queue_count; }
uint64_t Streamer::events_dropped() const noexcept { return impl_->dropped_events; }
uint64_t Streamer::bytes_read() const noexcept { return impl_->bytes_read.load(std::memory_order_relaxed); }
uint64_t Streamer::decoded_levels_skipped() const noexcept { return impl_->decoded_levels_skipped; }
uint32_t Streamer::jobs_in_flight() const noexcept {
  uint32_t n = 0;
  for (uint32_t j = 0; j < impl_->jobs.size(); ++j) {
    const uint8_t s = impl_->jobs[j].state.load(std::memory_order_relaxed);
    n += s == detail::kJobRunnable || s == detail::kJobRunning || s == detail::kJobReading;
  }
  return n;
}

}  // namespace btflod
