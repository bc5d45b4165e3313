// btflod web client — the runtime half of the browser viewer, compiled to WebAssembly with
// emscripten: container directories (codec/container.hpp), payload verification (CRC-32), the
// tile decoder (codec/tile_codec.hpp: zstd tiles — tile format 3, the default coder — through
// zstd's decompressor, deflate tiles — format 2 — through zlib or libdeflate; all three built
// from Debian's sources), feedback
// votes (lod/feedback.hpp), the tile cache and page tables (vt/tile_cache.hpp,
// backend/page_table_writes.hpp), the scheduler with U' packet streaming (vt/scheduler.hpp,
// paper 000 §5–6) and the GLSL ES 3.00 programs (shader/glsl_generator.hpp).
//
// JavaScript (www/btflod_client.js) owns I/O and the GPU: it fetches byte ranges with `Range:`,
// hands verified-or-not bytes to bw_deliver(), uploads what bw_apply_uploads() reports and
// draws with WebGL 2. The C interface below passes plain integers and pointers into the wasm
// heap; every function returns a status (0 = success) or a count, and bw_last_error() holds the
// message of the last failure. Untrusted bytes (directories, payloads) are checked by the
// library's readers: a corrupt payload is refused before it is decoded, never uploaded.
// Single-threaded (the browser's main thread); nothing allocates per frame after bw_start().
// This is the program's one implementation translation unit (btflod.hpp: the non-inline code of
// the headers it includes — CRC-32, inflate back ends, half conversion, dispatch — is compiled
// here). Only runtime headers are included, so no Eigen or offline code enters the module.
#define BTFLOD_IMPLEMENTATION 1
#include <emscripten/emscripten.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "btflod/backend/page_table_writes.hpp"
#include "btflod/codec/container.hpp"
#include "btflod/codec/tile_codec.hpp"
#include "btflod/core/half.hpp"
#include "btflod/lod/feedback.hpp"
#include "btflod/shader/glsl_generator.hpp"
#include "btflod/vt/scheduler.hpp"
#include "btflod/vt/tile_cache.hpp"
#include "btflod/vt/vt_layout.hpp"
#include "web_material.hpp"

namespace btflod::web {

/// Return codes of the C interface (JavaScript mirrors them in btflod_client.js).
enum Code : int {
  kOk = 0,
  kBadArgument = 1,   ///< unknown id, call out of order
  kCorrupt = 2,       ///< payload failed its size/CRC check: fetch again
  kDecodeFailed = 3,  ///< verified payload that does not decode (or its parent is missing)
  kBusy = 4,          ///< decoding budget full: deliver again later
  kFailed = 5,        ///< set-up failure, see bw_last_error()
};

struct ClientMaterial {
  BsvtfDirectory dir;
  AngularTextures angular;
  std::vector<float> u_rgba;  ///< eigen_abrdfs texture: lights × views × C layers, RGBA32F
  std::vector<float> u;       ///< U row-major (row · C + c), for the CPU side
  uint32_t set_index = 0;
  uint32_t packets_loaded = 0;  ///< U' packets delivered (in order)
  /// Per (flat tile · K + local texture): arena slot of the decoded tile, or kNotDecoded.
  std::vector<uint32_t> decoded_slot;
  /// Per (flat tile · K + local texture): the verified payload (compressed, ~1/10 of the decoded
  /// size), kept to decode the tile again when a child needs it after the arena evicted it.
  std::vector<std::vector<uint8_t>> payloads;
  std::vector<uint8_t> delivered;  ///< per (local texture, flat tile): delivered at least once
  double weight_total = 0, weight_delivered = 0;
};

/// One entry of the request list JavaScript reads (all uint32 for a flat Uint32Array view).
struct RequestInfo {
  uint32_t id;  ///< scheduler request id, or kRootBase + root index
  uint32_t material;
  uint32_t kind;            ///< 0 tile, 1 U' packet
  uint32_t key_lo, key_hi;  ///< local tile key (kind 0) or packet index (kind 1)
  uint32_t offset_lo, offset_hi;
  uint32_t size;
};

/// One upload JavaScript performs after bw_apply_uploads().
struct UploadInfo {
  uint32_t kind;  ///< 0 tile into `slot`, 1 U' packet (re-upload layers of `material`)
  uint32_t slot;
  uint32_t material;
  uint32_t packet;
  uint32_t texels;  ///< heap pointer to (T+2B)² · 4 half bits (kind 0)
};

/// One page-table texel JavaScript writes: layer, mip, x, y, entry.
struct PageWrite {
  uint32_t layer, mip, x, y, entry;
};

inline constexpr uint32_t kRootBase = 0x40000000u;
inline constexpr uint32_t kNotDecoded = 0xffffffffu;
inline constexpr uint32_t kOrderBase = 0x50000000u;

class Client {
 public:
  std::string error;
  std::vector<std::unique_ptr<ClientMaterial>> materials;
  VtSet set;
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Scheduler> scheduler;
  std::unique_ptr<VoteCounter> votes;
  std::unique_ptr<TileDecoder> decoder;
  TileLayout layout{};
  uint32_t finest_level = 0;
  uint32_t angular_resolution = 32;
  ShaderConfig base_config;
  // Decoded tiles (the parents of later tiles): an LRU arena of decoded_capacity slots, not one
  // copy per tile of every material. Roots (level 0) are never evicted; an evicted ancestor is
  // decoded again from its kept payload when a child needs it (redecodes).
  std::vector<float> arena;
  uint32_t decoded_capacity = 256;
  std::vector<uint64_t> arena_stamp;                              // last use; 0 = free
  std::vector<std::pair<ClientMaterial*, uint32_t>> arena_owner;  // (material, tile entry)
  std::vector<uint8_t> arena_pinned;                              // roots
  uint64_t arena_clock = 0;
  uint64_t evictions = 0, redecodes = 0;
  std::vector<uint16_t> staging;      // half texels per request id (+ roots at the end)
  std::vector<float> packet_scratch;  // one unpacked U' packet
  std::vector<RequestInfo> requests;  // this frame's new requests
  std::vector<RequestInfo> roots;     // pinned root tiles, fetched before streaming
  std::vector<UploadInfo> uploads;
  std::vector<uint32_t> pending_root_uploads;
  std::vector<PageTableWrite> writes;
  std::vector<PageWrite> page_writes;
  std::vector<uint8_t> slot_used;
  std::vector<TileId> slot_tiles;
  std::vector<uint8_t> root_decoded;
  std::string shader_text;
  std::vector<RequestInfo> order;       // fixed component-by-component order (comparison)
  std::vector<uint16_t> order_staging;  // half texels of ordered deliveries until uploaded
  uint64_t frame = 0;
  bool started = false;
  bool full_rewrite = true;
  double decode_us_total = 0;
  uint64_t decodes = 0;

