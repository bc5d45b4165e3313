// btflod — the BSVTF scheduler: add/swap decisions of paper 000 §5.1–5.2, U-column priority of
// §6, budgets, hysteresis and a global LOD bias under overload.
//
// Per frame (plan()):
//  1. Add candidates: every tile with votes v > 0 (eq. 9, from a VoteCounter; a material's votes
//     apply to each of its ⌈C/4⌉ virtual textures) that is not resident, not requested, and whose
//     parent is resident (§5.2 restricts add to that case). Priority P = w(i, l, l−1)·v(i, l).
//  2. Swap candidates: resident leaves (no resident descendants, not the root, not inserted
//     during the last `hysteresis_frames` frames). For two leaves of the same virtual texture,
//     the swap removes both and inserts their deepest common ancestor A at a level below both
//     (already resident: nothing to insert, two slots freed). Cost (eq. 10) per removed tile t:
//       c(l', t) = v(t) · Σ_{k = r+1}^{l_t} w(anc_k(t), k, k−1),  r = max(l', deepest resident ancestor)
//     i.e. the weights of the in-between levels whose detail the swap reveals. (Eq. 10 as printed
//     starts the sum at k = l', which would also charge A's own weight w(A, l', l'−1), a detail
//     that A keeps; we start at l'+1.) Pairs come from the four cheapest leaves of each virtual
//     texture (pairs (1st, 2nd) and (3rd, 4th)), so no O(S²) search.
//  3. Decision (§5.2): take add candidates by descending P; with a free slot, add; otherwise find
//     the three lowest-cost swaps and perform the cheapest valid one only if c* < P*, then add;
//     else stop — the cache already holds the better set.
//  4. §6 (optional, stream_u_columns): the U'-packet of the next virtual texture of a material
//     (four columns U'_c, like the RGBA packing) has priority Σ v(i, l)·‖T_il‖²_F/T² over the
//     resident tiles of that texture; it is requested before an add whose P is lower. Tiles of
//     virtual textures whose U'-packet is not loaded are not added (they could not contribute).
// Requests go out as TileRequest; the pipeline reports begin_decode()/finish_decode(); uploads
// are applied by apply_uploads() within the per-frame upload budget. Every budget refusal and
// every visible-but-missing tile is counted. Everything after create() is allocation-free,
// noexcept and deterministic (ties broken by texture and tile index). Not thread-safe.
//
// The scheduler keeps no pointer to the cache: every call that reads or changes it takes the
// cache as an argument, so both objects can be moved (e.g. as members of a runtime object).
// Every cache operation it performs (swap removals, inserts, the ancestors an insert hides) is
// reported by the cache itself (TileCache::touched_tiles() and deltas()). Byte budgets count
// real payload bytes: the runtime sets each tile's and each U' packet's size from the container
// index (set_tile_bytes, set_u_packet_bytes); tile_bytes / u_packet_bytes are the defaults.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/core/allocator.hpp"
#include "btflod/core/result.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"

namespace btflod {

/// Every budget of the streaming path in one place.
struct SchedulerBudgets {
  uint32_t uploads_per_frame = 32;         ///< tiles written into the cache per frame
  uint32_t tiles_decoding = 16;            ///< tiles being decoded at once
  uint32_t requests_in_flight = 64;        ///< requested, not yet uploaded
  uint64_t bytes_in_flight = 16ull << 20;  ///< bytes of those requests
};

enum class PriorityMode : uint8_t {
  weighted,    ///< paper 000: P = w·v, cost eq. 10
  votes_only,  ///< w ≡ 1: P = v, cost = v · revealed levels (LibVT/Unreal-style)
};

/// Bytes of one U' packet of four components: rows (lights · views · colour channels) × 4
/// halves, as the container stores it (runtime/codec/container.hpp).
constexpr uint64_t u_packet_bytes_for(uint32_t lights, uint32_t views, uint32_t colour_channels = 3) noexcept {
  return static_cast<uint64_t>(lights) * views * colour_channels * 4 * 2;
}

struct SchedulerConfig {
  SchedulerBudgets budgets;
  PriorityMode mode = PriorityMode::weighted;
  uint32_t hysteresis_frames = 1;  ///< a tile inserted at frame f is not swapped out before f + this
  /// Bytes counted per tile request unless set_tile_bytes() gave the tile's real payload size
  /// (72×72 RGBA16F uncompressed; the runtime uses the container's payload sizes instead).
  uint64_t tile_bytes = 41472;
  // Global LOD bias under overload.
  uint32_t overload_missing_tiles = 512;  ///< visible-but-missing tiles above which a frame is overloaded
  uint32_t overload_frames = 4;           ///< consecutive overloaded frames before the bias rises one level
  uint32_t calm_frames = 30;              ///< consecutive calm frames before it falls one level
  uint32_t max_lod_bias = 2;
  // Paper 000 §6.
  bool stream_u_columns = false;  ///< false: every U' packet is loaded from the start
  /// Four U' columns as the container stores them (runtime/codec/container.hpp: u_rows × 4 halves): for
  /// UBO2014, u_rows = 151² direction pairs × RGB, so 151² · 3 · 4 · 2 = 547,224 bytes (the
  /// paper's "534 KB" rounded it). set_u_packet_bytes() replaces it per material.
  uint64_t u_packet_bytes = u_packet_bytes_for(151, 151, 3);
};

/// Counters of one frame (frame()) and since creation (total()).
struct SchedulerCounters {
  uint64_t adds = 0;               ///< add operations issued
  uint64_t swaps = 0;              ///< swap operations performed
  uint64_t ancestors_removed = 0;  ///< post-condition removals of covered ancestors
  uint64_t requests = 0;           ///< tile requests issued
  uint64_t u_requests = 0;         ///< U' packet requests issued
  uint64_t bytes_requested = 0;
  uint64_t uploads = 0;          ///< tiles written into the cache
  uint64_t visible_missing = 0;  ///< (texture, tile) pairs voted for directly but not resident
  uint64_t upload_budget_hits = 0;
  uint64_t decoding_budget_hits = 0;
  uint64_t request_budget_hits = 0;
  uint64_t byte_budget_hits = 0;
  uint64_t swaps_rejected = 0;  ///< best add not taken because c* ≥ P* (or no swap possible)
  uint64_t budget_hits() const noexcept {
    return upload_budget_hits + decoding_budget_hits + request_budget_hits + byte_budget_hits;
  }
  /// Adds another set of counters to this one.
  void accumulate(const SchedulerCounters& f) noexcept {
    adds += f.adds, swaps += f.swaps, ancestors_removed += f.ancestors_removed, requests += f.requests;
    u_requests += f.u_requests, bytes_requested += f.bytes_requested, uploads += f.uploads;
    visible_missing += f.visible_missing, upload_budget_hits += f.upload_budget_hits;
    decoding_budget_hits += f.decoding_budget_hits, request_budget_hits += f.request_budget_hits;
    byte_budget_hits += f.byte_budget_hits, swaps_rejected += f.swaps_rejected;
  }
};

/// One request for the tile source. For a U' packet, tile = {texture, 0, 0, 0} and u_packet.
struct TileRequest {
  uint32_t id = 0;  ///< pass back to begin_decode()/finish_decode()/cancel()
  TileId tile;
  uint64_t bytes = 0;
  bool u_packet = false;
  uint32_t slot = kNoSlot;  ///< cache slot reserved for the tile (kNoSlot for U' packets)
};

class Scheduler {
 public:
  /// An empty scheduler (assign the result of create()).
  Scheduler() = default;

