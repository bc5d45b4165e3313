// btflod — a byte-budgeted LRU cache of compressed payloads in storage fixed at set-up (the
// client-side RAM cache of paper 000 §6: "a least recently used caching strategy to keep as many
// tiles that have been received as possible"). The Streamer keeps its verified ancestors' payloads
// here, so a child's decode chain rarely reads again; get() and put() never allocate.
//
// Storage, all allocated by the constructor from the configuration, through the RuntimeAllocator
// it is given (core/allocator.hpp; operator new by default):
//   - a byte arena of ⌊byte_budget / chunk_bytes⌋ chunks; a payload occupies ⌈size / chunk⌉
//     chunks chained by a next-chunk array (no fragmentation: any free chunk fits any payload,
//     the cost is < 1 chunk of slack per entry); the memory held never exceeds byte_budget;
//   - max_entries entry records (key, size, first chunk) linked into an intrusive doubly linked
//     LRU list (most recently used at the head) and a free list;
//   - an open-addressing index (linear probing, power-of-two capacity ≥ 2 · max_entries, so the
//     load factor stays ≤ 1/2; deletions shift back, no tombstones) from key to entry.
// put() evicts from the LRU tail until the payload's chunks and an entry record are free.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "btflod/core/allocator.hpp"

namespace btflod {

/// Sizes of a PayloadCache, fixed at construction.
struct PayloadCacheConfig {
  size_t byte_budget = 32u << 20;  ///< arena bytes (whole chunks); payloads held never exceed it
  size_t max_entries = 4096;       ///< payloads held at most
  size_t chunk_bytes = 512;        ///< arena granule (≥ 16); a payload wastes < 1 chunk
};

/// Byte-budgeted LRU of byte strings keyed by a 64-bit key. Not thread-safe: the owner
/// serialises calls (the Streamer calls it from its update thread). No call after construction allocates or
/// throws. Keys are any uint64_t; payloads are copied in and out.
class PayloadCache {
 public:
  /// An empty cache that holds nothing (every put() is rejected).
  PayloadCache() = default;
  /// What the constructor allocates for `config`. No allocation.
  static AllocationTally memory_required(const PayloadCacheConfig& config) noexcept {
    const size_t chunk = std::max<size_t>(config.chunk_bytes, 16);
    const size_t chunks = std::min<size_t>(config.byte_budget / chunk, kNone - 1);
    const size_t entries = std::min(config.max_entries, chunks);
    AllocationTally t;
    if (chunks == 0 || entries == 0) return t;
    size_t index_size = 4;
    while (index_size < 2 * entries) index_size *= 2;
    t.array<decltype(arena_)>(chunks * chunk);
    t.array<decltype(next_chunk_)>(chunks);
    t.array<decltype(entries_)>(entries);
    t.array<decltype(index_)>(index_size);
    return t;
  }
  /// Allocates the arena, the entry records and the index for `config` through `allocator`
  /// (chunk_bytes is raised to at least 16; a budget below one chunk or max_entries 0 make a
  /// cache that holds nothing). When an allocation fails the cache holds nothing and
  /// allocation_failed() is true. Set-up only; noexcept.
  explicit PayloadCache(const PayloadCacheConfig& config, const RuntimeAllocator& allocator = {}) noexcept
      : chunk_(std::max<size_t>(config.chunk_bytes, 16)),
        chunks_(std::min<size_t>(config.byte_budget / std::max<size_t>(config.chunk_bytes, 16), kNone - 1)),
        max_entries_(std::min(config.max_entries, chunks_)) {
    if (chunks_ == 0 || max_entries_ == 0) {
      chunks_ = max_entries_ = 0;
      return;
    }
    size_t index_size = 4;
    while (index_size < 2 * max_entries_) index_size *= 2;
    if (!arena_.allocate(allocator, chunks_ * chunk_) || !next_chunk_.allocate(allocator, chunks_) ||
        !entries_.allocate(allocator, max_entries_) || !index_.allocate(allocator, index_size)) {
      arena_.reset();
      next_chunk_.reset();
      entries_.reset();
      index_.reset();
      chunks_ = max_entries_ = 0;
      allocation_failed_ = true;
      return;
    }
    for (size_t i = 0; i < chunks_; ++i) next_chunk_[i] = i + 1 < chunks_ ? static_cast<uint32_t>(i + 1) : kNone;
    free_chunk_ = 0;
    free_chunks_ = chunks_;
    for (size_t i = 0; i < max_entries_; ++i)
      entries_[i].next = i + 1 < max_entries_ ? static_cast<uint32_t>(i + 1) : kNone;
    free_entry_ = 0;
    index_size_ = index_size;
    std::fill_n(index_.data(), index_size_, kNone);
  }

