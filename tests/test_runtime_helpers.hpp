// Shared by the runtime tests (test_runtime_*.cpp): the reference texels of a tile, decoded
// straight from its container; small synthetic worlds of containers; an engine stand-in that
// keeps what the GPU would (cache slots, page tables, U′ packets) and checks it against the
// Streamer's cache; an engine-owned asynchronous I/O queue.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <deque>
#include <memory>
#include <new>
#include <span>
#include <utility>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "btflod/runtime/vt/tile_id.hpp"

namespace btflod_test {

/// Decodes tile t (container-local ids) of a container directly — the chain root → t, each
/// level against its decoded parent — and returns its float values. Fails the calling test
/// (EXPECT) when a payload does not decode.
inline std::vector<float> decode_direct_floats(const std::vector<uint8_t>& file, const btflod::BsvtfDirectory& d,
                                               btflod::TileId t) {
  using namespace btflod;
  const TileLayout layout = d.metadata.layout();
  TileDecoder dec(layout);
  std::vector<float> scratch(layout.sample_count()), out(layout.sample_count());
  EXPECT_EQ(decode_bsvtf_tile(d, file, t, dec, scratch, out), Status::success);
  return out;
}

/// decode_direct_floats() as half texels: the reference the runtime's rgba16f uploads must equal.
inline std::vector<uint16_t> decode_direct(const std::vector<uint8_t>& file, const btflod::BsvtfDirectory& d,
                                           btflod::TileId t) {
  const std::vector<float> f = decode_direct_floats(file, d, t);
  std::vector<uint16_t> h(f.size());
  btflod::float_to_half(f, h);
  return h;
}

using namespace btflod;

inline constexpr uint32_t kLights = 4, kViews = 5;

// Fills e's textures (size × size texels, C components) with smooth waves:
// 0.5 + 0.4 sin(fx (x + 1)(c + 1) + fy y (seed + 1)) / (1 + falloff · c).
inline void fill_smooth_textures(EigenTextures& e, uint32_t size, uint32_t components, uint32_t seed, float fx,
                                 float fy, float falloff) {
  e.textures.resize(static_cast<int>(size), static_cast<int>(size), static_cast<int>(components));
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x)
      for (uint32_t c = 0; c < components; ++c)
        e.textures.at(static_cast<int>(x), static_cast<int>(y), static_cast<int>(c)) =
            0.5f + 0.4f * std::sin(fx * (x + 1.0f) * (c + 1) + fy * y * (seed + 1)) / (1.0f + falloff * c);
}

// A smooth synthetic material: C components over W×H texels, U′ with kLights × kViews × 3 rows
// light-major (rows (l · V + v) · 3 + c).
inline EigenTextures make_eigen(uint32_t size, uint32_t components, uint32_t seed) {
  EigenTextures e;
  fill_smooth_textures(e, size, components, seed, 0.05f, 0.03f, 1.0f);
  e.light_count = kLights;
  e.view_count = kViews;
  e.angular.resize(size_t{kLights} * kViews * 3 * components);
  for (size_t i = 0; i < e.angular.size(); ++i) e.angular[i] = 0.1f + 0.01f * static_cast<float>((i * 7 + seed) % 50);
  return e;
}

inline std::vector<float> directions(uint32_t n) {
  std::vector<float> d;
  for (uint32_t i = 0; i < n; ++i) {
    const float a = 0.7f * i;
    d.insert(d.end(), {0.3f * std::cos(a), 0.3f * std::sin(a), std::sqrt(1.0f - 0.09f)});
  }
  return d;
}

// U′ of e in view-major order.
inline std::vector<float> to_view_major(const EigenTextures& e) {
  const uint32_t C = e.components();
  std::vector<float> out(e.angular.size());
  for (uint32_t l = 0; l < e.light_count; ++l)
    for (uint32_t v = 0; v < e.view_count; ++v)
      for (uint32_t c = 0; c < 3; ++c)
        for (uint32_t k = 0; k < C; ++k)
          out[((size_t{v} * e.light_count + l) * 3 + c) * C + k] =
              e.angular[((size_t{l} * e.view_count + v) * 3 + c) * C + k];
  return out;
}

inline std::vector<uint8_t> build(const EigenTextures& e, AngularRowOrder order = AngularRowOrder::light_major,
                                  uint32_t tile_size = 32) {
  BsvtfFromEigenOptions o;
  o.tile_size = tile_size;
  o.border = 4;
  o.light_directions = directions(kLights);
  o.view_directions = directions(kViews);
  if (order == AngularRowOrder::view_major) {
    EigenTextures vm = e;
    vm.angular = to_view_major(e);
    vm.row_order = AngularRowOrder::view_major;
    return build_bsvtf_from_eigen_textures(vm, o).value();
  }
  return build_bsvtf_from_eigen_textures(e, o).value();
}

