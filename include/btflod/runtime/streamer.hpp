// btflod — the engine's runtime object: one per world, one update() per frame.
//
// A Streamer serves every material of a world, each from its own `.bsvtf` container with its
// own component count C (⌈C/4⌉ virtual textures), through one tile cache (vt/cache_config.hpp's
// CacheConfig, the shape the shaders use), one scheduler (paper 000 §5: P = w·v, add/swap,
// budgets in real payload bytes) and one pool of decode jobs. Per frame:
//
//   update(feedback words, outputs)
//     1. finished jobs are collected: tiles decoded (against their parent chain, paper 000 §7)
//        become ready for the scheduler, U′ packets are converted to the caller's row order;
//     2. ready tiles are written into the cache within the upload budget → outputs.tile_uploads
//        (slot, tile, (T+2B)² RGBA half texels) and outputs.packet_uploads (U′ packets);
//     3. the feedback becomes votes (paper 000 eq. 9, summed over the rotation window), the
//        scheduler plans add/swap operations → new decode jobs (and async reads);
//     4. the page-table texels these operations changed (TileCache deltas + touched tiles,
//        backend/page_table_writes.hpp, filtered through a mirror so only texels whose value
//        changes are written) → outputs.page_table_writes;
//     5. residency events (material ready, packet loaded, fetch/decode failures).
//   The pinned root tiles and, unless U′ columns are streamed (§6), every U′ packet are loaded
//   by the same jobs as soon as the Streamer exists: nothing sleeps or blocks.
//
// Threads, I/O and memory belong to the engine:
//  * Decode work is exposed as jobs: acquire_job() + run_job() from any worker threads (or
//    pump() on the calling thread). stream/thread_executor.hpp is a ready-made thread pool for
//    those who do not care. A job reads its bytes from a blocking TileSource inside run_job(),
//    or an AsyncTileSource is asked for them in update() and complete_read() reports them.
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
// moved-from while a job runs or an async read is outstanding.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <new>
#include <span>
#include <utility>
#include <vector>

#include "btflod/backend/page_table_writes.hpp"
#include "btflod/codec/container.hpp"
#include "btflod/codec/tile_codec.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/result.hpp"
#include "btflod/lod/feedback.hpp"
#include "btflod/runtime/allocator.hpp"
#include "btflod/stream/payload_cache.hpp"
#include "btflod/stream/tile_source.hpp"
#include "btflod/vt/cache_config.hpp"
#include "btflod/vt/scheduler.hpp"
#include "btflod/vt/tile_cache.hpp"