  PayloadCache(PayloadCache&&) noexcept = default;
  PayloadCache& operator=(PayloadCache&&) noexcept = default;

  /// Copies the payload of `key` into the front of `out`, makes it the most recently used and
  /// returns its size; returns 0 (and leaves `out` and the order alone) when `key` is absent or
  /// `out` is too small for it (then size_of() says how much is needed).
  size_t get(uint64_t key, std::span<uint8_t> out) noexcept {
    const uint32_t e = find(key);
    if (e == kNone || entries_[e].size > out.size()) return 0;
    copy_out(entries_[e], out.data());
    unlink(e);
    push_front(e);
    return entries_[e].size;
  }

  /// Size of the payload of `key`, 0 when absent. Does not change the LRU order.
  size_t size_of(uint64_t key) const noexcept {
    const uint32_t e = find(key);
    return e == kNone ? 0 : entries_[e].size;
  }
  /// True when `key` is held. Does not change the LRU order.
  bool contains(uint64_t key) const noexcept { return find(key) != kNone; }

  /// Inserts a copy of `bytes` under `key` as the most recently used entry, evicting least
  /// recently used entries until it fits. Returns false, changing nothing, when `key` is already
  /// held (its bytes and place stay), `bytes` is empty or it needs more chunks than the arena has.
  bool put(uint64_t key, std::span<const uint8_t> bytes) noexcept {
    const size_t need = (bytes.size() + chunk_ - 1) / chunk_;
    if (bytes.empty() || need > chunks_ || find(key) != kNone) return false;
    while (free_chunks_ < need || free_entry_ == kNone) evict(tail_);
    const uint32_t e = free_entry_;
    free_entry_ = entries_[e].next;
    Entry& en = entries_[e];
    en.key = key;
    en.size = static_cast<uint32_t>(bytes.size());
    // Take `need` chunks off the free list; the chain keeps the free list's links.
    en.first_chunk = free_chunk_;
    uint32_t last = free_chunk_;
    for (size_t i = 1; i < need; ++i) last = next_chunk_[last];
    free_chunk_ = next_chunk_[last];
    next_chunk_[last] = kNone;
    free_chunks_ -= need;
    size_t done = 0;
    for (uint32_t c = en.first_chunk; c != kNone; c = next_chunk_[c]) {
      const size_t n = std::min(chunk_, bytes.size() - done);
      std::memcpy(arena_.data() + static_cast<size_t>(c) * chunk_, bytes.data() + done, n);
      done += n;
    }
    insert_index(e);
    push_front(e);
    bytes_ += bytes.size();
    ++count_;
    return true;
  }

  /// Removes `key` if held. Returns true when it was.
  bool erase(uint64_t key) noexcept {
    const uint32_t e = find(key);
    if (e == kNone) return false;
    remove(e);
    return true;
  }

  /// Removes every entry whose key satisfies pred(key) (e.g. the payloads of a material that
  /// left). Returns how many were removed. noexcept as pred is; no allocation; O(entries).
  template <class Pred>
  size_t erase_if(Pred&& pred) noexcept {
    size_t n = 0;
    for (uint32_t e = head_; e != kNone;) {
      const uint32_t next = entries_[e].next;
      if (pred(entries_[e].key)) {
        remove(e);
        ++n;
      }
      e = next;
    }
    return n;
  }

  /// Calls f(key, size) from the most to the least recently used entry (tests, diagnostics).
  template <class F>
  void for_each_mru(F&& f) const {
    for (uint32_t e = head_; e != kNone; e = entries_[e].next)
      f(entries_[e].key, static_cast<size_t>(entries_[e].size));
  }

  size_t bytes() const noexcept { return bytes_; }                  ///< payload bytes held
  size_t arena_bytes() const noexcept { return chunks_ * chunk_; }  ///< bytes reserved (≤ budget)
  size_t used_chunk_bytes() const noexcept { return (chunks_ - free_chunks_) * chunk_; }  ///< ≥ bytes()
  size_t entries() const noexcept { return count_; }
  size_t max_entries() const noexcept { return max_entries_; }
  uint64_t evictions() const noexcept { return evictions_; }  ///< entries evicted to make room
  /// True when the constructor's allocator failed (the cache then holds nothing).
  bool allocation_failed() const noexcept { return allocation_failed_; }

