// btflod web client — the runtime half of the browser viewer, compiled to WebAssembly with
// emscripten. Streaming is the engine runtime itself: one Streamer (runtime/streamer.hpp, the
// object native engines use) over every material, its reads handed to JavaScript through
// js_read_queue.hpp. The Streamer verifies payloads (size, CRC-32), decodes tiles against their
// parent chains (runtime/codec/tile_codec.hpp: zstd tiles — tile format 3, the default coder — and
// deflate tiles — format 2 — through zlib or libdeflate, all built from Debian's sources),
// counts the feedback votes, runs the scheduler with U′ packet streaming (paper 000 §5–6) and
// emits tile uploads and page-table writes. This file adds what the page needs around it: the
// angular lookup tables and the U′ texture layout (web_material.hpp), the GLSL ES 3.00 programs
// (runtime/shader/glsl_generator.hpp), and paper 004's fixed component order for comparison, which
// bypasses the scheduler and so has its own small cache.
//
// JavaScript (www/btflod_client.js) owns I/O and the GPU: per frame it hands the feedback words
// to bw_frame(), uploads what that released, fetches the byte ranges bw_reads() lists with
// `Range:` and reports each with bw_complete_read(). The C interface passes plain integers and
// pointers into the wasm heap; every function returns a status (0 = success) or a count, and
// bw_last_error() holds the message of the last failure. Untrusted bytes (directories,
// payloads) are checked by the library's readers: a corrupt payload is refused before it is
// decoded, never uploaded. Single-threaded (the browser's main thread): decode jobs run in
// bw_frame() through Streamer::pump(); nothing allocates per frame after bw_start().
// This is the program's one implementation translation unit (btflod.hpp: the non-inline code of
// the headers it includes — CRC-32, inflate back ends, half conversion, dispatch — is compiled
// here). Only runtime headers are included, so no Eigen or offline code enters the module.
#define BTFLOD_IMPLEMENTATION 1
#include <emscripten/emscripten.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/streamer.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"
#include "js_read_queue.hpp"
#include "web_material.hpp"

namespace btflod::web {

/// Return codes of the C interface (JavaScript mirrors them in btflod_client.js).
enum Code : int {
  kOk = 0,
  kBadArgument = 1,   ///< unknown id, call out of order
  kCorrupt = 2,       ///< payload failed its size/CRC check: fetch again
  kDecodeFailed = 3,  ///< verified payload that does not decode (or its parent is missing)
  kFailed = 5,        ///< set-up failure, see bw_last_error() (4 is reserved)
};

struct ClientMaterial {
  BsvtfDirectory dir;
  BsvtfAngularTables angular;
  std::vector<float> u_rgba;       ///< eigen_abrdfs texture: lights × views × C layers, RGBA32F
  uint32_t packets_loaded = 0;     ///< U′ packets uploaded (the highest g + 1)
  std::vector<uint8_t> delivered;  ///< per (local texture, flat tile): uploaded at least once
  double weight_total = 0, weight_delivered = 0;
  /// (offset, size, CRC-32) of every payload, by offset: lets the page check bytes it keeps.
  std::vector<std::array<uint64_t, 3>> payload_index;
};

/// One item of the fixed component order (all uint32 for a flat Uint32Array view).
struct RequestInfo {
  uint32_t id;  ///< kOrderBase + position in the order
  uint32_t material;
  uint32_t kind;            ///< 0 tile, 1 U' packet
  uint32_t key_lo, key_hi;  ///< local tile key (kind 0) or packet index (kind 1)
  uint32_t offset_lo, offset_hi;
  uint32_t size;
};

/// One upload JavaScript performs after bw_frame() (or an ordered delivery).
struct UploadInfo {
  uint32_t kind;  ///< 0 tile into `slot`, 1 U' packet (re-upload layers of `material`)
  uint32_t slot;
  uint32_t material;
  uint32_t packet;
  uint32_t texels;   ///< heap pointer to (T+2B)² · 4 half bits (kind 0, rgba16f cache)
  uint32_t unorm8;   ///< heap pointer to (T+2B)² · 4 bytes (kind 0, rgba8_affine cache)
  uint32_t map[4];   ///< the slot's map as its slot-map texel (pack_cache_slot_map; rgba8_affine, bc5_affine)
  uint32_t bc5 = 0;  ///< heap pointer to two BC5 planes of (T+2B)² bytes each (kind 0, bc5_affine cache)
};

// btflod_client.js reads the uploads as a flat Uint32Array of UPLOAD_STRIDE words each.
static_assert(sizeof(UploadInfo) == 11 * sizeof(uint32_t));

/// One page-table texel JavaScript writes: layer, mip, x, y, entry.
struct PageWrite {
  uint32_t layer, mip, x, y, entry;
};

inline constexpr uint32_t kOrderBase = 0x50000000u;

/// Paper 004 §5's order for comparison: component group by group (U′ packet g, then every tile
/// of virtual texture g coarse to fine), material after material, no feedback. Every tile keeps
/// its slot and its decoded samples (the children's parents), so the cache must hold them all.
struct FixedOrder {
  VtSet set;
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<TileDecoder> decoder;
  std::vector<RequestInfo> items;
  std::vector<std::vector<float>> decoded;  // per (material base + flat · K + local texture)
  std::vector<uint32_t> material_base;
  std::vector<uint16_t> staging;       // half texels of deliveries until JavaScript uploaded them
  std::vector<uint8_t> dirty;          // per global texture: page table to write again
  std::vector<PageTableWrite> writes;  // reserved for every page-table texel
};

class Client {
 public:
  std::string error;
  std::vector<std::unique_ptr<ClientMaterial>> materials;
  TileLayout layout{};
  uint32_t angular_resolution = 32;
  uint32_t decoded_cache_tiles = 16;
  CacheFormat cache_format = CacheFormat::rgba16f;  ///< bw_set_cache_format, before bw_start
  ShaderConfig base_config;
  std::string shader_text;
  // The engine runtime and its I/O.
  std::unique_ptr<JsReadQueue> read_queue;
  std::vector<std::unique_ptr<JsSource>> sources;
  Streamer streamer;
  std::vector<StreamerTileUpload> tile_uploads;
  std::vector<StreamerPacketUpload> packet_uploads;
  std::vector<PageTableWrite> table_writes;
  std::vector<ResidencyEvent> events;
  uint64_t refused = 0;  ///< payloads the runtime refused (size/CRC mismatch): fetched again
  uint64_t failed = 0;   ///< other failed reads or decodes
  // What JavaScript applies next.
  std::vector<UploadInfo> uploads;
  std::vector<PageWrite> page_writes;
  std::vector<float> packet_scratch;  // one U′ packet as floats
  std::unique_ptr<FixedOrder> order;
  uint64_t frame = 0;
  bool started = false;

