// btflod web streamer — the engine runtime (runtime/streamer.hpp: one Streamer per world, one
// update() per frame) compiled to WebAssembly, with JavaScript owning the I/O. This is the path
// a browser engine takes to adopt btflod: nothing here but a C interface over the library.
//
// Each material's bytes come from an AsyncTileSource whose start_read() only records the read
// (ticket, material, byte range, destination in the wasm heap); JavaScript takes the list after
// update() (bs_take_reads), fetches the ranges however it likes (fetch with `Range:`, a cache,
// a worker), copies the bytes to the destination and reports each read with
// bs_complete_read(ticket, status), in any order. bs_pump() then runs the decode jobs on the
// calling thread (the browser's main thread; a wasm build without threads). The Streamer
// verifies every payload (size, CRC-32) before decoding it, so JavaScript never checks bytes.
//
// Per frame: bs_update(feedback words) → tile uploads (slot, tile, half texels in the heap),
// U′ packet uploads, page-table writes and residency events, each read through a flat uint32
// view; then bs_take_reads() and bs_pump(). Pointers handed out stay valid until the next
// bs_update(). Set-up allocates; bs_update, bs_pump and bs_complete_read do not.
//
// samples/web/test/node_streamer.mjs drives this module under Node with out-of-order, failing
// and corrupted reads and checks it against independent decodes. The viewer's module
// (web_client.cpp) runs the same Streamer and adds what the page draws with.
#define BTFLOD_IMPLEMENTATION 1
#include <emscripten/emscripten.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/streamer.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"
#include "js_read_queue.hpp"

namespace btflod::web {

/// The module's state: the directories, their sources, the Streamer and the output buffers.
struct WebStreamer {
  std::string error;
  std::vector<std::unique_ptr<BsvtfDirectory>> directories;
  std::unique_ptr<JsReadQueue> read_queue;
  std::vector<std::unique_ptr<JsSource>> sources;
  Streamer streamer;
  bool created = false;
  // Caller-owned outputs of update() and their flat views for JavaScript.
  std::vector<StreamerTileUpload> tile_uploads;
  std::vector<StreamerPacketUpload> packet_uploads;
  std::vector<PageTableWrite> page_writes;
  std::vector<ResidencyEvent> events;
  StreamerOutputs outputs;
  std::vector<uint32_t> tile_view, packet_view, page_view, event_view;

  int fail(int code, std::string message) {
    error = std::move(message);
    return -code;
  }
};

WebStreamer& state() {
  static WebStreamer s;
  return s;
}

inline uint32_t heap_address(const void* p) { return static_cast<uint32_t>(reinterpret_cast<uintptr_t>(p)); }

}  // namespace btflod::web

using btflod::Status;
using btflod::web::state;

