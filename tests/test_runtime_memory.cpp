// btflod-label: unit
// Tests for Streamer::memory_required() (runtime/streamer.hpp): the memory a Streamer would
// hold, computed before creating it, equals, category by category and in allocations, what the
// created Streamer reports (stats().memory) and what went through the engine's allocator, for
// configurations that change every category; and it refuses what create() refuses.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "btflod/runtime/streamer.hpp"
#include "test_runtime_helpers.hpp"

using namespace btflod;
using namespace btflod_test;

namespace {

World two_materials() {
  World w;
  w.add(build(make_eigen(96, 6, 1)));
  w.add(build(make_eigen(64, 4, 2)));
  w.finish();
  return w;
}

void expect_same(const StreamerMemory& predicted, const StreamerMemory& held) {
  EXPECT_EQ(predicted.tile_cache, held.tile_cache);
  EXPECT_EQ(predicted.scheduler, held.scheduler);
  EXPECT_EQ(predicted.votes, held.votes);
  EXPECT_EQ(predicted.payload_cache, held.payload_cache);
  EXPECT_EQ(predicted.job_buffers, held.job_buffers);
  EXPECT_EQ(predicted.decoders, held.decoders);
  EXPECT_EQ(predicted.decoded_cache, held.decoded_cache);
  EXPECT_EQ(predicted.tables, held.tables);
  EXPECT_EQ(predicted.total, held.total);
  EXPECT_EQ(predicted.allocations, held.allocations);
}

// Predicts, creates with a counting engine allocator, and compares the prediction with the
// Streamer's report and with what the allocator holds (the ledger's own block included).
void check(std::span<const StreamerMaterial> materials, StreamerConfig config, const char* what) {
  SCOPED_TRACE(what);
  auto predicted = Streamer::memory_required(materials, config);
  ASSERT_TRUE(predicted) << predicted.error().message;
  CountingHeap heap;
  config.allocator = heap.callbacks();
  {
    auto s = Streamer::create(materials, config);
    ASSERT_TRUE(s) << s.error().message;
    expect_same(predicted.value(), s.value().stats().memory);
    EXPECT_EQ(static_cast<int64_t>(predicted.value().total), heap.bytes);
    EXPECT_EQ(static_cast<int64_t>(predicted.value().allocations), heap.blocks);
  }
  EXPECT_EQ(heap.bytes, 0);
}

}  // namespace

TEST(StreamerMemoryRequired, EqualsWhatTheCreatedStreamerHoldsForEveryCategory) {
  const World w = two_materials();
  const StreamerConfig base = small_config();
  check(w.materials, base, "small config");
  StreamerConfig c = base;
  c.payload_cache_bytes = StreamerConfig{}.payload_cache_bytes;
  c.vote_window_frames = StreamerConfig{}.vote_window_frames;
  c.decoded_cache_tiles = StreamerConfig{}.decoded_cache_tiles;
  check(w.materials, c, "default payload cache, vote window and decoded cache");

  c = base;
  c.decoded_cache_tiles = 0;
  c.payload_cache_bytes = 0;
  check(w.materials, c, "no decoded cache, no payload cache");

  c = base;
  c.vote_window_frames = 9;
  c.decode_workers = 7;
  c.root_jobs = 3;
  c.packet_jobs = 5;
  c.failure.held_tiles_capacity = 1000;
  c.scheduler.budgets.requests_in_flight = 41;
  c.scheduler.budgets.uploads_per_frame = 13;
  c.cache.delta_capacity = 777;
  check(w.materials, c, "every count changed");

  c = base;
  c.inflate_backend = InflateBackend::zlib;
  check(w.materials, c, "zlib tile decoders");

  // Room reserved for materials added later: the tables follow the capacity, not the materials.
  c = base;
  c.capacity = streamer_capacity_for(w.materials, 2);
  c.capacity.materials = 9;
  c.capacity.textures += 5;
  c.capacity.tiles += 3000;
  c.capacity.material_tiles += 1500;
  c.capacity.max_u_rows += 7;
  check(w.materials, c, "capacity beyond create()'s materials");
  check({}, c, "no materials, only a capacity");
}

TEST(StreamerMemoryRequired, GrowsWithTheBudgetsThatSizeIt) {
  const World w = two_materials();
  StreamerConfig c = small_config();
  const StreamerMemory m1 = Streamer::memory_required(w.materials, c).value();
  c.payload_cache_bytes *= 2;
  c.decode_workers *= 2;
  const StreamerMemory m2 = Streamer::memory_required(w.materials, c).value();
  // Twice the payload arena (its index and entry records do not change with the budget here).
  EXPECT_GT(m2.payload_cache, m1.payload_cache);
  const uint64_t budget = small_config().payload_cache_bytes;
  // The arena and its chunk links (512-byte chunks) double; the entry records and index do not.
  EXPECT_EQ(m2.payload_cache - m1.payload_cache, budget + budget / 512 * sizeof(uint32_t));
  EXPECT_EQ(m2.decoders, 2 * m1.decoders - (alignof(TileDecoder)));
  EXPECT_EQ(m2.tile_cache, m1.tile_cache);
  EXPECT_EQ(m2.scheduler, m1.scheduler);
}

TEST(StreamerMemoryRequired, RefusesWhatCreateRefuses) {
  const World w = two_materials();
  StreamerConfig c = small_config();
  c.capacity.textures = 1;  // below the materials' 3 textures
  auto r = Streamer::memory_required(w.materials, c);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().status, Status::invalid_argument);
  EXPECT_EQ(r.error().status, Streamer::create(w.materials, c).error().status);

  c = small_config();
  c.cache.slots_x = c.cache.slots_y = 1;  // one slot cannot pin three roots
  r = Streamer::memory_required(w.materials, c);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().status, Status::insufficient_space);

  EXPECT_FALSE(Streamer::memory_required({}, small_config()));  // nothing to stream, no room
}