  int fail(Code c, std::string message) {
    error = std::move(message);
    return c;
  }

  int add_material(std::span<const uint8_t> directory, uint64_t file_size) {
    if (started) return fail(kBadArgument, "add_material after start");
    auto d = parse_bsvtf_directory(directory, file_size);
    if (!d) return fail(kFailed, d.message());
    if (auto e = check_u_layout(d->metadata); !e) return fail(kFailed, e.message());
    auto m = std::make_unique<ClientMaterial>();
    m->dir = std::move(*d);
    const BsvtfMetadata& md = m->dir.metadata;
    if (!materials.empty() && (md.tile_size != layout.tile_size || md.border != layout.border))
      return fail(kFailed, "every material of one page must share tile size and border");
    layout = md.layout();
    auto a = build_angular_textures(md, angular_resolution);
    if (!a) return fail(kFailed, a.message());
    m->angular = std::move(*a);
    const size_t lights = md.light_directions.size() / 3, views = md.view_directions.size() / 3;
    m->u_rgba.assign(lights * views * md.component_count * 4, 0.0f);
    m->u.assign(static_cast<size_t>(md.u_rows) * md.component_count, 0.0f);
    materials.push_back(std::move(m));
    return static_cast<int>(materials.size() - 1);
  }

  int start(uint32_t slots_x, uint32_t slots_y, uint32_t feedback_shift, uint32_t uploads_per_frame,
            uint32_t requests_in_flight, bool stream_u) {
    if (started || materials.empty()) return fail(kBadArgument, "start: no materials or already started");
    for (auto& m : materials) {
      const BsvtfMetadata& md = m->dir.metadata;
      m->set_index =
          set.add_material(VtGeometry::make(md.width, md.height, md.tile_size, md.border), md.texture_count());
      const VtMaterial& vm = set.material(m->set_index);
      finest_level = std::max(finest_level, vm.levels.finest_level());
      // Paper 000 eq. 8 weights w from the tile index (the scheduler's priority P = w·v).
      const size_t tiles = vm.levels.tile_count();
      m->decoded_slot.assign(tiles * vm.texture_count, kNotDecoded);
      m->payloads.assign(tiles * vm.texture_count, {});
      m->delivered.assign(tiles * vm.texture_count, 0);
      for (const BsvtfTileEntry& e : m->dir.tiles) {
        if (e.id.texture >= vm.texture_count) continue;
        const uint32_t flat = vm.levels.index(e.id);
        set.weights(vm.first_texture + e.id.texture)[flat] = Half(e.weight);
        m->weight_total += e.weight;
      }
    }
    auto c = TileCache::create(set, TileCacheConfig{slots_x, slots_y, 1u << 16});
    if (!c) return fail(kFailed, c.message());
    cache = std::make_unique<TileCache>(std::move(*c));
    SchedulerConfig sc;
    sc.budgets.uploads_per_frame = uploads_per_frame;
    sc.budgets.requests_in_flight = requests_in_flight;
    sc.budgets.tiles_decoding = requests_in_flight;  // decoding is synchronous in bw_deliver
    sc.budgets.bytes_in_flight = 64ull << 20;
    sc.tile_bytes = layout.sample_count() * 2;
    sc.stream_u_columns = stream_u;
    // Over HTTP the request budget is hit on every frame of the initial load; the global LOD bias
    // that overload raises should fall again within a few frames, not 30, once the link is idle.
    sc.calm_frames = 5;
    sc.u_packet_bytes = materials[0]->dir.packets.empty() ? 1 : materials[0]->dir.packets[0].size;
    auto s = Scheduler::create(*cache, sc);
    if (!s) return fail(kFailed, s.message());
    scheduler = std::make_unique<Scheduler>(std::move(*s));
    // Requests count their real payload sizes against bytes_in_flight.
    for (auto& m : materials) {
      const VtMaterial& vm = set.material(m->set_index);
      for (const BsvtfTileEntry& e : m->dir.tiles)
        if (e.id.texture < vm.texture_count)
          scheduler->set_tile_bytes(vm.first_texture + e.id.texture, vm.levels.index(e.id), e.size);
    }
    votes = std::make_unique<VoteCounter>(vote_layouts(set), VoteWindowConfig{1u << (2 * feedback_shift), 0});
    decoder = std::make_unique<TileDecoder>(layout);
    // Decoded parents: a bounded LRU arena. A decode needs its ancestors (at most finest_level
    // of them) resident at once, and roots stay: the capacity is raised to cover both.
    size_t max_rows = 0, root_count = 0;
    for (auto& m : materials) {
      max_rows = std::max<size_t>(max_rows, m->dir.metadata.u_rows);
      root_count += set.material(m->set_index).texture_count;
    }
    decoded_capacity = std::max<uint32_t>(decoded_capacity, static_cast<uint32_t>(root_count) + finest_level + 4);
    arena.assign(static_cast<size_t>(decoded_capacity) * layout.sample_count(), 0.0f);
    arena_stamp.assign(decoded_capacity, 0);
    arena_owner.assign(decoded_capacity, {nullptr, 0});
    arena_pinned.assign(decoded_capacity, 0);
    packet_scratch.assign(max_rows * 4, 0.0f);
    // Roots: pinned, fetched first (one per virtual texture).
    for (uint32_t mi = 0; mi < materials.size(); ++mi) {
      const ClientMaterial& m = *materials[mi];
      for (uint32_t k = 0; k < set.material(m.set_index).texture_count; ++k) {
        const BsvtfTileEntry* e = m.dir.find(TileId{k, 0, 0, 0});
        if (!e) return fail(kFailed, "container without a root tile");
        roots.push_back(
            make_info(kRootBase + static_cast<uint32_t>(roots.size()), mi, 0, e->id.key(), e->offset, e->size));
      }
    }
    root_decoded.assign(roots.size(), 0);
    staging.assign((static_cast<size_t>(requests_in_flight) + roots.size()) * layout.sample_count(), 0);
    requests.reserve(requests_in_flight);
    uploads.reserve(requests_in_flight + roots.size());
    slot_used.assign(cache->slot_count(), 0);
    slot_tiles.assign(cache->slot_count(), TileId{});
    base_config.angular.resolution = angular_resolution;
    base_config.angular.parameterisation = DirectionParameterisation::parabolic;
    base_config.angular.lookup = AngularLookup::barycentric;
    base_config.vt.tile_size = layout.tile_size;
    base_config.vt.border = layout.border;
    base_config.vt.slots_x = slots_x;
    base_config.vt.slots_y = slots_y;
    base_config.vt.cache_layers = 1;
    base_config.vt.finest_level = finest_level;
    base_config.vt.trilinear = true;
    started = true;
    return kOk;
  }

