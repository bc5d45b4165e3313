// btflod-label: unit threads
// runtime/streamer.hpp under real concurrency, as an engine drives it: one Streamer, four
// engine-owned worker threads claiming and running decode jobs (acquire_job/run_job; a second
// test uses runtime/stream/thread_executor.hpp's four threads instead), one I/O thread completing
// AsyncTileSource reads out of order after random delays (some fail, some deliver corrupted
// bytes), and the frame thread calling update() with a moving feedback pattern. Checked every
// frame: each uploaded tile's texels equal a fresh decode of its container, each U′ packet
// equals its stored bytes, the tile cache's invariants hold and the engine's copy of the page
// table matches the cache. At the end everything drains (no read outstanding, no job running,
// workers joined) before the Streamer is destroyed. Bounded by a deadline; ./run.sh's
// ThreadSanitizer stage runs it (label `threads`).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/stream/thread_executor.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "faulty_async_io.hpp"
#include "test_runtime_helpers.hpp"

using namespace btflod;
using btflod_test::decode_direct;
using Clock = std::chrono::steady_clock;
using btflod_test::FaultyAsyncIo;
using btflod_test::FaultyIoConfig;

namespace {

// Materials: test_runtime_helpers.hpp's smooth synthetic eigen-textures and container builder.
using btflod_test::build;
using btflod_test::make_eigen;

// The engine's I/O (faulty_async_io.hpp): one thread serving the reads of every material, in
// random order, a third of them after a delay of up to 0.4 ms; 4 % fail (io_error) and 3 %
// deliver one damaged byte with success (the runtime's CRC check must catch them), a read that
// faulted is served intact the next time (so every material gets ready), and start_read()
// refuses a quarter of the time when six reads are queued.
FaultyIoConfig io_config() {
  FaultyIoConfig c;
  c.seed = 11;
  c.fail = 0.04;
  c.corrupt = 0.03;
  c.stall = 0;
  c.delay = 1.0 / 3;
  c.max_delay_us = 400;
  c.refuse = 0.25;
  c.refuse_from_depth = 6;
  c.intact_after_fault = true;
  return c;
}

// Engine-owned decode workers: each claims runnable jobs until none is left, then sleeps until
// woken (the Streamer's job notify hook, or an I/O completion) or 1 ms passes.
class Workers {
 public:
  Workers(StreamerJobQueue& queue, unsigned count) : queue_(queue), ran_(count) {
    for (auto& r : ran_) r.store(0);
    for (unsigned i = 0; i < count; ++i) threads_.emplace_back([this, i] { loop(i); });
  }
  ~Workers() { join(); }
  static void wake(void* self) { static_cast<Workers*>(self)->notify(); }
  void notify() {
    {
      std::lock_guard lock(mutex_);
      ++signals_;
    }
    cv_.notify_all();
  }
  /// Lets running jobs finish and joins every worker.
  void join() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_)
      if (t.joinable()) t.join();
  }
  uint64_t jobs_run() const {
    uint64_t n = 0;
    for (const auto& r : ran_) n += r.load();
    return n;
  }
  unsigned busy_workers() const {
    unsigned n = 0;
    for (const auto& r : ran_) n += r.load() > 0;
    return n;
  }

 private:
  void loop(unsigned index) {
    uint64_t seen = 0;
    for (;;) {
      for (uint32_t j = queue_.acquire_job(); j != StreamerJobQueue::kNoJob; j = queue_.acquire_job()) {
        queue_.run_job(j);
        ran_[index].fetch_add(1);
      }
      std::unique_lock lock(mutex_);
      cv_.wait_for(lock, std::chrono::milliseconds(1), [&] { return stopping_ || signals_ != seen; });
      if (stopping_) return;
      seen = signals_;
    }
  }

  StreamerJobQueue& queue_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stopping_ = false;
  uint64_t signals_ = 0;
  std::vector<std::atomic<uint64_t>> ran_;
  std::vector<std::thread> threads_;
};

