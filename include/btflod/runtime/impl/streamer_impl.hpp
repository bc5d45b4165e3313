// btflod — the Streamer's implementation (runtime/streamer.hpp documents the API): the job
// records, the decode of a tile's chain, failure handling (StreamerFailurePolicy) and update().
// Included by runtime/streamer.hpp's implementation section only (BTFLOD_RUNTIME_IMPLEMENTATION:
// compiled once per program); compiles alone too.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <new>
#include <span>
#include <utility>

#include "btflod/runtime/streamer.hpp"

namespace btflod {

namespace detail {

enum JobState : uint8_t {
  kJobFree,
  kJobReading,
  kJobRunnable,
  kJobRunning,
  kJobDone,
  kJobFailed,
  kJobHanded,
  kJobWaiting,  // a failed start-up job waiting for its back-off (retry_frame)
};
enum JobKind : uint8_t { kTileJob, kRootJob, kPacketJob };

struct TileRecord {  // one tile of a container: where its payload is
  uint64_t offset = 0;
  uint32_t size = 0;
  uint32_t crc = 0;
};

enum MaterialLife : uint8_t {
  kMaterialFree,      // the id is free
  kMaterialLive,      // added, not removed
  kMaterialRemoving,  // removed; jobs launched for it have not all ended (the id is not reused yet)
};

struct StreamerMaterialState {
  TileSource* source = nullptr;
  AsyncTileSource* async_source = nullptr;
  uint32_t first_texture = 0, texture_count = 0, components = 0;
  uint32_t tile_count = 0;   // per virtual texture
  uint32_t record_base = 0;  // index of (texture 0, flat 0) in the records array (the VtSet entry base)
  uint32_t generation = 0;   // bumped by every add of this id: jobs of an earlier one are stale
  uint8_t life = kMaterialFree;
  uint32_t lights = 0, views = 0, channels = 0, rows = 0;
  AngularRowOrder row_order = AngularRowOrder::light_major;
  uint32_t packet_base = 0;  // index of packet 0 in the packet records (= first_texture)
  uint32_t pool = 0;         // cache pool of its tiles
  uint32_t roots_loaded = 0, packets_loaded = 0;
  bool ready = false;
  bool failed = false;  // a root or start-up packet was given up (material_failed)
};

struct StreamerJob {
  std::atomic<uint8_t> state{kJobFree};
  std::atomic<uint32_t> reads_pending{0};
  std::atomic<uint8_t> read_status{0};
  uint8_t kind = kTileJob;
  uint32_t material = 0;
  uint32_t generation = 0;  // the material's generation at launch (stale when it differs)
  uint32_t pool = 0;        // the material's cache pool (its tile layout and cache format)
  // Everything run_job() reads is captured at launch, so a worker never reads the tables the
  // update thread changes when materials come and go.
  TileSource* source = nullptr;  // blocking source (null: the reads are async)
  uint32_t packet_rows = 0, packet_na = 0, packet_nb = 0, packet_channels = 0;
  uint8_t packet_swap = 0;
  uint32_t request = 0;  // scheduler request id (tile and scheduler packet jobs); kNoJob: start-up
  TileId tile;           // global id; for packets {texture, 0, 0, 0}
  uint32_t chain = 0;    // tiles root … tile
  uint32_t next_read = 0;
  TileId chain_tile[kMaxTileLevel + 1];
  uint32_t chain_offset[kMaxTileLevel + 1] = {};  // offset into bytes
  TileRecord chain_record[kMaxTileLevel + 1];     // where each chain tile's payload is (packets: [0])
  uint8_t chain_cached[kMaxTileLevel + 1] = {};   // bytes came from the payload cache
  uint32_t chain_start = 0;                       // first chain level decoded (those above come from `base`)
  const float* base = nullptr;                    // decoded ancestor chain_start − 1 (a pinned cache entry)
  uint32_t pinned = 0xffffffffu;                  // decoded-cache entry pinned for `base`
  uint8_t result_in_out = 0;                      // the decoded tile is in `out` (1) or `parent` (0)
  uint8_t parent_decoded = 0;                     // the other buffer holds the decoded parent of the tile
  uint8_t decoded_kept = 0;                       // the completion was handled (buffers offered, pin released)
  uint64_t retry_frame = 0;                       // kJobWaiting: the frame it starts again
  Status status = Status::success;
  uint8_t* bytes = nullptr;
  float* parent = nullptr;
  float* out = nullptr;
  CacheSlotMap map;  // rgba8_affine, bc5_affine: the map of the unorm8 or BC5 tile in `halves`
  uint16_t* halves = nullptr;
};

// Counts what goes through the engine's allocator, so that StreamerStats::memory reports it
// (allocated before everything else, released after everything else).
struct AllocationLedger {
  RuntimeAllocator inner;
  uint64_t live = 0, count = 0;
  static void* allocate(void* user, size_t bytes, size_t alignment) {
    AllocationLedger& l = *static_cast<AllocationLedger*>(user);
    void* p = l.inner.allocate_bytes(bytes, alignment);
    if (p != nullptr) l.live += bytes, ++l.count;
    return p;
  }
  static void deallocate(void* user, void* p, size_t bytes, size_t alignment) {
    AllocationLedger& l = *static_cast<AllocationLedger*>(user);
    l.inner.deallocate_bytes(p, bytes, alignment);
    l.live -= bytes, --l.count;
  }
  RuntimeAllocator counting() noexcept { return RuntimeAllocator{&allocate, &deallocate, this}; }
};

// A tile or streamed U′ packet held back until its back-off ends.
struct HeldWork {
  uint32_t texture = 0;  // global virtual texture (its material's packet: material index)
  uint32_t flat = 0;
  uint64_t until = 0;  // the frame it may be requested again
  uint8_t packet = 0;
};

// The cache pools of a configuration: StreamerConfig::pools, or the one pool `cache`.
inline std::span<const CacheConfig> streamer_pools(const StreamerConfig& c) noexcept {
  return c.pools.empty() ? std::span<const CacheConfig>(&c.cache, 1) : c.pools;
}

// What one container needs of the Streamer's reserved room.
struct StreamerMaterialNeeds {
  VtGeometry geometry;
  uint32_t textures = 0, tiles = 0;  // tiles: per texture × textures
  uint32_t level_count = 0, finest_tiles = 0;
  uint32_t max_tile_bytes = 0, max_packet_bytes = 0, rows = 0;
  AngularRowOrder row_order = AngularRowOrder::unspecified;
  uint32_t pool = 0;  // the cache pool it goes to
};

// Checks a material against the cache pools (its own, or the first that fits) and measures
// what it needs. No allocation.
inline Status check_streamer_material(const StreamerMaterial& sm, std::span<const CacheConfig> pools,
                                      StreamerMaterialNeeds& needs, const char** why) noexcept {
  const auto fail = [&](Status s, const char* text) {
    if (why != nullptr) *why = text;
    return s;
  };
  if (sm.directory == nullptr || (sm.source == nullptr) == (sm.async_source == nullptr))
    return fail(Status::invalid_argument, "a material needs a directory and exactly one source");
  const BsvtfMetadata& md = sm.directory->metadata;
  const auto fits = [&](const CacheConfig& c) { return md.tile_size == c.tile_size && md.border == c.border; };
  if (sm.pool == kStreamerAnyPool) {
    needs.pool = 0;
    while (needs.pool < pools.size() && !fits(pools[needs.pool])) ++needs.pool;
    if (needs.pool == pools.size())
      return fail(Status::invalid_argument, pools.size() == 1
                                                ? "the container's tile size or border differs from the cache's"
                                                : "no cache pool has the container's tile size and border");
  } else {
    if (sm.pool >= pools.size())
      return fail(Status::invalid_argument, "the material names a cache pool that does not exist");
    needs.pool = sm.pool;
    if (!fits(pools[sm.pool]))
      return fail(Status::invalid_argument, "the container's tile size or border differs from its cache pool's");
  }
  needs.row_order = md.u_row_order != AngularRowOrder::unspecified ? md.u_row_order : sm.assumed_row_order;
  if (needs.row_order == AngularRowOrder::unspecified)
    return fail(Status::invalid_argument,
                "a version-2 container does not store U's row order: set StreamerMaterial::assumed_row_order or "
                "rebuild it");
  const uint32_t lights = static_cast<uint32_t>(md.light_directions.size() / 3);
  const uint32_t views = static_cast<uint32_t>(md.view_directions.size() / 3);
  if (uint64_t{lights} * views * md.color_channels != md.u_rows)
    return fail(Status::invalid_argument, "the rows of U are not lights × views × colour channels");
  needs.geometry = VtGeometry::make(md.width, md.height, md.tile_size, md.border);
  if (!needs.geometry.valid() || needs.geometry.level_count() != md.level_count)
    return fail(Status::bad_data, "the container's level count does not match its size");
  needs.textures = md.texture_count();
  if (needs.textures == 0 || sm.directory->packets.size() < needs.textures)
    return fail(Status::bad_data, "the container has no U′ packet for each virtual texture");
  const VtLevelTable lv(needs.geometry);
  needs.tiles = lv.tile_count() * needs.textures;
  needs.level_count = md.level_count;
  needs.finest_tiles = std::max(lv.tiles_x[lv.finest_level()], lv.tiles_y[lv.finest_level()]);
  needs.rows = md.u_rows;
  needs.max_tile_bytes = needs.max_packet_bytes = 0;
  // The directory's entries are unique and sorted (runtime/codec/container.hpp): the hierarchy is
  // complete when as many of them lie in it as it has tiles (one linear pass, no lookups).
  uint64_t inside = 0;
  for (const BsvtfTileEntry& e : sm.directory->tiles) {
    if (e.id.texture >= needs.textures || !lv.geometry.contains(e.id)) continue;
    ++inside;
    needs.max_tile_bytes = std::max(needs.max_tile_bytes, e.size);
  }
  if (inside != needs.tiles) return fail(Status::bad_data, "a tile of the hierarchy is missing from the container");
  for (uint32_t k = 0; k < needs.textures; ++k)
    needs.max_packet_bytes = std::max(needs.max_packet_bytes, sm.directory->packets[k].size);
  return Status::success;
}

}  // namespace detail

struct Streamer::Impl final : StreamerJobQueue {
  detail::AllocationLedger* ledger = nullptr;  // owned by Streamer::destroy()
  RuntimeAllocator allocator;                  // ledger->counting()
  StreamerConfig config;                       // config.pools is empty here: the pools are copied below
  CacheConfig pools[kMaxCachePools] = {};
  TileLayout layouts[kMaxCachePools] = {};  // per pool: T, B, 4 components
  uint32_t pool_count = 1;
  size_t max_samples = 0;  // the largest pool's samples per tile (job and decoded-cache buffers)
  TileCache cache;
  Scheduler scheduler;
  VoteCounter votes;
  PayloadCache payloads;
  RuntimeArray<detail::StreamerMaterialState> materials;
  RuntimeArray<detail::TileRecord> records;         // per material, texture, flat tile
  RuntimeArray<detail::TileRecord> packet_records;  // per material, packet
  RuntimeArray<uint32_t> texture_material;          // global texture → material
  RuntimeArray<detail::StreamerJob> jobs;           // [tile jobs | root jobs | packet jobs]
  uint32_t tile_jobs = 0, root_jobs = 0, packet_jobs = 0;
  RuntimeArray<uint8_t> job_bytes;
  RuntimeArray<float> job_floats;
  RuntimeArray<uint16_t> job_halves;
  RuntimeArray<uint8_t> decoder_storage;  // decode_workers TileDecoders per pool, pool-major
  RuntimeArray<std::atomic<uint8_t>> decoder_busy;
  uint32_t decoder_count = 0;
  std::atomic<uint64_t> decoder_busy_hits{0};
  // Failures (StreamerFailurePolicy): per tile record and per packet record, saturating.
  RuntimeArray<uint8_t> tile_failures;
  RuntimeArray<uint8_t> packet_failures;
  RuntimeArray<uint8_t> startup_failed;  // per global texture: 1 root given up, 2 packet given up
  RuntimeArray<detail::HeldWork> held;
  uint32_t held_count = 0;
  uint32_t tiles_unavailable = 0, materials_failed_now = 0;
  uint64_t tile_failure_count = 0, packet_failure_count = 0, retry_count = 0, cancelled_count = 0;
  uint64_t feedback_ignored = 0;
  bool quiescing = false;
  // Materials that come and go (runtime/impl/streamer_materials.hpp).
  StreamerCapacity capacity;  // resolved at create()
  uint32_t live_materials = 0;
  uint64_t materials_added = 0, materials_removed_count = 0, jobs_dropped = 0;
  RuntimeArray<ResidencyEvent> notices;  // ring of material events for the next update()
  uint32_t notice_head = 0, notice_count = 0;
  StreamerMemory memory;
  size_t chain_bytes = 0, packet_bytes = 0, max_rows = 0;
  // Start-up queue: a ring of (global texture << 1 | is_packet), roots first; items a
  // retry_material() queues again go to its end (each item is in it at most once).
  RuntimeArray<uint32_t> startup;
  uint32_t startup_head = 0, startup_count = 0;
  // Scheduler packet requests waiting for a packet job.
  RuntimeArray<uint64_t> waiting_packets;  // (texture << 32) | request id
  uint32_t waiting_count = 0;
  // GPU page-table mirror and the queue of texels to write.
  RuntimeArray<uint32_t> texture_tile_base;  // global texture → index of flat 0 in mirror
  RuntimeArray<uint32_t> mirror;
  RuntimeArray<uint8_t> queued;
  RuntimeArray<uint32_t> queue;           // ring of mirror indices
  RuntimeArray<uint32_t> mirror_texture;  // mirror index → texture (for emission)
  size_t queue_head = 0, queue_count = 0;
  // Ready scheduler packets (request id → job) for apply_uploads.
  RuntimeArray<uint32_t> job_of_request;
  // Decoded-ancestor cache: entries own float buffers of one tile each; only the update
  // thread changes it. A job reads a pinned entry's buffer while it runs; finished jobs hand
  // their decoded tile (and its parent) over by swapping buffers with the least recently used
  // unpinned entry, so nothing is copied.
  struct DecodedEntry {
    uint64_t key = ~0ull;  // ~0: empty
    float* samples = nullptr;
    uint32_t pins = 0;
    uint64_t used = 0;
  };
  RuntimeArray<DecodedEntry> decoded;
  RuntimeArray<float> decoded_floats;
  uint64_t decoded_clock = 0;
  uint64_t decoded_levels_skipped = 0;
  uint64_t frame = 0;
  uint64_t dropped_events = 0;
  std::atomic<uint64_t> bytes_read{0};
  void (*notify)(void*) = nullptr;
  void* notify_user = nullptr;