  /// Allocates every per-frame array for the cache's VtSet and slot count and reads the tile
  /// weights w and energies from the set. Keeps no reference to `cache`: pass the same cache
  /// to every later call. Every array is allocated through `allocator` (its callbacks, or
  /// operator new), here and only here; a failing callback aborts (set-up memory is not
  /// optional, core/allocator.hpp). invalid_argument when a budget is zero.
  static Result<Scheduler> create(const TileCache& cache, const SchedulerConfig& config = {},
                                  const RuntimeAllocator& allocator = {}) {
    const SchedulerBudgets& b = config.budgets;
    if (b.uploads_per_frame == 0 || b.tiles_decoding == 0 || b.requests_in_flight == 0 || b.bytes_in_flight == 0)
      return make_error(Status::invalid_argument, "scheduler: every budget must be > 0");
    Scheduler s{CallbackAllocator<char>(allocator)};
    s.config_ = config;
    const VtSet& set = cache.set();
    s.pending_.assign(b.requests_in_flight, Pending{});
    s.free_requests_.reserve(b.requests_in_flight);
    for (uint32_t i = b.requests_in_flight; i-- > 0;) s.free_requests_.push_back(i);
    // Per-tile arrays are tile-major per material (index = entry_base + flat · K + k), like
    // the cache's slot table, so one material tile's K virtual textures share a cache line;
    // sized by the set's entries (its reservation, if any), per material and per texture id.
    s.material_base_.assign(set.material_count(), 0);
    s.material_textures_.assign(set.material_count(), 0);
    s.material_tiles_.assign(set.material_count(), 0);
    s.texture_base_.assign(set.texture_count(), 0);
    s.texture_stride_.assign(set.texture_count(), 1);
    s.texture_material_.assign(set.texture_count(), kNoMaterial);
    s.requested_.assign(set.entry_count(), 0);
    s.set_weights_.assign(set.entry_count(), 1.0f);
    s.weights_.assign(set.entry_count(), 1.0f);
    s.energies_.assign(set.entry_count(), 0.0f);
    s.tile_bytes_.assign(set.entry_count(), static_cast<uint32_t>(std::min<uint64_t>(config.tile_bytes, UINT32_MAX)));
    s.max_weights_.assign(set.entry_count(), 0.0f);  // per material tile: [entry_base + flat]
    s.u_packet_bytes_.assign(set.material_count(), config.u_packet_bytes);
    s.u_loaded_.assign(set.material_count(), 0);
    s.u_requested_.assign(set.material_count(), 0);
    s.u_priority_.assign(set.material_count(), 0.0);
    s.material_enabled_.assign(set.material_count(), 0);
    s.u_held_.assign(set.material_count(), 0);
    s.leaves_.assign(static_cast<size_t>(set.texture_count()) * kLeavesPerTexture, Leaf{});
    s.leaf_count_.assign(set.texture_count(), 0);
    for (uint32_t m = 0; m < set.material_count(); ++m)
      if (set.material_live(m)) s.init_material(set, m);
    s.adds_.reserve(b.requests_in_flight + 2);
    s.leaf_textures_.reserve(set.texture_count());
    s.pairs_.reserve(static_cast<size_t>(set.texture_count()) * 2);
    s.requests_out_.reserve(b.requests_in_flight);
    s.protected_stamp_.assign(cache.slot_count(), 0);
    return s;
  }

  /// What create() allocates for a cache over a set reserved with `capacity` (VtSet::reserve),
  /// with `slots` cache slots, and `config`. No allocation.
  static AllocationTally memory_required(const VtCapacity& capacity, uint64_t slots,
                                         const SchedulerConfig& config = {}) noexcept {
    const uint64_t requests = config.budgets.requests_in_flight, materials = capacity.materials,
                   textures = capacity.textures, entries = capacity.tile_entries;
    AllocationTally t;
    t.array<decltype(pending_)>(requests);
    t.array<decltype(free_requests_)>(requests);
    t.array<decltype(material_base_)>(materials);
    t.array<decltype(material_textures_)>(materials);
    t.array<decltype(material_tiles_)>(materials);
    t.array<decltype(texture_base_)>(textures);
    t.array<decltype(texture_stride_)>(textures);
    t.array<decltype(texture_material_)>(textures);
    t.array<decltype(requested_)>(entries);
    t.array<decltype(set_weights_)>(entries);
    t.array<decltype(weights_)>(entries);
    t.array<decltype(energies_)>(entries);
    t.array<decltype(tile_bytes_)>(entries);
    t.array<decltype(max_weights_)>(entries);
    t.array<decltype(u_packet_bytes_)>(materials);
    t.array<decltype(u_loaded_)>(materials);
    t.array<decltype(u_requested_)>(materials);
    t.array<decltype(u_priority_)>(materials);
    t.array<decltype(material_enabled_)>(materials);
    t.array<decltype(u_held_)>(materials);
    t.array<decltype(leaves_)>(textures * kLeavesPerTexture);
    t.array<decltype(leaf_count_)>(textures);
    t.array<decltype(adds_)>(requests + 2);
    t.array<decltype(leaf_textures_)>(textures);
    t.array<decltype(pairs_)>(textures * 2);
    t.array<decltype(requests_out_)>(requests);
    t.array<decltype(protected_stamp_)>(slots);
    return t;
  }