// What the engine keeps (cache texture slots, page table, U′ packets), checked against fresh
// decodes of the containers.
struct Engine : btflod_test::StreamerOutputBuffers {
  const std::vector<std::vector<uint8_t>>& files;
  const std::vector<BsvtfDirectory>& dirs;
  std::vector<std::vector<uint16_t>> slots;
  std::vector<std::vector<uint32_t>> page_table;
  std::map<std::pair<uint32_t, uint64_t>, std::vector<uint16_t>> reference;  // (material, local key)
  uint64_t tiles_checked = 0, packets_checked = 0, failed_events = 0, ready_events = 0, unavailable_events = 0;
  bool bad_failure_status = false;

  Engine(const Streamer& s, const std::vector<std::vector<uint8_t>>& f, const std::vector<BsvtfDirectory>& d)
      : StreamerOutputBuffers(s, 4096, 1024), files(f), dirs(d) {
    slots.resize(s.cache().slot_count());
    for (uint32_t t = 0; t < s.cache().set().texture_count(); ++t)
      page_table.emplace_back(s.cache().set().levels_of(t).tile_count(), 0xffffffffu);
  }

  // The texels tile `global` must have: decoded straight from its container, once.
  const std::vector<uint16_t>& expected(const Streamer& s, const TileId& global) {
    const uint32_t m = s.cache().set().material_of(global.texture);
    const TileId local{global.texture - s.first_texture(m), global.level, global.x, global.y};
    auto [it, inserted] = reference.try_emplace({m, local.key()});
    if (inserted) it->second = decode_direct(files[m], dirs[m], local);
    return it->second;
  }

  void apply(const Streamer& s, const StreamerOutputs& o) {
    for (size_t i = 0; i < o.tile_upload_count; ++i) {
      const StreamerTileUpload& u = o.tile_uploads[i];
      ASSERT_LT(u.slot, slots.size());
      slots[u.slot].assign(u.texels.begin(), u.texels.end());
      ASSERT_EQ(slots[u.slot], expected(s, u.tile))
          << "upload of tile " << u.tile.texture << "/" << u.tile.level << "/" << u.tile.x << "/" << u.tile.y;
      ++tiles_checked;
    }
    for (size_t i = 0; i < o.packet_upload_count; ++i) {
      const StreamerPacketUpload& p = o.packet_uploads[i];
      const BsvtfPacketEntry& e = dirs[p.material].packets[p.packet];
      ASSERT_EQ(p.halves.size_bytes(), e.size);  // the container is light-major, as delivered
      ASSERT_EQ(std::memcmp(p.halves.data(), files[p.material].data() + e.offset, e.size), 0) << "packet " << p.texture;
      ++packets_checked;
    }
    for (size_t i = 0; i < o.page_table_write_count; ++i) {
      const PageTableWrite& w = o.page_table_writes[i];
      page_table[w.tile.texture][s.cache().set().levels_of(w.tile.texture).index(w.tile)] = w.entry;
    }
    for (size_t i = 0; i < o.event_count; ++i) {
      const ResidencyEvent& e = o.events[i];
      if (e.kind == ResidencyEventKind::material_ready) ++ready_events;
      if (e.kind == ResidencyEventKind::tile_unavailable) ++unavailable_events;  // its parent serves
      if (e.kind == ResidencyEventKind::material_failed) ADD_FAILURE() << "material " << e.material << " failed";
      if (e.kind == ResidencyEventKind::tile_failed || e.kind == ResidencyEventKind::packet_failed) {
        ++failed_events;
        // Only what the I/O thread injected: a failed read or a corrupted payload.
        if (e.status != Status::io_error && e.status != Status::bad_data) bad_failure_status = true;
      }
    }
  }

  // The cache's invariants, every resident slot's texels, every page-table texel a shader reads.
  void check(const Streamer& s) {
    const TileCache& c = s.cache();
    std::string why;
    ASSERT_TRUE(c.check_invariants(&why)) << why;
    for (uint32_t slot = 0; slot < c.slot_count(); ++slot) {
      const SlotInfo& si = c.slot(slot);
      if (si.state != SlotInfo::State::used) continue;
      if (si.tile.level == 0 && !s.material_ready(c.set().material_of(si.tile.texture))) continue;  // loading
      ASSERT_EQ(slots[slot], expected(s, si.tile)) << "slot " << slot;
    }
    for (uint32_t t = 0; t < c.set().texture_count(); ++t) {
      const VtLevelTable& lv = c.set().levels_of(t);
      for (uint32_t i = 0; i < lv.tile_count(); ++i) {
        const TileId id = lv.tile(t, i);
        if (c.resident(id) || id.level == lv.finest_level()) {
          ASSERT_EQ(page_table[t][i], gpu_page_entry(c, id));
        }
      }
    }
  }
};