  Status add_material(const StreamerMaterial& sm, uint32_t& id, bool queue_startup, const char** why) noexcept;
  Status remove_material(uint32_t m) noexcept;
  bool stale(const detail::StreamerJob& job) const noexcept;
  void abandon_reads(uint32_t j) noexcept;
  bool evict_leaf(uint32_t pool) noexcept;
  void purge_cached(uint32_t m) noexcept;
  void announce_materials(StreamerOutputs& out) noexcept;
  void notice(const ResidencyEvent& e) noexcept;
  bool material_busy(uint32_t m) const noexcept;
  void release_material(uint32_t m) noexcept;

  Impl(TileCache&& c, Scheduler&& s, VoteCounter&& v)
      : cache(std::move(c)), scheduler(std::move(s)), votes(std::move(v)) {}
  ~Impl() override {
    for (uint32_t d = 0; d < decoder_count; ++d) decoder(d)->~TileDecoder();
  }

  TileDecoder* decoder(uint32_t d) noexcept {
    uint8_t* p = decoder_storage.data();
    p += (alignof(TileDecoder) - reinterpret_cast<uintptr_t>(p) % alignof(TileDecoder)) % alignof(TileDecoder);
    return reinterpret_cast<TileDecoder*>(p + size_t{d} * sizeof(TileDecoder));
  }
  // A free decoder of the pool's layout (decode_workers of them per pool).
  uint32_t claim_decoder(uint32_t pool) noexcept {
    const uint32_t per_pool = decoder_count / pool_count;
    for (uint32_t d = pool * per_pool; d < (pool + 1) * per_pool; ++d) {
      uint8_t expected = 0;
      if (decoder_busy[d].load(std::memory_order_relaxed) == 0 &&
          decoder_busy[d].compare_exchange_strong(expected, 1, std::memory_order_acquire))
        return d;
    }
    return kNoJob;
  }