  int fail(Code c, std::string message) {
    error = std::move(message);
    return c;
  }

  int add_material(std::span<const uint8_t> directory, uint64_t file_size) {
    if (started) return -fail(kBadArgument, "add_material after start");
    auto d = parse_bsvtf_directory(directory, file_size);
    if (!d) return -fail(kFailed, d.message());
    if (auto e = check_u_layout(d->metadata); !e) return -fail(kFailed, e.message());
    auto m = std::make_unique<ClientMaterial>();
    m->dir = std::move(*d);
    const BsvtfMetadata& md = m->dir.metadata;
    if (!materials.empty() && (md.tile_size != layout.tile_size || md.border != layout.border))
      return -fail(kFailed, "every material of one page must share tile size and border");
    layout = md.layout();
    auto a = build_angular_textures(md, angular_resolution);
    if (!a) return -fail(kFailed, a.message());
    m->angular = std::move(*a);
    const size_t lights = md.light_directions.size() / 3, views = md.view_directions.size() / 3;
    m->u_rgba.assign(lights * views * md.component_count * 4, 0.0f);
    for (const BsvtfTileEntry& e : m->dir.tiles) {
      m->weight_total += e.weight;
      m->payload_index.push_back({e.offset, e.size, e.crc});
    }
    for (const BsvtfPacketEntry& p : m->dir.packets) m->payload_index.push_back({p.offset, p.size, p.crc});
    std::sort(m->payload_index.begin(), m->payload_index.end());
    materials.push_back(std::move(m));
    return static_cast<int>(materials.size() - 1);
  }