  static RequestInfo make_info(uint32_t id, uint32_t material, uint32_t kind, uint64_t key, uint64_t offset,
                               uint32_t size) {
    return RequestInfo{id,
                       material,
                       kind,
                       static_cast<uint32_t>(key),
                       static_cast<uint32_t>(key >> 32),
                       static_cast<uint32_t>(offset),
                       static_cast<uint32_t>(offset >> 32),
                       size};
  }

  uint32_t material_of_set(uint32_t set_material) const noexcept {
    for (uint32_t i = 0; i < materials.size(); ++i)
      if (materials[i]->set_index == set_material) return i;
    return 0;
  }

  // Votes from this frame's feedback words → plan → the new requests.
  int plan(std::span<const uint32_t> words) {
    if (!started) return fail(kBadArgument, "frame before start");
    requests.clear();
    if (!words.empty()) votes->accumulate(words, 1, scheduler->lod_bias());
    for (const TileRequest& q : scheduler->plan(*cache, *votes, ++frame)) {
      const uint32_t sm = set.material_of(q.tile.texture);
      const uint32_t mi = material_of_set(sm);
      const ClientMaterial& m = *materials[mi];
      const uint32_t local = q.tile.texture - set.material(sm).first_texture;
      if (q.u_packet) {
        const BsvtfPacketEntry& p = m.dir.packets[local];
        requests.push_back(make_info(q.id, mi, 1, local, p.offset, p.size));
      } else {
        const BsvtfTileEntry* e = m.dir.find(TileId{local, q.tile.level, q.tile.x, q.tile.y});
        if (!e) {
          scheduler->cancel(*cache, q.id);
          continue;
        }
        requests.push_back(make_info(q.id, mi, 0, e->id.key(), e->offset, e->size));
      }
    }
    return static_cast<int>(requests.size());
  }

  // An arena slot for a new decoded tile: a free one, else the least recently used unpinned
  // one (its tile is decoded again from its payload if a child needs it later).
  uint32_t acquire_slot() {
    uint32_t best = kNotDecoded;
    for (uint32_t i = 0; i < decoded_capacity; ++i) {
      if (arena_stamp[i] == 0) return i;
      if (!arena_pinned[i] && (best == kNotDecoded || arena_stamp[i] < arena_stamp[best])) best = i;
    }
    release(best);
    ++evictions;
    return best;
  }

  float* slot_data(uint32_t slot) { return arena.data() + static_cast<size_t>(slot) * layout.sample_count(); }

  // The decoded samples of `local`, decoding it (and, recursively, its evicted ancestors) again
  // from the kept payloads when the arena dropped it. Null when a payload was never delivered.
  const float* decoded(ClientMaterial& m, TileId local, uint32_t depth = 0) {
    const VtMaterial& vm = set.material(m.set_index);
    const uint32_t entry = vm.levels.index(local) * vm.texture_count + local.texture;
    if (m.decoded_slot[entry] != kNotDecoded) {
      arena_stamp[m.decoded_slot[entry]] = ++arena_clock;
      return slot_data(m.decoded_slot[entry]);
    }
    if (m.payloads[entry].empty() || depth > finest_level) return nullptr;
    std::span<const float> parent;
    if (local.level > 0) {
      const float* p = decoded(m, local.parent(), depth + 1);
      if (!p) return nullptr;
      parent = std::span<const float>(p, layout.sample_count());
    }
    const uint32_t slot = acquire_slot();  // the ancestors just used are the newest: never evicted here
    if (decoder->decode(m.payloads[entry], parent, local.x & 1, local.y & 1,
                        std::span<float>(slot_data(slot), layout.sample_count())) != Status::success) {
      release(slot);
      return nullptr;
    }
    ++redecodes;
    place(m, entry, slot, local.level == 0);
    return slot_data(slot);
  }

