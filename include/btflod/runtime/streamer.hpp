// btflod — the engine's runtime object: one per world, one update() per frame.
//
// A Streamer serves every material of a world, each from its own `.bsvtf` container with its
// own component count C (⌈C/4⌉ virtual textures), through one tile cache of one or more pools
// (runtime/vt/cache_config.hpp's CacheConfig each, the shapes the shaders use: a material's
// tiles live in its pool's cache texture, which sets their tile size and texel format), one
// scheduler (paper 000 §5: P = w·v, add/swap, budgets in real payload bytes) and one set of
// decode jobs. Per frame:
//
//   update(feedback words, outputs)
//     1. finished jobs are collected: tiles decoded (against their parent chain, paper 000 §7)
//        become ready for the scheduler, U′ packets are converted to the caller's row order;
//     2. ready tiles are written into the cache within the upload budget → outputs.tile_uploads
//        (slot, tile, (T+2B)² RGBA half texels) and outputs.packet_uploads (U′ packets);
//     3. the feedback becomes votes (paper 000 eq. 9, summed over the rotation window), the
//        scheduler plans add/swap operations → new decode jobs (and async reads);
//     4. the page-table texels these operations changed (TileCache deltas + touched tiles,
//        runtime/backend/page_table_writes.hpp, filtered through a mirror so only texels whose value
//        changes are written) → outputs.page_table_writes;
//     5. residency events (material ready or failed, packet loaded, failures and give-ups);
//     6. the runnable decode jobs, claimed for the engine → outputs.runnable_jobs.
//   The pinned root tiles and, unless U′ columns are streamed (§6), every U′ packet are loaded
//   by the same jobs as soon as the Streamer exists: nothing sleeps or blocks. A material's
//   tiles are scheduled once it is ready. Failures end (StreamerFailurePolicy): bounded
//   retries with a doubling back-off, then a tile is given up (its parent keeps serving) or its
//   material fails (retry_material() after a repair). docs/vt.md, "Failures, jobs, quiescing".
//
// Threads, I/O and memory belong to the engine:
//  * Decode work is exposed as jobs: the handles update() claims for the engine
//    (outputs.runnable_jobs) or acquire_job(), then run_job() from any worker threads (or
//    pump() on the calling thread). runtime/stream/thread_executor.hpp is a ready-made thread pool for
//    those who do not care. A job reads its bytes from a blocking TileSource inside run_job(),
//    or an AsyncTileSource is asked for them in update() and complete_read() reports them (and
//    names the job it made runnable). decode_workers decoders serve all jobs.
//  * quiesce() stops new work; idle() says when nothing runs or reads, so the Streamer can be
//    destroyed. stats() reports memory by category, residency, jobs and failures.
//  * Every buffer is allocated in create() through StreamerConfig::allocator (or operator new):
//    the Streamer's own arrays, the tile cache, scheduler, vote counter and payload cache and
//    the temporaries of create() itself, and the tile decoders' symbol buffers, zlib and zstd
//    state. The one exception is libdeflate's decompressor (libdeflate 1.14 has no per-object
//    allocator), one malloc per decoder when StreamerConfig::inflate_backend is libdeflate;
//    with InflateBackend::zlib every byte goes through the callbacks
//    (tests/test_runtime_allocator.cpp). update(), the jobs and the completions allocate nothing.
//  * Headers used here include no thread, POSIX or GPU header; the runtime builds with
//    -fno-exceptions -fno-rtti.
//
// Determinism: with jobs run by pump() between updates, the same feedback gives the same
// outputs. Threading: update(), pump(), complete_read() targets and accessors belong to one
// thread, except acquire_job()/run_job() (any threads) and complete_read() (any thread).
// The Streamer is movable (its state lives in one allocation); it must not be destroyed or
// moved-from while a job runs, nor while the engine's I/O may still write into a read's buffer
// (quiesce(), then cancel or complete the reads and update() until idle()).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <new>
#include <span>
#include <utility>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/core/result.hpp"
#include "btflod/runtime/allocator.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/stream/payload_cache.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"
#include "btflod/runtime/vt/cache_config.hpp"
#include "btflod/runtime/vt/cache_format.hpp"
#include "btflod/runtime/vt/scheduler.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"