  // The Streamer over every material (paper 000 §5–6: P = w·v, budgets in payload bytes, U′
  // columns streamed by priority when stream_u), with JavaScript-owned reads.
  int start(uint32_t slots_x, uint32_t slots_y, uint32_t feedback_shift, uint32_t uploads_per_frame,
            uint32_t requests_in_flight, bool stream_u) {
    if (started || materials.empty()) return fail(kBadArgument, "start: no materials or already started");
    if (feedback_shift > 4 || uploads_per_frame == 0 || requests_in_flight == 0)
      return fail(kBadArgument, "start: feedback shift above 4 or a zero budget");
    StreamerConfig config;
    config.cache = CacheConfig{slots_x, slots_y, 1u << 16, layout.tile_size, layout.border, 1};
    config.cache.format = cache_format;
    config.scheduler.budgets.uploads_per_frame = uploads_per_frame;
    config.scheduler.budgets.requests_in_flight = requests_in_flight;
    config.scheduler.budgets.tiles_decoding = requests_in_flight;  // jobs run within bw_frame
    config.scheduler.budgets.bytes_in_flight = 64ull << 20;
    config.scheduler.stream_u_columns = stream_u;
    // Over HTTP the request budget is hit on every frame of the initial load; the global LOD bias
    // that overload raises should fall again within a few frames, not 30, once the link is idle.
    config.scheduler.calm_frames = 5;
    config.vote_window_frames = 1u << (2 * feedback_shift);
    config.decoded_cache_tiles = decoded_cache_tiles;
    config.decode_workers = 1;  // the jobs run on the page's thread, within bw_frame
    // One recorded read per job at a time at most: tile jobs, roots and packets.
    read_queue = std::make_unique<JsReadQueue>(static_cast<size_t>(requests_in_flight) * (kMaxTileLevel + 1) +
                                               config.root_jobs + config.packet_jobs);
    std::vector<StreamerMaterial> list;
    for (uint32_t m = 0; m < materials.size(); ++m) {
      sources.push_back(std::make_unique<JsSource>(*read_queue, m));
      StreamerMaterial sm;
      sm.directory = &materials[m]->dir;
      sm.async_source = sources.back().get();
      list.push_back(sm);
    }
    auto s = Streamer::create(list, config);
    if (!s) return fail(kFailed, s.message());
    streamer = std::move(*s);
    for (uint32_t m = 0; m < materials.size(); ++m)
      materials[m]->delivered.assign(
          static_cast<size_t>(streamer.cache().set().levels_of(streamer.first_texture(m)).tile_count()) *
              streamer.texture_count(m),
          0);
    tile_uploads.resize(streamer.tile_uploads_bound());
    packet_uploads.resize(streamer.packet_uploads_bound());
    table_writes.resize(4096);
    events.resize(256);
    uploads.reserve(tile_uploads.size() + packet_uploads.size());
    page_writes.reserve(table_writes.size());
    size_t max_rows = 0;
    for (auto& m : materials) max_rows = std::max<size_t>(max_rows, m->dir.metadata.u_rows);
    packet_scratch.assign(max_rows * 4, 0.0f);
    base_config.angular.resolution = angular_resolution;
    base_config.angular.parameterisation = DirectionParameterisation::parabolic;
    base_config.angular.lookup = AngularLookup::barycentric;
    uint32_t finest_level = 0;
    for (uint32_t m = 0; m < materials.size(); ++m)
      finest_level = std::max(finest_level, streamer.cache().set().levels_of(streamer.first_texture(m)).finest_level());
    base_config.vt.tile_size = layout.tile_size;
    base_config.vt.border = layout.border;
    base_config.vt.slots_x = slots_x;
    base_config.vt.slots_y = slots_y;
    base_config.vt.cache_layers = 1;
    base_config.vt.finest_level = finest_level;
    base_config.vt.trilinear = true;
    base_config.vt.format = cache_format;
    started = true;
    return kOk;
  }

  uint32_t material_of_texture(uint32_t texture) const noexcept {
    for (uint32_t m = 0; m < materials.size(); ++m)
      if (texture >= streamer.first_texture(m) && texture < streamer.first_texture(m) + streamer.texture_count(m))
        return m;
    return 0;
  }

  // Σ w of the tiles uploaded at least once (the page's quality estimate without a reference).
  void count_delivered(ClientMaterial& m, const VtLevelTable& levels, uint32_t texture_count, TileId local) {
    uint8_t& seen = m.delivered[static_cast<size_t>(levels.index(local)) * texture_count + local.texture];
    if (seen) return;
    seen = 1;
    if (const BsvtfTileEntry* e = m.dir.find(local)) m.weight_delivered += e->weight;
  }

  // U′ packet g of material `mi` (halves, light-major rows) into the material's U′ texture.
  void load_packet(uint32_t mi, uint32_t g, std::span<const uint16_t> halves) {
    ClientMaterial& m = *materials[mi];
    const std::span<float> packet(packet_scratch.data(), halves.size());
    for (size_t i = 0; i < halves.size(); ++i) packet[i] = half_bits_to_float(halves[i]);
    scatter_u_packet(m.dir.metadata, g, packet, m.u_rgba, {}, AngularRowOrder::light_major);
    m.packets_loaded = std::max(m.packets_loaded, g + 1);
    uploads.push_back(UploadInfo{1, 0, mi, g, 0, 0, {}, 0});
  }