  void release(uint32_t slot) {
    auto& [owner, entry] = arena_owner[slot];
    if (owner && owner->decoded_slot[entry] == slot) owner->decoded_slot[entry] = kNotDecoded;
    arena_owner[slot] = {nullptr, 0};
    arena_stamp[slot] = 0;
    arena_pinned[slot] = 0;
  }

  void place(ClientMaterial& m, uint32_t entry, uint32_t slot, bool pinned) {
    m.decoded_slot[entry] = slot;
    arena_owner[slot] = {&m, entry};
    arena_stamp[slot] = ++arena_clock;
    arena_pinned[slot] = pinned ? 1 : 0;
  }

  // Verifies and decodes one tile payload into its arena slot and `halves`.
  int decode_tile(ClientMaterial& m, TileId local, std::span<const uint8_t> bytes, uint16_t* halves) {
    const BsvtfTileEntry* e = m.dir.find(local);
    if (!e) return fail(kBadArgument, "unknown tile");
    if (verify_bsvtf_payload(e->size, e->crc, bytes) != Status::success)
      return fail(kCorrupt, format_message("tile %u/%u/%u/%u: payload size or CRC-32 mismatch", local.texture,
                                           local.level, local.x, local.y));
    const VtLevelTable& lv = set.material(m.set_index).levels;
    const uint32_t flat = lv.index(local);
    const uint32_t K = set.material(m.set_index).texture_count;
    const uint32_t entry = flat * K + local.texture;
    if (m.payloads[entry].empty()) m.payloads[entry].assign(bytes.begin(), bytes.end());
    std::span<const float> parent;
    if (local.level > 0) {
      const float* p = decoded(m, local.parent());
      if (!p) return fail(kDecodeFailed, "parent tile not decoded");
      parent = std::span<const float>(p, layout.sample_count());
    }
    uint32_t slot = m.decoded_slot[entry];
    if (slot == kNotDecoded) slot = acquire_slot();  // the parent is the newest: not evicted here
    float* out = slot_data(slot);
    const auto t0 = std::chrono::steady_clock::now();
    const Status s =
        decoder->decode(bytes, parent, local.x & 1, local.y & 1, std::span<float>(out, layout.sample_count()));
    decode_us_total += std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    ++decodes;
    if (s != Status::success) {
      release(slot);  // whatever it held is overwritten
      m.payloads[entry].clear();
      return fail(kDecodeFailed, decoder->message());
    }
    place(m, entry, slot, local.level == 0);
    float_to_half(std::span<const float>(out, layout.sample_count()),
                  std::span<uint16_t>(halves, layout.sample_count()));
    // Paper 000 §6: ‖T‖²_F / T² of the tile (interior texels) for the U' packet priority.
    double energy = 0;
    const uint32_t S = layout.stored_size(), B = layout.border;
    for (uint32_t y = B; y < S - B; ++y)
      for (uint32_t x = B; x < S - B; ++x)
        for (uint32_t c = 0; c < 4; ++c) {
          const double v = out[(static_cast<size_t>(y) * S + x) * 4 + c];
          energy += v * v;
        }
    // The scheduler keeps its own copy of w and the energies (vt/scheduler.hpp set_energy).
    scheduler->set_energy(set.material(m.set_index).first_texture + local.texture, flat,
                          static_cast<float>(energy / (static_cast<double>(layout.tile_size) * layout.tile_size)));
    uint8_t& seen = m.delivered[static_cast<size_t>(flat) * K + local.texture];
    if (!seen) {
      seen = 1;
      m.weight_delivered += e->weight;
    }
    return kOk;
  }

  // Paper 004 §5's order for comparison: component group by group (U' packet g, then every
  // tile of virtual texture g coarse to fine), material after material, no feedback.
  int build_component_order() {
    order.clear();
    for (uint32_t mi = 0; mi < materials.size(); ++mi) {
      const ClientMaterial& m = *materials[mi];
      for (uint32_t g = 0; g < m.dir.packets.size(); ++g) {
        const BsvtfPacketEntry& p = m.dir.packets[g];
        order.push_back(make_info(kOrderBase + static_cast<uint32_t>(order.size()), mi, 1, g, p.offset, p.size));
        for (const BsvtfTileEntry& e : m.dir.tiles)
          if (e.id.texture == g && e.id.level > 0)
            order.push_back(
                make_info(kOrderBase + static_cast<uint32_t>(order.size()), mi, 0, e.id.key(), e.offset, e.size));
      }
    }
    order_staging.clear();
    order_staging.reserve(order.size() * layout.sample_count());  // pointers stay valid until uploaded
    return static_cast<int>(order.size());
  }

