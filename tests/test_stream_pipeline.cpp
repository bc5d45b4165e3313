// btflod-label: unit threads
// Tests for stream/tile_source.hpp and stream/pipeline.hpp: sources (memory, file, throttled),
// delivery of exactly what a direct decode gives, priority order, ancestor fetches, stale-request
// cancellation, checksum and truncation faults (re-requested or skipped, never cached), the
// byte-budgeted LRU, the upload budget, clean shutdown with requests in flight, and a randomised
// stress run with faults that must never deliver a wrong tile.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <random>
#include <set>
#include <thread>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/core/thread_pool.hpp"
#include "btflod/stream/pipeline.hpp"
#include "btflod/stream/file_source.hpp"
#include "btflod/stream/tile_source.hpp"

namespace {

using namespace btflod;
using namespace std::chrono_literals;

float value(uint32_t comp, double u, double v) {
  return static_cast<float>((1.0 + comp) * (std::sin(7.0 * u + comp) * std::cos(5.0 * v) + 0.2 * std::sin(37.0 * u * v + comp)));
}

// A small material: T = 16, B = 4, 4 levels (85 tiles), 4 components, 12 rows of U.
struct Fixture {
  std::vector<uint8_t> file;
  BsvtfDirectory dir;
  std::map<uint64_t, std::vector<float>> reference;  // decoded tiles, key → samples
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture fx;
    BsvtfMetadata md;
    md.material_name = "stream-test";
    md.tile_size = 16;
    md.border = 4;
    md.level_count = 4;
    md.width = md.height = 128;
    md.component_count = 4;
    md.u_rows = 12;
    std::vector<float> u(12 * 4);
    for (size_t i = 0; i < u.size(); ++i) u[i] = 0.05f * static_cast<float>(i);
    const TileLayout layout = md.layout();
    const uint32_t s = layout.stored_size();
    std::vector<std::vector<float>> samples;
    std::vector<BsvtfTileInput> tiles;
    for (uint32_t l = 0; l < 4; ++l)
      for (uint32_t y = 0; y < (1u << l); ++y)
        for (uint32_t x = 0; x < (1u << l); ++x) {
          std::vector<float> t(layout.sample_count());
          const double w = 16.0 * (1u << l);
          for (uint32_t j = 0; j < s; ++j)
            for (uint32_t i = 0; i < s; ++i) {
              const double px = std::clamp(x * 16.0 - 4 + i, 0.0, w - 1), py = std::clamp(y * 16.0 - 4 + j, 0.0, w - 1);
              for (uint32_t k = 0; k < 4; ++k) t[(j * s + i) * 4 + k] = value(k, (px + 0.5) / w, (py + 0.5) / w);
            }
          samples.push_back(std::move(t));
          tiles.push_back({TileId{0, l, x, y}, {}, 1.0f + static_cast<float>(x + y)});
        }
    for (size_t i = 0; i < tiles.size(); ++i) tiles[i].samples = samples[i];
    ThreadPool pool(1);
    BsvtfBuildOptions o;
    o.pool = &pool;
    fx.file = build_bsvtf(md, u, tiles, o).value();
    fx.dir = read_bsvtf(fx.file).value();
    TileDecoder dec(layout);
    for (uint32_t l = 0; l < 4; ++l)
      for (const auto& e : fx.dir.tiles) {
        if (e.id.level != l) continue;
        std::vector<float> out(layout.sample_count());
        std::span<const float> parent;
        if (l > 0) parent = fx.reference.at(e.id.parent().key());
        EXPECT_EQ(dec.decode(std::span<const uint8_t>(fx.file).subspan(e.offset, e.size), parent, e.id.x & 1, e.id.y & 1, out),
                  Status::success);
        fx.reference[e.id.key()] = out;
      }
    return fx;
  }();
  return f;
}