namespace btflod {

/// StreamerMaterial::pool for "the first pool whose tile size and border match the container".
inline constexpr uint32_t kStreamerAnyPool = 0xffffffffu;

/// One material of the world: its parsed container directory (copied at creation) and where
/// its bytes come from — exactly one of `source` (blocking reads inside jobs) and
/// `async_source` (engine-owned I/O). Sources must outlive the Streamer.
struct StreamerMaterial {
  const BsvtfDirectory* directory = nullptr;
  TileSource* source = nullptr;
  AsyncTileSource* async_source = nullptr;
  /// Row order of U for a version-2 container (which does not store it); ignored otherwise.
  AngularRowOrder assumed_row_order = AngularRowOrder::unspecified;
  /// Cache pool (StreamerConfig::pools) its tiles live in: an index, whose tile size and border
  /// must be the container's, or kStreamerAnyPool for the lowest pool whose tile size and border
  /// are the container's (with one pool: that pool).
  uint32_t pool = kStreamerAnyPool;
};

/// What the Streamer does when a read, a checksum or a decode fails (docs/vt.md, "Failures").
/// A failed tile is retried after a back-off that doubles per failure (first_backoff_frames,
/// 2×, 4×, … up to max_backoff_frames); after `tile_attempts` failures it is reported
/// unavailable (ResidencyEventKind::tile_unavailable) and never requested again, so its parent
/// keeps serving its area. A pinned root or a start-up U′ packet that fails `startup_attempts`
/// times fails its material (material_failed): none of its tiles is scheduled until the engine
/// calls Streamer::retry_material(). A material's tiles are scheduled only once it is ready.
struct StreamerFailurePolicy {
  uint32_t tile_attempts = 4;         ///< consecutive failures of one tile before it is given up (≥ 1)
  uint32_t startup_attempts = 4;      ///< failures of a root or start-up packet before its material fails (≥ 1)
  uint32_t packet_attempts = 4;       ///< failures of a streamed U′ packet (§6) before it is given up (≥ 1)
  uint32_t first_backoff_frames = 2;  ///< frames before the first retry (0: retry on the next update)
  uint32_t max_backoff_frames = 120;  ///< cap of the doubling back-off
  /// Tiles waiting for their back-off at once; a failure beyond it is retried without waiting
  /// (its attempts still count).
  uint32_t held_tiles_capacity = 256;
};

/// Room reserved at creation for materials added while the Streamer runs (add_material()).
/// Every field 0 (the default): exactly what the materials given to create() need, so nothing
/// can be added until one is removed. A field below what create()'s materials need is an error.
/// Every table is sized from these, so adding and removing materials allocates nothing.
struct StreamerCapacity {
  uint32_t materials = 0;         ///< material ids (≤ 1023, the feedback word's limit)
  uint32_t textures = 0;          ///< virtual textures = page-table layers = U′ packets, over live materials
  uint32_t tiles = 0;             ///< Σ over live materials of tiles per texture × textures
  uint32_t material_tiles = 0;    ///< Σ over live materials of tiles per texture (the vote counter's
                                  ///< room; 0: create()'s when `tiles` is 0, else `tiles`)
  uint32_t max_level_count = 0;   ///< L + 1 of any material (page-table mips)
  uint32_t max_finest_tiles = 0;  ///< finest-level tiles per side of any material (page-table size)
  uint32_t max_tile_bytes = 0;    ///< largest tile payload of any material (decode chain buffers)
  uint32_t max_packet_bytes = 0;  ///< largest U′ packet payload
  uint32_t max_u_rows = 0;        ///< rows of the largest U′ packet (U′ texture height)
};

/// The room to reserve so that any `live_at_once` of `candidates` (the materials a world may
/// stream, e.g. every level's) can be live together: the ids, and the layers and tile entries of
/// the `live_at_once` largest, the largest tile, packet, row count and hierarchy of all. Ranges
/// are handed out first-fit, so after many adds and removes of different sizes an add can find
/// the room in total but not in one piece (insufficient_space): reserve headroom when materials
/// churn. Candidates that fail the Streamer's checks are skipped. Set-up helper (allocates).
StreamerCapacity streamer_capacity_for(std::span<const StreamerMaterial> candidates, uint32_t live_at_once);

/// Everything fixed at creation.
struct StreamerConfig {
  /// The cache (slots, layers, tile size, border, texel format) when `pools` is empty: the one
  /// pool, whose tile size and border must match every container. The same value configures
  /// the shader generator (VirtualTextureConfig). With format rgba8_affine the decode jobs also
  /// quantise each tile (runtime/vt/cache_format.hpp), on the engine's workers, and the uploads
  /// carry unorm8 texels and their slot map; with bc5_affine they also encode the quantised tile
  /// as BC5 blocks (runtime/vt/cache_bc5.hpp), and the uploads carry the blocks and the slot map.
  CacheConfig cache;
  /// Cache pools (at most kMaxCachePools), when not empty: pool p is pools[p], a cache texture of
  /// its own (and slot-map table for the affine formats) with its own slots, and `cache` is not
  /// used. Each material lives in one pool (StreamerMaterial::pool), whose tile size and border
  /// are its container's; the page table, U′ texture, budgets and jobs are shared by all pools
  /// (docs/vt.md, "Cache pools"). Read by create() and memory_required() only (copied).
  std::span<const CacheConfig> pools{};
  /// Budgets, priorities, hysteresis, LOD bias (runtime/vt/scheduler.hpp). Byte budgets count the
  /// containers' real payload sizes.
  SchedulerConfig scheduler;
  /// Frames summed by the vote window (d² for feedback decimated d×d with rotation).
  uint32_t vote_window_frames = 16;
  /// Votes per feedback word.
  uint32_t vote_weight = 1;
  /// Row order of the U′ packets handed to the engine (the shaders' is light-major). Packets of
  /// containers in the other order are reordered by the decode job.
  AngularRowOrder u_row_order = AngularRowOrder::light_major;
  /// U′ packets fetched/decoded at once (each buffer holds one packet).
  uint32_t packet_jobs = 2;
  /// Jobs loading pinned root tiles at once.
  uint32_t root_jobs = 8;
  /// Byte budget of the payload cache that keeps ancestors' compressed tiles, so a child's
  /// decode chain (root → parent) rarely needs another read.
  size_t payload_cache_bytes = 8u << 20;
  /// Decoded tiles kept (as floats, (T+2B)² × 4 each) so a decode job starts from its deepest
  /// cached ancestor instead of decoding the chain from the root (and reads no payload above
  /// it). 0 disables the cache. The output is the same either way.
  uint32_t decoded_cache_tiles = 16;
  /// Tile decoders (each with its inflate state and symbol buffer): the most jobs the engine
  /// runs at once. A run_job() that finds every decoder busy puts its job back (runnable) and
  /// returns at once, so running more threads than this wastes their time but is safe.
  uint32_t decode_workers = 4;
  /// Retries, back-off and give-up counts.
  StreamerFailurePolicy failure;
  /// Room for materials added later (StreamerCapacity; default: none beyond create()'s).
  StreamerCapacity capacity;
  /// Allocation callbacks for every buffer of the Streamer (tile cache, scheduler, vote counter,
  /// payload cache, jobs, tile decoders), except libdeflate's decompressor (see the file comment).
  RuntimeAllocator allocator;
  /// The tile decoders' inflate implementation: libdeflate (the default when compiled in,
  /// faster) or zlib (every allocation through `allocator`). Same output either way.
  InflateBackend inflate_backend = default_inflate_backend();
};

/// A tile to copy into cache slot `slot` of pool `pool`'s cache texture (the slot within that
/// pool, as the page-table entries name it) this frame, valid until the next update().
/// tile.texture is the global virtual texture (page-table layer). In the format of the pool
/// (StreamerConfig::cache with one pool): rgba16f fills `texels` ((T+2B)² × 4 half bits) and leaves `unorm8`
/// empty; rgba8_affine fills `unorm8` ((T+2B)² × 4 bytes) and `map` (the slot's texel of the
/// slot-map table) and leaves `texels` empty; bc5_affine fills `bc5` (cache_bc5_tile_bytes(T+2B)
/// bytes, runtime/vt/cache_bc5.hpp's two-plane layout) and `map`.
struct StreamerTileUpload {
  uint32_t slot = 0;
  TileId tile;
  std::span<const uint16_t> texels;
  std::span<const uint8_t> unorm8{};  // default member initialisers: {slot, tile, texels} stays warning-free
  CacheSlotMap map{};
  std::span<const uint8_t> bc5{};
  uint32_t pool = 0;  ///< the cache pool (StreamerConfig::pools) of the tile's material
};

/// A U′ packet: four components (4g … 4g+3) of material `material`, rows × 4 halves in the
/// configured row order (rows = lights · views · colour channels), valid until the next update().
struct StreamerPacketUpload {
  uint32_t material = 0;
  uint32_t packet = 0;   ///< g, the virtual texture within the material
  uint32_t texture = 0;  ///< global virtual texture (first_texture(material) + g)
  uint32_t rows = 0;
  std::span<const uint16_t> halves;
};

enum class ResidencyEventKind : uint8_t {
  material_ready,      ///< every root tile and (unless streamed) every U′ packet was handed out
  packet_loaded,       ///< a U′ packet was handed out (packet_uploads)
  tile_failed,         ///< a tile could not be read or decoded (status says why); retried after a back-off
  packet_failed,       ///< a U′ packet could not be read or verified; retried after a back-off
  tile_unavailable,    ///< a tile failed StreamerFailurePolicy::tile_attempts times: never requested again
  material_failed,     ///< a root or start-up U′ packet failed startup_attempts times (terminal until
                       ///< retry_material()); tile = the failing texture's root or packet
  packet_unavailable,  ///< a streamed U′ packet (§6) failed packet_attempts times: never requested again
  material_removed,    ///< remove_material() took effect: page-table layers [tile.texture, tile.texture +
                       ///< layers) and its cache slots are free; nothing of it is uploaded any more
  material_released,   ///< the last job or read of a removed material ended: its sources may be
                       ///< destroyed and its id is free for add_material()
};

/// Something the engine may want to react to.
struct ResidencyEvent {
  ResidencyEventKind kind = ResidencyEventKind::material_ready;
  uint32_t material = 0;
  TileId tile;  ///< global texture id (tile events); {texture, 0, 0, 0} for packet events
  Status status = Status::success;
  uint32_t layers = 0;  ///< material_removed: page-table layers freed from tile.texture on
};

/// Caller-owned outputs of one update(). Capacities: tile_uploads ≥ tile_uploads_bound(),
/// packet_uploads ≥ packet_uploads_bound(); page_table_writes and events any size (what does
/// not fit waits for the next update, resp. is counted in events_dropped()); runnable_jobs any
/// size (jobs that do not fit stay runnable for acquire_job()).
struct StreamerOutputs {
  std::span<StreamerTileUpload> tile_uploads;
  std::span<StreamerPacketUpload> packet_uploads;
  std::span<PageTableWrite> page_table_writes;
  std::span<ResidencyEvent> events;
  /// Jobs claimed for the engine by this update: hand each to a worker that calls run_job()
  /// once. Empty span: nothing is claimed (workers pull with acquire_job()).
  std::span<uint32_t> runnable_jobs{};
  size_t tile_upload_count = 0;
  size_t packet_upload_count = 0;
  size_t page_table_write_count = 0;
  size_t event_count = 0;
  size_t runnable_job_count = 0;
};

/// Bytes the Streamer holds, by what they are for: allocated in create(), constant afterwards
/// (nothing allocates later). total is everything allocated through StreamerConfig::allocator
/// and still held (libdeflate's decompressors, outside the callbacks, are not counted).
struct StreamerMemory {
  uint64_t tile_cache = 0;     ///< slot table, per-tile slot indices, page-table bookkeeping
  uint64_t scheduler = 0;      ///< requests, weights, priorities, per-tile flags
  uint64_t votes = 0;          ///< vote counter (window of feedback frames)
  uint64_t payload_cache = 0;  ///< compressed ancestors (payload_cache_bytes + index)
  uint64_t job_buffers = 0;    ///< payload chains, decode scratch, output texels, U′ packets
  uint64_t decoders = 0;       ///< decode_workers tile decoders (symbols, zlib/zstd state)
  uint64_t decoded_cache = 0;  ///< decoded_cache_tiles decoded ancestors
  uint64_t tables = 0;         ///< per-material, per-tile records, page-table mirror, queues,
                               ///< failure counts, the Streamer object and its allocation ledger
  uint64_t total = 0;          ///< all of the above
  uint64_t allocations = 0;    ///< allocations held (each through the callbacks)
};

/// Residency of one cache pool.
struct StreamerPoolStats {
  uint32_t slots = 0, slots_used = 0;  ///< slots of the pool, of which hold a tile (roots included)
  uint32_t materials_live = 0;         ///< live materials whose tiles live in the pool
  uint64_t resident_bytes = 0;  ///< GPU bytes the resident tiles fill (slots_used × slot bytes, slot map included)
  uint64_t texture_bytes = 0;   ///< GPU bytes of the pool's cache texture and slot-map table
};

/// A snapshot of the Streamer's state and counters since creation. Cheap (O(jobs)); any frame.
struct StreamerStats {
  StreamerMemory memory;
  uint64_t frame = 0;                  ///< update() calls so far
  uint32_t slots = 0, slots_used = 0;  ///< cache slots of every pool, of which hold a tile (roots included)
  uint32_t pool_count = 1;             ///< cache pools; pools[0 … pool_count) are theirs
  StreamerPoolStats pools[kMaxCachePools] = {};
  uint32_t materials_live = 0;          ///< materials added and not removed
  uint32_t materials_removing = 0;      ///< removed materials whose jobs have not all ended
  uint32_t materials_ready = 0;         ///< materials whose roots (and U′ unless streamed) are loaded
  uint32_t materials_failed = 0;        ///< materials in the failed state now
  uint32_t jobs_reading = 0;            ///< jobs waiting for async reads
  uint32_t jobs_runnable = 0;           ///< jobs ready to run (not claimed)
  uint32_t jobs_running = 0;            ///< jobs claimed or running
  uint32_t jobs_waiting_retry = 0;      ///< start-up jobs waiting for their back-off
  uint32_t tiles_backing_off = 0;       ///< tiles held until their back-off ends
  uint32_t tiles_unavailable = 0;       ///< tiles given up (and not reset by retry_material())
  uint64_t tile_failures = 0;           ///< tile and root jobs that failed (read, checksum, decode)
  uint64_t packet_failures = 0;         ///< U′ packet jobs that failed
  uint64_t retries = 0;                 ///< failed work started again (after its back-off)
  uint64_t cancelled = 0;               ///< jobs dropped because reads were cancelled (no failure counted)
  uint64_t jobs_dropped = 0;            ///< jobs of removed materials that ended and were dropped
  uint64_t materials_added = 0;         ///< add_material() successes (create()'s materials included)
  uint64_t materials_removed = 0;       ///< remove_material() successes
  uint64_t feedback_ignored = 0;        ///< voted tiles (per frame) of materials not ready or failed
  uint64_t feedback_rejected = 0;       ///< feedback words naming no live material or no tile of it
  uint64_t bytes_read = 0;              ///< payload bytes read from sources
  uint64_t decoded_levels_skipped = 0;  ///< see Streamer::decoded_levels_skipped()
  uint64_t events_dropped = 0;          ///< events that did not fit the caller's span
  uint64_t decoder_busy = 0;            ///< run_job() calls that found every decoder busy
};

/// Shape of one cache pool's GPU resources: its cache texture (and, for the affine formats, its
/// slot-map table of `slots` RGBA32UI texels).
struct StreamerPoolLayout {
  CacheConfig cache;                                             ///< the pool's configuration
  uint32_t cache_width = 0, cache_height = 0, cache_layers = 0;  ///< texels of the pool's cache texture
  uint32_t slots = 0;                                            ///< slots (slot-map texels)
};

/// Shapes of the GPU resources an engine allocates for a Streamer (docs/shaders.md): the
/// cache textures (one per pool; cache_* repeat pool 0's), the page table (one R32UI 2D-array
/// layer per virtual texture, mip s holding level L − s of that texture) and the U′ texture
/// (one RGBA16F packet per virtual texture).
struct StreamerGpuLayout {
  uint32_t cache_width = 0, cache_height = 0, cache_layers = 0;  ///< texels of pool 0's tile cache
  uint32_t pool_count = 1;                                       ///< cache pools
  StreamerPoolLayout pools[kMaxCachePools] = {};                 ///< pools[0 … pool_count)
  uint32_t page_table_width = 0, page_table_height = 0;          ///< finest-level tiles, max over textures
  uint32_t page_table_levels = 0;                                ///< L + 1, max over textures
  uint32_t page_table_layers = 0;                                ///< virtual textures
  uint32_t u_rows = 0;                                           ///< rows of the largest U′ packet
  uint32_t u_packets = 0;                                        ///< virtual textures
};

/// The work a thread executor pulls (runtime/stream/thread_executor.hpp). Thread-safe.
class StreamerJobQueue {
 public:
  static constexpr uint32_t kNoJob = 0xffffffffu;
  virtual ~StreamerJobQueue() = default;
  /// Claims a runnable job and returns its handle, or kNoJob. Any thread; lock-free.
  virtual uint32_t acquire_job() noexcept = 0;
  /// Runs a job this thread claimed (acquire_job(), claim_job() or an update()'s
  /// runnable_jobs): reads through a blocking source, verifies, decodes. Any thread; distinct
  /// jobs run concurrently. A handle that is out of range or not claimed is ignored; a job
  /// that finds every decoder busy is put back (runnable). No allocation.
  virtual void run_job(uint32_t job) noexcept = 0;
  /// Claims job `job` if it is runnable (e.g. the handle complete_read() returned). Returns
  /// true when the caller now owns it and must run_job() it. Any thread; lock-free.
  virtual bool claim_job(uint32_t job) noexcept = 0;
  /// Registers a function update() calls when it made jobs runnable (e.g. to wake workers).
  virtual void set_job_notify(void (*notify)(void* user), void* user) noexcept = 0;
};

class Streamer {
 public:
  static constexpr uint32_t kNoJob = StreamerJobQueue::kNoJob;

