// Allocation callbacks (core/allocator.hpp RuntimeAllocator) reach every array of the runtime's
// objects: the VtSet, TileCache, Scheduler and PayloadCache allocate only through the callbacks
// given at creation — no global operator new while they are built, copied or moved — return
// every byte when they go, and allocate nothing while they work. A Streamer built with
// callbacks makes no global operator new call of its own: the only ones left during create()
// are its tile decoders' (runtime/codec/tile_codec.hpp owns their symbol buffers), counted exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <new>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/stream/payload_cache.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "btflod/runtime/vt/scheduler.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "test_counting_new.hpp"
#include "test_wave_container.hpp"

using namespace btflod;

namespace {

struct Counter {
  int64_t live = 0;
  uint64_t calls = 0;
  uint64_t bytes = 0;
};

RuntimeAllocator counting(Counter& c) {
  RuntimeAllocator a;
  a.user = &c;
  a.allocate = [](void* u, size_t n, size_t align) -> void* {
    auto* k = static_cast<Counter*>(u);
    k->live += static_cast<int64_t>(n);
    k->bytes += n;
    ++k->calls;
    return ::operator new(n, std::align_val_t(align), std::nothrow);
  };
  a.deallocate = [](void* u, void* p, size_t n, size_t align) {
    static_cast<Counter*>(u)->live -= static_cast<int64_t>(n);
    ::operator delete(p, std::align_val_t(align), std::nothrow);
  };
  return a;
}

// Three materials, 1 to 3 virtual textures each.
VtSet make_set() {
  VtSet set;
  set.add_material(VtGeometry::make(256, 256, 32, 4), 2);
  set.add_material(VtGeometry::make(96, 200, 32, 4), 1);
  set.add_material(VtGeometry::make(512, 128, 32, 4), 3);
  for (uint32_t t = 0; t < set.texture_count(); ++t)
    for (Half& w : set.weights(t)) w = Half(0.5f + 0.1f * static_cast<float>(t));
  return set;
}

std::vector<uint32_t> every_finest_tile(const VtSet& set) {
  std::vector<uint32_t> words;
  for (uint32_t m = 0; m < set.material_count(); ++m) {
    const VtLevelTable& lv = set.material(m).levels;
    const uint32_t L = lv.finest_level();
    for (uint32_t y = 0; y < lv.tiles_y[L]; ++y)
      for (uint32_t x = 0; x < lv.tiles_x[L]; ++x) words.push_back(pack_feedback(FeedbackTile{m, L, x, y}));
  }
  return words;
}

}  // namespace

// VtSet, TileCache and Scheduler: built, copied and moved through the callbacks only; a cache
// under add/swap pressure and the scheduler's frames allocate nothing; every byte comes back.
TEST(RuntimeAllocator, CacheSchedulerAndSetAllocateOnlyThroughTheCallbacks) {
  const VtSet source = make_set();  // operator new: built before counting
  const std::vector<uint32_t> words = every_finest_tile(source);
  VoteCounter votes(vote_layouts(source));
  votes.count(words);
  Counter counter;
  const RuntimeAllocator al = counting(counter);
  {
    const uint64_t global_before = btflod_test::global_news();
    VtSet set(source, al);
    EXPECT_EQ(set.texture_count(), source.texture_count());
    EXPECT_EQ(set.weights(5)[3], source.weights(5)[3]);
    const uint64_t set_calls = counter.calls;
    EXPECT_GE(set_calls, 5u);
    auto cache = TileCache::create(set, TileCacheConfig{4, 4, 64}, al);
    ASSERT_TRUE(cache.ok()) << cache.message();
    const uint64_t cache_calls = counter.calls - set_calls;
    EXPECT_GE(cache_calls, 12u);  // its arrays and its set's copy
    auto sched = Scheduler::create(*cache, SchedulerConfig{}, al);
    ASSERT_TRUE(sched.ok()) << sched.message();
    EXPECT_GE(counter.calls - set_calls - cache_calls, 20u);
    EXPECT_EQ(btflod_test::global_news(), global_before) << "a set-up allocation bypassed the callbacks";
    TileCache moved_cache = std::move(*cache);
    Scheduler moved_sched = std::move(*sched);
    const TileCache copied = moved_cache;  // copies allocate through the same callbacks
    EXPECT_EQ(btflod_test::global_news(), global_before);
    const uint64_t calls = counter.calls;
    uint64_t swaps = 0;
    for (uint64_t f = 1; f <= 30; ++f) {
      moved_sched.run_frame(moved_cache, votes, f);
      swaps += moved_sched.frame().swaps;
    }
    EXPECT_GE(moved_sched.total().uploads, 10u);                // every free slot filled
    EXPECT_GT(swaps + moved_sched.total().swaps_rejected, 0u);  // then the 16 slots were full
    EXPECT_EQ(counter.calls, calls) << "a frame allocated";
    EXPECT_EQ(btflod_test::global_news(), global_before);
    EXPECT_TRUE(moved_cache.check_invariants());
    EXPECT_GT(counter.live, 0);
  }
  EXPECT_EQ(counter.live, 0) << "bytes not returned";
}