// Wraps a source and damages chosen reads: flips a byte (checksum fault) or cuts the transfer.
class FaultySource final : public TileSource {
 public:
  explicit FaultySource(TileSource& inner) : inner_(inner) {}
  Result<uint64_t> size() override { return inner_.size(); }
  VoidResult read(uint64_t offset, std::span<uint8_t> out, const std::atomic<bool>* cancel) override {
    {
      std::lock_guard lock(mutex_);
      if (offset == target_ && corruptions_left_ > 0) {
        --corruptions_left_;
        if (truncate_) return make_error(Status::short_output, "faulty: transfer cut at %llu", static_cast<unsigned long long>(offset));
        auto r = inner_.read(offset, out, cancel);
        out[out.size() / 2] ^= 0x5a;
        return r;
      }
      // Every `fault_period_`-th payload read fails, so the number of faults does not depend on
      // how the worker threads happen to interleave; which kind of fault and where is random.
      if (fault_period_ > 0 && offset >= payload_offset_ && ++payload_reads_ % fault_period_ == 0) {
        auto r = inner_.read(offset, out, cancel);
        if ((rng_() & 1) && !out.empty()) {
          out[rng_() % out.size()] ^= 0x01;
          return r;
        }
        return make_error(Status::io_error, "faulty: random source error");
      }
    }
    return inner_.read(offset, out, cancel);
  }
  std::string describe() const override { return "faulty"; }
  void damage(uint64_t offset, int times, bool truncate) {
    std::lock_guard lock(mutex_);
    target_ = offset;
    corruptions_left_ = times;
    truncate_ = truncate;
  }
  void periodic_faults(unsigned period, uint64_t payload_offset) {
    std::lock_guard lock(mutex_);
    fault_period_ = period;
    payload_offset_ = payload_offset;
  }

 private:
  TileSource& inner_;
  std::mutex mutex_;
  uint64_t target_ = ~uint64_t{0};
  int corruptions_left_ = 0;
  bool truncate_ = false;
  unsigned fault_period_ = 0;
  uint64_t payload_reads_ = 0;
  uint64_t payload_offset_ = 0;
  std::mt19937 rng_{7};
};

struct Collected {
  std::vector<StreamItem> order;
  std::map<uint64_t, std::vector<float>> tiles;
  std::map<uint32_t, std::vector<float>> packets;
  int wrong = 0;
};

// Delivers until `done()` or 10 s pass; checks every delivered tile against the reference.
template <class Done>
bool pump(StreamingPipeline& p, Collected& c, Done done, size_t budget = 4) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    p.deliver(budget, [&](const StreamDelivery& d) {
      c.order.push_back(d.item);
      if (d.item.kind == StreamItem::Kind::tile) {
        std::vector<float> v(d.samples.begin(), d.samples.end());
        if (v != fixture().reference.at(d.item.tile.key())) ++c.wrong;
        c.tiles[d.item.tile.key()] = std::move(v);
      } else {
        c.packets[d.item.packet] = std::vector<float>(d.samples.begin(), d.samples.end());
      }
    });
    std::this_thread::sleep_for(200us);
  }
  return true;
}

std::vector<StreamItem> all_tiles() {
  std::vector<StreamItem> v;
  for (const auto& e : fixture().dir.tiles) v.push_back(StreamItem::for_tile(e.id));
  return v;
}

TEST(StreamSources, MemoryAndFileServeTheSameBytesAndRejectOutOfRange) {
  const auto& file = fixture().file;
  const std::string path = std::string(BTFLOD_TEST_TMP_DIR) + "/stream_sources.bsvtf";
  ASSERT_TRUE(write_file_bytes(path, file).ok());
  MemorySource mem{std::span<const uint8_t>(file)};
  auto fs = FileSource::open(path);
  ASSERT_TRUE(fs.ok()) << fs.message();
  EXPECT_EQ(fs.value()->size().value(), file.size());
  std::vector<uint8_t> a(1000), b(1000);
  ASSERT_TRUE(mem.read(321, a).ok());
  ASSERT_TRUE(fs.value()->read(321, b).ok());
  EXPECT_EQ(a, b);
  EXPECT_EQ(0, std::memcmp(a.data(), file.data() + 321, a.size()));
  EXPECT_EQ(mem.read(file.size() - 10, a).status(), Status::short_output);
  EXPECT_EQ(fs.value()->read(file.size() - 10, b).status(), Status::short_output);
  EXPECT_EQ(FileSource::open(path + ".missing").status(), Status::io_error);
}

TEST(StreamSources, ThrottledSourceDeliversTheSameBytesAndHonoursCancel) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  ThrottledSource slow(mem, 1e6, 1000us);
  std::vector<uint8_t> a(500);
  ASSERT_TRUE(slow.read(100, a).ok());
  EXPECT_EQ(0, std::memcmp(a.data(), fixture().file.data() + 100, a.size()));
  ThrottledSource very_slow(mem, 10.0, std::chrono::microseconds(60'000'000));  // a minute of latency
  std::atomic<bool> cancel{true};
  EXPECT_EQ(very_slow.read(0, a, &cancel).status(), Status::cancelled);
}