  // Delivery of an item of the fixed order: straight into the cache (every tile keeps its slot,
  // ancestors stay: the page table names the deepest), bypassing the scheduler.
  int deliver_ordered(uint32_t i, std::span<const uint8_t> bytes) {
    if (i >= order.size()) return fail(kBadArgument, "unknown order item");
    const RequestInfo& info = order[i];
    ClientMaterial& m = *materials[info.material];
    if (info.kind == 1) {
      const BsvtfPacketEntry& p = m.dir.packets[info.key_lo];
      if (verify_bsvtf_payload(p.size, p.crc, bytes) != Status::success) return fail(kCorrupt, "U packet CRC mismatch");
      unpack_bsvtf_packet(bytes, packet_scratch);
      scatter_u_packet(m.dir.metadata, info.key_lo, packet_scratch, m.u_rgba, m.u);
      m.packets_loaded = std::max(m.packets_loaded, info.key_lo + 1);
      uploads.push_back(UploadInfo{1, 0, info.material, info.key_lo, 0});
      return kOk;
    }
    const TileId local = TileId::from_key(static_cast<uint64_t>(info.key_hi) << 32 | info.key_lo);
    // One staging buffer per delivery: JavaScript uploads before the next delivery is handed in.
    order_staging.resize(order_staging.size() + layout.sample_count());
    uint16_t* halves = order_staging.data() + order_staging.size() - layout.sample_count();
    if (int c = decode_tile(m, local, bytes, halves); c != kOk) return c;
    const uint32_t slot = cache->reserve_slot();
    if (slot == kNoSlot) return fail(kFailed, "cache too small for the whole material");
    const TileId global{set.material(m.set_index).first_texture + local.texture, local.level, local.x, local.y};
    if (cache->insert(global, slot, frame) != Status::success) return fail(kFailed, "insert failed");
    uploads.push_back(
        UploadInfo{0, slot, info.material, 0, static_cast<uint32_t>(reinterpret_cast<uintptr_t>(halves))});
    return kOk;
  }

  int deliver(uint32_t id, std::span<const uint8_t> bytes) {
    if (!started) return fail(kBadArgument, "deliver before start");
    if (id >= kOrderBase) return deliver_ordered(id - kOrderBase, bytes);
    if (id >= kRootBase) {
      const uint32_t r = id - kRootBase;
      if (r >= roots.size() || root_decoded[r]) return fail(kBadArgument, "unknown root");
      const RequestInfo& info = roots[r];
      ClientMaterial& m = *materials[info.material];
      const TileId local = TileId::from_key(static_cast<uint64_t>(info.key_hi) << 32 | info.key_lo);
      uint16_t* halves = staging.data() + (scheduler->config().budgets.requests_in_flight + r) * layout.sample_count();
      if (int c = decode_tile(m, local, bytes, halves); c != kOk) return c;
      // The cache pins every root at creation (vt/tile_cache.hpp); older caches leave it to us.
      const TileId global{set.material(m.set_index).first_texture + local.texture, 0, 0, 0};
      uint32_t slot = cache->slot_of(global);
      if (slot == kNoSlot) {
        slot = cache->reserve_slot();
        if (slot == kNoSlot) return fail(kFailed, "cache too small for the root tiles");
        if (cache->insert(global, slot, 0) != Status::success) return fail(kFailed, "root insert failed");
      }
      root_decoded[r] = 1;
      uploads.push_back(
          UploadInfo{0, slot, info.material, 0, static_cast<uint32_t>(reinterpret_cast<uintptr_t>(halves))});
      return kOk;
    }
    // A scheduler request: find it among those issued (ids are reused only after retirement).
    if (!scheduler->begin_decode(id)) return fail(kBusy, "request not awaiting data or decoding budget full");
    const RequestInfo* info = nullptr;
    for (size_t i = issued_.size(); i-- > 0;)
      if (issued_[i].id == id) {
        info = &issued_[i];
        break;
      }
    if (!info) {
      scheduler->cancel(*cache, id);
      return fail(kBadArgument, "unknown request id");
    }
    ClientMaterial& m = *materials[info->material];
    int code = kOk;
    if (info->kind == 1) {
      const BsvtfPacketEntry& p = m.dir.packets[info->key_lo];
      if (verify_bsvtf_payload(p.size, p.crc, bytes) != Status::success) {
        code = fail(kCorrupt, format_message("U packet %u: payload size or CRC-32 mismatch", info->key_lo));
      } else {
        unpack_bsvtf_packet(bytes, packet_scratch);
        scatter_u_packet(m.dir.metadata, info->key_lo, packet_scratch, m.u_rgba, m.u);
      }
    } else {
      const TileId local = TileId::from_key(static_cast<uint64_t>(info->key_hi) << 32 | info->key_lo);
      code = decode_tile(m, local, bytes, staging.data() + static_cast<size_t>(id) * layout.sample_count());
    }
    // A refused payload frees its request and slot: the scheduler plans the tile again from the
    // next frame's votes (a new request, a new fetch), so corrupt bytes never reach the cache.
    if (code == kOk)
      scheduler->finish_decode(id);
    else
      scheduler->cancel(*cache, id);
    return code;
  }

  // Uploads ready requests (scheduler order, budgeted) and the page-table writes they cause.
  int apply_uploads() {
    if (!started) return fail(kBadArgument, "apply before start");
    scheduler->apply_uploads(*cache, [&](const TileRequest& q) {
      const uint32_t sm = set.material_of(q.tile.texture);
      const uint32_t mi = material_of_set(sm);
      if (q.u_packet) {
        const uint32_t local = q.tile.texture - set.material(sm).first_texture;
        materials[mi]->packets_loaded = std::max(materials[mi]->packets_loaded, local + 1);
        uploads.push_back(UploadInfo{1, 0, mi, local, 0});
      } else {
        const uint16_t* h = staging.data() + static_cast<size_t>(q.id) * layout.sample_count();
        uploads.push_back(UploadInfo{0, q.slot, mi, 0, static_cast<uint32_t>(reinterpret_cast<uintptr_t>(h))});
      }
    });
    // Page tables (docs/shaders.md): the cache's deltas plus the own-level chain of every tile
    // that entered or left a slot (a hidden tile changes no finest-level entry).
    writes.clear();
    if (full_rewrite || cache->deltas_overflowed()) {
      for (uint32_t t = 0; t < set.texture_count(); ++t) append_full_page_table_writes(*cache, t, writes);
      full_rewrite = false;
    } else {
      append_page_table_writes(*cache, cache->deltas(), writes);
      for (uint32_t s = 0; s < cache->slot_count(); ++s) {
        const SlotInfo& si = cache->slot(s);
        const bool used = si.state == SlotInfo::State::used;
        if (used == (slot_used[s] != 0) && (!used || si.tile == slot_tiles[s])) continue;
        if (slot_used[s]) append_tile_chain_writes(*cache, slot_tiles[s], writes);
        if (used) append_tile_chain_writes(*cache, si.tile, writes);
      }
    }
    for (uint32_t s = 0; s < cache->slot_count(); ++s) {
      const SlotInfo& si = cache->slot(s);
      slot_used[s] = si.state == SlotInfo::State::used ? 1 : 0;
      slot_tiles[s] = si.tile;
    }
    cache->clear_deltas();
    page_writes.clear();
    for (const PageTableWrite& w : writes)
      page_writes.push_back(PageWrite{w.tile.texture, w.page_mip, w.tile.x, w.tile.y, w.entry});
    return static_cast<int>(uploads.size());
  }