  /// Sets w(i, l, l−1) of tile `flat` of virtual texture `texture` (paper 000 eq. 8; e.g. from
  /// a container's tile index). In votes_only mode the priority keeps using 1. Out-of-range ids
  /// are ignored. noexcept, no allocation.
  void set_weight(uint32_t texture, uint32_t flat, float w) noexcept {
    if (!texture_live(texture)) return;
    const size_t i = index(texture, flat);
    if (i >= set_weights_.size()) return;
    set_weights_[i] = w;
    weights_[i] = config_.mode == PriorityMode::votes_only ? 1.0f : w;
    update_max_weight(texture_material_[texture], flat);
  }
  /// Sets a tile's w, ‖T‖²_F / T² and request bytes at once without refreshing the material's
  /// add bound (a new material's tiles, in bulk): call refresh_weight_bounds(material) after
  /// the last. Out-of-range ids are ignored. noexcept, no allocation.
  void set_tile_values(uint32_t texture, uint32_t flat, float w, float e, uint32_t bytes) noexcept {
    if (!texture_live(texture)) return;
    const size_t i = index(texture, flat);
    if (i >= set_weights_.size()) return;
    set_weights_[i] = w;
    weights_[i] = config_.mode == PriorityMode::votes_only ? 1.0f : w;
    energies_[i] = e;
    tile_bytes_[i] = bytes;
  }
  /// Recomputes the add bound of every tile of a material (after set_tile_values). noexcept.
  void refresh_weight_bounds(uint32_t material) noexcept {
    if (material >= material_tiles_.size()) return;
    for (uint32_t flat = 0; flat < material_tiles_[material]; ++flat) update_max_weight(material, flat);
  }
  /// Sets ‖T‖²_F / T² of a tile (paper 000 §6's U'-packet priority). Out-of-range ids ignored.
  void set_energy(uint32_t texture, uint32_t flat, float e) noexcept {
    if (!texture_live(texture)) return;
    const size_t i = index(texture, flat);
    if (i < energies_.size()) energies_[i] = e;
  }
  /// Sets the bytes a request for this tile counts against bytes_in_flight (its real payload
  /// size). Out-of-range ids are ignored. noexcept.
  void set_tile_bytes(uint32_t texture, uint32_t flat, uint32_t bytes) noexcept {
    if (!texture_live(texture)) return;
    const size_t i = index(texture, flat);
    if (i < tile_bytes_.size()) tile_bytes_[i] = bytes;
  }
  /// Sets the bytes a U' packet request of material m counts (its real packet size).
  void set_u_packet_bytes(uint32_t material, uint64_t bytes) noexcept {
    if (material < u_packet_bytes_.size()) u_packet_bytes_[material] = bytes;
  }
  /// Holds a tile back (held = true: never added or inserted as a swap ancestor) or lets it be
  /// requested again (false), e.g. while a failed read backs off or after it was given up. A
  /// tile with a request in flight is not changed (cancel() the request first). Out-of-range
  /// ids are ignored. noexcept, no allocation.
  void hold_tile(uint32_t texture, uint32_t flat, bool held) noexcept {
    if (!texture_live(texture)) return;
    const size_t i = index(texture, flat);
    if (i >= requested_.size() || requested_[i] == kRequested) return;
    requested_[i] = held ? kHeld : 0;
  }
  /// True when the tile is held back (hold_tile). Out-of-range ids: false.
  bool tile_held(uint32_t texture, uint32_t flat) const noexcept {
    if (!texture_live(texture)) return false;
    const size_t i = index(texture, flat);
    return i < requested_.size() && requested_[i] == kHeld;
  }
  /// Enables (default) or disables scheduling for a material: a disabled material gets no
  /// add and no U′ packet request (its resident tiles stay and may still be swapped out).
  /// Out-of-range ids are ignored.
  void set_material_enabled(uint32_t material, bool enabled) noexcept {
    if (material < material_enabled_.size()) material_enabled_[material] = enabled ? 1 : 0;
  }
  /// True when the material may be scheduled (set_material_enabled). Out of range: false.
  bool material_enabled(uint32_t material) const noexcept {
    return material < material_enabled_.size() && material_enabled_[material] != 0;
  }
  /// Holds back (or releases) the §6 U′ packet requests of a material. Out of range: ignored.
  void hold_u_packets(uint32_t material, bool held) noexcept {
    if (material < u_held_.size()) u_held_[material] = held ? 1 : 0;
  }

  /// Adds a material to the cache (TileCache::add_material, which needs a VtSet reservation)
  /// and to the scheduler: its tiles start with weight 1, energy 0 and config().tile_bytes
  /// (set_weight / set_energy / set_tile_bytes give the real values), scheduling enabled.
  /// Writes the material id. `pool`: the cache pool its tiles live in. Errors as
  /// TileCache::add_material. noexcept, no allocation.
  Status add_material(TileCache& cache, const VtGeometry& geometry, uint32_t texture_count, uint32_t& material,
                      uint32_t pool = 0) noexcept {
    const Status st = cache.add_material(geometry, texture_count, material, pool);
    if (st == Status::success) init_material(cache.set(), material);
    return st;
  }
  /// Removes a material: cancels its requests in flight (their reserved slots are freed), then
  /// removes it from the cache (TileCache::remove_material: its slots are freed, its ids become
  /// free). Other materials' requests and tiles are not touched. invalid_argument for a
  /// material that is not live. noexcept, no allocation.
  Status remove_material(TileCache& cache, uint32_t material) noexcept {
    const VtSet& set = cache.set();
    if (!set.material_live(material)) return Status::invalid_argument;
    for (uint32_t id = 0; id < pending_.size(); ++id)
      if (pending_[id].state != State::idle && set.material_of(pending_[id].tile.texture) == material)
        cancel(cache, id);
    const VtMaterial vm = set.material(material);
    for (uint32_t k = 0; k < vm.texture_count; ++k) {
      texture_material_[vm.first_texture + k] = kNoMaterial;
      leaf_count_[vm.first_texture + k] = 0;
    }
    material_enabled_[material] = 0;
    u_loaded_[material] = u_requested_[material] = u_held_[material] = 0;
    u_priority_[material] = 0.0;
    return cache.remove_material(material);
  }

