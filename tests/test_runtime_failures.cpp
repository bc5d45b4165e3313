// btflod-label: unit threads
// Tests for the Streamer's failure policy, engine-owned jobs, quiescing and what the engine can
// see (runtime/streamer.hpp): a corrupt tile is retried with back-off at most
// tile_attempts times and then reported unavailable while its parent keeps serving; a corrupt
// root fails its material once and none of its children is ever requested; retry_material()
// after a repair brings it back; jobs handed out by update() and by complete_read() run exactly
// once; cancelled reads drain without counting failures and a Streamer destroyed with reads
// outstanding returns every byte; the memory report equals what went through the engine's
// allocator, with one decoder per declared worker.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "btflod/runtime/stream/thread_executor.hpp"
#include "btflod/runtime/streamer.hpp"
#include "test_runtime_helpers.hpp"

using namespace btflod;
using namespace btflod_test;

namespace {

// Flips a byte in the middle of a tile's payload (its CRC then fails; the directory is intact).
void corrupt_tile(World& w, size_t m, TileId local) {
  const BsvtfDirectory d = read_bsvtf(w.files[m]).value();
  const BsvtfTileEntry* e = d.find(local);
  ASSERT_NE(e, nullptr);
  w.files[m][e->offset + e->size / 2] ^= 0x5a;
}

struct EventLog {
  std::vector<ResidencyEvent> all;
  void add(const StreamerOutputs& o) { all.insert(all.end(), o.events.begin(), o.events.begin() + o.event_count); }
  size_t count(ResidencyEventKind k, uint32_t material, const TileId* tile = nullptr) const {
    return static_cast<size_t>(std::count_if(all.begin(), all.end(), [&](const ResidencyEvent& e) {
      return e.kind == k && e.material == material && (tile == nullptr || e.tile == *tile);
    }));
  }
};

// Runs frames with full feedback; jobs run on this thread.
void run_logged(Streamer& s, Engine& e, EventLog& log, uint32_t frames) {
  const auto fb = full_feedback(s);
  for (uint32_t f = 0; f < frames; ++f) {
    StreamerOutputs o;
    ASSERT_EQ(e.frame(s, fb, o), Status::success);
    log.add(o);
    s.pump();
  }
}

// Resumes s and runs 40 frames whose reads q serves: the material gets ready and the engine's
// copies are exact.
void resume_and_expect_loaded(const World& w, Streamer& s, Engine& e, QueueSource& q, const std::vector<uint32_t>& fb) {
  s.resume();
  for (int f = 0; f < 40; ++f) {
    StreamerOutputs o;
    ASSERT_EQ(e.frame(s, fb, o), Status::success);
    q.complete_all(s);
    s.pump();
  }
  EXPECT_TRUE(s.material_ready(0));
  check_engine(w, s, e);
}

}  // namespace

TEST(RuntimeFailures, CorruptTileIsRetriedWithBackOffThenReportedUnavailable) {
  World w;
  w.add(build(make_eigen(128, 4, 1)));  // one virtual texture, L = 2
  const TileId bad{0, 2, 1, 2};
  corrupt_tile(w, 0, bad);
  w.finish();
  StreamerConfig cfg = small_config();
  cfg.failure.tile_attempts = 3;
  cfg.failure.first_backoff_frames = 2;
  auto s = std::move(Streamer::create(w.materials, cfg).value());
  Engine e(s);
  EventLog log;
  run_logged(s, e, log, 80);
  const TileId global{s.first_texture(0), bad.level, bad.x, bad.y};
  // Exactly tile_attempts failures, then one terminal event; nothing after it.
  EXPECT_EQ(log.count(ResidencyEventKind::tile_failed, 0, &global), 3u);
  EXPECT_EQ(log.count(ResidencyEventKind::tile_unavailable, 0, &global), 1u);
  const StreamerStats st = s.stats();
  EXPECT_EQ(st.tile_failures, 3u);
  EXPECT_EQ(st.tiles_unavailable, 1u);
  EXPECT_EQ(st.tiles_backing_off, 0u);
  EXPECT_GE(st.retries, 2u);  // two back-offs ended
  // Its parent keeps serving its area; every other tile is exact.
  EXPECT_FALSE(s.cache().resident(global));
  EXPECT_TRUE(s.cache().resident(global.parent()));
  EXPECT_TRUE(s.scheduler().tile_held(global.texture, s.cache().set().levels_of(global.texture).index(global)));
  check_engine(w, s, e);
}