struct World {
  std::vector<std::vector<uint8_t>> files;
  std::vector<BsvtfDirectory> dirs;
  std::vector<std::unique_ptr<MemorySource>> sources;
  std::vector<StreamerMaterial> materials;
  void add(std::vector<uint8_t> file) { files.push_back(std::move(file)); }
  void finish(AsyncTileSource* async = nullptr) {
    for (auto& f : files) {
      dirs.push_back(read_bsvtf(f).value());
      sources.push_back(std::make_unique<MemorySource>(std::span<const uint8_t>(f)));
    }
    for (size_t i = 0; i < files.size(); ++i)
      materials.push_back(StreamerMaterial{&dirs[i], async ? nullptr : sources[i].get(), async});
  }
};

inline StreamerConfig small_config() {
  StreamerConfig c;
  c.cache = CacheConfig{8, 8, 1u << 12, 32, 4, 1};
  c.scheduler.budgets.uploads_per_frame = 8;
  c.scheduler.budgets.requests_in_flight = 16;
  c.vote_window_frames = 1;
  return c;
}

// The engine's allocator callbacks, counting the bytes and blocks they hold.
struct CountingHeap {
  int64_t bytes = 0, blocks = 0;
  static void* allocate(void* user, size_t n, size_t alignment) {
    auto* l = static_cast<CountingHeap*>(user);
    l->bytes += static_cast<int64_t>(n);
    ++l->blocks;
    return ::operator new(n, std::align_val_t(alignment));
  }
  static void deallocate(void* user, void* p, size_t n, size_t alignment) {
    auto* l = static_cast<CountingHeap*>(user);
    l->bytes -= static_cast<int64_t>(n);
    --l->blocks;
    ::operator delete(p, std::align_val_t(alignment));
  }
  RuntimeAllocator callbacks() { return RuntimeAllocator{&allocate, &deallocate, this}; }
};

// Every finest tile of every material voted once per frame.
inline std::vector<uint32_t> full_feedback(const Streamer& s) {
  std::vector<uint32_t> words;
  for (uint32_t m = 0; m < s.material_count(); ++m) {
    const VtLevelTable& lv = s.cache().set().material(m).levels;
    const uint32_t L = lv.finest_level();
    for (uint32_t y = 0; y < lv.tiles_y[L]; ++y)
      for (uint32_t x = 0; x < lv.tiles_x[L]; ++x) words.push_back(pack_feedback(FeedbackTile{m, L, x, y}));
  }
  return words;
}

// The output buffers an engine hands to Streamer::update(): room for every upload one update
// can make, `writes` page-table writes and `events` residency events.
struct StreamerOutputBuffers {
  std::vector<StreamerTileUpload> tile_out;
  std::vector<StreamerPacketUpload> packet_out;
  std::vector<PageTableWrite> writes_out;
  std::vector<ResidencyEvent> events_out;
  StreamerOutputBuffers(const Streamer& s, size_t writes, size_t events)
      : tile_out(s.tile_uploads_bound()),
        packet_out(s.packet_uploads_bound()),
        writes_out(writes),
        events_out(events) {}
  StreamerOutputs outputs() { return StreamerOutputs{tile_out, packet_out, writes_out, events_out}; }
};

// Index of an upload's slot among all of the Streamer's slots (the cache's global slot): the
// pool's first slot plus the slot within the pool that the upload names.
inline uint32_t global_slot(const Streamer& s, const StreamerTileUpload& u) {
  return s.cache().pool_first_slot(u.pool) + u.slot;
}