  /// Bytes a request for the tile counts (set_tile_bytes or config().tile_bytes).
  /// Precondition: texture and flat index in range.
  uint32_t tile_bytes(uint32_t texture, uint32_t flat) const noexcept { return tile_bytes_[index(texture, flat)]; }

  /// The configuration given to create().
  const SchedulerConfig& config() const noexcept { return config_; }
  /// Counters of the current frame (since the last plan(), including its uploads).
  const SchedulerCounters& frame() const noexcept { return frame_counters_; }
  /// Counters since create().
  const SchedulerCounters& total() const noexcept { return total_counters_; }
  /// Levels by which the feedback requests should be coarsened (VoteCounter level_drop or the
  /// LOD selector's bias). Rises under sustained overload, falls when calm.
  uint32_t lod_bias() const noexcept { return lod_bias_; }
  /// U' packets (virtual textures) of a material that are loaded.
  uint32_t u_loaded(uint32_t material) const noexcept { return u_loaded_[material]; }
  /// Last computed §6 priority of the material's next U' packet.
  double u_priority(uint32_t material) const noexcept { return u_priority_[material]; }
  /// Requests issued and not yet uploaded or cancelled.
  uint32_t requests_in_flight() const noexcept { return in_flight_; }
  /// Bytes of those requests.
  uint64_t bytes_in_flight() const noexcept { return bytes_in_flight_; }

  /// Plans frame `frame` from this frame's votes: issues add/swap operations (swaps remove
  /// their two tiles at once; inserts wait for data) and returns the new requests (valid until
  /// the next plan()). Also updates the LOD bias. noexcept, no allocation, deterministic.
  /// Precondition: votes were built for the same materials as the cache's VtSet.
  std::span<const TileRequest> plan(TileCache& cache, const VoteCounter& votes, uint64_t frame) noexcept {
    frame_ = frame;
    frame_counters_ = SchedulerCounters{};
    requests_out_.clear();
    collect_adds(cache, votes);
    // The swap candidates are needed only once the cache is full and an add wants a slot
    // (decide_adds collects them then: nothing it does before the first swap changes a used
    // slot); §6's packet priorities come from collect_adds' pass over the voted tiles.
    leaves_ready_ = 0;
    pairs_sorted_ = 0;
    decide(cache, votes);
    update_bias();
    total_counters_.accumulate(frame_counters_);
    return requests_out_;
  }

  /// The data of request `id` arrived and may be decoded. Returns false (and counts a decoding
  /// budget hit) when tiles_decoding are already being decoded; call again later.
  bool begin_decode(uint32_t id) noexcept {
    if (id >= pending_.size() || pending_[id].state != State::requested) return false;
    if (decoding_ >= config_.budgets.tiles_decoding) {
      ++frame_counters_.decoding_budget_hits;
      ++total_counters_.decoding_budget_hits;
      return false;
    }
    pending_[id].state = State::decoding;
    ++decoding_;
    return true;
  }
  /// Request `id` is decoded and ready for upload.
  void finish_decode(uint32_t id) noexcept {
    if (id >= pending_.size() || pending_[id].state != State::decoding) return;
    pending_[id].state = State::ready;
    --decoding_;
  }
  /// Drops a request (e.g. the source failed); its reserved slot is freed in `cache`.
  void cancel(TileCache& cache, uint32_t id) noexcept {
    if (id >= pending_.size() || pending_[id].state == State::idle) return;
    Pending& p = pending_[id];
    if (p.state == State::decoding) --decoding_;
    if (p.u_packet)
      u_requested_[cache.set().material_of(p.tile.texture)] = 0;
    else {
      cache.release_slot(p.slot);
      requested_[index(p.tile.texture, cache.set().levels_of(p.tile.texture).index(p.tile))] = 0;
    }
    retire(id);
  }

  /// Writes ready requests into the cache in request order, at most uploads_per_frame (counts
  /// a budget hit when more were ready). Calls upload(request) for each tile before it becomes
  /// visible, so the backend can copy its texels into the slot. The inserts and the ancestors
  /// they hide (removed) show in cache.touched_tiles(). Returns tiles uploaded.
  template <class UploadFn>
  uint32_t apply_uploads(TileCache& cache, UploadFn&& upload) noexcept {
    uint32_t done = 0;
    for (;;) {
      const uint32_t next = oldest_ready();  // oldest request first
      if (next == kNoRequest) break;
      if (done == config_.budgets.uploads_per_frame) {
        ++frame_counters_.upload_budget_hits;
        ++total_counters_.upload_budget_hits;
        break;
      }
      Pending& p = pending_[next];
      TileRequest r{next, p.tile, p.bytes, p.u_packet, p.slot};
      if (p.u_packet) {
        const uint32_t m = cache.set().material_of(p.tile.texture);
        u_loaded_[m] = std::max(u_loaded_[m], p.tile.texture - cache.set().material(m).first_texture + 1);
        u_requested_[m] = 0;
        upload(r);
      } else {
        upload(r);
        requested_[index(p.tile.texture, cache.set().levels_of(p.tile.texture).index(p.tile))] = 0;
        if (cache.insert(p.tile, p.slot, frame_) == Status::success) {
          const uint32_t removed = cache.remove_hidden_ancestors(p.tile);  // add post-condition
          frame_counters_.ancestors_removed += removed;
          total_counters_.ancestors_removed += removed;
        } else {
          cache.release_slot(p.slot);
        }
      }
      ++frame_counters_.uploads;
      ++total_counters_.uploads;
      ++done;
      retire(next);
    }
    return done;
  }
  /// apply_uploads() without a backend callback (bookkeeping only, e.g. tests).
  uint32_t apply_uploads(TileCache& cache) noexcept {
    return apply_uploads(cache, [](const TileRequest&) {});
  }