namespace {
// Every second read of one byte range fails.
struct FlakySource final : TileSource {
  std::span<const uint8_t> bytes;
  uint64_t flaky_offset = 0;
  uint32_t reads = 0;
  Result<uint64_t> size() override { return static_cast<uint64_t>(bytes.size()); }
  VoidResult read(uint64_t offset, std::span<uint8_t> out, const std::atomic<bool>* = nullptr) override {
    if (offset == flaky_offset && reads++ % 2 == 0) return make_error(Status::io_error, "flaky");
    std::memcpy(out.data(), bytes.data() + offset, out.size());
    return {};
  }
  std::string describe() const override { return "flaky"; }
};
}  // namespace

// Attempts count consecutive failures: a tile whose reads fail every other time is evicted and
// requested again and again, and is never given up with tile_attempts = 2.
TEST(RuntimeFailures, OnlyConsecutiveFailuresCountTowardsGivingUp) {
  World w;
  w.add(build(make_eigen(128, 4, 13)));  // L = 2: 4×4 finest tiles
  w.finish();
  const TileId flaky{0, 2, 0, 0};
  FlakySource src;
  src.bytes = w.files[0];
  src.flaky_offset = w.dirs[0].find(flaky)->offset;
  w.materials[0].source = &src;
  StreamerConfig cfg = small_config();
  cfg.cache.slots_x = 3;  // 6 slots: root, parent and four tiles of one corner; the other corner evicts them
  cfg.cache.slots_y = 2;
  cfg.payload_cache_bytes = 0;  // every request reads its payloads
  cfg.decoded_cache_tiles = 0;
  cfg.failure.tile_attempts = 2;
  cfg.failure.first_backoff_frames = 1;
  auto s = std::move(Streamer::create(w.materials, cfg).value());
  Engine e(s);
  EventLog log;
  uint32_t visits_resident = 0;
  for (uint32_t f = 0; f < 240; ++f) {
    const uint32_t half = (f / 30) % 2;  // two tiles of one corner, then of the opposite one, ...
    std::vector<uint32_t> fb;
    for (uint32_t y = 0; y < 2; ++y)
      for (uint32_t x = 0; x < 2; ++x) fb.push_back(pack_feedback(FeedbackTile{0, 2, 2 * half + x, 2 * half + y}));
    StreamerOutputs o;
    ASSERT_EQ(e.frame(s, fb, o), Status::success);
    log.add(o);
    s.pump();
    visits_resident += f % 30 == 29 && half == 0 && s.cache().resident(TileId{s.first_texture(0), 2, 0, 0});
  }
  EXPECT_GE(log.count(ResidencyEventKind::tile_failed, 0), 3u);  // failed on several visits
  EXPECT_EQ(log.count(ResidencyEventKind::tile_unavailable, 0), 0u);
  EXPECT_EQ(visits_resident, 4u);  // and was resident at the end of every visit
  check_engine(w, s, e);
}

TEST(RuntimeFailures, BackOffDoublesBetweenAttempts) {
  World w;
  w.add(build(make_eigen(128, 4, 2)));
  const TileId bad{0, 1, 0, 1};
  corrupt_tile(w, 0, bad);
  w.finish();
  StreamerConfig cfg = small_config();
  cfg.failure.tile_attempts = 4;
  cfg.failure.first_backoff_frames = 3;
  cfg.failure.max_backoff_frames = 100;
  auto s = std::move(Streamer::create(w.materials, cfg).value());
  Engine e(s);
  const auto fb = full_feedback(s);
  std::vector<uint64_t> frames_failed;
  for (uint32_t f = 1; f <= 60; ++f) {
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update(fb, o), Status::success);
    for (size_t i = 0; i < o.event_count; ++i)
      if (o.events[i].kind == ResidencyEventKind::tile_failed) frames_failed.push_back(f);
    e.apply(s, o);
    s.pump();
  }
  ASSERT_EQ(frames_failed.size(), 4u);
  // A failure seen at frame f is held until f + 3·2^(n−1); the request goes out then and its
  // job fails at the next update.
  EXPECT_EQ(frames_failed[1] - frames_failed[0], 3u + 1u);
  EXPECT_EQ(frames_failed[2] - frames_failed[1], 6u + 1u);
  EXPECT_EQ(frames_failed[3] - frames_failed[2], 12u + 1u);
}