  // One frame of the Streamer: the decode jobs whose bytes arrived run, then update() with this
  // frame's feedback words. Its outputs become uploads and page writes for JavaScript (valid
  // until the next bw_frame). Returns the number of new reads (bw_reads()).
  int frame_update(std::span<const uint32_t> words) {
    if (!started) return -fail(kBadArgument, "frame before start");
    if (order) return -fail(kBadArgument, "frame in the fixed component order");
    streamer.pump();
    StreamerOutputs out{tile_uploads, packet_uploads, table_writes, events};
    if (streamer.update(words, out) != Status::success) return -fail(kFailed, "update failed");
    ++frame;
    uploads.clear();
    page_writes.clear();
    for (size_t i = 0; i < out.tile_upload_count; ++i) {
      const StreamerTileUpload& u = tile_uploads[i];
      const uint32_t mi = material_of_texture(u.tile.texture);
      const uint32_t first = streamer.first_texture(mi);
      const TileId local{u.tile.texture - first, u.tile.level, u.tile.x, u.tile.y};
      count_delivered(*materials[mi], streamer.cache().set().levels_of(u.tile.texture), streamer.texture_count(mi),
                      local);
      const std::array<uint32_t, 4> map = pack_cache_slot_map(u.map);
      uploads.push_back(UploadInfo{0,
                                   u.slot,
                                   mi,
                                   0,
                                   static_cast<uint32_t>(reinterpret_cast<uintptr_t>(u.texels.data())),
                                   static_cast<uint32_t>(reinterpret_cast<uintptr_t>(u.unorm8.data())),
                                   {map[0], map[1], map[2], map[3]},
                                   static_cast<uint32_t>(reinterpret_cast<uintptr_t>(u.bc5.data()))});
    }
    for (size_t i = 0; i < out.packet_upload_count; ++i)
      load_packet(packet_uploads[i].material, packet_uploads[i].packet, packet_uploads[i].halves);
    for (size_t i = 0; i < out.page_table_write_count; ++i) {
      const PageTableWrite& w = table_writes[i];
      page_writes.push_back(PageWrite{w.tile.texture, w.page_mip, w.tile.x, w.tile.y, w.entry});
    }
    for (size_t i = 0; i < out.event_count; ++i) {
      const ResidencyEvent& e = events[i];
      if (e.kind != ResidencyEventKind::tile_failed && e.kind != ResidencyEventKind::packet_failed) continue;
      ++(e.status == Status::bad_data ? refused : failed);
    }
    return static_cast<int>(read_queue->take());
  }

  void complete_read(uint64_t ticket, uint32_t status) {
    if (!started) return;
    streamer.complete_read(
        ticket, status <= static_cast<uint32_t>(Status::cancelled) ? static_cast<Status>(status) : Status::io_error);
  }

  // The fixed order's items, its own cache (every tile of every material) and decoders.
  int build_component_order() {
    if (!started) return -fail(kBadArgument, "component order before start");
    if (order) return static_cast<int>(order->items.size());
    // The fixed order stages half texels for an rgba16f cache texture (the comparison of paper
    // 004 §5's order needs no compact cache).
    if (cache_format != CacheFormat::rgba16f) return -fail(kBadArgument, "the fixed component order needs rgba16f");
    auto o = std::make_unique<FixedOrder>();
    for (const auto& m : materials) {
      const BsvtfMetadata& md = m->dir.metadata;
      o->set.add_material(VtGeometry::make(md.width, md.height, md.tile_size, md.border), md.texture_count());
    }
    auto c = TileCache::create(o->set, TileCacheConfig{base_config.vt.slots_x, base_config.vt.slots_y, 1u << 16});
    if (!c) return -fail(kFailed, c.message());
    o->cache = std::make_unique<TileCache>(std::move(*c));
    uint32_t entries = 0;
    for (uint32_t mi = 0; mi < materials.size(); ++mi) {
      const VtMaterial& vm = o->set.material(mi);
      o->material_base.push_back(entries);
      entries += vm.levels.tile_count() * vm.texture_count;
      const ClientMaterial& m = *materials[mi];
      for (uint32_t g = 0; g < m.dir.packets.size(); ++g) {
        const BsvtfPacketEntry& p = m.dir.packets[g];
        o->items.push_back(make_info(mi, 1, g, p.offset, p.size, o->items.size()));
        for (const BsvtfTileEntry& e : m.dir.tiles)  // sorted by key: coarse to fine
          if (e.id.texture == g) o->items.push_back(make_info(mi, 0, e.id.key(), e.offset, e.size, o->items.size()));
      }
    }
    o->decoder = std::make_unique<TileDecoder>(layout);
    if (o->cache->slot_count() < entries) return -fail(kFailed, "cache too small for every tile of the materials");
    o->decoded.resize(entries);
    o->dirty.assign(o->set.texture_count(), 1);  // the roots' slots: written on the first upload
    size_t texels = 0;
    for (uint32_t t = 0; t < o->set.texture_count(); ++t) texels += o->set.levels_of(t).tile_count();
    o->writes.reserve(texels);
    page_writes.reserve(texels);
    o->staging.reserve(o->items.size() * layout.sample_count());  // pointers stay valid until uploaded
    uploads.clear();
    page_writes.clear();
    order = std::move(o);
    return static_cast<int>(order->items.size());
  }

  static RequestInfo make_info(uint32_t material, uint32_t kind, uint64_t key, uint64_t offset, uint32_t size,
                               size_t position) {
    return RequestInfo{kOrderBase + static_cast<uint32_t>(position),
                       material,
                       kind,
                       static_cast<uint32_t>(key),
                       static_cast<uint32_t>(key >> 32),
                       static_cast<uint32_t>(offset),
                       static_cast<uint32_t>(offset >> 32),
                       size};
  }