  Streamer() = default;
  Streamer(const Streamer&) = delete;
  Streamer& operator=(const Streamer&) = delete;
  Streamer(Streamer&& o) noexcept : impl_(std::exchange(o.impl_, nullptr)) {}
  Streamer& operator=(Streamer&& o) noexcept {
    if (this != &o) {
      destroy();
      impl_ = std::exchange(o.impl_, nullptr);
    }
    return *this;
  }
  /// Precondition: no job running, no async read outstanding.
  ~Streamer() { destroy(); }

  /// Builds the VtSet from the containers (per-material C, tile weights w and energies from
  /// the index, real payload sizes for the byte budgets), the cache, the scheduler, the vote
  /// counter, every job buffer and decoder, and queues the pinned roots and U′ packets.
  /// Errors: invalid_argument (no materials, a material with no or two sources, a container
  /// whose tile size/border differs from its pool's (config.cache with one pool) or fits no
  /// pool, a material naming a pool that does not exist, more than kMaxCachePools pools or an
  /// invalid one, a row order unknown and not assumed, more than 1023 materials — the feedback
  /// word's limit), insufficient_space (the allocator failed, or a pool with fewer slots than
  /// its materials' virtual textures), bad_data (a directory missing a
  /// tile of its hierarchy). Set-up only (allocates).
  static Result<Streamer> create(std::span<const StreamerMaterial> materials, const StreamerConfig& config = {});

