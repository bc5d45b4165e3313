// btflod — Streamer::create() (every buffer sized and allocated through the engine's
// callbacks, the memory report measured on the way) and the Streamer's accessors. Included by
// runtime/streamer.hpp; compiles alone too.
#pragma once

#include <algorithm>
#include <new>
#include <utility>

#include "btflod/runtime/streamer_impl.hpp"

namespace btflod {

inline Result<Streamer> Streamer::create(std::span<const StreamerMaterial> materials, const StreamerConfig& config) {
  if (materials.empty()) return make_error(Status::invalid_argument, "streamer: no materials");
  if (materials.size() > 1023)
    return make_error(Status::invalid_argument, "streamer: %zu materials, the feedback word holds at most 1023",
                      materials.size());
  if (!config.cache.valid())
    return make_error(Status::invalid_argument, "streamer: cache of %u×%u×%u slots of %u+2·%u texels is not valid",
                      config.cache.slots_x, config.cache.slots_y, config.cache.cache_layers, config.cache.tile_size,
                      config.cache.border);
  if (config.packet_jobs == 0 || config.root_jobs == 0 || config.decode_workers == 0 ||
      config.u_row_order == AngularRowOrder::unspecified)
    return make_error(Status::invalid_argument,
                      "streamer: packet_jobs, root_jobs and decode_workers must be > 0 and u_row_order specified");
  const StreamerFailurePolicy& fp = config.failure;
  if (fp.tile_attempts == 0 || fp.startup_attempts == 0 || fp.packet_attempts == 0)
    return make_error(Status::invalid_argument, "streamer: failure policy attempts must be ≥ 1");
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
  VtSet set(al);
  uint32_t total_tiles = 0, max_levels = 0, max_payload = 0, max_packet = 0, max_rows = 0, max_texture_count = 0;
  for (size_t m = 0; m < materials.size(); ++m) {
    const StreamerMaterial& sm = materials[m];
    if (sm.directory == nullptr || (sm.source == nullptr) == (sm.async_source == nullptr))
      return make_error(Status::invalid_argument, "streamer: material %zu needs a directory and exactly one source", m);
    const BsvtfMetadata& md = sm.directory->metadata;
    if (md.tile_size != config.cache.tile_size || md.border != config.cache.border)
      return make_error(Status::invalid_argument,
                        "streamer: material %zu (%s) has %u-texel tiles with border %u, the cache %u and %u", m,
                        md.material_name.c_str(), md.tile_size, md.border, config.cache.tile_size, config.cache.border);
    const AngularRowOrder order =
        md.u_row_order != AngularRowOrder::unspecified ? md.u_row_order : sm.assumed_row_order;
    if (order == AngularRowOrder::unspecified)
      return make_error(Status::invalid_argument,
                        "streamer: material %zu (%s) is a version-%u container that does not store U's row order; set "
                        "StreamerMaterial::assumed_row_order or rebuild it",
                        m, md.material_name.c_str(), sm.directory->header.version);
    const uint32_t lights = static_cast<uint32_t>(md.light_directions.size() / 3);
    const uint32_t views = static_cast<uint32_t>(md.view_directions.size() / 3);
    if (uint64_t{lights} * views * md.color_channels != md.u_rows)
      return make_error(Status::invalid_argument,
                        "streamer: material %zu: %u rows of U, but %u lights × %u views × %u channels", m, md.u_rows,
                        lights, views, md.color_channels);
    const VtGeometry g = VtGeometry::make(md.width, md.height, md.tile_size, md.border);
    if (!g.valid() || g.level_count() != md.level_count)
      return make_error(Status::bad_data, "streamer: material %zu: %ux%u texels need %u levels, the container has %u",
                        m, md.width, md.height, g.level_count(), md.level_count);
    const uint32_t mi = set.add_material(g, md.texture_count());
    const VtMaterial& vm = set.material(mi);
    for (uint32_t k = 0; k < vm.texture_count; ++k)
      for (uint32_t i = 0; i < vm.levels.tile_count(); ++i) {
        const BsvtfTileEntry* e = sm.directory->find(vm.levels.tile(k, i));
        if (e == nullptr)
          return make_error(Status::bad_data,
                            "streamer: material %zu: tile %u of virtual texture %u missing from the container", m, i,
                            k);
        set.weights(vm.first_texture + k)[i] = Half(e->weight);
        set.energies(vm.first_texture + k)[i] = Half(e->energy);
        max_payload = std::max(max_payload, e->size);
      }
    for (const BsvtfPacketEntry& p : sm.directory->packets) max_packet = std::max(max_packet, p.size);
    total_tiles += vm.levels.tile_count() * vm.texture_count;
    max_levels = std::max(max_levels, md.level_count);
    max_rows = std::max(max_rows, md.u_rows);
    max_texture_count = std::max(max_texture_count, vm.texture_count);
  }
  const uint64_t set_bytes = ledger->live, set_allocations = ledger->count;  // a create() temporary
  StreamerMemory memory;
  uint64_t mark = ledger->live;
  auto cache = TileCache::create(set, config.cache, al);
  if (!cache) return cache.error();
  memory.tile_cache = ledger->live - mark;
  mark = ledger->live;
  SchedulerConfig sc = config.scheduler;
  auto sched = Scheduler::create(cache.value(), sc, al);
  if (!sched) return sched.error();
  memory.scheduler = ledger->live - mark;
  // Real payload sizes for the byte budgets.
  for (uint32_t m = 0; m < set.material_count(); ++m) {
    const VtMaterial& vm = set.material(m);
    for (uint32_t k = 0; k < vm.texture_count; ++k)
      for (uint32_t i = 0; i < vm.levels.tile_count(); ++i)
        sched->set_tile_bytes(vm.first_texture + k, i, materials[m].directory->find(vm.levels.tile(k, i))->size);
    sched->set_u_packet_bytes(m, materials[m].directory->packets.empty() ? 0 : materials[m].directory->packets[0].size);
  }
  RuntimeArray<VoteLayout> layouts;  // a create() temporary too
  const uint64_t layouts_bytes = uint64_t{sizeof(VoteLayout)} * set.material_count();
  if (!layouts.allocate(al, set.material_count()))
    return make_error(Status::insufficient_space, "streamer: allocator failed");
  for (uint32_t m = 0; m < set.material_count(); ++m) {
    const VtLevelTable& lv = set.material(m).levels;
    layouts[m] = VoteLayout{lv.finest_level(), lv.tiles_x[lv.finest_level()], lv.tiles_y[lv.finest_level()]};
  }
  mark = ledger->live;
  VoteCounter votes(layouts.span(), VoteWindowConfig{std::max(1u, config.vote_window_frames), 0}, al);
  memory.votes = ledger->live - mark;

  void* mem = al.allocate_bytes(sizeof(Impl), alignof(Impl));
  if (mem == nullptr) return make_error(Status::insufficient_space, "streamer: allocator failed");
  Impl* im = ::new (mem) Impl(std::move(cache.value()), std::move(sched.value()), std::move(votes));
  out.impl_ = im;
  im->ledger = std::exchange(ledger_guard.ledger, nullptr);
  im->allocator = al;
  im->config = config;
  im->layout = TileLayout{config.cache.tile_size, config.cache.border, 4};
  mark = ledger->live;
  im->payloads = PayloadCache(PayloadCacheConfig{config.payload_cache_bytes, 4096, 512}, al);
  if (im->payloads.allocation_failed())
    return make_error(Status::insufficient_space, "streamer: allocating the payload cache failed");
  memory.payload_cache = ledger->live - mark;
  const auto fail = [&](const char* what) {
    return make_error(Status::insufficient_space, "streamer: allocating %s failed", what);
  };
  const uint32_t nm = static_cast<uint32_t>(materials.size());
  if (!im->materials.allocate(al, nm) || !im->records.allocate(al, total_tiles) ||
      !im->texture_material.allocate(al, set.texture_count()))
    return fail("material tables");
  uint32_t packets_total = 0;
  for (uint32_t m = 0; m < nm; ++m) packets_total += set.material(m).texture_count;
  if (!im->packet_records.allocate(al, packets_total)) return fail("packet table");
  uint32_t record = 0, packet = 0;
  for (uint32_t m = 0; m < nm; ++m) {
    const VtMaterial& vm = set.material(m);
    const BsvtfMetadata& md = materials[m].directory->metadata;
    detail::StreamerMaterialState& ms = im->materials[m];
    ms.source = materials[m].source;
    ms.async_source = materials[m].async_source;
    ms.first_texture = vm.first_texture;
    ms.texture_count = vm.texture_count;
    ms.components = md.component_count;
    ms.tile_count = vm.levels.tile_count();
    ms.record_base = record;
    ms.lights = static_cast<uint32_t>(md.light_directions.size() / 3);
    ms.views = static_cast<uint32_t>(md.view_directions.size() / 3);
    ms.channels = md.color_channels;
    ms.rows = md.u_rows;
    ms.row_order = md.u_row_order != AngularRowOrder::unspecified ? md.u_row_order : materials[m].assumed_row_order;
    ms.packet_base = packet;
    for (uint32_t k = 0; k < vm.texture_count; ++k) {
      im->texture_material[vm.first_texture + k] = m;
      for (uint32_t i = 0; i < ms.tile_count; ++i) {
        const BsvtfTileEntry* e = materials[m].directory->find(vm.levels.tile(k, i));
        im->records[record++] = detail::TileRecord{e->offset, e->size, e->crc};
      }
      const BsvtfPacketEntry& p = materials[m].directory->packets[k];
      im->packet_records[packet++] = detail::TileRecord{p.offset, p.size, p.crc};
    }
  }
  // Jobs: one per request in flight plus one per upload of a frame (a job whose texels were
  // handed out is reused only after the next update), root jobs, packet jobs.
  im->tile_jobs = config.scheduler.budgets.requests_in_flight + config.scheduler.budgets.uploads_per_frame;
  im->root_jobs = config.root_jobs;
  im->packet_jobs = config.packet_jobs;
  const uint32_t tile_like = im->tile_jobs + im->root_jobs;
  const uint32_t nj = tile_like + im->packet_jobs;
  im->chain_bytes = static_cast<size_t>(max_levels) * max_payload;
  im->packet_bytes = max_packet;
  im->max_rows = max_rows;
  const size_t samples = im->layout.sample_count();
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
  // One tile decoder per worker the engine declares (not per job).
  mark = ledger->live;
  if (!im->decoder_storage.allocate(al, size_t{config.decode_workers} * sizeof(TileDecoder) + alignof(TileDecoder)) ||
      !im->decoder_busy.allocate(al, config.decode_workers))
    return fail("tile decoders");
  for (uint32_t d = 0; d < config.decode_workers; ++d) {
    ::new (static_cast<void*>(im->decoder(d))) TileDecoder(im->layout, config.inflate_backend, al);
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
  // Failure bookkeeping.
  const uint32_t textures = set.texture_count();
  if (!im->tile_failures.allocate(al, total_tiles) || !im->packet_failures.allocate(al, packets_total) ||
      !im->startup_failed.allocate(al, textures) || !im->held.allocate(al, config.failure.held_tiles_capacity))
    return fail("failure tables");
  // Start-up queue: every root, then every U′ packet unless the scheduler streams them (§6).
  // A material's tiles are scheduled once it is ready (its roots verified and uploaded).
  if (!im->startup.allocate(al, size_t{textures} * 2)) return fail("start-up queue");
  for (uint32_t t = 0; t < textures; ++t) im->push_startup(t << 1);
  if (!config.scheduler.stream_u_columns)
    for (uint32_t t = 0; t < textures; ++t) im->push_startup(t << 1 | 1);
  for (uint32_t m = 0; m < nm; ++m) im->scheduler.set_material_enabled(m, false);
  // GPU page-table mirror: every texel queued once (the initial full upload).
  if (!im->texture_tile_base.allocate(al, textures) || !im->mirror.allocate(al, total_tiles) ||
      !im->queued.allocate(al, total_tiles) || !im->queue.allocate(al, std::max<uint32_t>(total_tiles, 1)) ||
      !im->mirror_texture.allocate(al, total_tiles))
    return fail("page-table mirror");
  uint32_t base = 0;
  for (uint32_t t = 0; t < textures; ++t) {
    im->texture_tile_base[t] = base;
    const VtLevelTable& lv = im->cache.set().levels_of(t);
    for (uint32_t i = 0; i < lv.tile_count(); ++i) {
      im->mirror_texture[base + i] = t;
      im->mirror[base + i] = 0xffffffffu;  // never a valid entry: the first write always goes out
      im->queue_write(t, i, gpu_page_entry(im->cache, lv.tile(t, i)));
    }
    base += lv.tile_count();
  }
  im->cache.clear_deltas();
  // What is left: the Streamer object, the material, tile and packet tables, the page-table
  // mirror and queues (the create() temporaries are released when it returns: not counted).
  memory.total = ledger->live - set_bytes - layouts_bytes + sizeof(detail::AllocationLedger);
  memory.allocations = ledger->count - set_allocations;  // the layouts out, the ledger in: one each
  memory.tables = memory.total - memory.tile_cache - memory.scheduler - memory.votes - memory.payload_cache -
                  memory.job_buffers - memory.decoders - memory.decoded_cache;
  im->memory = memory;
  return out;
}

inline void Streamer::destroy() noexcept {
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

inline Status Streamer::update(std::span<const uint32_t> feedback, StreamerOutputs& out) noexcept {
  return impl_ != nullptr ? impl_->update(feedback, out) : Status::invalid_argument;
}
inline size_t Streamer::tile_uploads_bound() const noexcept { return impl_->tile_uploads_bound(); }
inline size_t Streamer::packet_uploads_bound() const noexcept { return impl_->packet_uploads_bound(); }
inline uint32_t Streamer::acquire_job() noexcept { return impl_->acquire_job(); }
inline void Streamer::run_job(uint32_t job) noexcept { impl_->run_job(job); }
inline uint32_t Streamer::pump(uint32_t max_jobs) noexcept {
  uint32_t n = 0;
  while (n < max_jobs) {
    const uint32_t j = impl_->acquire_job();
    if (j == kNoJob) break;
    impl_->run_job(j);
    ++n;
  }
  return n;
}
inline StreamerJobQueue& Streamer::jobs() noexcept { return *impl_; }
inline bool Streamer::claim_job(uint32_t job) noexcept { return impl_->claim_job(job); }
inline uint32_t Streamer::complete_read(uint64_t ticket, Status status) noexcept {
  return impl_->complete_read(ticket, status);
}
inline void Streamer::quiesce() noexcept { impl_->quiescing = true; }
inline void Streamer::resume() noexcept { impl_->quiescing = false; }
inline bool Streamer::idle() const noexcept {
  for (uint32_t j = 0; j < impl_->jobs.size(); ++j) {
    const uint8_t s = impl_->jobs[j].state.load(std::memory_order_acquire);
    if (s == detail::kJobReading || s == detail::kJobRunnable || s == detail::kJobRunning) return false;
  }
  return true;
}
inline bool Streamer::material_failed(uint32_t m) const noexcept {
  return m < impl_->materials.size() && impl_->materials[m].failed;
}
inline Status Streamer::retry_material(uint32_t m) noexcept { return impl_->retry_material(m); }
inline StreamerStats Streamer::stats() const noexcept {
  const Impl& im = *impl_;
  StreamerStats st;
  st.memory = im.memory;
  st.frame = im.frame;
  st.slots = im.cache.slot_count();
  st.slots_used = im.cache.used_count();
  for (uint32_t m = 0; m < im.materials.size(); ++m) st.materials_ready += im.materials[m].ready ? 1u : 0u;
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
inline StreamerGpuLayout Streamer::gpu_layout() const noexcept {
  const Impl& im = *impl_;
  StreamerGpuLayout g;
  const CacheConfig& c = im.config.cache;
  const uint32_t stored = c.tile_size + 2 * c.border;
  g.cache_width = c.slots_x * stored;
  g.cache_height = c.slots_y * stored;
  g.cache_layers = c.cache_layers;
  const VtSet& set = im.cache.set();
  g.page_table_layers = g.u_packets = set.texture_count();
  for (uint32_t m = 0; m < set.material_count(); ++m) {
    const VtLevelTable& lv = set.material(m).levels;
    g.page_table_width = std::max(g.page_table_width, lv.tiles_x[lv.finest_level()]);
    g.page_table_height = std::max(g.page_table_height, lv.tiles_y[lv.finest_level()]);
    g.page_table_levels = std::max(g.page_table_levels, lv.finest_level() + 1);
    g.u_rows = std::max(g.u_rows, im.materials[m].rows);
  }
  return g;
}
inline const TileCache& Streamer::cache() const noexcept { return impl_->cache; }
inline const Scheduler& Streamer::scheduler() const noexcept { return impl_->scheduler; }
inline const VoteCounter& Streamer::votes() const noexcept { return impl_->votes; }
inline uint32_t Streamer::material_count() const noexcept { return static_cast<uint32_t>(impl_->materials.size()); }
inline uint32_t Streamer::first_texture(uint32_t m) const noexcept { return impl_->materials[m].first_texture; }
inline uint32_t Streamer::texture_count(uint32_t m) const noexcept { return impl_->materials[m].texture_count; }
inline uint32_t Streamer::component_count(uint32_t m) const noexcept { return impl_->materials[m].components; }
inline bool Streamer::material_ready(uint32_t m) const noexcept { return impl_->materials[m].ready; }
inline size_t Streamer::pending_page_table_writes() const noexcept { return impl_->queue_count; }
inline uint64_t Streamer::events_dropped() const noexcept { return impl_->dropped_events; }
inline uint64_t Streamer::bytes_read() const noexcept { return impl_->bytes_read.load(std::memory_order_relaxed); }
inline uint64_t Streamer::decoded_levels_skipped() const noexcept { return impl_->decoded_levels_skipped; }
inline uint32_t Streamer::jobs_in_flight() const noexcept {
  uint32_t n = 0;
  for (uint32_t j = 0; j < impl_->jobs.size(); ++j) {
    const uint8_t s = impl_->jobs[j].state.load(std::memory_order_relaxed);
    n += s == detail::kJobRunnable || s == detail::kJobRunning || s == detail::kJobReading;
  }
  return n;
}

}  // namespace btflod