  /// Convenience for an immediate tile source (memory, tests, replay): plan, decode every
  /// request within the decoding budget, apply uploads. Returns the frame's counters.
  const SchedulerCounters& run_frame(TileCache& cache, const VoteCounter& votes, uint64_t frame) noexcept {
    plan(cache, votes, frame);
    for (uint32_t id = 0; id < pending_.size(); ++id)
      if (pending_[id].state == State::requested && begin_decode(id)) finish_decode(id);
    apply_uploads(cache);
    return frame_counters_;
  }

 private:
  template <class T>
  using Vec = std::vector<T, CallbackAllocator<T>>;  // every array through the creator's callbacks

  explicit Scheduler(const CallbackAllocator<char>& a)
      : pending_(a),
        free_requests_(a),
        material_base_(a),
        material_textures_(a),
        material_tiles_(a),
        requested_(a),
        texture_base_(a),
        texture_stride_(a),
        set_weights_(a),
        weights_(a),
        energies_(a),
        tile_bytes_(a),
        u_packet_bytes_(a),
        u_loaded_(a),
        u_requested_(a),
        u_priority_(a),
        material_enabled_(a),
        u_held_(a),
        adds_(a),
        leaves_(a),
        leaf_count_(a),
        leaf_textures_(a),
        pairs_(a),
        requests_out_(a),
        protected_stamp_(a),
        texture_material_(a),
        max_weights_(a) {}

  static constexpr uint32_t kLeavesPerTexture = 4;
  static constexpr uint8_t kRequested = 1;  // requested_: a request is in flight
  static constexpr uint8_t kHeld = 2;       // requested_: held back (hold_tile)
  static constexpr uint32_t kNoRequest = 0xffffffffu;
  enum class State : uint8_t { idle, requested, decoding, ready };
  struct Pending {
    TileId tile;
    uint32_t slot = kNoSlot;
    uint64_t bytes = 0;
    uint64_t sequence = 0;
    State state = State::idle;
    bool u_packet = false;
  };
  struct AddCandidate {
    double priority = 0;
    uint32_t texture = 0;
    uint32_t flat = 0;
  };
  struct Leaf {
    double cost = 0;  // to its deepest resident ancestor
    uint32_t flat = 0;
    uint32_t slot = 0;
  };
  struct Pair {
    double cost = 0;
    uint32_t texture = 0;
    uint32_t a = 0, b = 0;  // leaf positions within the texture's leaf list
  };

  size_t index(uint32_t texture, uint32_t flat) const noexcept {
    return texture_base_[texture] + static_cast<size_t>(flat) * texture_stride_[texture];
  }
  bool texture_live(uint32_t texture) const noexcept {
    return texture < texture_material_.size() && texture_material_[texture] != kNoMaterial;
  }
  // A live material's per-tile, per-material and per-texture entries (at create or add).
  void init_material(const VtSet& set, uint32_t m) noexcept {
    const VtMaterial& vm = set.material(m);
    const uint32_t K = vm.texture_count, tiles = vm.levels.tile_count();
    material_base_[m] = vm.entry_base;
    material_textures_[m] = K;
    material_tiles_[m] = tiles;
    for (uint32_t k = 0; k < K; ++k) {
      const uint32_t t = vm.first_texture + k;
      texture_base_[t] = vm.entry_base + k;
      texture_stride_[t] = K;
      texture_material_[t] = m;
      leaf_count_[t] = 0;
      const std::span<const Half> w = set.weights(t);
      const std::span<const Half> e = set.energies(t);
      for (uint32_t i = 0; i < tiles; ++i) {
        const size_t x = index(t, i);
        requested_[x] = 0;
        set_weights_[x] = w[i].to_float();
        weights_[x] = config_.mode == PriorityMode::votes_only ? 1.0f : set_weights_[x];
        energies_[x] = e[i].to_float();
        tile_bytes_[x] = static_cast<uint32_t>(std::min<uint64_t>(config_.tile_bytes, UINT32_MAX));
      }
    }
    for (uint32_t flat = 0; flat < tiles; ++flat) update_max_weight(m, flat);
    u_packet_bytes_[m] = config_.u_packet_bytes;
    u_loaded_[m] = config_.stream_u_columns ? 0 : K;
    u_requested_[m] = 0;
    u_priority_[m] = 0.0;
    material_enabled_[m] = 1;
    u_held_[m] = 0;
  }
  // The bound collect_adds() uses: no add candidate of this material tile has a priority above
  // max_weights_ · v (NaN weights are left out: their candidates are never kept once the list
  // is full either).
  void update_max_weight(uint32_t material, uint32_t flat) noexcept {
    const uint32_t K = material_textures_[material];
    const float* w = weights_.data() + material_base_[material] + static_cast<size_t>(flat) * K;
    float mx = 0.0f;
    for (uint32_t k = 0; k < K; ++k) mx = std::max(mx, w[k]);
    max_weights_[material_base_[material] + flat] = mx;
  }
  float weight(uint32_t texture, uint32_t flat) const noexcept { return weights_[index(texture, flat)]; }

  static bool add_before(const AddCandidate& a, const AddCandidate& b) noexcept {
    if (a.priority != b.priority) return a.priority > b.priority;
    if (a.texture != b.texture) return a.texture < b.texture;
    return a.flat < b.flat;
  }