// Feedback of frame f: per material a 2×2 window of finest tiles walking across the material
// (one step every 6 frames), and one vote one level coarser.
std::vector<uint32_t> moving_feedback(const Streamer& s, uint32_t f) {
  std::vector<uint32_t> words;
  for (uint32_t m = 0; m < s.material_count(); ++m) {
    const VtLevelTable& lv = s.cache().set().material(m).levels;
    const uint32_t L = lv.finest_level(), tx = lv.tiles_x[L], ty = lv.tiles_y[L];
    const uint32_t step = f / 6 + 5 * m;
    const uint32_t x0 = step % (tx - 1), y0 = (step / (tx - 1)) % (ty - 1);
    for (uint32_t dy = 0; dy < 2; ++dy)
      for (uint32_t dx = 0; dx < 2; ++dx) words.push_back(pack_feedback(FeedbackTile{m, L, x0 + dx, y0 + dy}));
    words.push_back(pack_feedback(FeedbackTile{m, L - 1, (step / 3) % lv.tiles_x[L - 1], 0}));
  }
  return words;
}

}  // namespace

namespace {

// Who runs the decode jobs: four engine-owned threads (Workers above) or the ready-made
// runtime/stream/thread_executor.hpp with four threads.
enum class Executor { engine_workers, thread_executor };

void stream_and_drain(Executor kind) {
  // The whole test, drain included, must finish by this deadline (a few seconds in release).
  const auto deadline = Clock::now() + std::chrono::seconds(120);
  std::vector<std::vector<uint8_t>> files;
  files.push_back(build(make_eigen(128, 6, 1)));  // 2 virtual textures, 3 levels
  files.push_back(build(make_eigen(128, 3, 2)));  // 1 virtual texture, 3 levels
  std::vector<BsvtfDirectory> dirs;
  for (const auto& f : files) dirs.push_back(read_bsvtf(f).value());

  FaultyAsyncIo io(io_config());
  std::vector<FaultyAsyncIo::Source> sources;
  for (const auto& f : files) sources.push_back(io.source(f));
  std::vector<StreamerMaterial> materials;
  for (size_t m = 0; m < files.size(); ++m) {
    materials.push_back(StreamerMaterial{&dirs[m], nullptr, &sources[m]});
  }
  StreamerConfig cfg;
  cfg.cache = CacheConfig{5, 4, 1u << 12, 32, 4, 1};  // 20 slots for 63 tiles: swaps
  cfg.scheduler.budgets.uploads_per_frame = 6;
  cfg.scheduler.budgets.requests_in_flight = 12;
  cfg.vote_window_frames = 2;
  cfg.decoded_cache_tiles = 4;
  cfg.payload_cache_bytes = 16u << 10;  // a few payloads: reads go on all run long
  auto created = Streamer::create(materials, cfg);
  ASSERT_TRUE(created.ok()) << created.message();
  Streamer s = std::move(created.value());  // not moved again: the I/O thread holds its address

  Engine e(s, files, dirs);
  std::optional<Workers> workers;
  std::optional<ThreadExecutor> executor;
  if (kind == Executor::engine_workers) {
    workers.emplace(s.jobs(), 4);
    s.jobs().set_job_notify(&Workers::wake, &*workers);
    io.start(
        s, [](void* w, uint32_t) { static_cast<Workers*>(w)->notify(); }, &*workers);
  } else {
    executor.emplace(s.jobs(), 4);  // registers its own notify hook
    io.start(
        s, [](void* x, uint32_t) { static_cast<ThreadExecutor*>(x)->notify(); }, &*executor);
  }
  const auto jobs_run = [&] { return workers ? workers->jobs_run() : executor->jobs_run(); };
  // Before the Streamer is destroyed, even when an assertion ends the test early: the I/O
  // thread completes what is left (as cancelled) and exits, the workers finish and are joined.
  struct StopThreads {
    FaultyAsyncIo& io;
    Streamer& s;
    std::optional<Workers>& workers;
    std::optional<ThreadExecutor>& executor;
    void operator()() {
      io.stop();
      s.jobs().set_job_notify(nullptr, nullptr);
      if (workers) workers->join();
      if (executor) executor.reset();  // unregisters its hook, joins its threads
    }
    ~StopThreads() { (*this)(); }
  } stop_threads{io, s, workers, executor};

  // Waits for this frame's work up to 1 ms: frames overlap running jobs and pending reads.
  const auto settle = [&] {
    const auto until = Clock::now() + std::chrono::milliseconds(1);
    while (Clock::now() < until && (s.jobs_in_flight() > 0 || io.outstanding() > 0)) std::this_thread::yield();
  };
  constexpr uint32_t kFrames = 300;
  bool in_time = true;
  for (uint32_t f = 0; f < kFrames && !::testing::Test::HasFatalFailure(); ++f) {
    if (Clock::now() > deadline) {
      in_time = false;
      break;
    }
    StreamerOutputs o = e.outputs();
    const std::vector<uint32_t> fb = moving_feedback(s, f);
    ASSERT_EQ(s.update(fb, o), Status::success);
    e.apply(s, o);
    e.check(s);
    settle();
  }
  // Drain: no new votes; update until two updates in a row see no read outstanding and no job
  // reading, runnable or running (the second one collected every job that finished before).
  bool drained = false;
  for (uint32_t quiet = 0; in_time && !::testing::Test::HasFatalFailure();) {
    if (Clock::now() > deadline) {
      in_time = false;
      break;
    }
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update({}, o), Status::success);
    e.apply(s, o);
    e.check(s);
    quiet = io.outstanding() == 0 && s.jobs_in_flight() == 0 ? quiet + 1 : 0;
    if (quiet == 2) {
      drained = true;
      break;
    }
    settle();
  }
  EXPECT_TRUE(in_time) << "not done by the deadline";
  ASSERT_TRUE(drained);
  EXPECT_EQ(io.outstanding(), 0u);
  EXPECT_EQ(s.jobs_in_flight(), 0u);
  stop_threads();
  EXPECT_EQ(io.counters.cancelled.load(), 0u);  // nothing was left to cancel