namespace btflod {

/// One material of the world: its parsed container directory (copied at creation) and where
/// its bytes come from — exactly one of `source` (blocking reads inside jobs) and
/// `async_source` (engine-owned I/O). Sources must outlive the Streamer.
struct StreamerMaterial {
  const BsvtfDirectory* directory = nullptr;
  TileSource* source = nullptr;
  AsyncTileSource* async_source = nullptr;
  /// Row order of U for a version-2 container (which does not store it); ignored otherwise.
  AngularRowOrder assumed_row_order = AngularRowOrder::unspecified;
};

/// What the Streamer does when a read, a checksum or a decode fails (docs/vt.md, "Failures").
/// A failed tile is retried after a back-off that doubles per failure (first_backoff_frames,
/// 2×, 4×, … up to max_backoff_frames); after `tile_attempts` failures it is reported
/// unavailable (ResidencyEventKind::tile_unavailable) and never requested again, so its parent
/// keeps serving its area. A pinned root or a start-up U′ packet that fails `startup_attempts`
/// times fails its material (material_failed): none of its tiles is scheduled until the engine
/// calls Streamer::retry_material(). A material's tiles are scheduled only once it is ready.
struct StreamerFailurePolicy {
  uint32_t tile_attempts = 4;         ///< failures of one tile before it is given up (≥ 1)
  uint32_t startup_attempts = 4;      ///< failures of a root or start-up packet before its material fails (≥ 1)
  uint32_t packet_attempts = 4;       ///< failures of a streamed U′ packet (§6) before it is given up (≥ 1)
  uint32_t first_backoff_frames = 2;  ///< frames before the first retry (0: retry on the next update)
  uint32_t max_backoff_frames = 120;  ///< cap of the doubling back-off
  /// Tiles waiting for their back-off at once; a failure beyond it is retried without waiting
  /// (its attempts still count).
  uint32_t held_tiles_capacity = 256;
};

/// Everything fixed at creation.
struct StreamerConfig {
  /// The cache (slots, layers, tile size, border); tile size and border must match every
  /// container. The same value configures the shader generator (VirtualTextureConfig).
  CacheConfig cache;
  /// Budgets, priorities, hysteresis, LOD bias (vt/scheduler.hpp). Byte budgets count the
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
  /// Allocation callbacks for every buffer of the Streamer (tile cache, scheduler, vote counter,
  /// payload cache, jobs, tile decoders), except libdeflate's decompressor (see the file comment).
  RuntimeAllocator allocator;
  /// The tile decoders' inflate implementation: libdeflate (the default when compiled in,
  /// faster) or zlib (every allocation through `allocator`). Same output either way.
  InflateBackend inflate_backend = default_inflate_backend();
};

/// A tile to copy into cache slot `slot` this frame. texels: (T+2B)² × 4 half bits, valid
/// until the next update(). tile.texture is the global virtual texture (page-table layer).
struct StreamerTileUpload {
  uint32_t slot = 0;
  TileId tile;
  std::span<const uint16_t> texels;
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
  material_ready,  ///< every root tile and (unless streamed) every U′ packet was handed out
  packet_loaded,   ///< a U′ packet was handed out (packet_uploads)
  tile_failed,     ///< a tile could not be read or decoded (status says why); retried after a back-off
  packet_failed,   ///< a U′ packet could not be read or verified; retried after a back-off
  tile_unavailable,    ///< a tile failed StreamerFailurePolicy::tile_attempts times: never requested again
  material_failed,     ///< a root or start-up U′ packet failed startup_attempts times (terminal until
                       ///< retry_material()); tile = the failing texture's root or packet
  packet_unavailable,  ///< a streamed U′ packet (§6) failed packet_attempts times: never requested again
};

/// Something the engine may want to react to.
struct ResidencyEvent {
  ResidencyEventKind kind = ResidencyEventKind::material_ready;
  uint32_t material = 0;
  TileId tile;  ///< global texture id (tile events); {texture, 0, 0, 0} for packet events
  Status status = Status::success;
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
  uint64_t tile_cache = 0;       ///< slot table, per-tile slot indices, page-table bookkeeping
  uint64_t scheduler = 0;        ///< requests, weights, priorities, per-tile flags
  uint64_t votes = 0;            ///< vote counter (window of feedback frames)
  uint64_t payload_cache = 0;    ///< compressed ancestors (payload_cache_bytes + index)
  uint64_t job_buffers = 0;      ///< payload chains, decode scratch, output texels, U′ packets
  uint64_t decoders = 0;         ///< decode_workers tile decoders (symbols, zlib/zstd state)
  uint64_t decoded_cache = 0;    ///< decoded_cache_tiles decoded ancestors
  uint64_t tables = 0;           ///< per-material, per-tile records, page-table mirror, queues,
                                 ///< failure counts, the Streamer object and its allocation ledger
  uint64_t total = 0;            ///< all of the above
  uint64_t allocations = 0;      ///< allocations held (each through the callbacks)
};

/// A snapshot of the Streamer's state and counters since creation. Cheap (O(jobs)); any frame.
struct StreamerStats {
  StreamerMemory memory;
  uint64_t frame = 0;                   ///< update() calls so far
  uint32_t slots = 0, slots_used = 0;   ///< cache slots, of which hold a tile (roots included)
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
  uint64_t feedback_ignored = 0;        ///< feedback words naming no material, or one not ready or failed
  uint64_t bytes_read = 0;              ///< payload bytes read from sources
  uint64_t decoded_levels_skipped = 0;  ///< see Streamer::decoded_levels_skipped()
  uint64_t events_dropped = 0;          ///< events that did not fit the caller's span
  uint64_t decoder_busy = 0;            ///< run_job() calls that found every decoder busy
};

/// Shapes of the GPU resources an engine allocates for a Streamer (docs/shaders.md): the
/// cache texture, the page table (one R32UI 2D-array layer per virtual texture, mip s holding
/// level L − s of that texture) and the U′ texture (one RGBA16F packet per virtual texture).
struct StreamerGpuLayout {
  uint32_t cache_width = 0, cache_height = 0, cache_layers = 0;  ///< texels of the tile cache
  uint32_t page_table_width = 0, page_table_height = 0;          ///< finest-level tiles, max over textures
  uint32_t page_table_levels = 0;                                 ///< L + 1, max over textures
  uint32_t page_table_layers = 0;                                 ///< virtual textures
  uint32_t u_rows = 0;                                            ///< rows of the largest U′ packet
  uint32_t u_packets = 0;                                         ///< virtual textures
};

/// The work a thread executor pulls (stream/thread_executor.hpp). Thread-safe.
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

struct StreamerMaterialState {
  TileSource* source = nullptr;
  AsyncTileSource* async_source = nullptr;
  uint32_t first_texture = 0, texture_count = 0, components = 0;
  uint32_t tile_count = 0;   // per virtual texture
  uint32_t record_base = 0;  // index of (texture 0, flat 0) in the records array
  uint32_t lights = 0, views = 0, channels = 0, rows = 0;
  AngularRowOrder row_order = AngularRowOrder::light_major;
  uint32_t packet_base = 0;  // index of packet 0 in the packet records
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
  uint32_t request = 0;  // scheduler request id (tile and scheduler packet jobs); kNoJob: start-up
  TileId tile;           // global id; for packets {texture, 0, 0, 0}
  uint32_t chain = 0;    // tiles root … tile
  uint32_t next_read = 0;
  TileId chain_tile[kMaxTileLevel + 1];
  uint32_t chain_offset[kMaxTileLevel + 1] = {};  // offset into bytes
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
  uint64_t until = 0;    // the frame it may be requested again
  uint8_t packet = 0;
};

}  // namespace detail

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
  /// whose tile size/border differs from config.cache or whose row order is unknown and not
  /// assumed, more than 1023 materials — the feedback word's limit), insufficient_space (the
  /// allocator failed, or fewer slots than virtual textures), bad_data (a directory missing a
  /// tile of its hierarchy). Set-up only (allocates).
  static Result<Streamer> create(std::span<const StreamerMaterial> materials, const StreamerConfig& config = {});

  /// One frame: see the file comment. `feedback`: this frame's packed feedback words
  /// (lod/feedback.hpp; material = index in the create() list); empty = no new votes.
  /// Returns invalid_argument when an output span is below its bound (nothing done then).
  /// noexcept, no allocation, deterministic for a given job completion order.
  Status update(std::span<const uint32_t> feedback, StreamerOutputs& out) noexcept;

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
  /// Shapes of the cache texture, page table and U′ texture the engine must allocate.
  StreamerGpuLayout gpu_layout() const noexcept;

  // --- state ---------------------------------------------------------------------------
  const TileCache& cache() const noexcept;
  const Scheduler& scheduler() const noexcept;
  const VoteCounter& votes() const noexcept;
  uint32_t material_count() const noexcept;
  /// First global virtual texture (page-table layer) of a material, and its count ⌈C/4⌉.
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
  void destroy() noexcept;
  Impl* impl_ = nullptr;
};