TEST(StreamPipeline, DeliversExactlyTheDecodedTilesPacketsAndProgress) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  auto p = StreamingPipeline::open(mem);
  ASSERT_TRUE(p.ok()) << p.message();
  auto wanted = all_tiles();
  wanted.push_back(StreamItem::for_packet(0));
  p.value()->request(wanted);
  Collected c;
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.tiles.size() == 85 && c.packets.size() == 1; }));
  EXPECT_EQ(c.wrong, 0);
  const auto pr = p.value()->progress();
  EXPECT_EQ(pr.tiles_delivered, 85u);
  EXPECT_EQ(pr.tiles_total, 85u);
  EXPECT_EQ(pr.packets_delivered, 1u);
  EXPECT_EQ(pr.components_delivered, 4u);
  EXPECT_DOUBLE_EQ(pr.converged_fraction, 1.0);
  EXPECT_EQ(pr.bytes_received, pr.bytes_total) << "every payload fetched exactly once";
  EXPECT_EQ(pr.checksum_failures + pr.source_errors + pr.skipped, 0u);
  for (uint32_t r = 0; r < 12; ++r)
    for (uint32_t k = 0; k < 4; ++k) EXPECT_NEAR(c.packets[0][r * 4 + k], 0.05f * (r * 4 + k), 2e-3);
}

TEST(StreamPipeline, OneWorkerServesRequestsInPriorityOrder) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  ThrottledSource slow(mem, 0, 500us);
  PipelineConfig cfg;
  cfg.worker_threads = 1;
  auto p = StreamingPipeline::open(slow, cfg);
  ASSERT_TRUE(p.ok());
  const std::vector<StreamItem> wanted = {StreamItem::for_tile({0, 2, 3, 1}), StreamItem::for_packet(0),
                                          StreamItem::for_tile({0, 0, 0, 0}), StreamItem::for_tile({0, 3, 0, 7}),
                                          StreamItem::for_tile({0, 1, 1, 1})};
  p.value()->request(wanted);
  Collected c;
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.order.size() == wanted.size(); }));
  EXPECT_EQ(c.order, wanted);
  EXPECT_EQ(c.wrong, 0);
}

TEST(StreamPipeline, FetchesMissingAncestorsBeforeDecoding) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  auto p = StreamingPipeline::open(mem);
  ASSERT_TRUE(p.ok());
  const std::vector<StreamItem> wanted = {StreamItem::for_tile({0, 3, 5, 2})};
  p.value()->request(wanted);
  Collected c;
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.order.size() == 1; }));
  EXPECT_EQ(c.wrong, 0);
  const auto pr = p.value()->progress();
  EXPECT_EQ(pr.ancestor_fetches, 3u);  // levels 0, 1, 2
  EXPECT_EQ(pr.decodes, 4u);
  // A sibling now decodes from the cached parent: no new ancestor fetch.
  const std::vector<StreamItem> sibling = {StreamItem::for_tile({0, 3, 4, 2})};
  p.value()->request(sibling);
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.order.size() == 2; }));
  EXPECT_EQ(p.value()->progress().ancestor_fetches, 3u);
  EXPECT_EQ(p.value()->progress().decodes, 5u);
  EXPECT_EQ(c.wrong, 0);
}

TEST(StreamPipeline, StaleRequestsAreCancelled) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  ThrottledSource slow(mem, 0, 20ms);
  PipelineConfig cfg;
  cfg.worker_threads = 1;
  auto p = StreamingPipeline::open(slow, cfg);
  ASSERT_TRUE(p.ok());
  std::vector<StreamItem> first;
  for (uint32_t i = 0; i < 10; ++i) first.push_back(StreamItem::for_tile({0, 3, i % 8, i / 8}));
  p.value()->request(first);
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (p.value()->progress().fetches == 0 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(100us);
  const std::vector<StreamItem> second = {StreamItem::for_tile({0, 1, 0, 0}), StreamItem::for_tile({0, 1, 1, 0})};
  p.value()->request(second);
  Collected c;
  ASSERT_TRUE(pump(*p.value(), c, [&] { return p.value()->idle(); }));
  EXPECT_EQ(c.wrong, 0);
  std::set<uint64_t> delivered;
  for (const auto& item : c.order) delivered.insert(item.key());
  EXPECT_TRUE(delivered.count(second[0].key()) && delivered.count(second[1].key()));
  EXPECT_EQ(delivered.size(), 2u) << "a stale tile was delivered";
  EXPECT_EQ(p.value()->progress().stale_cancelled, 10u);  // 9 queued + 1 in flight
}