  // --- StreamerJobQueue ---
  bool claim_job(uint32_t j) noexcept override {
    if (j >= jobs.size()) return false;
    uint8_t expected = detail::kJobRunnable;
    return jobs[j].state.compare_exchange_strong(expected, detail::kJobRunning, std::memory_order_acquire);
  }
  uint32_t acquire_job() noexcept override {
    for (uint32_t j = 0; j < jobs.size(); ++j) {
      uint8_t expected = detail::kJobRunnable;
      if (jobs[j].state.load(std::memory_order_relaxed) == detail::kJobRunnable &&
          jobs[j].state.compare_exchange_strong(expected, detail::kJobRunning, std::memory_order_acquire))
        return j;
    }
    return kNoJob;
  }
  void set_job_notify(void (*fn)(void*), void* user) noexcept override {
    notify = fn;
    notify_user = user;
  }
  void run_job(uint32_t j) noexcept override {
    if (j >= jobs.size()) return;
    detail::StreamerJob& job = jobs[j];
    if (job.state.load(std::memory_order_acquire) != detail::kJobRunning) return;  // not claimed
    Status s;
    if (job.kind == detail::kPacketJob) {
      s = run_packet(job);
    } else {
      const uint32_t d = claim_decoder(job.pool);
      if (d == kNoJob) {  // more threads than decode_workers: someone else runs it later
        decoder_busy_hits.fetch_add(1, std::memory_order_relaxed);
        job.state.store(detail::kJobRunnable, std::memory_order_release);
        return;
      }
      s = run_tile(job, *decoder(d));
      decoder_busy[d].store(0, std::memory_order_release);
    }
    job.status = s;
    job.state.store(s == Status::success ? detail::kJobDone : detail::kJobFailed, std::memory_order_release);
  }