  /// What create(materials, config) would allocate through config.allocator, by category, in
  /// the figures stats().memory reports after creation (every buffer is sized by the config's
  /// budgets and the resolved StreamerCapacity, so adding and removing materials later changes
  /// nothing). Computed without creating the Streamer: the only allocation is one probe tile
  /// decoder through operator new (TileDecoder::memory_required: zlib's and zstd's state sizes
  /// are private to them), about 130 KB, released before returning. Scans the directories as
  /// create() does, so costs O(tiles) for materials given here; with no materials (a world
  /// that adds them later) it is O(1) beyond the probe. Errors: those of create() that the
  /// config and directories decide (not allocator failures). Set-up only.
  static Result<StreamerMemory> memory_required(std::span<const StreamerMaterial> materials,
                                                const StreamerConfig& config = {});

  /// One frame: see the file comment. `feedback`: this frame's packed feedback words
  /// (runtime/lod/feedback.hpp; material = index in the create() list); empty = no new votes.
  /// Returns invalid_argument when an output span is below its bound (nothing done then).
  /// noexcept, no allocation, deterministic for a given job completion order.
  Status update(std::span<const uint32_t> feedback, StreamerOutputs& out) noexcept;

  // --- materials that come and go --------------------------------------------------------
  /// Adds a material to the running Streamer at any frame, in the room reserved by
  /// StreamerConfig::capacity: it takes the lowest free material id (written to `id`; the
  /// material field of its feedback words) and the first free run of ⌈C/4⌉ page-table layers
  /// (first_texture(id)), both stable until it is removed. Its roots and U′ packets are queued
  /// like create()'s; its page-table texels are written in full by the next update()s;
  /// material_ready follows. When its pool has fewer free slots than the material has virtual
  /// textures, the oldest leaf tiles of other materials of that pool are evicted to pin its
  /// roots (their parents keep serving); nothing else of other materials changes.
  /// Errors (nothing changes then; `why`, when given, points to a static explanation):
  /// invalid_argument (no directory, not exactly one source, a pool that does not exist, a tile
  /// size or border other than its pool's or than every pool's, an unknown row order, rows ≠ lights × views × channels,
  /// a hierarchy the container does not match), bad_data (a tile missing from the directory), insufficient_space (no
  /// free id, no run of free layers, no free tile entries, a tile, packet, level count or page table larger than the
  /// capacity allows, or too few evictable slots). Update thread; noexcept; no allocation; O(tiles of the material +
  /// cache slots).
  Status add_material(const StreamerMaterial& material, uint32_t& id, const char** why = nullptr) noexcept;
  /// Removes a live material at any frame: its requests are cancelled, its queued work dropped,
  /// its tiles leave the cache (slots free at once), its feedback words are rejected from now
  /// on (stats().feedback_rejected), its page-table layers are free (ResidencyEventKind::
  /// material_removed in the next update()). Jobs already reading or running for it end and
  /// are dropped; once none is left (at once when nothing of it was in flight), its id is free
  /// for add_material() and material_released says its sources may be destroyed. Other
  /// materials' resident tiles are not touched. invalid_argument
  /// for an id that is not live. Update thread; noexcept; no allocation.
  Status remove_material(uint32_t id) noexcept;
  /// True when material id is live (created or added, not removed).
  bool material_live(uint32_t id) const noexcept;