// ------------------------------------------------------------------------------------------
// Implementation (inline: header-only).

struct Streamer::Impl final : StreamerJobQueue {
  detail::AllocationLedger* ledger = nullptr;  // owned by Streamer::destroy()
  RuntimeAllocator allocator;                  // ledger->counting()
  StreamerConfig config;
  TileLayout layout;
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
  RuntimeArray<uint8_t> decoder_storage;  // decode_workers TileDecoders
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
  uint32_t claim_decoder() noexcept {
    for (uint32_t d = 0; d < decoder_count; ++d) {
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
      const uint32_t d = claim_decoder();
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
    TileSource* src = materials[job.material].source;
    if (src == nullptr) return Status::invalid_argument;
    auto r = src->read(offset, dst);
    if (!r) return r.status();
    bytes_read.fetch_add(dst.size(), std::memory_order_relaxed);
    return Status::success;
  }

  Status run_tile(detail::StreamerJob& job, TileDecoder& decoder) noexcept {
    const uint32_t m = job.material;
    const uint32_t k = local_texture(job.tile);
    const VtLevelTable& lv = cache.set().levels_of(job.tile.texture);
    // Decode chain_start … tile, each level against the previous one (the first against the
    // cached ancestor `base`, or nothing for the root), alternating between the two buffers.
    float* buffers[2] = {job.out, job.parent};
    const float* previous = job.base;
    uint32_t current = 0;
    for (uint32_t i = job.chain_start; i < job.chain; ++i) {
      const TileId t = job.chain_tile[i];
      const detail::TileRecord& rec = record_of(m, k, lv.index(t));
      std::span<uint8_t> dst(job.bytes + job.chain_offset[i], rec.size);
      if (!job.chain_cached[i] && materials[m].async_source == nullptr) {
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
    float_to_half(std::span<const float>(previous, layout.sample_count()),
                  std::span<uint16_t>(job.halves, layout.sample_count()));
    return Status::success;
  }

  Status run_packet(detail::StreamerJob& job) noexcept {
    const detail::StreamerMaterialState& ms = materials[job.material];
    const uint32_t g = local_texture(job.tile);
    const detail::TileRecord& rec = packet_records[ms.packet_base + g];
    std::span<uint8_t> dst(job.bytes, rec.size);
    if (ms.async_source == nullptr) {
      const Status s = read_blocking(job, dst, rec.offset);
      if (s != Status::success) return s;
    }
    if (verify_bsvtf_payload(rec.size, rec.crc, dst) != Status::success) return Status::bad_data;
    // Rows (a · n_b + b) · channels + colour; reorder when the container's order differs.
    const bool swap = ms.row_order != config.u_row_order;
    const uint32_t na = ms.row_order == AngularRowOrder::light_major ? ms.lights : ms.views;
    const uint32_t nb = ms.row_order == AngularRowOrder::light_major ? ms.views : ms.lights;
    for (uint32_t a = 0; a < na; ++a)
      for (uint32_t b = 0; b < nb; ++b)
        for (uint32_t c = 0; c < ms.channels; ++c) {
          const size_t src_row = (static_cast<size_t>(a) * nb + b) * ms.channels + c;
          const size_t dst_row = swap ? (static_cast<size_t>(b) * na + a) * ms.channels + c : src_row;
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
      if (i < job.chain_start) {  // not decoded: no payload needed
        job.chain_cached[i] = 1;
        continue;
      }
      const detail::TileRecord& rec = record_of(m, k, lv.index(t));
      const uint64_t key = (static_cast<uint64_t>(m) << 48) ^ TileId { k, t.level, t.x, t.y }.key();
      job.chain_cached[i] = payloads.get(key, std::span<uint8_t>(job.bytes + offset, rec.size)) == rec.size ? 1 : 0;
      if (!job.chain_cached[i]) ++reads;
      offset += rec.size;
    }
    job.next_read = 0;
    return reads;
  }

  static uint64_t decoded_key(uint32_t material, uint32_t local_texture, const TileId& t) noexcept {
    return (static_cast<uint64_t>(material) << 48) ^ TileId { local_texture, t.level, t.x, t.y }.key();
  }
  uint32_t find_decoded(uint64_t key) const noexcept {
    for (uint32_t e = 0; e < decoded.size(); ++e)
      if (decoded[e].key == key) return e;
    return kNoJob;
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
      const detail::TileRecord& rec = packet_records[materials[job.material].packet_base + local_texture(job.tile)];
      if (!src->start_read(rec.offset, std::span<uint8_t>(job.bytes, rec.size), ticket_of(j, 0))) return false;
      bytes_read.fetch_add(rec.size, std::memory_order_relaxed);
      job.next_read = 1;
      return true;
    }
    const uint32_t k = local_texture(job.tile);
    const VtLevelTable& lv = cache.set().levels_of(job.tile.texture);
    for (; job.next_read < job.chain; ++job.next_read) {
      const uint32_t i = job.next_read;
      if (job.chain_cached[i]) continue;
      const detail::TileRecord& rec = record_of(job.material, k, lv.index(job.chain_tile[i]));
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
    launch(j, prepare_chain(job));
  }
  void start_packet_job(uint32_t j, uint32_t request, uint32_t texture) noexcept {
    detail::StreamerJob& job = jobs[j];
    job.kind = detail::kPacketJob;
    job.request = request;
    job.tile = TileId{texture, 0, 0, 0};
    job.material = texture_material[texture];
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
      const uint64_t key = (static_cast<uint64_t>(job.material) << 48) ^ TileId { k, t.level, t.x, t.y }.key();
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

  // A root or start-up U′ packet job failed: back off, or fail the material.
  void startup_failed_job(uint32_t j, StreamerOutputs& out) noexcept {
    detail::StreamerJob& job = jobs[j];
    const uint32_t m = job.material, t = job.tile.texture;
    detail::StreamerMaterialState& ms = materials[m];
    const bool packet = job.kind == detail::kPacketJob;
    if (job.status == Status::cancelled) {  // the engine cancelled the read: not a failure
      ++cancelled_count;
      job.state.store(detail::kJobWaiting, std::memory_order_relaxed);
      job.retry_frame = frame + 1;
      return;
    }
    const uint32_t k = t - ms.first_texture;
    uint8_t& fails = packet ? packet_failures[ms.packet_base + k] : tile_failures[record_index(m, k, 0)];
    packet ? ++packet_failure_count : ++tile_failure_count;
    push_event(out, ResidencyEvent{packet ? ResidencyEventKind::packet_failed : ResidencyEventKind::tile_failed, m,
                                   job.tile, job.status});
    if (bump(fails) < config.failure.startup_attempts) {
      job.state.store(detail::kJobWaiting, std::memory_order_relaxed);
      job.retry_frame = frame + backoff_frames(fails);
      return;
    }
    startup_failed[t] |= packet ? 2 : 1;
    job.state.store(detail::kJobFree, std::memory_order_relaxed);
    if (!ms.failed) {
      ms.failed = true;
      ++materials_failed_now;
      scheduler.set_material_enabled(m, false);
      push_event(out, ResidencyEvent{ResidencyEventKind::material_failed, m, job.tile, job.status});
    }
  }

  // A scheduler request failed (its request is cancelled already): hold the tile or packet back
  // for its back-off, or give it up.
  void request_failed_job(const detail::StreamerJob& job, StreamerOutputs& out) noexcept {
    const uint32_t m = job.material;
    const detail::StreamerMaterialState& ms = materials[m];
    const uint32_t k = job.tile.texture - ms.first_texture;
    if (job.status == Status::cancelled) {
      ++cancelled_count;
      return;
    }
    if (job.kind == detail::kPacketJob) {
      ++packet_failure_count;
      push_event(out, ResidencyEvent{ResidencyEventKind::packet_failed, m, job.tile, job.status});
      const uint32_t fails = bump(packet_failures[ms.packet_base + k]);
      scheduler.hold_u_packets(m, true);
      if (fails >= config.failure.packet_attempts) {
        push_event(out, ResidencyEvent{ResidencyEventKind::packet_unavailable, m, job.tile, job.status});
      } else if (held_count < held.size()) {
        held[held_count++] = detail::HeldWork{m, k, frame + backoff_frames(fails), 1};
      } else {
        scheduler.hold_u_packets(m, false);
      }
      return;
    }
    ++tile_failure_count;
    push_event(out, ResidencyEvent{ResidencyEventKind::tile_failed, m, job.tile, job.status});
    const uint32_t flat = cache.set().levels_of(job.tile.texture).index(job.tile);
    const uint32_t fails = bump(tile_failures[record_index(m, k, flat)]);
    if (fails >= config.failure.tile_attempts) {
      scheduler.hold_tile(job.tile.texture, flat, true);
      ++tiles_unavailable;
      push_event(out, ResidencyEvent{ResidencyEventKind::tile_unavailable, m, job.tile, job.status});
    } else if (held_count < held.size()) {
      scheduler.hold_tile(job.tile.texture, flat, true);
      held[held_count++] = detail::HeldWork{job.tile.texture, flat, frame + backoff_frames(fails), 0};
    }
  }

  // Held work whose back-off ended may be requested again.
  void release_held() noexcept {
    for (uint32_t i = 0; i < held_count;) {
      const detail::HeldWork h = held[i];
      if (h.until > frame) {
        ++i;
        continue;
      }
      if (h.packet)
        scheduler.hold_u_packets(h.texture, false);
      else
        scheduler.hold_tile(h.texture, h.flat, false);
      ++retry_count;
      held[i] = held[--held_count];
    }
  }

  Status retry_material(uint32_t m) noexcept {
    if (m >= materials.size()) return Status::invalid_argument;
    detail::StreamerMaterialState& ms = materials[m];
    for (uint32_t k = 0; k < ms.texture_count; ++k) {
      const uint32_t t = ms.first_texture + k;
      for (uint32_t flat = 0; flat < ms.tile_count; ++flat) {
        uint8_t& f = tile_failures[record_index(m, k, flat)];
        if (f >= config.failure.tile_attempts && flat > 0 && scheduler.tile_held(t, flat)) {
          scheduler.hold_tile(t, flat, false);
          --tiles_unavailable;
        }
        f = 0;
      }
      packet_failures[ms.packet_base + k] = 0;
      if (startup_failed[t] & 1) push_startup(t << 1);
      if (startup_failed[t] & 2) push_startup(t << 1 | 1);
      startup_failed[t] = 0;
    }
    for (uint32_t i = 0; i < held_count;) {  // held work of this material: released now
      const detail::HeldWork h = held[i];
      const bool mine = h.packet ? h.texture == m : texture_material[h.texture] == m;
      if (!mine) {
        ++i;
        continue;
      }
      if (!h.packet) scheduler.hold_tile(h.texture, h.flat, false);
      held[i] = held[--held_count];
    }
    scheduler.hold_u_packets(m, false);
    if (ms.failed) {
      ms.failed = false;
      --materials_failed_now;
    }
    return Status::success;
  }

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
    // Retry async reads a source refused.
    if (!quiescing)
      for (uint32_t j = 0; j < jobs.size(); ++j)
        if (jobs[j].state.load(std::memory_order_acquire) == detail::kJobReading) start_reads(j);
    // 2. Finished jobs.
    for (uint32_t j = 0; j < jobs.size(); ++j) {
      detail::StreamerJob& job = jobs[j];
      const uint8_t st = job.state.load(std::memory_order_acquire);
      if (st != detail::kJobDone && st != detail::kJobFailed) continue;
      const bool ok = st == detail::kJobDone;
      if (job.kind != detail::kPacketJob) keep_decoded(job, ok);
      if (job.kind == detail::kRootJob) {
        if (ok && out.tile_upload_count < out.tile_uploads.size()) {
          keep_payloads(job);
          out.tile_uploads[out.tile_upload_count++] = StreamerTileUpload{
              cache.slot_of(job.tile), job.tile, std::span<const uint16_t>(job.halves, layout.sample_count())};
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
      if (job.kind == detail::kTileJob) keep_payloads(job);
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
        out.tile_uploads[out.tile_upload_count++] =
            StreamerTileUpload{q.slot, q.tile, std::span<const uint16_t>(job.halves, layout.sample_count())};
      }
      job_of_request[q.id] = kNoJob;
      job.state.store(detail::kJobHanded, std::memory_order_relaxed);
    });
    // 4. Votes and plan (none while quiescing: nothing new starts).
    for (const uint32_t word : feedback) {
      const uint32_t m = unpack_feedback(word).material;
      feedback_ignored += m >= materials.size() || !materials[m].ready || materials[m].failed;
    }
    if (!feedback.empty()) votes.accumulate(feedback, config.vote_weight, scheduler.lod_bias());
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

  // 5. Page-table texels changed by this frame's operations, then the runnable jobs.
  Status finish_update(StreamerOutputs& out) noexcept {
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
  memory.allocations = ledger->count - set_allocations - 1 + 1;  // − the layouts, + the ledger
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