TEST(StreamPipeline, ChecksumFaultIsReRequestedAndDeliveredCorrectly) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  FaultySource faulty(mem);
  const auto* e = fixture().dir.find({0, 1, 1, 0});
  faulty.damage(e->offset, 1, false);
  auto p = StreamingPipeline::open(faulty);
  ASSERT_TRUE(p.ok());
  const std::vector<StreamItem> wanted = {StreamItem::for_tile({0, 1, 1, 0})};
  p.value()->request(wanted);
  Collected c;
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.order.size() == 1; }));
  EXPECT_EQ(c.wrong, 0);
  const auto pr = p.value()->progress();
  EXPECT_EQ(pr.checksum_failures, 1u);
  EXPECT_EQ(pr.retries, 1u);
  EXPECT_EQ(pr.skipped, 0u);
  std::vector<PipelineEvent> events;
  p.value()->drain_events([&](const PipelineEvent& ev) { events.push_back(ev); });
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].status, Status::bad_data);
  EXPECT_FALSE(events[0].skipped);
  EXPECT_NE(events[0].message.find("checksum"), std::string::npos) << events[0].message;
}

TEST(StreamPipeline, PersistentFaultIsSkippedAndNeverCached) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  FaultySource faulty(mem);
  const auto* root = fixture().dir.find({0, 0, 0, 0});
  faulty.damage(root->offset, 1000, false);  // the root (an ancestor of everything) is corrupt
  PipelineConfig cfg;
  cfg.max_retries = 2;
  auto p = StreamingPipeline::open(faulty, cfg);
  ASSERT_TRUE(p.ok());
  const std::vector<StreamItem> wanted = {StreamItem::for_tile({0, 2, 1, 1})};
  p.value()->request(wanted);
  Collected c;
  ASSERT_TRUE(pump(*p.value(), c, [&] { return p.value()->idle(); }));
  EXPECT_TRUE(c.order.empty());
  auto pr = p.value()->progress();
  EXPECT_EQ(pr.checksum_failures, 3u);
  EXPECT_EQ(pr.skipped, 1u);
  EXPECT_EQ(pr.compressed_cache_bytes, 0u) << "nothing unverified may be cached";
  int skipped_events = 0;
  p.value()->drain_events([&](const PipelineEvent& ev) {
    EXPECT_EQ(ev.item.tile, (TileId{0, 0, 0, 0})) << "the event names the ancestor that failed";
    skipped_events += ev.skipped;
  });
  EXPECT_EQ(skipped_events, 1);
  // The link recovers: a new request succeeds and delivers the right data.
  faulty.damage(root->offset, 0, false);
  p.value()->request(wanted);
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.order.size() == 1; }));
  EXPECT_EQ(c.wrong, 0);
}

TEST(StreamPipeline, TruncatedTransferIsASourceErrorAndRetried) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  FaultySource faulty(mem);
  faulty.damage(fixture().dir.packets[0].offset, 2, true);
  auto p = StreamingPipeline::open(faulty);
  ASSERT_TRUE(p.ok());
  const std::vector<StreamItem> wanted = {StreamItem::for_packet(0)};
  p.value()->request(wanted);
  Collected c;
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.order.size() == 1; }));
  const auto pr = p.value()->progress();
  EXPECT_EQ(pr.source_errors, 2u);
  EXPECT_EQ(pr.retries, 2u);
  EXPECT_EQ(pr.packets_delivered, 1u);
}

TEST(StreamPipeline, CompressedLruRespectsItsByteBudgetAndHits) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  PipelineConfig cfg;
  cfg.compressed_cache_bytes = 3 * fixture().dir.tiles[0].size;
  cfg.decoded_cache_tiles = 1;
  cfg.worker_threads = 1;  // the last delivered tile is then the most recently cached one
  auto p = StreamingPipeline::open(mem, cfg);
  ASSERT_TRUE(p.ok());
  p.value()->request(all_tiles());
  Collected c;
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.tiles.size() == 85; }));
  auto pr = p.value()->progress();
  EXPECT_LE(pr.compressed_cache_bytes, cfg.compressed_cache_bytes);
  EXPECT_GT(pr.evictions, 0u);
  EXPECT_EQ(c.wrong, 0);
  // The most recent tile is still cached: asking again is a cache hit, not a fetch.
  const StreamItem last = c.order.back();
  const uint64_t fetches = pr.fetches, hits = pr.cache_hits;
  p.value()->request(std::vector<StreamItem>{last});
  ASSERT_TRUE(pump(*p.value(), c, [&] { return c.order.size() == 86; }));
  pr = p.value()->progress();
  EXPECT_GT(pr.cache_hits, hits);
  EXPECT_EQ(c.wrong, 0);
  (void)fetches;
}