  // The add candidates of this frame's voted tiles and, in the same pass, §6's U' packet
  // priorities: a material's next packet has priority Σ v·‖T‖²_F over the resident tiles of the
  // virtual texture it completes; tiles without votes add 0, so the voted tiles (every tile with
  // v > 0) give the whole sum.
  void collect_adds(const TileCache& cache, const VoteCounter& votes) noexcept {
    adds_.clear();
    if (config_.stream_u_columns) std::fill(u_priority_.begin(), u_priority_.end(), 0.0);
    const VtSet& set = cache.set();
    // One more than can be requested, so a refusal by the request budget is seen and counted.
    const size_t keep = config_.budgets.requests_in_flight + 1;
    for (const uint32_t word : votes.touched()) {
      const FeedbackTile ft = unpack_feedback(word);
      if (ft.material >= set.material_count()) continue;
      const VtMaterial& m = set.material(ft.material);
      if (ft.level > m.levels.finest_level()) continue;
      const uint32_t flat = m.levels.index(ft.level, ft.x, ft.y);
      const uint32_t v = votes.votes_at(ft.material, flat);
      const uint32_t direct = votes.direct_votes_at(ft.material, flat);
      const uint32_t parent_flat = ft.level > 0 ? m.levels.index(ft.level - 1, ft.x >> 1, ft.y >> 1) : 0;
      const uint32_t usable = material_enabled_[ft.material] ? std::min(u_loaded_[ft.material], m.texture_count) : 0;
      const uint32_t* slots = cache.material_slots(ft.material, flat);
      const uint32_t* parent_slots = cache.material_slots(ft.material, parent_flat);
      const size_t base = material_base_[ft.material] + static_cast<size_t>(flat) * m.texture_count;
      if (config_.stream_u_columns) {
        const uint32_t next = u_loaded_[ft.material];
        if (next < m.texture_count && slots[next] != kNoSlot)
          u_priority_[ft.material] += static_cast<double>(v) * energies_[base + next];
      }
      const uint8_t* requested = requested_.data() + base;
      const float* weights = weights_.data() + base;
      // Branch-light: the tests below combine with | and & (no short circuit), so the loop
      // branches only for tiles that can be added (same decisions as the plain if-chain).
      const bool voted = direct > 0, has_parent = ft.level > 0;
      // Once the list is full, a tile whose best possible priority is below its last entry adds
      // nothing (add_before() is false for every candidate): only its missing count matters.
      if (adds_.size() == keep &&
          static_cast<double>(max_weights_[material_base_[ft.material] + flat]) * v < adds_.back().priority) {
        if (voted) {
          uint32_t missing = 0;
          for (uint32_t k = 0; k < usable; ++k) missing += static_cast<uint32_t>(slots[k] == kNoSlot);
          frame_counters_.visible_missing += missing;
        }
        continue;
      }
      uint32_t missing_count = 0;  // a local: requested (bytes) may alias the counters
      for (uint32_t k = 0; k < usable; ++k) {
        const bool missing = slots[k] == kNoSlot;
        missing_count += static_cast<uint32_t>(missing);
        if (!(missing & has_parent & (requested[k] == 0) & (parent_slots[k] != kNoSlot))) continue;
        const AddCandidate c{static_cast<double>(weights[k]) * v, m.first_texture + k, flat};  // paper 000 §5.2
        if (c.priority <= 0.0) continue;
        if (adds_.size() == keep && !add_before(c, adds_.back())) continue;
        // Insert into the descending list (at most `keep` entries; capacity reserved).
        auto it = std::upper_bound(adds_.begin(), adds_.end(), c, add_before);
        if (adds_.size() == keep) adds_.pop_back();
        adds_.insert(it, c);
      }
      if (voted) frame_counters_.visible_missing += missing_count;
    }
  }

  // One pass over the slots: per-texture cheapest leaves (the swap candidates of §5.2).
  void collect_leaves(const TileCache& cache, const VoteCounter& votes) noexcept {
    const VtSet& set = cache.set();
    for (uint32_t t : leaf_textures_) leaf_count_[t] = 0;
    leaf_textures_.clear();
    pairs_.clear();
    pairs_sorted_ = 0;
    leaves_ready_ = 1;
    for (uint32_t s = 0; s < cache.slot_count(); ++s) {
      const SlotInfo& si = cache.slot(s);
      if (si.state != SlotInfo::State::used) continue;
      const uint32_t tex = si.tile.texture;
      const uint32_t mat = set.material_of(tex);
      const uint32_t v = votes.votes_at(mat, si.flat_index);
      if (si.tile.level == 0 || cache.resident_below_at(tex, si.flat_index) != 0) continue;
      if (si.added_frame + config_.hysteresis_frames > frame_) continue;  // hysteresis
      const VtLevelTable& lv = set.levels_of(tex);
      // Cost of revealing the deepest resident ancestor (eq. 10 with l' = that ancestor); 0
      // without votes, whatever the weights.
      double wsum = 0;
      if (v != 0)
        for (TileId a = si.tile; a.level > 0;) {
          wsum += weight(tex, lv.index(a));
          a = a.parent();
          if (cache.slot_at(tex, lv.index(a)) != kNoSlot) break;
        }
      const Leaf leaf{wsum * v, si.flat_index, s};
      uint32_t& n = leaf_count_[tex];
      if (n == 0) leaf_textures_.push_back(tex);
      Leaf* list = &leaves_[static_cast<size_t>(tex) * kLeavesPerTexture];
      // Keep the kLeavesPerTexture cheapest, ascending by (cost, flat index).
      uint32_t pos = n;
      while (pos > 0 &&
             (leaf.cost < list[pos - 1].cost || (leaf.cost == list[pos - 1].cost && leaf.flat < list[pos - 1].flat)))
        --pos;
      if (pos >= kLeavesPerTexture) continue;
      for (uint32_t i = std::min(n, kLeavesPerTexture - 1); i > pos; --i) list[i] = list[i - 1];
      list[pos] = leaf;
      if (n < kLeavesPerTexture) ++n;
    }
  }