  /// Capacity outputs.tile_uploads needs: the scheduler's uploads per frame + root jobs.
  size_t tile_uploads_bound() const noexcept;
  /// Capacity outputs.packet_uploads needs: packet jobs.
  size_t packet_uploads_bound() const noexcept;

  /// Claims / runs jobs (see StreamerJobQueue). pump() runs up to max_jobs runnable jobs on
  /// the calling thread and returns how many ran.
  uint32_t acquire_job() noexcept;
  void run_job(uint32_t job) noexcept;
  uint32_t pump(uint32_t max_jobs = 0xffffffffu) noexcept;
  /// The job interface of this Streamer; stays valid when the Streamer is moved.
  StreamerJobQueue& jobs() noexcept;

  /// Claims a specific runnable job (see StreamerJobQueue::claim_job).
  bool claim_job(uint32_t job) noexcept;

  /// Reports an AsyncTileSource read started with `ticket`: success when its bytes are in the
  /// buffer, Status::cancelled when the engine cancelled the read (the job is dropped without
  /// counting a failure and its work is asked for again later), anything else on failure.
  /// Returns the job this completion made runnable (its last read), or kNoJob; the engine may
  /// claim_job() it and hand it to a worker, or leave it for acquire_job(). Any thread, once
  /// per ticket; unknown tickets are ignored. noexcept.
  uint32_t complete_read(uint64_t ticket, Status status) noexcept;