TEST(StreamPipeline, UploadBudgetLimitsEachDelivery) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  auto p = StreamingPipeline::open(mem);
  ASSERT_TRUE(p.ok());
  std::vector<StreamItem> wanted;
  for (uint32_t i = 0; i < 16; ++i) wanted.push_back(StreamItem::for_tile({0, 2, i % 4, i / 4}));
  p.value()->request(wanted);
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  size_t total = 0;
  while (total < 16 && std::chrono::steady_clock::now() < deadline) {
    const size_t n = p.value()->deliver(3, [](const StreamDelivery&) {});
    EXPECT_LE(n, 3u);
    total += n;
    std::this_thread::sleep_for(1ms);
  }
  EXPECT_EQ(total, 16u);
}

namespace {
// Counts the reads a pipeline makes through it and how many are running right now: after the
// pipeline's destructor returns, none may be running and none may start (no worker is left).
struct WatchedSource final : TileSource {
  TileSource& inner;
  std::atomic<uint64_t> started{0};
  std::atomic<int> running{0};
  explicit WatchedSource(TileSource& i) : inner(i) {}
  Result<uint64_t> size() override { return inner.size(); }
  VoidResult read(uint64_t o, std::span<uint8_t> out, const std::atomic<bool>* c) override {
    started.fetch_add(1);
    running.fetch_add(1);
    auto r = inner.read(o, out, c);
    running.fetch_sub(1);
    return r;
  }
  std::string describe() const override { return "watched(" + inner.describe() + ")"; }
};

// Destroys the pipeline and returns how long its destructor took.
std::chrono::steady_clock::duration destroy(std::unique_ptr<StreamingPipeline>& p) {
  const auto t0 = std::chrono::steady_clock::now();
  p.reset();
  return std::chrono::steady_clock::now() - t0;
}

// Waits (up to 10 s) until `done` holds; returns whether it did.
template <class F>
bool wait_until(F done) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}
}  // namespace

// The destructor's promise (pipeline.hpp: cancels in-flight reads, drops queued work, joins the
// workers): it returns promptly even with 30-second reads in flight or workers blocked on a full
// ready queue, and once it has returned no read runs or starts. Leaks are LeakSanitizer's job
// (./run.sh's ASan stage runs this file with detect_leaks=1).
TEST(StreamPipeline, ShutdownWithRequestsInFlightAndFullReadyQueueIsClean) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  ThrottledSource glacial(mem, 0, std::chrono::microseconds(30'000'000));
  // Reads that would take 30 s each are in flight when the pipeline is destroyed (the
  // directory comes through the fast source).
  struct SplitSource final : TileSource {
    TileSource& fast;
    TileSource& slow;
    uint64_t dir;
    SplitSource(TileSource& f, TileSource& s, uint64_t d) : fast(f), slow(s), dir(d) {}
    Result<uint64_t> size() override { return fast.size(); }
    VoidResult read(uint64_t o, std::span<uint8_t> out, const std::atomic<bool>* c) override {
      return o < dir ? fast.read(o, out, c) : slow.read(o, out, c);
    }
    std::string describe() const override { return "split"; }
  } split(mem, glacial, fixture().dir.header.directory_size);
  {
    WatchedSource watched(split);
    PipelineConfig cfg;
    cfg.worker_threads = 3;
    auto p = StreamingPipeline::open(watched, cfg);
    ASSERT_TRUE(p.ok());
    p.value()->request(all_tiles());
    // A worker is inside a 30-second read (of the root, which the other workers wait for).
    ASSERT_TRUE(wait_until([&] { return watched.running.load() >= 1; }));
    const uint64_t started = watched.started.load();
    const auto took = destroy(p.value());
    EXPECT_LT(took, 5s) << "the destructor waited for the reads instead of cancelling them";
    EXPECT_EQ(watched.running.load(), 0);
    EXPECT_EQ(watched.started.load(), started);  // the cancelled reads were not retried
    std::this_thread::sleep_for(20ms);           // a worker still alive would start another read
    EXPECT_EQ(watched.started.load(), started);
  }
  {
    // Workers blocked on a full ready queue (nothing is ever delivered) also shut down.
    WatchedSource watched(mem);
    PipelineConfig cfg;
    cfg.ready_capacity = 1;
    auto p = StreamingPipeline::open(watched, cfg);
    ASSERT_TRUE(p.ok());
    p.value()->request(all_tiles());
    ASSERT_TRUE(wait_until([&] { return p.value()->progress().decodes >= 3; }));
    const PipelineProgress before = p.value()->progress();
    EXPECT_EQ(before.tiles_delivered, 0u);
    EXPECT_LT(before.decodes, all_tiles().size());  // blocked: the queue holds one tile
    const auto took = destroy(p.value());
    EXPECT_LT(took, 5s);
    EXPECT_EQ(watched.running.load(), 0);
    const uint64_t started = watched.started.load();
    std::this_thread::sleep_for(20ms);
    EXPECT_EQ(watched.started.load(), started);
  }
}