  const detail::StreamerMaterialState& mat(uint32_t m) const noexcept { return materials[m]; }
  uint32_t local_texture(const TileId& global) const noexcept {
    return global.texture - materials[texture_material[global.texture]].first_texture;
  }
  const detail::TileRecord& record_of(uint32_t m, uint32_t local_tex, uint32_t flat) const noexcept {
    const detail::StreamerMaterialState& ms = materials[m];
    return records[ms.record_base + static_cast<size_t>(local_tex) * ms.tile_count + flat];
  }

  // Reads the payloads the job does not have yet through the blocking source.
  Status read_blocking(detail::StreamerJob& job, std::span<uint8_t> dst, uint64_t offset) noexcept {
    TileSource* src = job.source;
    if (src == nullptr) return Status::invalid_argument;
    auto r = src->read(offset, dst);
    if (!r) return r.status();
    bytes_read.fetch_add(dst.size(), std::memory_order_relaxed);
    return Status::success;
  }

  Status run_tile(detail::StreamerJob& job, TileDecoder& decoder) noexcept {
    const TileLayout& layout = layouts[job.pool];
    const CacheConfig& cache_config = pools[job.pool];
    // Decode chain_start … tile, each level against the previous one (the first against the
    // cached ancestor `base`, or nothing for the root), alternating between the two buffers.
    float* buffers[2] = {job.out, job.parent};
    const float* previous = job.base;
    uint32_t current = 0;
    for (uint32_t i = job.chain_start; i < job.chain; ++i) {
      const TileId t = job.chain_tile[i];
      const detail::TileRecord& rec = job.chain_record[i];
      std::span<uint8_t> dst(job.bytes + job.chain_offset[i], rec.size);
      if (!job.chain_cached[i] && job.source != nullptr) {
        const Status s = read_blocking(job, dst, rec.offset);
        if (s != Status::success) return s;
      }
      if (const Status v = verify_bsvtf_payload(rec.size, rec.crc, dst); v != Status::success) return Status::bad_data;
      const Status d = decoder.decode(
          dst, t.level > 0 ? std::span<const float>(previous, layout.sample_count()) : std::span<const float>(),
          t.x & 1u, t.y & 1u, std::span<float>(buffers[current], layout.sample_count()));
      if (d != Status::success) return d;
      previous = buffers[current];
      current ^= 1u;
    }
    const uint32_t decoded_levels = job.chain - job.chain_start;
    job.result_in_out = decoded_levels > 0 && previous == job.out ? 1 : 0;
    job.parent_decoded = decoded_levels >= 2 ? 1 : 0;
    const std::span<const float> values(previous, layout.sample_count());
    uint8_t* bytes = reinterpret_cast<uint8_t*>(job.halves);  // sample_count · 2 bytes
    if (cache_config.format == CacheFormat::rgba8_affine) {   // unorm8 in the first half of the buffer
      job.map = encode_cache_tile_unorm8(values, std::span<uint8_t>(bytes, layout.sample_count()));
    } else if (cache_config.format == CacheFormat::bc5_affine) {
      // The blocks (sample_count / 2 bytes) in the first quarter of the buffer, the unorm8
      // scratch (sample_count bytes) in its second half: the buffer of any format fits both.
      const uint32_t side = cache_config.padded_tile_size();
      job.map =
          encode_cache_tile_bc5(values, side, std::span<uint8_t>(bytes + layout.sample_count(), layout.sample_count()),
                                std::span<uint8_t>(bytes, cache_bc5_tile_bytes(side)));
    } else {
      float_to_half(values, std::span<uint16_t>(job.halves, layout.sample_count()));
    }
    return Status::success;
  }