  const char* program_source(int program, int stage, uint32_t material) {
    if (!started || material >= materials.size()) return nullptr;
    ShaderConfig c = base_config;
    c.components = materials[material]->dir.metadata.component_count;
    auto src = generate_program(static_cast<ShaderProgram>(program), GlslTarget::es300, c);
    if (!src) {
      error = src.message();
      return nullptr;
    }
    shader_text = stage == 0 ? src->vertex : src->fragment;
    return shader_text.c_str();
  }

  // Requests issued (for deliver()'s lookup; newest last, ids are reused after retirement).
  std::vector<RequestInfo> issued_;
};

Client& client() {
  static Client c;
  return c;
}

}  // namespace btflod::web

using btflod::web::client;

extern "C" {

/// Message of the last failure (empty when none). Valid until the next call.
EMSCRIPTEN_KEEPALIVE const char* bw_last_error() { return client().error.c_str(); }

/// Sets the angular lookup-table resolution used by bw_add_material (before it). Returns 0.
EMSCRIPTEN_KEEPALIVE int bw_set_angular_resolution(uint32_t r) {
  if (r < 1 || r > 1024) return btflod::web::kBadArgument;
  client().angular_resolution = r;
  return 0;
}

/// Parses a material's directory (`len` bytes: at least the directory, see the header's
/// directory_size) of a file of `file_size` bytes. Returns the material index (≥ 0) or −code.
/// Untrusted input: every field is validated by parse_bsvtf_directory.
EMSCRIPTEN_KEEPALIVE int bw_add_material(const uint8_t* bytes, uint32_t len, double file_size) {
  const int r = client().add_material(std::span<const uint8_t>(bytes, len), static_cast<uint64_t>(file_size));
  return r;
}

/// Directory size a client must fetch, from the first 128 bytes; 0 on a bad header.
EMSCRIPTEN_KEEPALIVE double bw_directory_size(const uint8_t* header, uint32_t len, double file_size) {
  auto h = btflod::parse_bsvtf_header(std::span<const uint8_t>(header, len), static_cast<uint64_t>(file_size));
  if (!h) {
    client().error = h.message();
    return 0;
  }
  return static_cast<double>(h->directory_size);
}

/// Creates the VT set, cache (slots_x × slots_y), scheduler and vote counter. Returns 0 or a code.
EMSCRIPTEN_KEEPALIVE int bw_start(uint32_t slots_x, uint32_t slots_y, uint32_t feedback_shift,
                                  uint32_t uploads_per_frame, uint32_t requests_in_flight, int stream_u) {
  return client().start(slots_x, slots_y, feedback_shift, uploads_per_frame, requests_in_flight, stream_u != 0);
}

/// Pinned root tiles to fetch first: count, and a pointer to RequestInfo[count].
EMSCRIPTEN_KEEPALIVE int bw_root_count() { return static_cast<int>(client().roots.size()); }
EMSCRIPTEN_KEEPALIVE const void* bw_roots() { return client().roots.data(); }

/// The fixed component-by-component order (paper 004 §5: U' packet g and the tiles of virtual
/// texture g, group after group) as RequestInfo[count] with ids for bw_deliver; for comparing
/// streaming orders. Returns the count.
EMSCRIPTEN_KEEPALIVE int bw_component_order() { return client().build_component_order(); }
EMSCRIPTEN_KEEPALIVE const void* bw_order() { return client().order.data(); }

/// Counts this frame's feedback words and plans. Returns the number of new requests (pointer:
/// bw_requests()) or −code. words may be null with count 0 (no feedback this frame).
EMSCRIPTEN_KEEPALIVE int bw_frame(const uint32_t* words, uint32_t count) {
  auto& c = client();
  const int n = c.plan(std::span<const uint32_t>(words, count));
  if (n < 0) return n;
  for (const auto& r : c.requests) c.issued_.push_back(r);
  // Forget issued entries the scheduler no longer knows (delivered or cancelled long ago).
  if (c.issued_.size() > 4096) c.issued_.erase(c.issued_.begin(), c.issued_.begin() + 2048);
  return n;
}
EMSCRIPTEN_KEEPALIVE const void* bw_requests() { return client().requests.data(); }

/// Hands the bytes of request `id` (or a root) over: verified (size, CRC-32), decoded against
/// its parent and staged for upload. Returns 0, kCorrupt (refetch), kDecodeFailed, kBusy or
/// kBadArgument. Corrupt or undecodable bytes are never staged.
EMSCRIPTEN_KEEPALIVE int bw_deliver(uint32_t id, const uint8_t* bytes, uint32_t len) {
  return client().deliver(id, std::span<const uint8_t>(bytes, len));
}

/// Drops request `id` (the fetch failed for good); the scheduler plans it again later.
EMSCRIPTEN_KEEPALIVE void bw_cancel(uint32_t id) {
  if (client().scheduler && id < btflod::web::kRootBase) client().scheduler->cancel(*client().cache, id);
}

/// Applies ready uploads; returns how many (pointer bw_uploads(), cleared by bw_uploads_done()),
/// with the page-table writes in bw_page_writes() (count bw_page_write_count()).
EMSCRIPTEN_KEEPALIVE int bw_apply_uploads() { return client().apply_uploads(); }
EMSCRIPTEN_KEEPALIVE const void* bw_uploads() { return client().uploads.data(); }
EMSCRIPTEN_KEEPALIVE void bw_uploads_done() {
  client().uploads.clear();
  client().order_staging.clear();
}
EMSCRIPTEN_KEEPALIVE int bw_page_write_count() { return static_cast<int>(client().page_writes.size()); }
EMSCRIPTEN_KEEPALIVE const void* bw_page_writes() { return client().page_writes.data(); }

/// GLSL ES 3.00 source of `program` (ShaderProgram order: 0 fmf, 1 bsvtf, 2 feedback, …),
/// stage 0 vertex / 1 fragment, for material `m`'s component count. Null on error.
EMSCRIPTEN_KEEPALIVE const char* bw_program_source(int program, int stage, uint32_t m) {
  return client().program_source(program, stage, m);
}

/// GLSL ES 3.00 source of the pca_views program (paper 004: PCA over groups of k views), stage 0
/// vertex / 1 fragment, for C components per group, k views per group, `lights` light
/// directions and angular tables of `resolution`². Null on error (bw_last_error).
EMSCRIPTEN_KEEPALIVE const char* bw_pca_program_source(int stage, uint32_t components, uint32_t views_per_group,
                                                       uint32_t lights, uint32_t resolution) {
  auto& c = client();
  btflod::ShaderConfig config;
  config.components = components;
  config.angular.resolution = resolution;
  config.angular.parameterisation = btflod::DirectionParameterisation::parabolic;
  config.angular.lookup = btflod::AngularLookup::barycentric;
  config.pca.views_per_group = views_per_group;
  config.pca.light_count = lights;
  auto src = btflod::generate_program(btflod::ShaderProgram::pca_views, btflod::GlslTarget::es300, config);
  if (!src) {
    c.error = src.message();
    return nullptr;
  }
  c.shader_text = stage == 0 ? src->vertex : src->fragment;
  return c.shader_text.c_str();
}

/// GLSL ES 3.00 source of the pca_rings program (paper 004: PCA over groups of k views, the
/// view/light lookup by the ring search over the uniform block btflod_DirectionRings, packed by
/// pack_ring_search_block), stage 0 vertex / 1 fragment, for C components per group, k views per
/// group and `lights` light directions. Null on error (bw_last_error).
EMSCRIPTEN_KEEPALIVE const char* bw_pca_rings_program_source(int stage, uint32_t components, uint32_t views_per_group,
                                                             uint32_t lights) {
  auto& c = client();
  btflod::ShaderConfig config;
  config.components = components;
  config.pca.views_per_group = views_per_group;
  config.pca.light_count = lights;
  auto src = btflod::generate_program(btflod::ShaderProgram::pca_rings, btflod::GlslTarget::es300, config);
  if (!src) {
    c.error = src.message();
    return nullptr;
  }
  c.shader_text = stage == 0 ? src->vertex : src->fragment;
  return c.shader_text.c_str();
}

/// CRC-32 (the container's, codec/container.hpp) of `len` bytes: the page checks .pcak chunks
/// with it before they reach a texture.
EMSCRIPTEN_KEEPALIVE uint32_t bw_crc32(const uint8_t* bytes, uint32_t len) {
  return btflod::crc32_of(std::span<const uint8_t>(bytes, len));
}

/// Material facts as uint32[16]: width, height, levels, C, lights, views, first page-table layer,
/// tile size, border, finest level, packets, packets loaded, page-table side (2^finest of the
/// page), slots_x, slots_y, angular resolution.
EMSCRIPTEN_KEEPALIVE int bw_material_info(uint32_t m, uint32_t* out) {
  auto& c = client();
  if (!c.started || m >= c.materials.size()) return btflod::web::kBadArgument;
  const auto& mat = *c.materials[m];
  const auto& md = mat.dir.metadata;
  const auto& vm = c.set.material(mat.set_index);
  const uint32_t v[16] = {md.width,
                          md.height,
                          md.level_count,
                          md.component_count,
                          static_cast<uint32_t>(md.light_directions.size() / 3),
                          static_cast<uint32_t>(md.view_directions.size() / 3),
                          vm.first_texture,
                          md.tile_size,
                          md.border,
                          vm.levels.finest_level(),
                          static_cast<uint32_t>(mat.dir.packets.size()),
                          mat.packets_loaded,
                          1u << c.finest_level,
                          c.base_config.vt.slots_x,
                          c.base_config.vt.slots_y,
                          c.angular_resolution};
  std::memcpy(out, v, sizeof v);
  return 0;
}
/// Total virtual textures (page-table layers) over all materials.
EMSCRIPTEN_KEEPALIVE int bw_texture_count() { return static_cast<int>(client().set.texture_count()); }
/// Pointers to a material's eigen_abrdfs (RGBA32F) and angular tables (index RGBA32UI, weight RGBA32F).
EMSCRIPTEN_KEEPALIVE const float* bw_u_rgba(uint32_t m) { return client().materials[m]->u_rgba.data(); }
EMSCRIPTEN_KEEPALIVE const uint32_t* bw_angular_index(uint32_t m) {
  return client().materials[m]->angular.index.data();
}
EMSCRIPTEN_KEEPALIVE const float* bw_angular_weight(uint32_t m) { return client().materials[m]->angular.weight.data(); }
/// Σ w of delivered tiles / Σ w of all tiles of material m (paper 000 eq. 8), in [0, 1].
EMSCRIPTEN_KEEPALIVE double bw_converged_fraction(uint32_t m) {
  const auto& mat = *client().materials[m];
  return mat.weight_total > 0 ? mat.weight_delivered / mat.weight_total : 0.0;
}
/// Requests issued and not yet uploaded or cancelled.
EMSCRIPTEN_KEEPALIVE int bw_in_flight() {
  return client().scheduler ? static_cast<int>(client().scheduler->requests_in_flight()) : 0;
}
/// Visible-but-missing tiles of the last plan (0 once the view has converged).
EMSCRIPTEN_KEEPALIVE double bw_visible_missing() {
  return client().scheduler ? static_cast<double>(client().scheduler->frame().visible_missing) : 0.0;
}
/// Scheduler state for diagnostics as double[10]: U' packets loaded of materials 0 and 1, cache
/// slots used, and this frame's adds, requests, U' requests, swaps, rejected swaps, budget hits,
/// LOD bias. Returns 0.
/// Bounds the decoded-parent arena to `tiles` decoded tiles (raised to roots + finest level + 4).
/// Call before bw_start. Returns 0, or kBadArgument after start.
EMSCRIPTEN_KEEPALIVE int bw_set_decoded_capacity(uint32_t tiles) {
  auto& c = client();
  if (c.started) return btflod::web::kBadArgument;
  c.decoded_capacity = tiles;
  return 0;
}

/// Decoded-parent arena as double[5]: capacity (tiles), resident tiles, evictions, tiles decoded
/// again from their kept payloads, arena bytes.
EMSCRIPTEN_KEEPALIVE int bw_decoded_stats(double* out) {
  auto& c = client();
  if (!c.started) return btflod::web::kBadArgument;
  size_t resident = 0;
  for (uint64_t s : c.arena_stamp) resident += s != 0;
  out[0] = c.decoded_capacity;
  out[1] = static_cast<double>(resident);
  out[2] = static_cast<double>(c.evictions);
  out[3] = static_cast<double>(c.redecodes);
  out[4] = static_cast<double>(c.arena.size() * sizeof(float));
  return 0;
}

EMSCRIPTEN_KEEPALIVE int bw_counters(double* out) {
  auto& c = client();
  if (!c.started) return btflod::web::kBadArgument;
  const auto& f = c.scheduler->frame();
  out[0] = c.scheduler->u_loaded(0);
  out[1] = c.materials.size() > 1 ? c.scheduler->u_loaded(1) : 0;
  out[2] = c.cache->used_count();
  out[3] = static_cast<double>(f.adds);
  out[4] = static_cast<double>(f.requests);
  out[5] = static_cast<double>(f.u_requests);
  out[6] = static_cast<double>(f.swaps);
  out[7] = static_cast<double>(f.swaps_rejected);
  out[8] = static_cast<double>(f.budget_hits());
  out[9] = c.scheduler->lod_bias();
  return 0;
}

/// The scheduler's global LOD bias (raised under overload; 0 when requests are at full detail).
EMSCRIPTEN_KEEPALIVE int bw_lod_bias() {
  return client().scheduler ? static_cast<int>(client().scheduler->lod_bias()) : 0;
}

/// Mean tile decode time in µs over this page's decodes, and their count.
EMSCRIPTEN_KEEPALIVE double bw_decode_us_mean() {
  return client().decodes ? client().decode_us_total / static_cast<double>(client().decodes) : 0.0;
}
EMSCRIPTEN_KEEPALIVE double bw_decode_count() { return static_cast<double>(client().decodes); }

/// Decodes every tile of an in-memory container `repeats` times (inflate backend for deflate
/// tiles 0 zlib, 1 libdeflate when built in; zstd tiles always through zstd) and writes double[5]: hash low 32 bits,
/// hash high 32 bits, tiles, mean decode µs per tile, mean inflate µs per tile. Returns 0 or the decoder's status.
EMSCRIPTEN_KEEPALIVE int bw_decode_container(const uint8_t* bytes, uint32_t len, int backend, int repeats,
                                             double* out) {
  const auto r = btflod::web::decode_container_tiles(
      std::span<const uint8_t>(bytes, len),
      backend == 1 ? btflod::InflateBackend::libdeflate : btflod::InflateBackend::zlib, repeats);
  out[0] = static_cast<double>(r.hash & 0xffffffffu);
  out[1] = static_cast<double>(r.hash >> 32);
  out[2] = r.tiles;
  out[3] = r.tiles ? r.decode_us / r.tiles : 0.0;
  out[4] = r.tiles ? r.inflate_us / r.tiles : 0.0;
  return static_cast<int>(r.status);
}

/// Byte offset of the entropy-coded stream inside a tile payload, its decoded size and its coder
/// (0 raw deflate, 1 zstd; for the browser's DecompressionStream('deflate-raw') comparison on
/// deflate tiles): writes uint32[3]; returns 0 or 1 (not a valid tile header).
EMSCRIPTEN_KEEPALIVE int bw_inflate_container(const uint8_t* payload, uint32_t len, uint32_t* out) {
  btflod::TileHeaderInfo info;
  if (btflod::tile_peek_header(std::span<const uint8_t>(payload, len), info) != btflod::Status::success) return 1;
  out[0] = static_cast<uint32_t>(btflod::tile_header_size(info.channels));
  out[1] = info.symbol_bytes;
  out[2] = static_cast<uint32_t>(info.coder);
  return 0;
}

}  // extern "C"