// PayloadCache: the arena, chunk links, entries and index come from the callbacks (the arena's
// bytes at least), puts and gets allocate nothing, every byte comes back; a failing callback
// leaves a cache that holds nothing and says so.
TEST(RuntimeAllocator, PayloadCacheAllocatesThroughTheCallbacksAndReportsFailure) {
  Counter counter;
  const RuntimeAllocator al = counting(counter);
  {
    std::vector<uint8_t> bytes(700), out(700);
    for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<uint8_t>(i * 7);
    const uint64_t global_before = btflod_test::global_news();
    PayloadCache cache(PayloadCacheConfig{64u << 10, 100, 256}, al);
    EXPECT_FALSE(cache.allocation_failed());
    EXPECT_EQ(counter.calls, 4u);
    EXPECT_GE(counter.bytes, 64u << 10);
    PayloadCache moved = std::move(cache);
    const uint64_t global_mid = btflod_test::global_news();
    for (uint64_t k = 0; k < 300; ++k) EXPECT_TRUE(moved.put(k, bytes));
    EXPECT_EQ(moved.get(299, out), bytes.size());
    EXPECT_EQ(out, bytes);
    EXPECT_GT(moved.evictions(), 0u);
    EXPECT_EQ(btflod_test::global_news(), global_mid);
    EXPECT_EQ(global_mid, global_before);
    EXPECT_EQ(counter.calls, 4u);
  }
  EXPECT_EQ(counter.live, 0);
  RuntimeAllocator failing;
  failing.allocate = [](void*, size_t, size_t) -> void* { return nullptr; };
  failing.deallocate = [](void*, void*, size_t, size_t) {};
  PayloadCache none(PayloadCacheConfig{64u << 10, 100, 256}, failing);
  EXPECT_TRUE(none.allocation_failed());
  const uint8_t b[4] = {1, 2, 3, 4};
  EXPECT_FALSE(none.put(1, b));
  EXPECT_EQ(none.arena_bytes(), 0u);
}

// A tile decoder on the zlib backend takes its symbol buffer, its inflate state and zlib's own
// state and 32 KiB window from the callbacks, and gives every byte back.
TEST(RuntimeAllocator, TileDecoderAllocatesThroughTheCallbacks) {
  Counter counter;
  {
    const uint64_t global_before = btflod_test::global_news();
    TileDecoder decoder(TileLayout{32, 4, 4}, InflateBackend::zlib, counting(counter));
    EXPECT_EQ(btflod_test::global_news(), global_before);
    EXPECT_GE(counter.calls, 4u);  // symbols, inflater state, zlib's state, zlib's window
    EXPECT_GE(counter.bytes, tile_symbol_bound(TileLayout{32, 4, 4}) + (32u << 10));
    EXPECT_EQ(decoder.backend(), InflateBackend::zlib);
  }
  EXPECT_EQ(counter.live, 0);
  RuntimeAllocator failing;
  failing.allocate = [](void*, size_t, size_t) -> void* { return nullptr; };
  failing.deallocate = [](void*, void*, size_t, size_t) {};
  TileDecoder none(TileLayout{32, 4, 4}, InflateBackend::zlib, failing);
  std::vector<float> out(TileLayout{32, 4, 4}.sample_count());
  const uint8_t payload[16] = {};
  EXPECT_EQ(none.decode(payload, {}, 0, 0, out), Status::invalid_argument);
}

// Streamer::create with callbacks and the zlib inflate backend: no global operator new call at
// all — tile cache, scheduler, vote counter, payload cache, job buffers, the tile decoders and
// the temporaries of create() go through the callbacks; destruction returns every byte and
// streaming allocates nothing.
TEST(RuntimeAllocator, StreamerCreateAllocatesOnlyThroughTheCallbacks) {
  const std::vector<uint8_t> file =
      btflod_test::build_wave_container(96, 6, 0.1f, 0.07f, {0, 0, 1, 0, 0.6f, 0.8f, -0.6f, 0, 0.8f}).value();
  const BsvtfDirectory dir = read_bsvtf(file).value();
  MemorySource source{std::span<const uint8_t>(file)};
  const StreamerMaterial material{&dir, &source, nullptr};
  StreamerConfig cfg;
  cfg.cache = CacheConfig{6, 6, 1u << 12, 32, 4, 1};
  cfg.scheduler.budgets.uploads_per_frame = 4;
  cfg.scheduler.budgets.requests_in_flight = 8;
  cfg.root_jobs = 2;
  cfg.inflate_backend = InflateBackend::zlib;
  Counter counter;
  cfg.allocator = counting(counter);
  const uint64_t decoders =
      cfg.scheduler.budgets.requests_in_flight + cfg.scheduler.budgets.uploads_per_frame + cfg.root_jobs;
  {
    const uint64_t before = btflod_test::global_news();
    auto created = Streamer::create(std::span<const StreamerMaterial>(&material, 1), cfg);
    ASSERT_TRUE(created.ok()) << created.message();
    EXPECT_EQ(btflod_test::global_news(), before) << "create() called the global operator new";
    EXPECT_GE(counter.bytes, decoders * (32u << 10)) << "the decoders' zlib windows are callback memory";
    Streamer s = std::move(*created);
    EXPECT_GT(counter.calls, 40u);
    EXPECT_GT(counter.live, int64_t{8} << 20);  // the 8 MiB payload cache is callback memory
    std::vector<StreamerTileUpload> tiles(s.tile_uploads_bound());
    std::vector<StreamerPacketUpload> packets(s.packet_uploads_bound());
    std::vector<PageTableWrite> writes(1024);
    std::vector<ResidencyEvent> events(16);
    const std::vector<uint32_t> fb = every_finest_tile(s.cache().set());
    const uint64_t calls = counter.calls, global = btflod_test::global_news();
    for (int f = 0; f < 20; ++f) {
      StreamerOutputs out{tiles, packets, writes, events};
      ASSERT_EQ(s.update(fb, out), Status::success);
      s.pump();
    }
    EXPECT_TRUE(s.material_ready(0));
    EXPECT_GT(s.scheduler().total().uploads, 4u);
    EXPECT_EQ(counter.calls, calls);
    EXPECT_EQ(btflod_test::global_news(), global);
  }
  EXPECT_EQ(counter.live, 0);
}