  // The upload of a finished tile job into global slot `slot`, in its pool's format (the slot
  // within the pool's cache texture).
  StreamerTileUpload tile_upload(uint32_t slot, const detail::StreamerJob& job) const noexcept {
    const TileLayout& layout = layouts[job.pool];
    const CacheConfig& cache_config = pools[job.pool];
    StreamerTileUpload u{cache.pool_local_slot(slot), job.tile, {}, {}, {}, {}, job.pool};
    if (cache_config.format == CacheFormat::rgba8_affine) {
      u.unorm8 = std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(job.halves), layout.sample_count());
      u.map = job.map;
    } else if (cache_config.format == CacheFormat::bc5_affine) {
      u.bc5 = std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(job.halves),
                                       cache_bc5_tile_bytes(cache_config.padded_tile_size()));
      u.map = job.map;
    } else {
      u.texels = std::span<const uint16_t>(job.halves, layout.sample_count());
    }
    return u;
  }

  Status run_packet(detail::StreamerJob& job) noexcept {
    const detail::TileRecord& rec = job.chain_record[0];
    std::span<uint8_t> dst(job.bytes, rec.size);
    if (job.source != nullptr) {
      const Status s = read_blocking(job, dst, rec.offset);
      if (s != Status::success) return s;
    }
    if (verify_bsvtf_payload(rec.size, rec.crc, dst) != Status::success) return Status::bad_data;
    // Rows (a · n_b + b) · channels + colour; reorder when the container's order differs.
    const bool swap = job.packet_swap != 0;
    const uint32_t na = job.packet_na, nb = job.packet_nb, channels = job.packet_channels;
    for (uint32_t a = 0; a < na; ++a)
      for (uint32_t b = 0; b < nb; ++b)
        for (uint32_t c = 0; c < channels; ++c) {
          const size_t src_row = (static_cast<size_t>(a) * nb + b) * channels + c;
          const size_t dst_row = swap ? (static_cast<size_t>(b) * na + a) * channels + c : src_row;
          std::memcpy(job.halves + dst_row * 4, job.bytes + src_row * 8, 8);
        }
    return Status::success;
  }

  bool push_event(StreamerOutputs& out, const ResidencyEvent& e) noexcept {
    if (out.event_count < out.events.size()) {
      out.events[out.event_count++] = e;
      return true;
    }
    ++dropped_events;
    return false;
  }

  // Sets up a tile job's chain (root … tile) with cached payloads copied in; returns the
  // number of reads needed.
  uint32_t prepare_chain(detail::StreamerJob& job) noexcept {
    const uint32_t m = job.material;
    const uint32_t k = local_texture(job.tile);
    const VtLevelTable& lv = cache.set().levels_of(job.tile.texture);
    job.chain = job.tile.level + 1;
    release_decoded(job);
    job.decoded_kept = 0;
    // The deepest decoded ancestor (or the tile itself) in the decoded cache: pinned, and the
    // chain is decoded below it only.
    job.chain_start = 0;
    job.base = nullptr;
    for (uint32_t i = job.chain; i-- > 0 && decoded.size() > 0;) {
      const uint32_t e = find_decoded(decoded_key(m, k, job.tile.ancestor(i)));
      if (e == kNoJob) continue;
      ++decoded[e].pins;
      decoded[e].used = ++decoded_clock;
      job.pinned = e;
      job.base = decoded[e].samples;
      job.chain_start = i + 1;
      decoded_levels_skipped += i + 1;
      break;
    }
    uint32_t offset = 0, reads = 0;
    for (uint32_t i = 0; i < job.chain; ++i) {
      const TileId t = job.tile.ancestor(i);
      job.chain_tile[i] = t;
      job.chain_offset[i] = offset;
      job.chain_record[i] = record_of(m, k, lv.index(t));
      if (i < job.chain_start) {  // not decoded: no payload needed
        job.chain_cached[i] = 1;
        continue;
      }
      const detail::TileRecord& rec = record_of(m, k, lv.index(t));
      const uint64_t key = decoded_key(m, k, t);
      job.chain_cached[i] = payloads.get(key, std::span<uint8_t>(job.bytes + offset, rec.size)) == rec.size ? 1 : 0;
      if (!job.chain_cached[i]) ++reads;
      offset += rec.size;
    }
    job.next_read = 0;
    return reads;
  }

  // Key of a material's tile in the payload and decoded caches: the material id above the
  // container-local tile key (a local texture < 2^14 for C ≤ 65536 fills bits 40–53; ids < 2^10
  // take bits 54–63), so keys of different materials never meet and a material's are found by
  // key_material().
  static uint64_t decoded_key(uint32_t material, uint32_t local_texture, const TileId& t) noexcept {
    return (static_cast<uint64_t>(material) << 54) | TileId{local_texture, t.level, t.x, t.y}.key();
  }
  static uint32_t key_material(uint64_t key) noexcept { return static_cast<uint32_t>(key >> 54); }
  uint32_t find_decoded(uint64_t key) const noexcept {
    for (uint32_t e = 0; e < decoded.size(); ++e)
      if (decoded[e].key == key) return e;
    return kNoJob;
  }
  // A stale job's pin: released, and the entry forgotten (it holds a removed material's tile,
  // whose id may already name another material).
  void drop_stale_pin(detail::StreamerJob& job) noexcept {
    const uint32_t e = job.pinned;
    release_decoded(job);
    if (e != kNoJob && decoded[e].pins == 0) decoded[e].key = ~0ull;
  }
  // Releases the job's pin on the decoded cache (update thread).
  void release_decoded(detail::StreamerJob& job) noexcept {
    if (job.pinned != kNoJob) --decoded[job.pinned].pins;
    job.pinned = kNoJob;
    job.base = nullptr;
  }
  // Hands a decoded tile over to the cache: the job's buffer `samples` is swapped with the
  // least recently used unpinned entry's (nothing when the tile is cached already or every
  // entry is pinned).
  void offer_decoded(uint64_t key, float*& samples) noexcept {
    if (find_decoded(key) != kNoJob) return;
    uint32_t victim = kNoJob;
    for (uint32_t e = 0; e < decoded.size(); ++e)
      if (decoded[e].pins == 0 && (victim == kNoJob || decoded[e].used < decoded[victim].used)) victim = e;
    if (victim == kNoJob) return;
    std::swap(decoded[victim].samples, samples);
    decoded[victim].key = key;
    decoded[victim].used = ++decoded_clock;
  }
  // A finished tile or root job (once): releases its pin and, when it succeeded, offers the
  // tile and its decoded parent to the decoded cache.
  void keep_decoded(detail::StreamerJob& job, bool ok) noexcept {
    if (job.decoded_kept) return;
    job.decoded_kept = 1;
    release_decoded(job);
    if (!ok || decoded.size() == 0 || job.chain_start >= job.chain) return;
    const uint32_t k = local_texture(job.tile);
    float*& result = job.result_in_out ? job.out : job.parent;
    float*& other = job.result_in_out ? job.parent : job.out;
    offer_decoded(decoded_key(job.material, k, job.tile), result);
    if (job.parent_decoded) offer_decoded(decoded_key(job.material, k, job.tile.parent()), other);
  }

  static uint64_t ticket_of(uint32_t job, uint32_t item) noexcept { return (static_cast<uint64_t>(job) << 8) | item; }

  // Starts the async reads of a job that are not started yet. Returns false when the source
  // refused one (retried next update).
  bool start_reads(uint32_t j) noexcept {
    detail::StreamerJob& job = jobs[j];
    AsyncTileSource* src = materials[job.material].async_source;
    if (job.kind == detail::kPacketJob) {
      if (job.next_read > 0) return true;
      const detail::TileRecord& rec = job.chain_record[0];
      if (!src->start_read(rec.offset, std::span<uint8_t>(job.bytes, rec.size), ticket_of(j, 0))) return false;
      bytes_read.fetch_add(rec.size, std::memory_order_relaxed);
      job.next_read = 1;
      return true;
    }
    for (; job.next_read < job.chain; ++job.next_read) {
      const uint32_t i = job.next_read;
      if (job.chain_cached[i]) continue;
      const detail::TileRecord& rec = job.chain_record[i];
      if (!src->start_read(rec.offset, std::span<uint8_t>(job.bytes + job.chain_offset[i], rec.size), ticket_of(j, i)))
        return false;
      bytes_read.fetch_add(rec.size, std::memory_order_relaxed);
    }
    return true;
  }

  uint32_t complete_read(uint64_t ticket, Status status) noexcept {
    const uint32_t j = static_cast<uint32_t>(ticket >> 8);
    if (j >= jobs.size()) return kNoJob;
    detail::StreamerJob& job = jobs[j];
    if (job.state.load(std::memory_order_acquire) != detail::kJobReading) return kNoJob;
    if (status != Status::success) job.read_status.store(static_cast<uint8_t>(status), std::memory_order_relaxed);
    if (job.reads_pending.fetch_sub(1, std::memory_order_acq_rel) != 1) return kNoJob;
    const uint8_t rs = job.read_status.load(std::memory_order_relaxed);
    if (rs != 0) {
      job.status = static_cast<Status>(rs);
      job.state.store(detail::kJobFailed, std::memory_order_release);
      return kNoJob;
    }
    job.state.store(detail::kJobRunnable, std::memory_order_release);
    return j;
  }

  // Hands a job to the source or the executor.
  void launch(uint32_t j, uint32_t reads) noexcept {
    detail::StreamerJob& job = jobs[j];
    job.status = Status::success;
    job.read_status.store(0, std::memory_order_relaxed);
    if (materials[job.material].async_source == nullptr || reads == 0) {
      job.state.store(detail::kJobRunnable, std::memory_order_release);
      return;
    }
    job.reads_pending.store(reads, std::memory_order_relaxed);
    job.state.store(detail::kJobReading, std::memory_order_release);
    start_reads(j);
  }

  void start_tile_job(uint32_t j, uint8_t kind, uint32_t request, const TileId& global) noexcept {
    detail::StreamerJob& job = jobs[j];
    job.kind = kind;
    job.request = request;
    job.tile = global;
    job.material = texture_material[global.texture];
    job.generation = materials[job.material].generation;
    job.pool = materials[job.material].pool;
    job.source = materials[job.material].source;
    launch(j, prepare_chain(job));
  }
  void start_packet_job(uint32_t j, uint32_t request, uint32_t texture) noexcept {
    detail::StreamerJob& job = jobs[j];
    job.kind = detail::kPacketJob;
    job.request = request;
    job.tile = TileId{texture, 0, 0, 0};
    job.material = texture_material[texture];
    const detail::StreamerMaterialState& ms = materials[job.material];
    job.generation = ms.generation;
    job.source = ms.source;
    job.chain_record[0] = packet_records[ms.packet_base + (texture - ms.first_texture)];
    job.packet_rows = ms.rows;
    job.packet_swap = ms.row_order != config.u_row_order ? 1 : 0;
    job.packet_na = ms.row_order == AngularRowOrder::light_major ? ms.lights : ms.views;
    job.packet_nb = ms.row_order == AngularRowOrder::light_major ? ms.views : ms.lights;
    job.packet_channels = ms.channels;
    job.next_read = 0;
    launch(j, 1);
  }
  uint32_t free_job(uint32_t begin, uint32_t end) const noexcept {
    for (uint32_t j = begin; j < end; ++j)
      if (jobs[j].state.load(std::memory_order_acquire) == detail::kJobFree) return j;
    return kNoJob;
  }

  // Caches a finished tile job's chain payloads (so later children need not read them).
  void keep_payloads(const detail::StreamerJob& job) noexcept {
    const uint32_t k = local_texture(job.tile);
    const VtLevelTable& lv = cache.set().levels_of(job.tile.texture);
    for (uint32_t i = 0; i < job.chain; ++i) {
      if (job.chain_cached[i]) continue;
      const TileId t = job.chain_tile[i];
      const detail::TileRecord& rec = record_of(job.material, k, lv.index(t));
      const uint64_t key = decoded_key(job.material, k, t);
      payloads.put(key, std::span<const uint8_t>(job.bytes + job.chain_offset[i], rec.size));
    }
  }

  void mark_loaded(uint32_t m, bool packet, StreamerOutputs& out) noexcept {
    detail::StreamerMaterialState& ms = materials[m];
    if (packet)
      ++ms.packets_loaded;
    else
      ++ms.roots_loaded;
    const bool packets_done = config.scheduler.stream_u_columns || ms.packets_loaded >= ms.texture_count;
    if (!ms.ready && ms.roots_loaded >= ms.texture_count && packets_done) {
      ms.ready = true;
      scheduler.set_material_enabled(m, true);  // its tiles are scheduled from now on
      push_event(out, ResidencyEvent{ResidencyEventKind::material_ready, m, TileId{ms.first_texture, 0, 0, 0},
                                     Status::success});
    }
  }

  void emit_packet(const detail::StreamerJob& job, StreamerOutputs& out) noexcept {
    const detail::StreamerMaterialState& ms = materials[job.material];
    const uint32_t g = local_texture(job.tile);
    packet_failures[ms.packet_base + g] = 0;
    out.packet_uploads[out.packet_upload_count++] = StreamerPacketUpload{
        job.material, g, job.tile.texture, ms.rows, std::span<const uint16_t>(job.halves, size_t{ms.rows} * 4)};
    push_event(out, ResidencyEvent{ResidencyEventKind::packet_loaded, job.material, job.tile, Status::success});
    mark_loaded(job.material, true, out);
  }

  void queue_write(uint32_t texture, uint32_t flat, uint32_t entry) noexcept {
    const uint32_t i = texture_tile_base[texture] + flat;
    if (mirror[i] == entry) return;
    mirror[i] = entry;
    if (queued[i]) return;
    queued[i] = 1;
    queue[(queue_head + queue_count) % queue.size()] = i;
    ++queue_count;
  }

  // --- failures (StreamerFailurePolicy) ---
  uint64_t backoff_frames(uint32_t failures) const noexcept {
    const StreamerFailurePolicy& p = config.failure;
    uint64_t d = p.first_backoff_frames;
    for (uint32_t i = 1; i < failures && d < p.max_backoff_frames; ++i) d *= 2;
    return std::min<uint64_t>(d, p.max_backoff_frames);
  }
  static uint32_t bump(uint8_t& failures) noexcept {
    if (failures < 255) ++failures;
    return failures;
  }
  uint32_t record_index(uint32_t m, uint32_t local_tex, uint32_t flat) const noexcept {
    return materials[m].record_base + local_tex * materials[m].tile_count + flat;
  }
  void push_startup(uint32_t item) noexcept {
    if (startup_count == startup.size()) return;  // cannot happen: each item is queued at most once
    startup[(startup_head + startup_count) % startup.size()] = item;
    ++startup_count;
  }

  // Failures (runtime/impl/streamer_failures.hpp).
  void startup_failed_job(uint32_t j, StreamerOutputs& out) noexcept;
  void request_failed_job(const detail::StreamerJob& job, StreamerOutputs& out) noexcept;
  void release_held() noexcept;
  Status retry_material(uint32_t m) noexcept;

  Status update(std::span<const uint32_t> feedback, StreamerOutputs& out) noexcept {
    if (out.tile_uploads.size() < tile_uploads_bound() || out.packet_uploads.size() < packet_uploads_bound())
      return Status::invalid_argument;
    out.tile_upload_count = out.packet_upload_count = out.page_table_write_count = out.event_count = 0;
    out.runnable_job_count = 0;
    ++frame;
    // 1. Jobs whose outputs were handed out last frame become free.
    for (uint32_t j = 0; j < jobs.size(); ++j)
      if (jobs[j].state.load(std::memory_order_acquire) == detail::kJobHanded)
        jobs[j].state.store(detail::kJobFree, std::memory_order_relaxed);
    // Retry async reads a source refused. A removed material's, and every job's while
    // quiescing, are abandoned instead: the job ends (cancelled) with its last started read, so
    // a quiesced Streamer drains even when the source refused reads.
    for (uint32_t j = 0; j < jobs.size(); ++j) {
      if (jobs[j].state.load(std::memory_order_acquire) != detail::kJobReading) continue;
      if (quiescing || stale(jobs[j]))
        abandon_reads(j);
      else
        start_reads(j);
    }
    // 2. Finished jobs.
    for (uint32_t j = 0; j < jobs.size(); ++j) {
      detail::StreamerJob& job = jobs[j];
      const uint8_t st = job.state.load(std::memory_order_acquire);
      if (st != detail::kJobDone && st != detail::kJobFailed) continue;
      const bool ok = st == detail::kJobDone;
      if (stale(job)) {  // its material was removed: dropped
        drop_stale_pin(job);
        job.decoded_kept = 1;
        job.state.store(detail::kJobFree, std::memory_order_relaxed);
        ++jobs_dropped;
        continue;
      }
      if (job.kind != detail::kPacketJob) keep_decoded(job, ok);
      if (job.kind == detail::kRootJob) {
        if (ok && out.tile_upload_count < out.tile_uploads.size()) {
          keep_payloads(job);
          out.tile_uploads[out.tile_upload_count++] = tile_upload(cache.slot_of(job.tile), job);
          tile_failures[record_index(job.material, local_texture(job.tile), 0)] = 0;
          mark_loaded(job.material, false, out);
          job.state.store(detail::kJobHanded, std::memory_order_relaxed);
        } else if (!ok) {
          startup_failed_job(j, out);  // the root is pinned: retried after a back-off, or the material fails
        }
        continue;
      }
      if (job.request == kNoJob) {  // start-up packet
        if (ok && out.packet_upload_count < out.packet_uploads.size()) {
          emit_packet(job, out);
          job.state.store(detail::kJobHanded, std::memory_order_relaxed);
        } else if (!ok) {
          startup_failed_job(j, out);
        }
        continue;
      }
      if (!ok) {  // scheduler request: dropped, held back for its back-off or given up
        scheduler.cancel(cache, job.request);
        job_of_request[job.request] = kNoJob;
        job.state.store(detail::kJobFree, std::memory_order_relaxed);
        request_failed_job(job, out);
        continue;
      }
      if (job.kind == detail::kTileJob) {
        keep_payloads(job);
        // A success ends the tile's run of failures: attempts count consecutive failures.
        tile_failures[record_index(job.material, local_texture(job.tile),
                                   cache.set().levels_of(job.tile.texture).index(job.tile))] = 0;
      } else {
        packet_failures[materials[job.material].packet_base + local_texture(job.tile)] = 0;
      }
      // Ready for the scheduler (a job already reported stays ready until apply_uploads takes
      // it; begin_decode then returns false and changes nothing).
      if (scheduler.begin_decode(job.request)) scheduler.finish_decode(job.request);
    }
    release_held();
    // 3. Uploads in request order within the budget.
    scheduler.apply_uploads(cache, [&](const TileRequest& q) {
      const uint32_t j = job_of_request[q.id];
      if (j == kNoJob) return;
      detail::StreamerJob& job = jobs[j];
      if (q.u_packet) {
        if (out.packet_upload_count < out.packet_uploads.size()) emit_packet(job, out);
      } else if (out.tile_upload_count < out.tile_uploads.size()) {
        out.tile_uploads[out.tile_upload_count++] = tile_upload(q.slot, job);
      }
      job_of_request[q.id] = kNoJob;
      job.state.store(detail::kJobHanded, std::memory_order_relaxed);
    });
    // 4. Votes and plan (none while quiescing: nothing new starts).
    if (!feedback.empty()) {
      votes.accumulate(feedback, config.vote_weight, scheduler.lod_bias());
      // Voted tiles of materials that are not ready or failed schedule nothing; counted per
      // distinct tile (not per word: a pass over every word costs as much as the votes).
      for (const uint32_t word : votes.touched()) {
        const uint32_t m = unpack_feedback(word).material;
        feedback_ignored += !materials[m].ready || materials[m].failed;
      }
    }
    if (quiescing) return finish_update(out);
    const std::span<const TileRequest> requests = scheduler.plan(cache, votes, frame);
    for (const TileRequest& q : requests) {
      if (q.u_packet) {
        if (waiting_count < waiting_packets.size())
          waiting_packets[waiting_count++] = (uint64_t{q.tile.texture} << 32) | q.id;
        else
          scheduler.cancel(cache, q.id);
        continue;
      }
      // A free tile job (jobs handed out this frame stay untouched until the next update, so
      // there are requests_in_flight + uploads_per_frame of them: one is always free).
      const uint32_t j = free_job(0, tile_jobs);
      if (j == kNoJob) {
        scheduler.cancel(cache, q.id);
        continue;
      }
      job_of_request[q.id] = j;
      start_tile_job(j, detail::kTileJob, q.id, q.tile);
    }
    // Scheduler packets waiting for a packet job.
    const uint32_t packet_begin = tile_jobs + root_jobs;
    while (waiting_count > 0) {
      const uint32_t j = free_job(packet_begin, packet_begin + packet_jobs);
      if (j == kNoJob) break;
      const uint64_t w = waiting_packets[0];
      std::memmove(waiting_packets.data(), waiting_packets.data() + 1, (waiting_count - 1) * sizeof(uint64_t));
      --waiting_count;
      const uint32_t id = static_cast<uint32_t>(w);
      job_of_request[id] = j;
      start_packet_job(j, id, static_cast<uint32_t>(w >> 32));
    }
    // Start-up jobs whose back-off ended start again.
    for (uint32_t j = tile_jobs; j < jobs.size(); ++j) {
      detail::StreamerJob& job = jobs[j];
      if (job.state.load(std::memory_order_relaxed) != detail::kJobWaiting || job.retry_frame > frame) continue;
      ++retry_count;
      if (job.kind == detail::kRootJob)
        start_tile_job(j, detail::kRootJob, kNoJob, job.tile);
      else
        start_packet_job(j, kNoJob, job.tile.texture);
    }
    // Start-up: roots, then packets (then what retry_material() queued again).
    while (startup_count > 0) {
      const uint32_t item = startup[startup_head];
      if (texture_material[item >> 1] == kNoMaterial) {  // cannot happen: removals purge the queue
        startup_head = (startup_head + 1) % static_cast<uint32_t>(startup.size());
        --startup_count;
        continue;
      }
      const bool root = (item & 1u) == 0;
      const uint32_t j =
          root ? free_job(tile_jobs, tile_jobs + root_jobs) : free_job(packet_begin, packet_begin + packet_jobs);
      if (j == kNoJob) break;
      startup_head = (startup_head + 1) % static_cast<uint32_t>(startup.size());
      --startup_count;
      if (root)
        start_tile_job(j, detail::kRootJob, kNoJob, TileId{item >> 1, 0, 0, 0});
      else
        start_packet_job(j, kNoJob, item >> 1);
    }
    return finish_update(out);
  }

  // 5. Page-table texels changed by this frame's operations, removed materials, then the
  // runnable jobs.
  Status finish_update(StreamerOutputs& out) noexcept {
    announce_materials(out);
    for_each_frame_page_table_write(cache, [&](const PageTableWrite& w) {
      queue_write(w.tile.texture, cache.set().levels_of(w.tile.texture).index(w.tile), w.entry);
    });
    cache.clear_deltas();
    while (queue_count > 0 && out.page_table_write_count < out.page_table_writes.size()) {
      const uint32_t i = queue[queue_head];
      queue_head = (queue_head + 1) % queue.size();
      --queue_count;
      queued[i] = 0;
      const uint32_t t = mirror_texture[i];
      const VtLevelTable& lv = cache.set().levels_of(t);
      const TileId tile = lv.tile(t, i - texture_tile_base[t]);
      out.page_table_writes[out.page_table_write_count++] =
          PageTableWrite{tile, lv.finest_level() - tile.level, mirror[i]};
    }
    // Runnable jobs (launched now or made runnable by async completions) are claimed for the
    // engine as far as its span holds; executors pulling with acquire_job() are woken for the rest.
    bool unclaimed = false;
    for (uint32_t j = 0; j < jobs.size(); ++j) {
      if (jobs[j].state.load(std::memory_order_relaxed) != detail::kJobRunnable) continue;
      if (out.runnable_job_count < out.runnable_jobs.size() && claim_job(j))
        out.runnable_jobs[out.runnable_job_count++] = j;
      else
        unclaimed = true;
    }
    if (unclaimed && notify != nullptr) notify(notify_user);
    return Status::success;
  }

  size_t tile_uploads_bound() const noexcept { return config.scheduler.budgets.uploads_per_frame + root_jobs; }
  size_t packet_uploads_bound() const noexcept { return packet_jobs; }
};

}  // namespace btflod

// The failure policy and the live materials, then creation and the accessors, which use both.
#include "btflod/runtime/impl/streamer_failures.hpp"
#include "btflod/runtime/impl/streamer_materials.hpp"

#include "btflod/runtime/impl/streamer_create.hpp"
