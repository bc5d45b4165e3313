// btflod-label: unit threads
// Tests for stream/payload_cache.hpp (the pipeline's compressed-payload LRU in fixed storage)
// and for the pipeline's "no allocation after set-up": a counting global operator new in this
// executable counts every heap allocation, on any thread, while steady-state streaming runs
// (workers fetching, verifying, caching with evictions, decoding tiles and U packets; the render
// thread requesting and delivering). The old cache (std::list + unordered_map + a vector per
// entry) allocated on every insert and fails the test.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <list>
#include <map>
#include <new>
#include <random>
#include <thread>
#include <vector>

#include "btflod/core/thread_pool.hpp"
#include "btflod/stream/payload_cache.hpp"
#include "btflod/stream/pipeline.hpp"
#include "btflod/stream/tile_source.hpp"

// Counts global allocations on any thread (the pipeline must not allocate after set-up).
#include "test_counting_new.hpp"

namespace {

using namespace btflod;
using namespace std::chrono_literals;

std::vector<uint8_t> payload(uint64_t key, size_t size) {
  std::vector<uint8_t> v(size);
  for (size_t i = 0; i < size; ++i) v[i] = static_cast<uint8_t>(key * 31 + i * 7 + (i >> 8));
  return v;
}

std::vector<uint64_t> mru_keys(const PayloadCache& c) {
  std::vector<uint64_t> k;
  c.for_each_mru([&](uint64_t key, size_t) { k.push_back(key); });
  return k;
}

TEST(PayloadCache, EvictsTheLeastRecentlyUsedAndGetRefreshes) {
  PayloadCache c(PayloadCacheConfig{4 * 64, 16, 64});  // 4 chunks of 64 bytes
  for (uint64_t k = 1; k <= 4; ++k) ASSERT_TRUE(c.put(k, payload(k, 64)));
  EXPECT_EQ(mru_keys(c), (std::vector<uint64_t>{4, 3, 2, 1}));
  std::vector<uint8_t> out(64);
  EXPECT_EQ(c.get(1, out), 64u);
  EXPECT_EQ(out, payload(1, 64));
  EXPECT_EQ(mru_keys(c), (std::vector<uint64_t>{1, 4, 3, 2}));
  ASSERT_TRUE(c.put(5, payload(5, 64)));  // evicts 2, the least recently used
  EXPECT_EQ(mru_keys(c), (std::vector<uint64_t>{5, 1, 4, 3}));
  EXPECT_FALSE(c.contains(2));
  EXPECT_EQ(c.evictions(), 1u);
  ASSERT_TRUE(c.put(6, payload(6, 130)));  // 3 chunks: evicts 3, 4 and 1
  EXPECT_EQ(mru_keys(c), (std::vector<uint64_t>{6, 5}));
  EXPECT_EQ(c.evictions(), 4u);
  EXPECT_EQ(c.bytes(), 64u + 130u);
  EXPECT_EQ(c.used_chunk_bytes(), 4u * 64u);
  out.resize(130);
  EXPECT_EQ(c.get(6, out), 130u);
  EXPECT_EQ(out, payload(6, 130));
}

TEST(PayloadCache, RejectsDuplicatesEmptyAndOversizedAndShortOutput) {
  PayloadCache c(PayloadCacheConfig{1000, 8, 100});  // 10 chunks
  ASSERT_TRUE(c.put(7, payload(7, 250)));
  ASSERT_TRUE(c.put(8, payload(8, 10)));
  EXPECT_FALSE(c.put(7, payload(99, 40))) << "a held key keeps its bytes";
  EXPECT_EQ(mru_keys(c), (std::vector<uint64_t>{8, 7})) << "and its place";
  EXPECT_FALSE(c.put(9, {}));
  EXPECT_FALSE(c.put(10, payload(10, 1001)));
  EXPECT_EQ(c.entries(), 2u);
  std::vector<uint8_t> small(249);
  EXPECT_EQ(c.get(7, small), 0u) << "too small an output span";
  EXPECT_EQ(c.size_of(7), 250u);
  EXPECT_EQ(mru_keys(c), (std::vector<uint64_t>{8, 7})) << "a failed get does not refresh";
  std::vector<uint8_t> out(250);
  EXPECT_EQ(c.get(7, out), 250u);
  EXPECT_EQ(out, payload(7, 250));
  EXPECT_TRUE(c.erase(7));
  EXPECT_FALSE(c.erase(7));
  EXPECT_EQ(c.bytes(), 10u);
  PayloadCache none;
  EXPECT_FALSE(none.put(1, payload(1, 1)));
  EXPECT_EQ(none.get(1, out), 0u);
}

TEST(PayloadCache, HoldsAtMostMaxEntries) {
  PayloadCache c(PayloadCacheConfig{1 << 16, 3, 64});
  for (uint64_t k = 0; k < 10; ++k) ASSERT_TRUE(c.put(k, payload(k, 5)));
  EXPECT_EQ(mru_keys(c), (std::vector<uint64_t>{9, 8, 7}));
  EXPECT_EQ(c.evictions(), 7u);
}

// Against a straightforward model (std::list, most recent first) under random puts, gets and
// erases with multi-chunk payloads and colliding keys: same contents, same order, same bytes,
// and the arena never holds more than its budget.
TEST(PayloadCache, MatchesAReferenceLruUnderRandomOperations) {
  constexpr size_t kChunk = 64, kBudget = 40 * 64 + 13, kMaxEntries = 12;
  PayloadCache c(PayloadCacheConfig{kBudget, kMaxEntries, kChunk});
  const size_t chunks = kBudget / kChunk;
  struct M {
    uint64_t key;
    std::vector<uint8_t> bytes;
  };
  std::list<M> model;
  size_t model_chunks = 0;
  uint64_t model_evictions = 0;
  const auto need = [&](size_t n) { return (n + kChunk - 1) / kChunk; };
  std::mt19937_64 rng(42);
  std::vector<uint8_t> out(2000);
  for (int op = 0; op < 20000; ++op) {
    // Keys from a small set that includes values differing only in high bits.
    const uint64_t key = (rng() % 40) * ((op & 1) ? 1ull : (1ull << 40));
    const int kind = static_cast<int>(rng() % 10);
    auto it = model.begin();
    while (it != model.end() && it->key != key) ++it;
    if (kind < 5) {  // put
      const size_t size = 1 + rng() % 700;
      const std::vector<uint8_t> bytes = payload(key ^ static_cast<uint64_t>(op), size);
      const bool expect = it == model.end() && need(size) <= chunks;
      ASSERT_EQ(c.put(key, bytes), expect) << "op " << op;
      if (expect) {
        while (chunks - model_chunks < need(size) || model.size() == kMaxEntries) {
          model_chunks -= need(model.back().bytes.size());
          model.pop_back();
          ++model_evictions;
        }
        model.push_front({key, bytes});
        model_chunks += need(size);
      }
    } else if (kind < 9) {  // get
      const size_t n = c.get(key, out);
      ASSERT_EQ(n, it == model.end() ? 0 : it->bytes.size()) << "op " << op;
      if (it != model.end()) {
        ASSERT_EQ(0, std::memcmp(out.data(), it->bytes.data(), n)) << "op " << op;
        model.splice(model.begin(), model, it);
      }
    } else {  // erase
      ASSERT_EQ(c.erase(key), it != model.end());
      if (it != model.end()) {
        model_chunks -= need(it->bytes.size());
        model.erase(it);
      }
    }
    std::vector<uint64_t> keys;
    size_t bytes = 0;
    for (const M& m : model) keys.push_back(m.key), bytes += m.bytes.size();
    ASSERT_EQ(mru_keys(c), keys) << "op " << op;
    ASSERT_EQ(c.bytes(), bytes);
    ASSERT_EQ(c.used_chunk_bytes(), model_chunks * kChunk);
    ASSERT_LE(c.used_chunk_bytes(), kBudget);
    ASSERT_EQ(c.evictions(), model_evictions);
  }
  EXPECT_GT(model_evictions, 1000u);
}

// --- the pipeline: steady-state streaming does not allocate ------------------------------------

float value(uint32_t comp, double u, double v) {
  return static_cast<float>((1.0 + comp) *
                            (std::sin(9.0 * u + comp) * std::cos(6.0 * v) + 0.3 * std::sin(41.0 * u * v + comp)));
}

// T = 16, B = 4, 3 levels (21 tiles), 8 components (2 textures, 2 U packets of 60 rows).
struct Fixture {
  std::vector<uint8_t> file;
  BsvtfDirectory dir;
  std::map<uint64_t, std::vector<float>> reference;  // decoded tiles
};
const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture fx;
    BsvtfMetadata md;
    md.material_name = "cache-test";
    md.tile_size = 16;
    md.border = 4;
    md.level_count = 3;
    md.width = md.height = 64;
    md.component_count = 8;
    md.u_rows = 60;
    std::vector<float> u(60 * 8);
    for (size_t i = 0; i < u.size(); ++i) u[i] = 0.01f * static_cast<float>(i % 97);
    const TileLayout layout = md.layout();
    const uint32_t s = layout.stored_size();
    std::vector<std::vector<float>> samples;
    std::vector<BsvtfTileInput> tiles;
    for (uint32_t k = 0; k < 2; ++k)
      for (uint32_t l = 0; l < 3; ++l)
        for (uint32_t y = 0; y < (1u << l); ++y)
          for (uint32_t x = 0; x < (1u << l); ++x) {
            std::vector<float> t(layout.sample_count());
            const double w = 16.0 * (1u << l);
            for (uint32_t j = 0; j < s; ++j)
              for (uint32_t i = 0; i < s; ++i) {
                const double px = std::clamp(x * 16.0 - 4 + i, 0.0, w - 1),
                             py = std::clamp(y * 16.0 - 4 + j, 0.0, w - 1);
                for (uint32_t c = 0; c < 4; ++c)
                  t[(j * s + i) * 4 + c] = value(4 * k + c, (px + 0.5) / w, (py + 0.5) / w);
              }
            samples.push_back(std::move(t));
            tiles.push_back({TileId{k, l, x, y}, {}, 1.0f});
          }
    for (size_t i = 0; i < tiles.size(); ++i) tiles[i].samples = samples[i];
    ThreadPool pool(1);
    BsvtfBuildOptions o;
    o.pool = &pool;
    fx.file = build_bsvtf(md, u, tiles, o).value();
    fx.dir = read_bsvtf(fx.file).value();
    TileDecoder dec(layout);
    for (uint32_t l = 0; l < 3; ++l)
      for (const auto& e : fx.dir.tiles) {
        if (e.id.level != l) continue;
        std::vector<float> out(layout.sample_count());
        std::span<const float> parent;
        if (l > 0) parent = fx.reference.at(e.id.parent().key());
        EXPECT_EQ(dec.decode(std::span<const uint8_t>(fx.file).subspan(e.offset, e.size), parent, e.id.x & 1,
                             e.id.y & 1, out),
                  Status::success);
        fx.reference[e.id.key()] = out;
      }
    return fx;
  }();
  return f;
}