TEST(RuntimeFailures, CorruptRootFailsItsMaterialOnceAndNoChildIsScheduled) {
  World w;
  w.add(build(make_eigen(128, 4, 3)));
  w.add(build(make_eigen(128, 4, 4)));
  const std::vector<uint8_t> intact = w.files[1];
  corrupt_tile(w, 1, TileId{0, 0, 0, 0});
  w.finish();
  StreamerConfig cfg = small_config();
  cfg.failure.startup_attempts = 3;
  cfg.failure.first_backoff_frames = 1;
  auto s = std::move(Streamer::create(w.materials, cfg).value());
  Engine e(s);
  EventLog log;
  run_logged(s, e, log, 60);
  EXPECT_TRUE(s.material_ready(0));
  EXPECT_FALSE(s.material_ready(1));
  EXPECT_TRUE(s.material_failed(1));
  EXPECT_EQ(log.count(ResidencyEventKind::material_failed, 1), 1u);
  // Only the root was ever tried: its three attempts, no child job.
  EXPECT_EQ(log.count(ResidencyEventKind::tile_failed, 1), 3u);
  EXPECT_EQ(s.stats().tile_failures, 3u);
  EXPECT_EQ(s.stats().materials_failed, 1u);
  const VtLevelTable& lv = s.cache().set().material(1).levels;
  for (uint32_t i = 1; i < lv.tile_count(); ++i) EXPECT_FALSE(s.cache().resident(lv.tile(s.first_texture(1), i)));
  EXPECT_GT(s.stats().feedback_ignored, 0u);  // the failed material's voted tiles
  check_engine(w, s, e);
  // The engine repairs the source and retries: the material loads and streams exactly.
  std::copy(intact.begin(), intact.end(), w.files[1].begin());  // the source reads these bytes
  EXPECT_EQ(s.retry_material(7), Status::invalid_argument);
  ASSERT_EQ(s.retry_material(1), Status::success);
  EXPECT_FALSE(s.material_failed(1));
  run_logged(s, e, log, 60);
  EXPECT_TRUE(s.material_ready(1));
  EXPECT_EQ(log.count(ResidencyEventKind::material_failed, 1), 1u);
  EXPECT_TRUE(s.cache().resident(lv.tile(s.first_texture(1), lv.tile_count() - 1)));
  check_engine(w, s, e);
}

// §6 streamed U′ packets: a damaged packet is retried packet_attempts times, then given up;
// the material's first packet and its tiles keep streaming.
TEST(RuntimeFailures, DamagedStreamedPacketIsGivenUpAndTheRestStreams) {
  World w;
  w.add(build(make_eigen(128, 8, 14)));  // two virtual textures, two U′ packets
  {
    const BsvtfDirectory d = read_bsvtf(w.files[0]).value();
    ASSERT_EQ(d.packets.size(), 2u);
    w.files[0][d.packets[1].offset + d.packets[1].size / 2] ^= 0x21;
  }
  w.finish();
  StreamerConfig cfg = small_config();
  cfg.scheduler.stream_u_columns = true;
  cfg.failure.packet_attempts = 3;
  cfg.failure.first_backoff_frames = 1;
  auto s = std::move(Streamer::create(w.materials, cfg).value());
  Engine e(s);
  EventLog log;
  run_logged(s, e, log, 80);
  const TileId packet1{s.first_texture(0) + 1, 0, 0, 0};
  EXPECT_TRUE(s.material_ready(0));
  EXPECT_FALSE(s.material_failed(0));
  EXPECT_EQ(log.count(ResidencyEventKind::packet_failed, 0, &packet1), 3u);
  EXPECT_EQ(log.count(ResidencyEventKind::packet_unavailable, 0, &packet1), 1u);
  EXPECT_EQ(s.scheduler().u_loaded(0), 1u);  // packet 0 only
  EXPECT_FALSE(e.packets[s.first_texture(0)].empty());
  EXPECT_EQ(s.stats().packet_failures, 3u);
  // Texture 0's finest tiles stream; texture 1 (no U′) gets none.
  const VtLevelTable& lv = s.cache().set().material(0).levels;
  EXPECT_TRUE(s.cache().resident(lv.tile(s.first_texture(0), lv.tile_count() - 1)));
  EXPECT_FALSE(s.cache().resident(lv.tile(s.first_texture(0) + 1, lv.tile_count() - 1)));
  check_engine(w, s, e);
}