 private:
  static constexpr uint32_t kNone = 0xffffffffu;
  struct Entry {
    uint64_t key = 0;
    uint32_t size = 0, first_chunk = kNone;
    uint32_t prev = kNone, next = kNone;  // LRU links; `next` doubles as the free-list link
    uint32_t slot = kNone;                // index_ slot holding this entry
  };

  size_t home(uint64_t key) const noexcept {  // Fibonacci hashing onto the power-of-two index
    return static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> 32) & (index_size_ - 1);
  }
  uint32_t find(uint64_t key) const noexcept {
    if (index_size_ == 0) return kNone;
    for (size_t s = home(key);; s = (s + 1) & (index_size_ - 1)) {
      const uint32_t e = index_[s];
      if (e == kNone) return kNone;
      if (entries_[e].key == key) return e;
    }
  }
  void insert_index(uint32_t e) noexcept {
    size_t s = home(entries_[e].key);
    while (index_[s] != kNone) s = (s + 1) & (index_size_ - 1);
    index_[s] = e;
    entries_[e].slot = static_cast<uint32_t>(s);
  }
  // Linear-probing deletion by backward shift (Knuth 6.4, algorithm R): later members of the
  // probe run move into the hole when their home does not lie cyclically in (hole, current].
  void erase_index(uint32_t e) noexcept {
    const size_t mask = index_size_ - 1;
    size_t hole = entries_[e].slot;
    index_[hole] = kNone;
    for (size_t s = (hole + 1) & mask; index_[s] != kNone; s = (s + 1) & mask) {
      const size_t h = home(entries_[index_[s]].key);
      const bool stays = hole <= s ? (hole < h && h <= s) : (hole < h || h <= s);
      if (stays) continue;
      index_[hole] = index_[s];
      entries_[index_[hole]].slot = static_cast<uint32_t>(hole);
      index_[s] = kNone;
      hole = s;
    }
  }
  void unlink(uint32_t e) noexcept {
    Entry& en = entries_[e];
    (en.prev != kNone ? entries_[en.prev].next : head_) = en.next;
    (en.next != kNone ? entries_[en.next].prev : tail_) = en.prev;
    en.prev = en.next = kNone;
  }
  void push_front(uint32_t e) noexcept {
    Entry& en = entries_[e];
    en.prev = kNone;
    en.next = head_;
    if (head_ != kNone) entries_[head_].prev = e;
    head_ = e;
    if (tail_ == kNone) tail_ = e;
  }
  void copy_out(const Entry& en, uint8_t* out) const noexcept {
    size_t done = 0;
    for (uint32_t c = en.first_chunk; c != kNone; c = next_chunk_[c]) {
      const size_t n = std::min<size_t>(chunk_, en.size - done);
      std::memcpy(out + done, arena_.data() + static_cast<size_t>(c) * chunk_, n);
      done += n;
    }
  }
  void remove(uint32_t e) noexcept {
    Entry& en = entries_[e];
    unlink(e);
    erase_index(e);
    // Return the chain to the free list.
    uint32_t last = en.first_chunk;
    size_t n = 1;
    while (next_chunk_[last] != kNone) last = next_chunk_[last], ++n;
    next_chunk_[last] = free_chunk_;
    free_chunk_ = en.first_chunk;
    free_chunks_ += n;
    bytes_ -= en.size;
    --count_;
    en = Entry{};
    en.next = free_entry_;
    free_entry_ = e;
  }
  void evict(uint32_t e) noexcept {
    remove(e);
    ++evictions_;
  }

  size_t chunk_ = 512, chunks_ = 0, max_entries_ = 0, index_size_ = 0;
  RuntimeArray<uint8_t> arena_;
  RuntimeArray<uint32_t> next_chunk_;
  RuntimeArray<Entry> entries_;
  RuntimeArray<uint32_t> index_;
  bool allocation_failed_ = false;
  uint32_t free_chunk_ = kNone, free_entry_ = kNone, head_ = kNone, tail_ = kNone;
  size_t free_chunks_ = 0, bytes_ = 0, count_ = 0;
  uint64_t evictions_ = 0;
};

}  // namespace btflod