TEST(StreamPipeline, OpenRejectsBrokenContainers) {
  auto broken = fixture().file;
  broken[fixture().dir.header.tile_index_offset + 5] ^= 1;
  MemorySource a(std::move(broken));
  auto p = StreamingPipeline::open(a);
  EXPECT_EQ(p.status(), Status::bad_data);
  EXPECT_NE(p.message().find("tile index"), std::string::npos) << p.message();
  MemorySource b(std::span<const uint8_t>(fixture().file).first(100));
  EXPECT_EQ(StreamingPipeline::open(b).status(), Status::short_output);
  MemorySource c(std::span<const uint8_t>(fixture().file));
  PipelineConfig zero;
  zero.worker_threads = 0;
  EXPECT_EQ(StreamingPipeline::open(c, zero).status(), Status::invalid_argument);
}

// Random wanted lists, random delivery budgets, one payload read in 25 damaged: every delivered
// tile is bit-exact, and the pipeline keeps running.
TEST(StreamPipeline, StressWithRandomFaultsNeverDeliversWrongData) {
  MemorySource mem(std::span<const uint8_t>(fixture().file));
  FaultySource faulty(mem);
  faulty.periodic_faults(25, fixture().dir.header.payload_offset);
  PipelineConfig cfg;
  cfg.worker_threads = 3;
  cfg.ready_capacity = 4;
  cfg.decoded_cache_tiles = 4;
  cfg.compressed_cache_bytes = 20'000;
  auto p = StreamingPipeline::open(faulty, cfg);
  ASSERT_TRUE(p.ok());
  std::mt19937 rng(3);
  const auto tiles = all_tiles();
  Collected c;
  // 300 random frames at least; then random frames go on until the pipeline has delivered and
  // read enough for the checks below, so a slow machine (sanitisers, a loaded CI) takes longer
  // instead of failing. A pipeline that stops delivering still fails, at the deadline.
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  const auto enough = [&] { return c.order.size() > 20u && p.value()->progress().fetches >= 25u; };
  for (int frame = 0; frame < 300 || (!enough() && std::chrono::steady_clock::now() < deadline); ++frame) {
    std::vector<StreamItem> wanted;
    const size_t n = rng() % 12;
    for (size_t i = 0; i < n; ++i) wanted.push_back(tiles[rng() % tiles.size()]);
    if (rng() % 5 == 0) wanted.push_back(StreamItem::for_packet(0));
    p.value()->request(wanted);
    p.value()->deliver(rng() % 4, [&](const StreamDelivery& d) {
      c.order.push_back(d.item);
      if (d.item.kind == StreamItem::Kind::tile &&
          !std::equal(d.samples.begin(), d.samples.end(), fixture().reference.at(d.item.tile.key()).begin()))
        ++c.wrong;
    });
    std::this_thread::sleep_for(300us);
  }
  EXPECT_EQ(c.wrong, 0);
  EXPECT_GT(c.order.size(), 20u);
  const auto pr = p.value()->progress();
  ASSERT_GE(pr.fetches, 25u) << "too few reads for the fault schedule to have fired";
  EXPECT_GT(pr.checksum_failures + pr.source_errors, 0u);
  EXPECT_LE(pr.compressed_cache_bytes, cfg.compressed_cache_bytes);
}

}  // namespace