TEST(RuntimeFailures, JobsHandedOutByUpdateAndByCompleteReadRunOnce) {
  World w;
  w.add(build(make_eigen(128, 6, 5)));
  QueueSource q;
  finish_queued(w, q);
  auto s = std::move(Streamer::create(w.materials, small_config()).value());
  Engine e(s);
  std::vector<uint32_t> handed(64);
  const auto fb = full_feedback(s);
  uint64_t from_update = 0, from_reads = 0;
  for (uint32_t f = 0; f < 60; ++f) {
    StreamerOutputs o = e.outputs();
    o.runnable_jobs = handed;
    ASSERT_EQ(s.update(fb, o), Status::success);
    e.apply(s, o);
    // Claimed for us: nobody else can take them.
    for (size_t i = 0; i < o.runnable_job_count; ++i) EXPECT_FALSE(s.claim_job(handed[i]));
    for (size_t i = 0; i < o.runnable_job_count; ++i) s.run_job(handed[i]);
    from_update += o.runnable_job_count;
    // The engine's I/O completes; each completion that makes a job runnable names it.
    while (!q.reads.empty()) {
      const uint32_t j = q.complete_front(s);
      if (j == Streamer::kNoJob) continue;
      ASSERT_TRUE(s.claim_job(j));
      EXPECT_FALSE(s.claim_job(j));
      s.run_job(j);
      ++from_reads;
    }
    EXPECT_EQ(s.acquire_job(), Streamer::kNoJob);  // nothing was left for a pulling executor
  }
  EXPECT_GT(from_reads, 10u);
  EXPECT_GT(from_update, 0u);  // jobs whose payloads were all cached needed no read
  EXPECT_TRUE(s.material_ready(0));
  EXPECT_TRUE(s.idle());
  check_engine(w, s, e);
  // Handles that are out of range or not claimed are ignored.
  s.run_job(100000);
  EXPECT_FALSE(s.claim_job(100000));
}

TEST(RuntimeFailures, QuiesceWithCancelledReadsDrainsWithoutFailures) {
  World w;
  w.add(build(make_eigen(128, 6, 6)));
  QueueSource q;
  finish_queued(w, q, false);
  auto s = std::move(Streamer::create(w.materials, small_config()).value());
  Engine e(s);
  const auto fb = full_feedback(s);
  StreamerOutputs o;
  ASSERT_EQ(e.frame(s, fb, o), Status::success);  // roots and packets: reads started
  ASSERT_FALSE(q.reads.empty());
  EXPECT_FALSE(s.idle());
  s.quiesce();
  // The engine cancels its outstanding reads; nothing new starts while quiescing.
  while (!q.reads.empty()) {
    s.complete_read(q.reads.front().ticket, Status::cancelled);
    q.reads.pop_front();
  }
  for (int f = 0; f < 3; ++f) {
    ASSERT_EQ(e.frame(s, fb, o), Status::success);
    EXPECT_TRUE(q.reads.empty());
    EXPECT_EQ(o.tile_upload_count, 0u);
  }
  EXPECT_TRUE(s.idle());
  const StreamerStats st = s.stats();
  EXPECT_GT(st.cancelled, 0u);
  EXPECT_EQ(st.tile_failures + st.packet_failures, 0u);
  // Resumed, the cancelled work is asked for again and the material loads.
  resume_and_expect_loaded(w, s, e, q, fb);
}

// A read the source refused is not retried while quiescing: its job ends (cancelled) so the
// Streamer still drains, and after resume() the work is asked for again.
TEST(RuntimeFailures, QuiesceDrainsWhenTheSourceRefusedAReadAndResumeLoads) {
  World w;
  w.add(build(make_eigen(128, 6, 6)));
  QueueSource q;
  finish_queued(w, q, true);  // the first read of the first update is refused
  auto s = std::move(Streamer::create(w.materials, small_config()).value());
  Engine e(s);
  const auto fb = full_feedback(s);
  StreamerOutputs o;
  ASSERT_EQ(e.frame(s, fb, o), Status::success);
  s.quiesce();
  for (int f = 0; f < 5 && !s.idle(); ++f) {
    q.complete_all(s);  // the reads that were started complete
    ASSERT_EQ(e.frame(s, fb, o), Status::success);
    s.pump();
  }
  EXPECT_TRUE(s.idle()) << "a job waiting for a refused read never ended";
  EXPECT_TRUE(q.reads.empty());
  EXPECT_EQ(s.stats().tile_failures + s.stats().packet_failures, 0u);
  resume_and_expect_loaded(w, s, e, q, fb);
}

