// btflod-label: unit
// Tests for runtime/stream/payload_cache.hpp (the Streamer's compressed-payload LRU in fixed storage):
// eviction order, refusals, the entry limit, and random operations against a reference LRU.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <list>
#include <new>
#include <random>
#include <vector>

#include "btflod/runtime/stream/payload_cache.hpp"
#include "btflod/runtime/stream/tile_source.hpp"

namespace {

using namespace btflod;

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

}  // namespace