  // Eq. 10 for one removed tile when A (level la) is the inserted/resident ancestor.
  double removal_cost(const TileCache& cache, uint32_t tex, const TileId& t, uint32_t la, uint32_t v) const noexcept {
    const VtLevelTable& lv = cache.set().levels_of(tex);
    double wsum = 0;
    for (TileId a = t; a.level > la;) {
      wsum += weight(tex, lv.index(a));
      a = a.parent();
      if (cache.slot_at(tex, lv.index(a)) != kNoSlot) break;
    }
    return wsum * v;
  }

  void build_pairs(const TileCache& cache, const VoteCounter& votes) noexcept {
    const VtSet& set = cache.set();
    for (uint32_t tex : leaf_textures_) {
      const uint32_t n = leaf_count_[tex];
      const Leaf* list = &leaves_[static_cast<size_t>(tex) * kLeavesPerTexture];
      const VtLevelTable& lv = set.levels_of(tex);
      const uint32_t mat = set.material_of(tex);
      for (uint32_t i = 0; i + 1 < n; i += 2) {
        const TileId a = lv.tile(tex, list[i].flat), b = lv.tile(tex, list[i + 1].flat);
        const TileId anc = TileCache::common_ancestor(a, b);
        const double cost = removal_cost(cache, tex, a, anc.level, votes.votes_at(mat, list[i].flat)) +
                            removal_cost(cache, tex, b, anc.level, votes.votes_at(mat, list[i + 1].flat));
        pairs_.push_back(Pair{cost, tex, i, i + 1});
      }
    }
    const auto less = [](const Pair& x, const Pair& y) {
      if (x.cost != y.cost) return x.cost < y.cost;
      if (x.texture != y.texture) return x.texture < y.texture;
      return x.a < y.a;
    };
    // Enough of the cheapest pairs for every swap a frame can issue, per pool (each pool's adds
    // swap among its own tiles).
    const size_t k =
        std::min<size_t>(pairs_.size(), (2u * size_t{config_.budgets.requests_in_flight} + 3) * cache.pool_count());
    std::partial_sort(pairs_.begin(), pairs_.begin() + static_cast<ptrdiff_t>(k), pairs_.end(), less);
    pairs_.resize(k);
    pairs_sorted_ = 1;
    next_pair_ = 0;
  }

  bool pair_valid(const TileCache& cache, const Pair& p) const noexcept {
    const Leaf* list = &leaves_[static_cast<size_t>(p.texture) * kLeavesPerTexture];
    for (const uint32_t i : {p.a, p.b}) {
      const uint32_t s = list[i].slot;
      const SlotInfo& si = cache.slot(s);
      if (si.state != SlotInfo::State::used || si.tile.texture != p.texture || si.flat_index != list[i].flat)
        return false;
      if (protected_stamp_[s] == frame_ + 1) return false;  // parent of an add issued this frame
      if (cache.resident_below_at(p.texture, list[i].flat) != 0) return false;
    }
    return true;
  }

  bool can_request(uint64_t bytes, uint32_t count) noexcept {
    if (in_flight_ + count > config_.budgets.requests_in_flight || free_requests_.size() < count) {
      ++frame_counters_.request_budget_hits;
      return false;
    }
    if (bytes_in_flight_ + bytes > config_.budgets.bytes_in_flight) {
      ++frame_counters_.byte_budget_hits;
      return false;
    }
    return true;
  }

  void issue(const TileCache& cache, const TileId& tile, uint32_t slot, uint64_t bytes, bool u_packet) noexcept {
    const uint32_t id = free_requests_.back();
    free_requests_.pop_back();
    pending_[id] = Pending{tile, slot, bytes, sequence_++, State::requested, u_packet};
    ++in_flight_;
    bytes_in_flight_ += bytes;
    requests_out_.push_back(TileRequest{id, tile, bytes, u_packet, slot});
    ++frame_counters_.requests;
    frame_counters_.bytes_requested += bytes;
    if (u_packet) {
      ++frame_counters_.u_requests;
    } else {
      requested_[index(tile.texture, cache.set().levels_of(tile.texture).index(tile))] = kRequested;
    }
  }

  void retire(uint32_t id) noexcept {
    --in_flight_;
    bytes_in_flight_ -= pending_[id].bytes;
    pending_[id] = Pending{};
    free_requests_.push_back(id);
  }

  uint32_t oldest_ready() const noexcept {
    uint32_t best = kNoRequest;
    for (uint32_t i = 0; i < pending_.size(); ++i)
      if (pending_[i].state == State::ready && (best == kNoRequest || pending_[i].sequence < pending_[best].sequence))
        best = i;
    return best;
  }

  // §6: request the next U' packet of the material with the highest priority above `p`.
  bool maybe_request_u(const TileCache& cache, double p) noexcept {
    if (!config_.stream_u_columns) return true;
    const VtSet& set = cache.set();
    for (;;) {
      uint32_t best = kNoRequest;
      for (uint32_t m = 0; m < set.material_count(); ++m) {
        if (u_requested_[m] || !material_enabled_[m] || u_held_[m] || u_loaded_[m] >= set.material(m).texture_count ||
            u_priority_[m] <= p)
          continue;
        if (best == kNoRequest || u_priority_[m] > u_priority_[best]) best = m;
      }
      if (best == kNoRequest) return true;
      if (!can_request(u_packet_bytes_[best], 1)) return false;
      const TileId packet{set.material(best).first_texture + u_loaded_[best], 0, 0, 0};
      issue(cache, packet, kNoSlot, u_packet_bytes_[best], true);
      u_requested_[best] = 1;
    }
  }

  void decide(TileCache& cache, const VoteCounter& votes) noexcept {
    // U' packets need no cache slot: once the adds are decided, any packet with priority > 0
    // that fits the budgets is requested too.
    if (decide_adds(cache, votes)) maybe_request_u(cache, 0.0);
  }