  // Delivery of an item of the fixed order, in order (a tile's parent came before it): verified,
  // decoded against the parent, inserted into the order's cache with its ancestors kept.
  int deliver_ordered(uint32_t id, std::span<const uint8_t> bytes) {
    if (!order || id < kOrderBase || id - kOrderBase >= order->items.size())
      return fail(kBadArgument, "unknown order item");
    FixedOrder& o = *order;
    const RequestInfo& info = o.items[id - kOrderBase];
    ClientMaterial& m = *materials[info.material];
    if (info.kind == 1) {
      const BsvtfPacketEntry& p = m.dir.packets[info.key_lo];
      if (verify_bsvtf_payload(p.size, p.crc, bytes) != Status::success) return fail(kCorrupt, "U packet CRC mismatch");
      unpack_bsvtf_packet(bytes, packet_scratch);
      scatter_u_packet(m.dir.metadata, info.key_lo, packet_scratch, m.u_rgba, {}, m.dir.metadata.u_row_order);
      m.packets_loaded = std::max(m.packets_loaded, info.key_lo + 1);
      uploads.push_back(UploadInfo{1, 0, info.material, info.key_lo, 0, 0, {}, 0});
      return kOk;
    }
    const TileId local = TileId::from_key(static_cast<uint64_t>(info.key_hi) << 32 | info.key_lo);
    const BsvtfTileEntry* e = m.dir.find(local);
    if (!e || verify_bsvtf_payload(e->size, e->crc, bytes) != Status::success)
      return fail(kCorrupt, format_message("tile %u/%u/%u/%u: payload size or CRC-32 mismatch", local.texture,
                                           local.level, local.x, local.y));
    const VtMaterial& vm = o.set.material(info.material);
    const auto entry_of = [&](const TileId& t) {
      return o.material_base[info.material] + vm.levels.index(t) * vm.texture_count + t.texture;
    };
    std::span<const float> parent;
    if (local.level > 0) {
      parent = o.decoded[entry_of(local.parent())];
      if (parent.empty()) return fail(kDecodeFailed, "parent tile not decoded");
    }
    std::vector<float>& samples = o.decoded[entry_of(local)];
    samples.resize(layout.sample_count());
    if (o.decoder->decode(bytes, parent, local.x & 1, local.y & 1, samples) != Status::success) {
      samples.clear();
      return fail(kDecodeFailed, o.decoder->message());
    }
    const TileId global{vm.first_texture + local.texture, local.level, local.x, local.y};
    uint32_t slot = o.cache->slot_of(global);  // roots are pinned at creation
    if (slot == kNoSlot) {
      slot = o.cache->reserve_slot();
      if (slot == kNoSlot || o.cache->insert(global, slot, frame) != Status::success)
        return fail(kFailed, "cache too small for the whole material");
    }
    o.staging.resize(o.staging.size() + layout.sample_count());
    uint16_t* halves = o.staging.data() + o.staging.size() - layout.sample_count();
    float_to_half(samples, std::span<uint16_t>(halves, layout.sample_count()));
    count_delivered(m, vm.levels, vm.texture_count, local);
    o.dirty[global.texture] = 1;
    uploads.push_back(
        UploadInfo{0, slot, info.material, 0, static_cast<uint32_t>(reinterpret_cast<uintptr_t>(halves)), 0, {}, 0});
    return kOk;
  }

  // Staged uploads; in the fixed order also the page tables of the textures it changed (whole
  // tables: the order's cache only grows, so a texture's entries change in many places at once).
  int staged_uploads() {
    if (!started) return -fail(kBadArgument, "uploads before start");
    if (order) {
      order->writes.clear();
      for (uint32_t t = 0; t < order->dirty.size(); ++t)
        if (order->dirty[t]) append_full_page_table_writes(*order->cache, t, order->writes);
      std::fill(order->dirty.begin(), order->dirty.end(), 0);
      page_writes.clear();
      for (const PageTableWrite& w : order->writes)
        page_writes.push_back(PageWrite{w.tile.texture, w.page_mip, w.tile.x, w.tile.y, w.entry});
    }
    return static_cast<int>(uploads.size());
  }

  void uploads_done() {
    uploads.clear();
    page_writes.clear();
    if (order) order->staging.clear();
  }

  const char* program_source(int program, int stage, uint32_t material) {
    if (!started || material >= materials.size()) return nullptr;
    ShaderConfig c = base_config;
    c.components = materials[material]->dir.metadata.component_count;
    c.value_transform = materials[material]->dir.metadata.value_transform;  // decoded by the program
    return stage_source(static_cast<ShaderProgram>(program), stage, c);
  }