extern "C" {

/// Message of the last failure. Valid until the next call.
EMSCRIPTEN_KEEPALIVE const char* bs_last_error() { return state().error.c_str(); }

/// Adds a material from a prefix of its container holding header and directory (or the whole
/// file); file_size is the container's size. Returns the material index or −status. Untrusted
/// bytes: parse_bsvtf_directory validates them. Before bs_create only.
EMSCRIPTEN_KEEPALIVE int bs_add_material(const uint8_t* bytes, uint32_t len, double file_size) {
  auto& s = state();
  if (s.created) return s.fail(static_cast<int>(Status::invalid_argument), "bs_add_material after bs_create");
  if (!bytes || !(file_size >= 0 && file_size < 9.0e15))
    return s.fail(static_cast<int>(Status::invalid_argument), "bad arguments");
  auto d = btflod::parse_bsvtf_directory(std::span<const uint8_t>(bytes, len), static_cast<uint64_t>(file_size));
  if (!d) return s.fail(static_cast<int>(d.status()), d.message());
  s.directories.push_back(std::make_unique<btflod::BsvtfDirectory>(std::move(*d)));
  return static_cast<int>(s.directories.size() - 1);
}

/// Creates the Streamer over every added material: a cache of slots_x × slots_y slots, the
/// scheduler's upload and request budgets, `decoded_cache_tiles` decoded ancestors kept, and at
/// most `max_reads` reads recorded per update. Returns 0 or −status (message: bs_last_error).
EMSCRIPTEN_KEEPALIVE int bs_create(uint32_t slots_x, uint32_t slots_y, uint32_t uploads_per_frame,
                                   uint32_t requests_in_flight, uint32_t decoded_cache_tiles, uint32_t max_reads) {
  using namespace btflod;
  auto& s = state();
  if (s.created || s.directories.empty())
    return s.fail(static_cast<int>(Status::invalid_argument), "bs_create: no materials or already created");
  if (max_reads == 0 || uploads_per_frame == 0 || requests_in_flight == 0)
    return s.fail(static_cast<int>(Status::invalid_argument), "bs_create: zero budget");
  s.read_queue = std::make_unique<web::JsReadQueue>(max_reads);
  std::vector<StreamerMaterial> materials;
  for (uint32_t m = 0; m < s.directories.size(); ++m) {
    s.sources.push_back(std::make_unique<web::JsSource>(*s.read_queue, m));
    StreamerMaterial sm;
    sm.directory = s.directories[m].get();
    sm.async_source = s.sources.back().get();
    materials.push_back(sm);
  }
  const BsvtfMetadata& md = s.directories.front()->metadata;
  StreamerConfig config;
  config.decode_workers = 1;  // the jobs run on the page's thread (bs_pump)
  config.cache = CacheConfig{slots_x, slots_y, 1u << 16, md.tile_size, md.border, 1};
  config.scheduler.budgets.uploads_per_frame = uploads_per_frame;
  config.scheduler.budgets.requests_in_flight = requests_in_flight;
  config.scheduler.budgets.tiles_decoding = requests_in_flight;
  config.decoded_cache_tiles = decoded_cache_tiles;
  auto created = Streamer::create(materials, config);
  if (!created) return s.fail(static_cast<int>(created.status()), created.message());
  s.streamer = std::move(*created);
  s.tile_uploads.resize(s.streamer.tile_uploads_bound());
  s.packet_uploads.resize(s.streamer.packet_uploads_bound());
  s.page_writes.resize(4096);
  s.events.resize(256);
  s.outputs.tile_uploads = s.tile_uploads;
  s.outputs.packet_uploads = s.packet_uploads;
  s.outputs.page_table_writes = s.page_writes;
  s.outputs.events = s.events;
  s.tile_view.resize(s.tile_uploads.size() * 6);
  s.packet_view.resize(s.packet_uploads.size() * 5);
  s.page_view.resize(s.page_writes.size() * 5);
  s.event_view.resize(s.events.size() * 7);
  s.created = true;
  return 0;
}

/// One frame: this frame's feedback words (null with count 0: no votes). Returns 0 or −status.
/// Then read the outputs with bs_tile_uploads / bs_packet_uploads / bs_page_writes / bs_events.
EMSCRIPTEN_KEEPALIVE int bs_update(const uint32_t* words, uint32_t count) {
  auto& s = state();
  if (!s.created) return s.fail(static_cast<int>(Status::invalid_argument), "bs_update before bs_create");
  if (!words && count) return s.fail(static_cast<int>(Status::invalid_argument), "null feedback");
  const Status st = s.streamer.update(std::span<const uint32_t>(words, count), s.outputs);
  if (st != Status::success) return s.fail(static_cast<int>(st), "update failed");
  const auto& o = s.outputs;
  for (size_t i = 0; i < o.tile_upload_count; ++i) {
    const auto& u = s.tile_uploads[i];
    const uint32_t v[6] = {u.slot,   u.tile.texture, u.tile.level,
                           u.tile.x, u.tile.y,       btflod::web::heap_address(u.texels.data())};
    std::copy(v, v + 6, s.tile_view.begin() + static_cast<std::ptrdiff_t>(i * 6));
  }
  for (size_t i = 0; i < o.packet_upload_count; ++i) {
    const auto& p = s.packet_uploads[i];
    const uint32_t v[5] = {p.material, p.packet, p.texture, p.rows, btflod::web::heap_address(p.halves.data())};
    std::copy(v, v + 5, s.packet_view.begin() + static_cast<std::ptrdiff_t>(i * 5));
  }
  for (size_t i = 0; i < o.page_table_write_count; ++i) {
    const auto& w = s.page_writes[i];
    const uint32_t v[5] = {w.tile.texture, w.page_mip, w.tile.x, w.tile.y, w.entry};
    std::copy(v, v + 5, s.page_view.begin() + static_cast<std::ptrdiff_t>(i * 5));
  }
  for (size_t i = 0; i < o.event_count; ++i) {
    const auto& e = s.events[i];
    const uint32_t v[7] = {static_cast<uint32_t>(e.kind),  e.material, e.tile.texture, e.tile.level, e.tile.x, e.tile.y,
                           static_cast<uint32_t>(e.status)};
    std::copy(v, v + 7, s.event_view.begin() + static_cast<std::ptrdiff_t>(i * 7));
  }
  return 0;
}

/// Counts of the last update's outputs and their flat views: tile uploads (slot, texture,
/// level, x, y, texels address; (T+2B)² × 4 half bits), packet uploads (material, packet,
/// texture, rows, halves address), page-table writes (texture, mip, x, y, entry), events
/// (kind, material, texture, level, x, y, status).
EMSCRIPTEN_KEEPALIVE uint32_t bs_tile_upload_count() {
  return static_cast<uint32_t>(state().outputs.tile_upload_count);
}
EMSCRIPTEN_KEEPALIVE const uint32_t* bs_tile_uploads() { return state().tile_view.data(); }
EMSCRIPTEN_KEEPALIVE uint32_t bs_packet_upload_count() {
  return static_cast<uint32_t>(state().outputs.packet_upload_count);
}
EMSCRIPTEN_KEEPALIVE const uint32_t* bs_packet_uploads() { return state().packet_view.data(); }
EMSCRIPTEN_KEEPALIVE uint32_t bs_page_write_count() {
  return static_cast<uint32_t>(state().outputs.page_table_write_count);
}
EMSCRIPTEN_KEEPALIVE const uint32_t* bs_page_writes() { return state().page_view.data(); }
EMSCRIPTEN_KEEPALIVE uint32_t bs_event_count() { return static_cast<uint32_t>(state().outputs.event_count); }
EMSCRIPTEN_KEEPALIVE const uint32_t* bs_events() { return state().event_view.data(); }

/// Takes the reads recorded since the last call; returns their count. bs_reads(): (ticket lo,
/// ticket hi, material, offset lo, offset hi, size, destination address) per read.
EMSCRIPTEN_KEEPALIVE uint32_t bs_take_reads() {
  auto& s = state();
  if (!s.created) return 0;
  return static_cast<uint32_t>(s.read_queue->take());
}
EMSCRIPTEN_KEEPALIVE const uint32_t* bs_reads() {
  auto& s = state();
  return s.created ? reinterpret_cast<const uint32_t*>(s.read_queue->taken().data()) : nullptr;
}

/// Reports a read: status 0 when its bytes are at the destination, else a Status value
/// (io_error, short_output, …). Each ticket once.
EMSCRIPTEN_KEEPALIVE void bs_complete_read(uint32_t ticket_lo, uint32_t ticket_hi, uint32_t status) {
  auto& s = state();
  if (!s.created) return;
  const Status st = status <= static_cast<uint32_t>(Status::cancelled) ? static_cast<Status>(status) : Status::io_error;
  s.streamer.complete_read(static_cast<uint64_t>(ticket_hi) << 32 | ticket_lo, st);
}

/// Runs up to max_jobs runnable decode jobs on this thread; returns how many ran.
EMSCRIPTEN_KEEPALIVE uint32_t bs_pump(uint32_t max_jobs) {
  return state().created ? state().streamer.pump(max_jobs) : 0;
}

/// The feedback word naming tile (level, x, y) of material m (runtime/lod/feedback.hpp).
EMSCRIPTEN_KEEPALIVE uint32_t bs_feedback_word(uint32_t m, uint32_t level, uint32_t x, uint32_t y) {
  return btflod::pack_feedback(btflod::FeedbackTile{m, level, x, y});
}

/// Material m: first virtual texture, texture count, finest level, tiles across and down at
/// `level`, ready (roots and U′ packets handed out). Returns 0 or −status.
EMSCRIPTEN_KEEPALIVE int bs_material_info(uint32_t m, uint32_t level, uint32_t* out) {
  auto& s = state();
  if (!s.created || m >= s.streamer.material_count() || !out)
    return s.fail(static_cast<int>(Status::invalid_argument), "bs_material_info: unknown material");
  const btflod::VtLevelTable& lv = s.streamer.cache().set().levels_of(s.streamer.first_texture(m));
  if (level > lv.finest_level()) return s.fail(static_cast<int>(Status::invalid_argument), "level past the finest");
  out[0] = s.streamer.first_texture(m);
  out[1] = s.streamer.texture_count(m);
  out[2] = lv.finest_level();
  out[3] = lv.tiles_x[level];
  out[4] = lv.tiles_y[level];
  out[5] = s.streamer.material_ready(m) ? 1 : 0;
  return 0;
}

/// Halves per tile upload, (T + 2B)² × 4 (every material shares T and B), or 0 before bs_create.
EMSCRIPTEN_KEEPALIVE uint32_t bs_tile_samples() {
  auto& s = state();
  return s.created ? static_cast<uint32_t>(s.directories.front()->metadata.layout().sample_count()) : 0;
}

/// Cache slot of global tile (texture, level, x, y), or 0xffffffff when it is not resident.
EMSCRIPTEN_KEEPALIVE uint32_t bs_slot_of(uint32_t texture, uint32_t level, uint32_t x, uint32_t y) {
  auto& s = state();
  if (!s.created || texture >= s.streamer.cache().set().texture_count()) return btflod::kNoSlot;
  return s.streamer.cache().slot_of(btflod::TileId{texture, level, x, y});
}

/// The page-table entry a rebuild from the cache gives tile (texture, level, x, y)
/// (runtime/backend/page_table_writes.hpp gpu_page_entry), to check a mirror of the writes.
EMSCRIPTEN_KEEPALIVE uint32_t bs_page_entry(uint32_t texture, uint32_t level, uint32_t x, uint32_t y) {
  auto& s = state();
  if (!s.created || texture >= s.streamer.cache().set().texture_count()) return 0;
  return btflod::gpu_page_entry(s.streamer.cache(), btflod::TileId{texture, level, x, y});
}

/// Streamer counters: bytes read, jobs in flight, decoded levels skipped, events dropped,
/// page-table writes pending, scheduler LOD bias. Returns 0.
EMSCRIPTEN_KEEPALIVE int bs_stats(double* out) {
  auto& s = state();
  if (!s.created || !out) return s.fail(static_cast<int>(Status::invalid_argument), "bs_stats");
  out[0] = static_cast<double>(s.streamer.bytes_read());
  out[1] = s.streamer.jobs_in_flight();
  out[2] = static_cast<double>(s.streamer.decoded_levels_skipped());
  out[3] = static_cast<double>(s.streamer.events_dropped());
  out[4] = static_cast<double>(s.streamer.pending_page_table_writes());
  out[5] = s.streamer.scheduler().lod_bias();
  return 0;
}

/// Decodes local tile (texture, level, x, y) of material m from the whole container `file`
/// with a fresh decoder, parent chain from the root — independently of the Streamer — into
/// (T+2B)² × 4 half bits at `out`. For checks. Returns 0 or −status.
EMSCRIPTEN_KEEPALIVE int bs_reference_tile(uint32_t m, uint32_t texture, uint32_t level, uint32_t x, uint32_t y,
                                           const uint8_t* file, uint32_t len, uint16_t* out) {
  using namespace btflod;
  auto& s = state();
  if (m >= s.directories.size() || !file || !out) return s.fail(static_cast<int>(Status::invalid_argument), "bad id");
  const BsvtfDirectory& d = *s.directories[m];
  const TileLayout layout = d.metadata.layout();
  TileDecoder decoder(layout);
  std::vector<float> parent, tile(layout.sample_count());
  for (uint32_t l = 0; l <= level; ++l) {
    const TileId id{texture, l, x >> (level - l), y >> (level - l)};
    const BsvtfTileEntry* e = d.find(id);
    if (!e || e->offset + e->size > len) return s.fail(static_cast<int>(Status::invalid_argument), "no such tile");
    const std::span<const uint8_t> payload(file + e->offset, e->size);
    if (verify_bsvtf_payload(e->size, e->crc, payload) != Status::success)
      return s.fail(static_cast<int>(Status::bad_data), "payload CRC mismatch");
    const Status st = decoder.decode(payload, parent, id.x & 1, id.y & 1, tile);
    if (st != Status::success) return s.fail(static_cast<int>(st), decoder.message());
    parent = tile;
  }
  float_to_half(tile, std::span<uint16_t>(out, layout.sample_count()));
  return 0;
}

}  // extern "C"