  // --- quiescing ------------------------------------------------------------------------
  /// From the next update() on, no job, read or retry is started (finished jobs are still
  /// collected and their outputs handed out), so that the engine can drain: complete or
  /// cancel its outstanding reads, let running jobs end, update() until idle(), then destroy
  /// the Streamer (or resume()). Update thread.
  void quiesce() noexcept;
  /// Starts work again after quiesce().
  void resume() noexcept;
  /// True when no job is reading, runnable or running: destroying the Streamer is safe then.
  /// Any thread.
  bool idle() const noexcept;

  // --- failures -------------------------------------------------------------------------
  /// True when the material failed (ResidencyEventKind::material_failed) and was not retried.
  bool material_failed(uint32_t material) const noexcept;
  /// Forgets the failures of a material (its failed start-up items are queued again, its
  /// unavailable tiles may be requested again), e.g. after the engine repaired its source.
  /// invalid_argument for an unknown material. Update thread; no allocation.
  Status retry_material(uint32_t material) noexcept;

  // --- what the engine can see ----------------------------------------------------------
  /// Memory, residency, jobs and failure counters (StreamerStats). O(jobs), no allocation.
  StreamerStats stats() const noexcept;
  /// Shapes of the cache textures (one per pool), page table and U′ texture the engine must
  /// allocate.
  StreamerGpuLayout gpu_layout() const noexcept;
  /// Cache pools (1 without StreamerConfig::pools).
  uint32_t pool_count() const noexcept;
  /// Configuration of pool p (StreamerConfig::pools[p], or StreamerConfig::cache with one pool).
  /// Precondition: p < pool_count().
  const CacheConfig& pool_config(uint32_t pool) const noexcept;
  /// Pool of a live material (0 for an id that is not live).
  uint32_t material_pool(uint32_t material) const noexcept;