  /// GLSL ES 3.00 source of stage 0 (vertex) or 1 (fragment) of `program` for `config`, held in
  /// shader_text until the next call. Null on error (in `error`).
  const char* stage_source(ShaderProgram program, int stage, const ShaderConfig& config) {
    auto src = generate_program(program, GlslTarget::es300, config);
    if (!src) {
      error = src.message();
      return nullptr;
    }
    shader_text = stage == 0 ? src->vertex : src->fragment;
    return shader_text.c_str();
  }
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
  if (!bytes || !(file_size >= 0 && file_size < 9.0e15)) return -btflod::web::kBadArgument;
  return client().add_material(std::span<const uint8_t>(bytes, len), static_cast<uint64_t>(file_size));
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

/// Creates the Streamer over every material: a cache of slots_x × slots_y slots, votes summed
/// over 4^feedback_shift frames, the scheduler's upload and request budgets, U′ columns streamed
/// by priority when stream_u. Its first bw_frame() asks for the pinned roots (and, without
/// stream_u, every U′ packet). Returns 0 or a code.
/// Sets the tile cache's texel format (0 rgba16f, 1 rgba8_affine: 4 bytes a texel, each slot
/// with its affine map in the slot-map texture, 2 bc5_affine: two BC5 planes of 1 byte a texel
/// with the same maps, encoded by the decode jobs) before bw_start. Returns 0, or an error code
/// after the start or for an unknown format.
EMSCRIPTEN_KEEPALIVE int bw_set_cache_format(uint32_t format) {
  btflod::web::Client& c = client();
  if (c.started || format > 2) return c.fail(btflod::web::kBadArgument, "cache format: 0, 1 or 2, before bw_start");
  c.cache_format = format == 2   ? btflod::CacheFormat::bc5_affine
                   : format == 1 ? btflod::CacheFormat::rgba8_affine
                                 : btflod::CacheFormat::rgba16f;
  return btflod::web::kOk;
}

EMSCRIPTEN_KEEPALIVE int bw_start(uint32_t slots_x, uint32_t slots_y, uint32_t feedback_shift,
                                  uint32_t uploads_per_frame, uint32_t requests_in_flight, int stream_u) {
  return client().start(slots_x, slots_y, feedback_shift, uploads_per_frame, requests_in_flight, stream_u != 0);
}

/// Bounds the decoded ancestors the runtime keeps (StreamerConfig::decoded_cache_tiles: a
/// decode starts from the deepest one kept). Call before bw_start. Returns 0, or kBadArgument
/// after start.
EMSCRIPTEN_KEEPALIVE int bw_set_decoded_capacity(uint32_t tiles) {
  auto& c = client();
  if (c.started) return btflod::web::kBadArgument;
  c.decoded_cache_tiles = tiles;
  return 0;
}

/// One frame: runs the decode jobs whose reads completed, then the Streamer's update with this
/// frame's feedback words (null with count 0: no votes). Returns the number of new reads to
/// perform (bw_reads()) or −code. The uploads and page writes it released are listed by
/// bw_apply_uploads() until bw_uploads_done() or the next bw_frame().
EMSCRIPTEN_KEEPALIVE int bw_frame(const uint32_t* words, uint32_t count) {
  if (!words && count) return -btflod::web::kBadArgument;
  return client().frame_update(std::span<const uint32_t>(words, count));
}

/// The reads of the last bw_frame(): (ticket lo, ticket hi, material, offset lo, offset hi,
/// size, destination address) per read. Copy `size` bytes to the destination, then call
/// bw_complete_read(ticket, 0); on failure pass a status instead (5 = io_error). Any order.
EMSCRIPTEN_KEEPALIVE const void* bw_reads() {
  auto& c = client();
  return c.started ? c.read_queue->taken().data() : nullptr;
}
EMSCRIPTEN_KEEPALIVE void bw_complete_read(uint32_t ticket_lo, uint32_t ticket_hi, uint32_t status) {
  client().complete_read(static_cast<uint64_t>(ticket_hi) << 32 | ticket_lo, status);
}

/// The fixed component-by-component order (paper 004 §5: U' packet g and the tiles of virtual
/// texture g, group after group) as RequestInfo[count] with ids for bw_deliver_ordered; for
/// comparing streaming orders. Switches the client to it (bw_frame is refused afterwards).
/// Returns the count or −code.
EMSCRIPTEN_KEEPALIVE int bw_component_order() { return client().build_component_order(); }
EMSCRIPTEN_KEEPALIVE const void* bw_order() {
  auto& c = client();
  return c.order ? c.order->items.data() : nullptr;
}

/// Hands the bytes of fixed-order item `id` over, in order: verified (size, CRC-32), decoded
/// against its parent and staged for upload. Returns 0, kCorrupt, kDecodeFailed or
/// kBadArgument. Corrupt or undecodable bytes are never staged.
EMSCRIPTEN_KEEPALIVE int bw_deliver_ordered(uint32_t id, const uint8_t* bytes, uint32_t len) {
  if (!bytes && len) return btflod::web::kBadArgument;
  return client().deliver_ordered(id, std::span<const uint8_t>(bytes, len));
}

/// Uploads to perform (pointer bw_uploads(), cleared by bw_uploads_done()), with the page-table
/// writes in bw_page_writes() (count bw_page_write_count()). Returns the count or −code.
EMSCRIPTEN_KEEPALIVE int bw_apply_uploads() { return client().staged_uploads(); }
EMSCRIPTEN_KEEPALIVE const void* bw_uploads() { return client().uploads.data(); }
EMSCRIPTEN_KEEPALIVE void bw_uploads_done() { client().uploads_done(); }
EMSCRIPTEN_KEEPALIVE int bw_page_write_count() { return static_cast<int>(client().page_writes.size()); }
EMSCRIPTEN_KEEPALIVE const void* bw_page_writes() { return client().page_writes.data(); }

/// 1 when bytes [offset, offset + len) of material m are a whole payload of its directory with
/// the right CRC-32 (the page keeps such bytes to serve a later read of the same range), else 0.
EMSCRIPTEN_KEEPALIVE int bw_payload_ok(uint32_t m, double offset, const uint8_t* bytes, uint32_t len) {
  auto& c = client();
  if (m >= c.materials.size() || !bytes || !(offset >= 0)) return 0;
  const auto& index = c.materials[m]->payload_index;
  const uint64_t o = static_cast<uint64_t>(offset);
  auto it = std::lower_bound(index.begin(), index.end(), std::array<uint64_t, 3>{o, 0, 0});
  if (it == index.end() || (*it)[0] != o || (*it)[1] != len) return 0;
  return btflod::crc32_of(std::span<const uint8_t>(bytes, len)) == (*it)[2] ? 1 : 0;
}

/// 1 once every material's roots (and, without U′ streaming, its U′ packets) were handed out.
EMSCRIPTEN_KEEPALIVE int bw_ready() {
  auto& c = client();
  if (!c.started) return 0;
  for (uint32_t m = 0; m < c.materials.size(); ++m)
    if (!c.streamer.material_ready(m)) return 0;
  return 1;
}

/// Payloads the runtime refused (size or CRC-32 mismatch; fetched again) and other failed
/// reads or decodes, as double[2]. Returns 0.
EMSCRIPTEN_KEEPALIVE int bw_faults(double* out) {
  out[0] = static_cast<double>(client().refused);
  out[1] = static_cast<double>(client().failed);
  return 0;
}

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
  btflod::ShaderConfig config;
  config.components = components;
  config.angular.resolution = resolution;
  config.angular.parameterisation = btflod::DirectionParameterisation::parabolic;
  config.angular.lookup = btflod::AngularLookup::barycentric;
  config.pca.views_per_group = views_per_group;
  config.pca.light_count = lights;
  return client().stage_source(btflod::ShaderProgram::pca_views, stage, config);
}

/// GLSL ES 3.00 source of the pca_rings program (paper 004: PCA over groups of k views, the
/// view/light lookup by the ring search over the uniform block btflod_DirectionRings, packed by
/// pack_ring_search_block), stage 0 vertex / 1 fragment, for C components per group, k views per
/// group and `lights` light directions. Null on error (bw_last_error).
EMSCRIPTEN_KEEPALIVE const char* bw_pca_rings_program_source(int stage, uint32_t components, uint32_t views_per_group,
                                                             uint32_t lights) {
  btflod::ShaderConfig config;
  config.components = components;
  config.pca.views_per_group = views_per_group;
  config.pca.light_count = lights;
  return client().stage_source(btflod::ShaderProgram::pca_rings, stage, config);
}

/// CRC-32 (the container's, runtime/codec/container.hpp) of `len` bytes: the page checks .pcak chunks
/// with it before they reach a texture.
EMSCRIPTEN_KEEPALIVE uint32_t bw_crc32(const uint8_t* bytes, uint32_t len) {
  return btflod::crc32_of(std::span<const uint8_t>(bytes, len));
}

/// Material facts as uint32[16]: width, height, levels, C, lights, views, first page-table layer,
/// tile size, border, finest level, packets, packets loaded, page-table side (2^finest of the
/// page), slots_x, slots_y, angular resolution.
EMSCRIPTEN_KEEPALIVE int bw_material_info(uint32_t m, uint32_t* out) {
  auto& c = client();
  if (!c.started || m >= c.materials.size() || !out) return btflod::web::kBadArgument;
  const auto& mat = *c.materials[m];
  const auto& md = mat.dir.metadata;
  const uint32_t first = c.streamer.first_texture(m);
  const uint32_t v[16] = {md.width,
                          md.height,
                          md.level_count,
                          md.component_count,
                          static_cast<uint32_t>(md.light_directions.size() / 3),
                          static_cast<uint32_t>(md.view_directions.size() / 3),
                          first,
                          md.tile_size,
                          md.border,
                          c.streamer.cache().set().levels_of(first).finest_level(),
                          static_cast<uint32_t>(mat.dir.packets.size()),
                          mat.packets_loaded,
                          1u << c.base_config.vt.finest_level,
                          c.base_config.vt.slots_x,
                          c.base_config.vt.slots_y,
                          c.angular_resolution};
  std::memcpy(out, v, sizeof v);
  return 0;
}
/// Total virtual textures (page-table layers) over all materials.
EMSCRIPTEN_KEEPALIVE int bw_texture_count() {
  auto& c = client();
  return c.started ? static_cast<int>(c.streamer.cache().set().texture_count()) : 0;
}
/// Pointers to a material's eigen_abrdfs (RGBA32F) and angular tables (index RGBA32UI, weight RGBA32F).
EMSCRIPTEN_KEEPALIVE const float* bw_u_rgba(uint32_t m) {
  auto& c = client();
  return m < c.materials.size() ? c.materials[m]->u_rgba.data() : nullptr;
}
EMSCRIPTEN_KEEPALIVE const uint32_t* bw_angular_index(uint32_t m) {
  auto& c = client();
  return m < c.materials.size() ? c.materials[m]->angular.index_rgba.data() : nullptr;
}
EMSCRIPTEN_KEEPALIVE const float* bw_angular_weight(uint32_t m) {
  auto& c = client();
  return m < c.materials.size() ? c.materials[m]->angular.weight_rgba.data() : nullptr;
}
/// Σ w of uploaded tiles / Σ w of all tiles of material m (paper 000 eq. 8), in [0, 1].
EMSCRIPTEN_KEEPALIVE double bw_converged_fraction(uint32_t m) {
  auto& c = client();
  if (m >= c.materials.size()) return 0.0;
  const auto& mat = *c.materials[m];
  return mat.weight_total > 0 ? mat.weight_delivered / mat.weight_total : 0.0;
}
/// Requests planned and not yet uploaded or cancelled, plus decode jobs in flight.
EMSCRIPTEN_KEEPALIVE int bw_in_flight() {
  auto& c = client();
  return c.started ? static_cast<int>(c.streamer.scheduler().requests_in_flight() + c.streamer.jobs_in_flight()) : 0;
}
/// Visible-but-missing tiles of the last plan (0 once the view has converged).
EMSCRIPTEN_KEEPALIVE double bw_visible_missing() {
  auto& c = client();
  return c.started ? static_cast<double>(c.streamer.scheduler().frame().visible_missing) : 0.0;
}

/// The runtime's decoded-ancestor cache and payload reads as double[5]: capacity (tiles), tile
/// levels a decode did not decode (nor read) because an ancestor was kept, payload bytes read,
/// cache bytes ((T+2B)² × 4 floats per tile), pending page-table writes.
EMSCRIPTEN_KEEPALIVE int bw_decoded_stats(double* out) {
  auto& c = client();
  if (!c.started || !out) return btflod::web::kBadArgument;
  out[0] = c.decoded_cache_tiles;
  out[1] = static_cast<double>(c.streamer.decoded_levels_skipped());
  out[2] = static_cast<double>(c.streamer.bytes_read());
  out[3] = static_cast<double>(c.decoded_cache_tiles) * static_cast<double>(c.layout.sample_count()) * sizeof(float);
  out[4] = static_cast<double>(c.streamer.pending_page_table_writes());
  return 0;
}

/// Scheduler state for diagnostics as double[10]: U' packets loaded of materials 0 and 1, cache
/// slots used, and this frame's adds, requests, U' requests, swaps, rejected swaps, budget hits,
/// LOD bias. Returns 0.
EMSCRIPTEN_KEEPALIVE int bw_counters(double* out) {
  auto& c = client();
  if (!c.started || !out) return btflod::web::kBadArgument;
  const auto& s = c.streamer.scheduler();
  const auto& f = s.frame();
  out[0] = s.u_loaded(0);
  out[1] = c.materials.size() > 1 ? s.u_loaded(1) : 0;
  out[2] = c.streamer.cache().used_count();
  out[3] = static_cast<double>(f.adds);
  out[4] = static_cast<double>(f.requests);
  out[5] = static_cast<double>(f.u_requests);
  out[6] = static_cast<double>(f.swaps);
  out[7] = static_cast<double>(f.swaps_rejected);
  out[8] = static_cast<double>(f.budget_hits());
  out[9] = s.lod_bias();
  return 0;
}

/// The scheduler's global LOD bias (raised under overload; 0 when requests are at full detail).
EMSCRIPTEN_KEEPALIVE int bw_lod_bias() {
  auto& c = client();
  return c.started ? static_cast<int>(c.streamer.scheduler().lod_bias()) : 0;
}

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