  EXPECT_TRUE(s.material_ready(0));
  EXPECT_TRUE(s.material_ready(1));
  EXPECT_EQ(e.ready_events, 2u);
  EXPECT_EQ(s.events_dropped(), 0u);
  EXPECT_FALSE(e.bad_failure_status);
  // The run really was concurrent, under pressure and through failures.
  EXPECT_GT(e.tiles_checked, 60u);
  EXPECT_EQ(e.packets_checked, 3u);
  EXPECT_GT(s.scheduler().total().swaps, 0u);
  EXPECT_GT(jobs_run(), 60u);
  if (workers) {
    EXPECT_GE(workers->busy_workers(), 2u);
  }
  EXPECT_GT(io.counters.reads.load(), 60u);
  EXPECT_GT(io.counters.failed.load() + io.counters.corrupted.load(), 0u);
  EXPECT_GT(e.failed_events, 0u);
  std::printf(
      "frames %u, tiles checked %llu, jobs run %llu, reads %llu (failed %llu, corrupted %llu, refused %llu), "
      "failure events %llu, tiles given up %llu, swaps %llu\n",
      kFrames, static_cast<unsigned long long>(e.tiles_checked), static_cast<unsigned long long>(jobs_run()),
      static_cast<unsigned long long>(io.counters.reads.load()),
      static_cast<unsigned long long>(io.counters.failed.load()),
      static_cast<unsigned long long>(io.counters.corrupted.load()),
      static_cast<unsigned long long>(io.counters.refused.load()), static_cast<unsigned long long>(e.failed_events),
      static_cast<unsigned long long>(e.unavailable_events),
      static_cast<unsigned long long>(s.scheduler().total().swaps));
}

}  // namespace

TEST(RuntimeThreads, FourEngineWorkersAndAnOutOfOrderIoThreadStreamExactTilesAndDrain) {
  stream_and_drain(Executor::engine_workers);
}

TEST(RuntimeThreads, ThreadExecutorAndAnOutOfOrderIoThreadStreamExactTilesAndDrain) {
  stream_and_drain(Executor::thread_executor);
}