  // Returns false when a request budget stopped the frame.
  bool decide_adds(TileCache& cache, const VoteCounter& votes) noexcept {
    const VtSet& set = cache.set();
    for (const AddCandidate& c : adds_) {
      if (!maybe_request_u(cache, c.priority)) return false;
      const TileId tile = set.levels_of(c.texture).tile(c.texture, c.flat);
      // A swap earlier this frame may have removed the parent or requested this very tile.
      if (requested_[index(c.texture, c.flat)] || !cache.resident(tile.parent())) continue;
      if (!can_request(tile_bytes_[index(c.texture, c.flat)], 1)) return false;
      // The tile goes to its material's pool: a full pool frees room by a swap among its own
      // tiles (other pools' slots cannot hold it).
      const uint32_t pool = cache.texture_pool(c.texture);
      if (cache.free_count(pool) == 0) {
        // §5.2: among the three lowest-cost swaps, the cheapest still valid; only if c* < P*.
        if (!leaves_ready_) collect_leaves(cache, votes);
        if (!pairs_sorted_) build_pairs(cache, votes);
        while (next_pair_ < pairs_.size() && !pair_valid(cache, pairs_[next_pair_])) ++next_pair_;
        // The cheapest valid pair of this pool (a pair used by a swap is invalid afterwards:
        // its leaves left the cache; other pools' pairs stay for their adds).
        size_t pick = next_pair_;
        if (cache.pool_count() > 1)
          while (pick < pairs_.size() &&
                 (cache.texture_pool(pairs_[pick].texture) != pool || !pair_valid(cache, pairs_[pick])))
            ++pick;
        if (pick == pairs_.size() || !(pairs_[pick].cost < c.priority)) {
          ++frame_counters_.swaps_rejected;
          if (cache.pool_count() > 1) continue;  // another pool's add may still find room
          return true;                           // candidates are sorted: no later add is worth a swap either
        }
        const Pair p = pairs_[pick];
        if (pick == next_pair_) ++next_pair_;
        const Leaf* list = &leaves_[static_cast<size_t>(p.texture) * kLeavesPerTexture];
        const VtLevelTable& lv = set.levels_of(p.texture);
        const TileId a = lv.tile(p.texture, list[p.a].flat), b = lv.tile(p.texture, list[p.b].flat);
        const TileId anc = TileCache::common_ancestor(a, b);
        const bool insert_anc = !cache.resident(anc) && !requested_[index(p.texture, lv.index(anc))];
        if (insert_anc &&
            !can_request(uint64_t{tile_bytes_[index(c.texture, c.flat)]} + tile_bytes_[index(p.texture, lv.index(anc))],
                         2))
          return false;
        TileId ancestor;
        if (cache.swap_remove(a, b, ancestor) != Status::success) continue;
        ++frame_counters_.swaps;
        if (insert_anc)
          issue(cache, anc, cache.reserve_slot(pool), tile_bytes_[index(p.texture, lv.index(anc))], false);
      }
      const uint32_t slot = cache.reserve_slot(pool);
      if (slot == kNoSlot) {
        if (cache.pool_count() > 1) continue;
        return true;
      }
      // The parent must survive this frame's swaps (add needs it, §5.2).
      const uint32_t parent_slot = cache.slot_of(tile.parent());
      if (parent_slot != kNoSlot) protected_stamp_[parent_slot] = frame_ + 1;
      issue(cache, tile, slot, tile_bytes_[index(c.texture, c.flat)], false);
      ++frame_counters_.adds;
    }
    return true;
  }

  void update_bias() noexcept {
    const bool overloaded =
        frame_counters_.budget_hits() > 0 || frame_counters_.visible_missing > config_.overload_missing_tiles;
    if (overloaded) {
      calm_streak_ = 0;
      if (++overload_streak_ >= config_.overload_frames) {
        overload_streak_ = 0;
        if (lod_bias_ < config_.max_lod_bias) ++lod_bias_;
      }
    } else {
      overload_streak_ = 0;
      if (++calm_streak_ >= config_.calm_frames) {
        calm_streak_ = 0;
        if (lod_bias_ > 0) --lod_bias_;
      }
    }
  }

  SchedulerConfig config_;
  uint64_t frame_ = 0;
  uint64_t sequence_ = 0;
  SchedulerCounters frame_counters_;
  SchedulerCounters total_counters_;
  Vec<Pending> pending_;
  Vec<uint32_t> free_requests_;
  Vec<uint32_t> material_base_;      // per material: its entry_base in the tile-major arrays below
  Vec<uint32_t> material_textures_;  // per material: K (0 for a free id)
  Vec<uint32_t> material_tiles_;     // per material: tiles per virtual texture
  Vec<uint8_t> requested_;           // per tile: 0, kRequested (a request is pending) or kHeld
  Vec<uint32_t> texture_base_;       // per texture: index of its flat tile 0
  Vec<uint32_t> texture_stride_;     // per texture: virtual textures of its material
  Vec<float> set_weights_;           // w(i, l, l−1) as given
  Vec<float> weights_;               // w as used (1 in votes_only mode)
  Vec<float> energies_;              // ‖T‖²_F / T² (§6)
  Vec<uint32_t> tile_bytes_;         // bytes a request counts
  Vec<uint64_t> u_packet_bytes_;     // per material
  Vec<uint32_t> u_loaded_;
  Vec<uint8_t> u_requested_;
  Vec<double> u_priority_;
  Vec<uint8_t> material_enabled_;  // per material: may be scheduled
  Vec<uint8_t> u_held_;            // per material: §6 packet requests held back
  Vec<AddCandidate> adds_;
  Vec<Leaf> leaves_;
  Vec<uint32_t> leaf_count_;
  Vec<uint32_t> leaf_textures_;
  Vec<Pair> pairs_;
  Vec<TileRequest> requests_out_;
  Vec<uint64_t> protected_stamp_;
  Vec<uint32_t> texture_material_;  // per texture: its material (kNoMaterial: free)
  Vec<float> max_weights_;          // per material tile [entry_base + flat]: max(0, max over its textures of w as used)
  size_t next_pair_ = 0;
  uint32_t pairs_sorted_ = 0;
  uint32_t leaves_ready_ = 0;  // collect_leaves() ran this frame
  uint32_t in_flight_ = 0;
  uint64_t bytes_in_flight_ = 0;
  uint32_t decoding_ = 0;
  uint32_t lod_bias_ = 0;
  uint32_t overload_streak_ = 0;
  uint32_t calm_streak_ = 0;
};

}  // namespace btflod