TEST(PipelineAllocation, SteadyStateStreamingDoesNotAllocate) {
  const Fixture& fx = fixture();
  MemorySource source{std::span<const uint8_t>(fx.file)};
  size_t payload_bytes = 0;
  for (const auto& t : fx.dir.tiles) payload_bytes += t.size;
  for (const auto& p : fx.dir.packets) payload_bytes += p.size;
  ASSERT_EQ(fx.dir.packets.size(), 2u);
  PipelineConfig config;
  config.worker_threads = 2;
  config.compressed_cache_bytes = payload_bytes / 3;  // evictions and re-fetches every round
  config.compressed_cache_chunk = 128;
  config.decoded_cache_tiles = 3;  // ancestors are re-fetched and re-decoded
  config.ready_capacity = 4;
  auto p = StreamingPipeline::open(source, config);
  ASSERT_TRUE(p.ok()) << p.message();
  StreamingPipeline& pipe = *p.value();

  // The wanted lists of every round, built before counting: finest tiles first (so ancestors
  // are fetched on the way), packets last, a different rotation each round.
  std::vector<StreamItem> items;
  for (uint32_t l = 3; l-- > 0;)
    for (const auto& e : fx.dir.tiles)
      if (e.id.level == l) items.push_back(StreamItem::for_tile(e.id));
  items.push_back(StreamItem::for_packet(0));
  items.push_back(StreamItem::for_packet(1));
  constexpr int kRounds = 6;
  std::vector<std::vector<StreamItem>> rounds(kRounds + 1, items);
  for (int r = 0; r <= kRounds; ++r)
    std::rotate(rounds[r].begin(), rounds[r].begin() + (5 * r) % items.size(), rounds[r].end());
  std::vector<std::vector<float>> packet_reference(2);
  for (uint32_t i = 0; i < 2; ++i) {
    const auto& e = fx.dir.packets[i];
    packet_reference[i].resize(e.size / 2);
    unpack_bsvtf_packet(std::span<const uint8_t>(fx.file).subspan(e.offset, e.size), packet_reference[i]);
  }

  size_t delivered = 0, wrong = 0;
  const auto sink = [&](const StreamDelivery& d) {  // allocation-free checks
    ++delivered;
    if (d.item.kind == StreamItem::Kind::tile) {
      const auto& ref = fx.reference.at(d.item.tile.key());
      if (d.samples.size() != ref.size() || std::memcmp(d.samples.data(), ref.data(), ref.size() * sizeof(float)) != 0)
        ++wrong;
    } else {
      const auto& ref = packet_reference[d.item.packet];
      if (d.samples.size() != ref.size() || std::memcmp(d.samples.data(), ref.data(), ref.size() * sizeof(float)) != 0)
        ++wrong;
    }
  };
  const auto run_round = [&](const std::vector<StreamItem>& wanted) {
    const size_t target = delivered + wanted.size();
    pipe.request(wanted);
    const auto deadline = std::chrono::steady_clock::now() + 20s;
    while (delivered < target && std::chrono::steady_clock::now() < deadline) {
      pipe.deliver(2, sink);
      std::this_thread::sleep_for(100us);
    }
    return delivered == target;
  };
  ASSERT_TRUE(run_round(rounds[0])) << "warm-up";  // set-up: first decodes, lazy library state
  const PipelineProgress before = pipe.progress();

  const uint64_t allocations_before = btflod_test::global_news();
  bool all = true;
  for (int r = 1; r <= kRounds; ++r) all = all && run_round(rounds[r]);
  const uint64_t allocations = btflod_test::global_news() - allocations_before;

  ASSERT_TRUE(all) << "every round delivers every item";
  const PipelineProgress after = pipe.progress();
  EXPECT_EQ(allocations, 0u) << "heap allocations while streaming";
  EXPECT_EQ(wrong, 0u) << "every delivery is the reference decode (checksummed payloads verified)";
  EXPECT_GT(after.evictions, before.evictions) << "the steady state must evict and re-insert";
  EXPECT_GT(after.fetches, before.fetches);
  EXPECT_GT(after.cache_hits, 0u);
  EXPECT_EQ(after.checksum_failures, 0u);
  EXPECT_LE(after.compressed_cache_bytes, config.compressed_cache_bytes);
  EXPECT_EQ(after.bytes_received - before.bytes_received > 0, true);
}

}  // namespace