// What an engine keeps: the cache textures (per slot texels, every pool's slots in the
// cache's global order), the GPU page table, U′ packets.
struct Engine : StreamerOutputBuffers {
  std::vector<std::vector<uint16_t>> slots;
  std::vector<std::vector<uint32_t>> page_table;  // per texture, flat tile index
  std::vector<std::vector<uint16_t>> packets;     // per global texture
  std::vector<uint32_t> ready;
  uint64_t tile_uploads = 0;
  explicit Engine(const Streamer& s, size_t writes = 4096) : StreamerOutputBuffers(s, writes, 64) {
    slots.resize(s.cache().slot_count());
    for (uint32_t t = 0; t < s.cache().set().texture_count(); ++t)
      page_table.emplace_back(s.cache().set().levels_of(t).tile_count(), 0xffffffffu);
    packets.resize(s.cache().set().texture_count());
  }
  void apply(const Streamer& s, const StreamerOutputs& o) {
    for (size_t i = 0; i < o.tile_upload_count; ++i) {
      slots[global_slot(s, o.tile_uploads[i])].assign(o.tile_uploads[i].texels.begin(), o.tile_uploads[i].texels.end());
      ++tile_uploads;
    }
    for (size_t i = 0; i < o.packet_upload_count; ++i)
      packets[o.packet_uploads[i].texture].assign(o.packet_uploads[i].halves.begin(), o.packet_uploads[i].halves.end());
    for (size_t i = 0; i < o.page_table_write_count; ++i) {
      const PageTableWrite& w = o.page_table_writes[i];
      page_table[w.tile.texture][s.cache().set().levels_of(w.tile.texture).index(w.tile)] = w.entry;
    }
    for (size_t i = 0; i < o.event_count; ++i)
      if (o.events[i].kind == ResidencyEventKind::material_ready) ready.push_back(o.events[i].material);
  }
  // One frame: fresh output spans in o, s.update(feedback, o) and, when it succeeds, its
  // outputs applied. Returns what update() returned.
  Status frame(Streamer& s, std::span<const uint32_t> feedback, StreamerOutputs& o) {
    o = outputs();
    const Status status = s.update(feedback, o);
    if (status == Status::success) apply(s, o);
    return status;
  }
};

// Checks the engine's copies against the streamer's cache: every resident slot holds the
// tile's exact texels, every GPU page-table texel the shader can reach is right.
inline void check_engine(const World& w, const Streamer& s, const Engine& e) {
  const TileCache& c = s.cache();
  for (uint32_t slot = 0; slot < c.slot_count(); ++slot) {
    const SlotInfo& si = c.slot(slot);
    if (si.state != SlotInfo::State::used) continue;
    const uint32_t m = c.set().material_of(si.tile.texture);
    if (si.tile.level == 0 && !s.material_ready(m)) continue;  // pinned root still loading
    const TileId local{si.tile.texture - s.first_texture(m), si.tile.level, si.tile.x, si.tile.y};
    ASSERT_EQ(e.slots[slot], decode_direct(w.files[m], w.dirs[m], local)) << "slot " << slot;
  }
  for (uint32_t t = 0; t < c.set().texture_count(); ++t) {
    const VtLevelTable& lv = c.set().levels_of(t);
    for (uint32_t i = 0; i < lv.tile_count(); ++i) {
      const TileId id = lv.tile(t, i);
      if (c.resident(id) || id.level == lv.finest_level()) {
        ASSERT_EQ(e.page_table[t][i], gpu_page_entry(c, id));
      }
    }
  }
}

inline uint32_t run(Streamer& s, Engine& e, const std::vector<uint32_t>& fb, uint32_t frames) {
  uint32_t uploads = 0;
  for (uint32_t f = 0; f < frames; ++f) {
    StreamerOutputs o = e.outputs();
    EXPECT_EQ(s.update(fb, o), Status::success);
    uploads += static_cast<uint32_t>(o.tile_upload_count);
    e.apply(s, o);
    s.pump();
  }
  return uploads;
}

// An engine-owned I/O queue: reads are served one update later, from memory.
struct QueueSource final : AsyncTileSource {
  struct Read {
    uint64_t offset;
    std::span<uint8_t> out;
    uint64_t ticket;
    size_t file;
  };
  std::vector<std::vector<uint8_t>>* files = nullptr;
  std::deque<Read> reads;
  size_t file = 0;
  bool refuse_next = true;
  bool start_read(uint64_t offset, std::span<uint8_t> out, uint64_t ticket) noexcept override {
    if (refuse_next) {  // the first read is refused: the runtime must retry it
      refuse_next = false;
      return false;
    }
    reads.push_back(Read{offset, out, ticket, file});
    return true;
  }
  // Serves the oldest read from memory and reports it complete; returns what complete_read()
  // returned (the job it made runnable, or Streamer::kNoJob). reads must not be empty.
  uint32_t complete_front(Streamer& s) {
    const Read r = reads.front();
    reads.pop_front();
    std::memcpy(r.out.data(), (*files)[r.file].data() + r.offset, r.out.size());
    return s.complete_read(r.ticket, Status::success);
  }
  void complete_all(Streamer& s) {
    while (!reads.empty()) complete_front(s);
  }
};

// Finishes w with every read going through q, which refuses its first read when refuse_first.
inline void finish_queued(World& w, QueueSource& q, bool refuse_first = true) {
  q.files = &w.files;
  q.refuse_next = refuse_first;
  w.finish(&q);
}

}  // namespace btflod_test