  // --- state ---------------------------------------------------------------------------
  const TileCache& cache() const noexcept;
  const Scheduler& scheduler() const noexcept;
  const VoteCounter& votes() const noexcept;
  /// Material ids (live or not): StreamerConfig::capacity.materials.
  uint32_t material_count() const noexcept;
  /// Live materials.
  uint32_t live_material_count() const noexcept;
  /// First global virtual texture (page-table layer) of a material, and its count ⌈C/4⌉ (0
  /// for an id that is not live).
  uint32_t first_texture(uint32_t material) const noexcept;
  uint32_t texture_count(uint32_t material) const noexcept;
  /// C of a material.
  uint32_t component_count(uint32_t material) const noexcept;
  /// True once every root tile (and, unless streamed, every U′ packet) was handed out.
  bool material_ready(uint32_t material) const noexcept;
  /// Page-table writes waiting for output capacity.
  size_t pending_page_table_writes() const noexcept;
  /// Events that did not fit the caller's span since creation.
  uint64_t events_dropped() const noexcept;
  /// Payload bytes read from sources since creation.
  uint64_t bytes_read() const noexcept;
  /// Tile levels decode jobs did not decode (nor read) since creation because the decoded
  /// cache held an ancestor (StreamerConfig::decoded_cache_tiles).
  uint64_t decoded_levels_skipped() const noexcept;
  /// Jobs currently runnable or running (an executor's hint).
  uint32_t jobs_in_flight() const noexcept;

 private:
  struct Impl;
  struct Room;  // the capacity create() resolves and what its materials need
  static Result<Room> resolve_room(std::span<const StreamerMaterial> materials, const StreamerConfig& config);
  static StreamerMemory memory_for(const StreamerConfig& config, const StreamerCapacity& capacity) noexcept;
  void destroy() noexcept;
  Impl* impl_ = nullptr;
};

}  // namespace btflod

// The implementation is compiled once per program, in the runtime implementation TU
// (cmake/btflod_runtime_implementation.cpp, VMA's pattern): a per-frame TU that calls update()
// sees the declarations above only. Split for reading: runtime/impl/streamer_impl.hpp (the per-frame
// object), which ends with runtime/impl/streamer_create.hpp (creation and accessors),
// runtime/impl/streamer_failures.hpp and runtime/impl/streamer_materials.hpp.
#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include "btflod/runtime/impl/streamer_impl.hpp"
#endif