TEST(RuntimeFailures, DestroyedWithReadsOutstandingReturnsEveryByte) {
  World w;
  w.add(build(make_eigen(128, 6, 7)));
  QueueSource q;
  finish_queued(w, q, false);
  CountingHeap ledger;
  {
    StreamerConfig cfg = small_config();
    cfg.allocator = ledger.callbacks();
    auto s = std::move(Streamer::create(w.materials, cfg).value());
    Engine e(s);
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update(full_feedback(s), o), Status::success);
    ASSERT_FALSE(q.reads.empty());
    EXPECT_GT(ledger.bytes, 0);
    q.reads.clear();  // the engine dropped its I/O (its reads will never write)
  }
  EXPECT_EQ(ledger.bytes, 0);
  EXPECT_EQ(ledger.blocks, 0);
}

TEST(RuntimeFailures, MemoryReportEqualsWhatTheAllocatorHoldsWithOneDecoderPerWorker) {
  World w;
  w.add(build(make_eigen(128, 6, 8)));
  w.add(build(make_eigen(64, 3, 9)));
  w.finish();
  const auto report = [&](uint32_t workers, CountingHeap& ledger) {
    StreamerConfig cfg = small_config();
    cfg.allocator = ledger.callbacks();
    cfg.decode_workers = workers;
    auto s = std::move(Streamer::create(w.materials, cfg).value());
    const StreamerMemory m = s.stats().memory;
    EXPECT_EQ(static_cast<int64_t>(m.total), ledger.bytes);
    EXPECT_EQ(static_cast<int64_t>(m.allocations), ledger.blocks);
    EXPECT_EQ(m.total, m.tile_cache + m.scheduler + m.votes + m.payload_cache + m.job_buffers + m.decoders +
                           m.decoded_cache + m.tables);
    EXPECT_GE(m.payload_cache, cfg.payload_cache_bytes);
    EXPECT_GE(m.decoded_cache, uint64_t{cfg.decoded_cache_tiles} * 40 * 40 * 4 * sizeof(float));
    return m;
  };
  CountingHeap a, b;
  const StreamerMemory one = report(1, a), four = report(4, b);
  EXPECT_GT(one.decoders, 0u);
  // Decoders scale with the declared workers only; nothing else changes.
  EXPECT_EQ(four.decoders - one.decoders, 3 * (one.decoders - alignof(TileDecoder)));
  EXPECT_EQ(four.job_buffers, one.job_buffers);
  EXPECT_EQ(four.tile_cache, one.tile_cache);
}

TEST(RuntimeFailures, OneDecoderServesSeveralThreadsAndFeedbackForUnknownMaterialsIsCounted) {
  World w;
  w.add(build(make_eigen(128, 6, 10)));
  w.finish();
  StreamerConfig cfg = small_config();
  cfg.decode_workers = 1;
  auto s = std::move(Streamer::create(w.materials, cfg).value());
  Engine e(s);
  auto fb = full_feedback(s);
  fb.push_back(pack_feedback(FeedbackTile{5, 0, 0, 0}));  // no such material
  const uint64_t rejected_before = s.stats().feedback_rejected;
  {
    ThreadExecutor workers(s.jobs(), 3);
    for (uint32_t f = 0; f < 60; ++f) {
      StreamerOutputs o;
      ASSERT_EQ(e.frame(s, fb, o), Status::success);
      workers.notify();
      for (int spin = 0; spin < 4000 && s.jobs_in_flight() > 0; ++spin) std::this_thread::yield();
    }
  }
  while (!s.idle()) s.pump();
  StreamerOutputs o;
  ASSERT_EQ(e.frame(s, fb, o), Status::success);
  EXPECT_TRUE(s.material_ready(0));
  EXPECT_GE(s.stats().feedback_rejected - rejected_before, 61u);  // one unknown word per frame at least
  check_engine(w, s, e);
}

TEST(RuntimeFailures, GpuLayoutNamesTheShapesToAllocate) {
  World w;
  w.add(build(make_eigen(128, 6, 11)));  // 2 textures, L = 2: 4×4 finest tiles
  w.add(build(make_eigen(64, 3, 12)));   // 1 texture, L = 1
  w.finish();
  auto s = std::move(Streamer::create(w.materials, small_config()).value());
  const StreamerGpuLayout g = s.gpu_layout();
  EXPECT_EQ(g.cache_width, 8u * 40u);
  EXPECT_EQ(g.cache_height, 8u * 40u);
  EXPECT_EQ(g.cache_layers, 1u);
  EXPECT_EQ(g.page_table_layers, 3u);
  EXPECT_EQ(g.page_table_width, 4u);
  EXPECT_EQ(g.page_table_height, 4u);
  EXPECT_EQ(g.page_table_levels, 3u);
  EXPECT_EQ(g.u_rows, kLights * kViews * 3);
  EXPECT_EQ(g.u_packets, 3u);
}
