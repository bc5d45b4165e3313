// btflod — the streaming pipeline: requests in the scheduler's priority order, fetched from a
// TileSource, verified, decoded on worker threads and handed to the backend within an upload
// budget (paper 000 §6).
//
// - request(wanted) replaces the wanted list each frame (highest priority first). Queued items no
//   longer wanted are dropped and in-flight ones are cancelled (stale requests).
// - A tile is decoded against its parent's decoded tile. The pipeline keeps a small LRU of
//   decoded tiles and a byte-budgeted LRU of verified compressed payloads (paper 000 §6: "a least
//   recently used caching strategy to keep as many tiles that have been received as possible in
//   the client-side RAM"); when an ancestor is in neither, it is fetched and decoded first.
// - Every payload is checked against its index entry (size, CRC-32) before it is decoded or
//   cached. A bad checksum, a truncated transfer or a source error is reported as an event and
//   the item is re-requested up to `max_retries` times, then skipped; nothing unverified enters a
//   cache. Later requests for a skipped item try again.
// - deliver(budget, sink) on the render thread hands over at most `budget` decoded items.
// - Shutdown (destructor) cancels in-flight reads and joins the workers; sources poll the cancel
//   flag, so it does not wait out slow transfers. No lock is held while reading, decoding or
//   calling the sink, and the render thread never waits for a worker, so nothing can deadlock.
//
// Threading: request(), deliver(), progress() and drain_events() may be called from any one
// thread at a time (the render thread). Every buffer is sized in open() from the config and the
// directory: request() and deliver() do not allocate, nor do the workers while fetching,
// verifying, caching (stream/payload_cache.hpp: fixed arena, index and intrusive LRU list) and
// decoding tiles and U packets. Only faults allocate (their event messages).
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "btflod/codec/container.hpp"
#include "btflod/codec/tile_codec.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/stream/payload_cache.hpp"
#include "btflod/stream/file_source.hpp"
#include "btflod/stream/tile_source.hpp"
#include "btflod/vt/tile_id.hpp"

namespace btflod {

/// One thing the pipeline can fetch: a tile or a packet of U (4 components).
struct StreamItem {
  enum class Kind : uint8_t { tile, packet };
  Kind kind = Kind::tile;
  TileId tile{};
  uint32_t packet = 0;

  static constexpr StreamItem for_tile(TileId id) noexcept { return StreamItem{Kind::tile, id, 0}; }
  static constexpr StreamItem for_packet(uint32_t index) noexcept { return StreamItem{Kind::packet, TileId{}, index}; }
  /// A unique 64-bit key (tile keys of a container never have bit 63 set: textures < 2^14).
  constexpr uint64_t key() const noexcept { return kind == Kind::tile ? tile.key() : ((uint64_t{1} << 63) | packet); }
  friend constexpr bool operator==(const StreamItem& a, const StreamItem& b) noexcept { return a.key() == b.key(); }
};

/// Budgets and sizes, all fixed at open().
struct PipelineConfig {
  unsigned worker_threads = 2;                ///< concurrent fetch+decode jobs (= requests in flight)
  size_t max_wanted = 4096;                   ///< longest wanted list; longer lists are truncated (counted)
  size_t compressed_cache_bytes = 32u << 20;  ///< byte budget of the compressed-payload LRU (allocated in open())
  size_t compressed_cache_entries = 0;        ///< payloads it holds at most; 0: one per tile and U packet
  size_t compressed_cache_chunk = 512;        ///< its arena granule (stream/payload_cache.hpp)
  size_t decoded_cache_tiles = 32;            ///< decoded tiles kept as parents for their children
  size_t ready_capacity = 32;                 ///< decoded items waiting for deliver()
  unsigned max_retries = 2;                   ///< re-requests after a checksum or source failure
  ProgressCallback progress;                  ///< called from deliver() with ("stream", converged fraction)
};

/// Counters and progress (paper 004 §5's progress bar: bytes, tiles, components and
/// fraction of the converged state).
struct PipelineProgress {
  uint64_t bytes_received = 0;   ///< verified payload bytes fetched from the source
  uint64_t bytes_total = 0;      ///< payload bytes of the whole container
  uint32_t tiles_delivered = 0;  ///< distinct tiles handed to the backend
  uint32_t tiles_total = 0;
  uint32_t packets_delivered = 0;  ///< distinct U packets handed over
  uint32_t packets_total = 0;
  uint32_t components_delivered = 0;  ///< eigen-ABRDF columns available (4 per packet, capped at C)
  /// Σ w of delivered tiles / Σ w of all tiles (paper 000 eq. 8: w is the error a tile removes),
  /// by tile count when every w is 0.
  double converged_fraction = 0.0;
  // Counters.
  uint64_t fetches = 0, cache_hits = 0, ancestor_fetches = 0, decodes = 0;
  uint64_t stale_cancelled = 0, checksum_failures = 0, source_errors = 0, decode_failures = 0;
  uint64_t retries = 0, skipped = 0, evictions = 0, upload_budget_hits = 0, wanted_truncated = 0;
  size_t compressed_cache_bytes = 0;
};

/// A fault the pipeline detected (see drain_events).
struct PipelineEvent {
  StreamItem item;
  Status status = Status::success;
  bool skipped = false;  ///< true: retries exhausted, the item was dropped
  std::string message;
};

/// A decoded item handed to the backend: tile samples (layout().sample_count() floats,
/// texel-interleaved RGBA) or a U packet (u_rows × 4 floats). Valid during the sink call only.
struct StreamDelivery {
  StreamItem item;
  std::span<const float> samples;
  float weight = 0.0f;  ///< the tile's w from the index (0 for packets)
};

class StreamingPipeline {
 public:
  /// Reads and validates the container directory through `source` (header, then directory),
  /// sizes every buffer and starts the workers. `source` must outlive the pipeline.
  /// Returns the reader's errors (bad_data, short_output, io_error, …) or invalid_argument for a
  /// config with 0 workers or 0 ready slots.
  static Result<std::unique_ptr<StreamingPipeline>> open(TileSource& source, PipelineConfig config = {}) {
    if (config.worker_threads == 0 || config.ready_capacity == 0 || config.max_wanted == 0)
      return make_error(Status::invalid_argument, "pipeline: worker_threads, ready_capacity and max_wanted must be > 0");
    auto size = source.size();
    if (!size) return size.error();
    std::vector<uint8_t> header(kBsvtfHeaderSize);
    if (size.value() < kBsvtfHeaderSize)
      return make_error(Status::short_output, "%s: %llu bytes, smaller than a bsvtf header", source.describe().c_str(),
                        static_cast<unsigned long long>(size.value()));
    if (auto r = source.read(0, header); !r) return r.error();
    auto h = parse_bsvtf_header(header, size.value());
    if (!h) return make_error(h.status(), "%s: %s", source.describe().c_str(), h.message().c_str());
    std::vector<uint8_t> directory(h->directory_size);
    if (auto r = source.read(0, directory); !r) return r.error();
    auto d = parse_bsvtf_directory(directory, size.value());
    if (!d) return make_error(d.status(), "%s: %s", source.describe().c_str(), d.message().c_str());
    return std::unique_ptr<StreamingPipeline>(new StreamingPipeline(source, std::move(config), std::move(d.value())));
  }

  StreamingPipeline(const StreamingPipeline&) = delete;
  StreamingPipeline& operator=(const StreamingPipeline&) = delete;
  /// Cancels in-flight reads, drops queued work and joins the workers.
  ~StreamingPipeline() { shutdown(); }

  const BsvtfDirectory& directory() const noexcept { return directory_; }
  TileLayout layout() const noexcept { return layout_; }

  /// Replaces the wanted list (highest priority first). Items not in the container are ignored;
  /// queued items that are no longer wanted are dropped and in-flight ones cancelled (both
  /// counted in stale_cancelled); items in flight or waiting for delivery are not fetched twice.
  /// No allocation. Call from the render thread.
  void request(std::span<const StreamItem> wanted) {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    // Old queue entries, sorted, to count the ones that become stale.
    scratch_old_.clear();
    for (size_t i = next_; i < pending_.size(); ++i) scratch_old_.push_back(pending_[i].key());
    pending_.clear();
    next_ = 0;
    for (const StreamItem& item : wanted) {
      if (pending_.size() == config_.max_wanted) {
        ++progress_.wanted_truncated;
        break;
      }
      if (!known(item) || busy(item)) continue;
      pending_.push_back(item);
    }
    scratch_new_.clear();
    for (const auto& item : pending_) scratch_new_.push_back(item.key());
    std::sort(scratch_old_.begin(), scratch_old_.end());
    std::sort(scratch_new_.begin(), scratch_new_.end());
    for (uint64_t k : scratch_old_)
      if (!std::binary_search(scratch_new_.begin(), scratch_new_.end(), k)) ++progress_.stale_cancelled;
    // In-flight items that are no longer wanted get cancelled.
    for (auto& job : jobs_) {
      if (!job.active || job.cancel.load()) continue;
      bool still = false;
      for (const StreamItem& item : wanted)
        if (item == job.item) {
          still = true;
          break;
        }
      if (!still) {
        job.cancel.store(true);
        ++progress_.stale_cancelled;
      }
    }
    work_.notify_all();
    slot_free_.notify_all();  // a cancelled job may be waiting for a ready slot or another fetch
    fetch_done_.notify_all();
  }

  /// Hands at most `budget` decoded items to `sink(const StreamDelivery&)`, oldest first, and
  /// returns how many. The sink runs without any pipeline lock held and may call request().
  /// No allocation. Call from the render thread.
  template <class Sink>
  size_t deliver(size_t budget, Sink&& sink) {
    {
      std::lock_guard lock(mutex_);
      delivering_.clear();
      while (!ready_order_.empty() && delivering_.size() < budget) {
        delivering_.push_back(ready_order_.front());
        ready_order_.erase(ready_order_.begin());
      }
      if (!ready_order_.empty()) ++progress_.upload_budget_hits;
    }
    for (size_t slot : delivering_) {
      const ReadySlot& r = ready_[slot];
      StreamDelivery d{r.item, r.item.kind == StreamItem::Kind::tile ? std::span<const float>(r.samples)
                                                                        : std::span<const float>(r.packet),
                       r.weight};
      sink(static_cast<const StreamDelivery&>(d));
    }
    double fraction = 0;
    {
      std::lock_guard lock(mutex_);
      for (size_t slot : delivering_) {
        ReadySlot& r = ready_[slot];
        count_delivery(r);
        r.item = StreamItem{};
        free_ready_.push_back(slot);
      }
      fraction = progress_.converged_fraction;
    }
    if (!delivering_.empty()) {
      slot_free_.notify_all();
      report_progress(config_.progress, "stream", fraction);
    }
    return delivering_.size();
  }

  /// A snapshot of the counters and progress. Thread-safe.
  PipelineProgress progress() const {
    std::lock_guard lock(mutex_);
    return progress_;
  }

  /// Calls sink(const PipelineEvent&) for every fault recorded since the last call and clears
  /// them. Returns the number of events. Thread-safe.
  template <class Sink>
  size_t drain_events(Sink&& sink) {
    std::vector<PipelineEvent> events;
    {
      std::lock_guard lock(mutex_);
      events.swap(events_);
    }
    for (const auto& e : events) sink(e);
    return events.size();
  }

  /// True when nothing is queued, in flight or waiting for delivery. Thread-safe.
  bool idle() const {
    std::lock_guard lock(mutex_);
    if (next_ < pending_.size() || !ready_order_.empty()) return false;
    for (const auto& job : jobs_)
      if (job.active) return false;
    return true;
  }

  /// Stops the workers: queued work is dropped, in-flight reads are cancelled. Idempotent.
  void shutdown() {
    {
      std::lock_guard lock(mutex_);
      if (stopping_ && workers_.empty()) return;
      stopping_ = true;
      pending_.clear();
      next_ = 0;
      for (auto& job : jobs_) job.cancel.store(true);
    }
    work_.notify_all();
    slot_free_.notify_all();
    fetch_done_.notify_all();
    for (auto& t : workers_) t.join();
    workers_.clear();
  }

 private:
  struct Job {  // one per worker: what it is working on
    StreamItem item;
    bool active = false;
    bool fetching = false;  // reading `fetching_key` from the source right now
    uint64_t fetching_key = 0;
    std::atomic<bool> cancel{false};
  };
  struct ReadySlot {
    StreamItem item;
    std::vector<float> samples;
    std::vector<float> packet;
    float weight = 0;
  };
  struct DecodedSlot {
    uint64_t key = 0;
    bool used = false;
    uint64_t stamp = 0;
    std::vector<float> samples;
  };

  StreamingPipeline(TileSource& source, PipelineConfig config, BsvtfDirectory directory)
      : source_(source), config_(std::move(config)), directory_(std::move(directory)), layout_(directory_.metadata.layout()) {
    const size_t items = directory_.tiles.size() + directory_.packets.size();
    compressed_ = PayloadCache(PayloadCacheConfig{
        config_.compressed_cache_bytes, config_.compressed_cache_entries ? config_.compressed_cache_entries : items,
        config_.compressed_cache_chunk});
    // The largest payload and U packet fix the workers' buffers, so no fetch ever grows them.
    max_payload_ = tile_encode_bound(layout_);
    for (const auto& t : directory_.tiles) max_payload_ = std::max<size_t>(max_payload_, t.size);
    for (const auto& p : directory_.packets) {
      max_payload_ = std::max<size_t>(max_payload_, p.size);
      max_packet_floats_ = std::max<size_t>(max_packet_floats_, p.size / 2);
    }
    pending_.reserve(config_.max_wanted);
    scratch_old_.reserve(config_.max_wanted);
    scratch_new_.reserve(config_.max_wanted);
    ready_.resize(config_.ready_capacity);
    for (size_t i = 0; i < ready_.size(); ++i) {
      ready_[i].samples.resize(layout_.sample_count());
      ready_[i].packet.reserve(max_packet_floats_);
      free_ready_.push_back(config_.ready_capacity - 1 - i);
    }
    ready_order_.reserve(config_.ready_capacity);
    free_ready_.reserve(config_.ready_capacity);
    delivering_.reserve(config_.ready_capacity);
    decoded_.resize(std::max<size_t>(config_.decoded_cache_tiles, 1));
    for (auto& d : decoded_) d.samples.resize(layout_.sample_count());
    delivered_.assign(directory_.tiles.size(), 0);
    packet_delivered_.assign(directory_.packets.size(), 0);
    for (const auto& t : directory_.tiles) {
      total_weight_ += t.weight;
      progress_.bytes_total += t.size;
    }
    for (const auto& p : directory_.packets) progress_.bytes_total += p.size;
    progress_.tiles_total = static_cast<uint32_t>(directory_.tiles.size());
    progress_.packets_total = static_cast<uint32_t>(directory_.packets.size());
    jobs_ = std::vector<Job>(config_.worker_threads);
    for (unsigned i = 0; i < config_.worker_threads; ++i) workers_.emplace_back([this, i] { worker(jobs_[i]); });
  }

  bool known(const StreamItem& item) const noexcept {
    return item.kind == StreamItem::Kind::tile ? directory_.find(item.tile) != nullptr : item.packet < directory_.packets.size();
  }
  // In flight or waiting for delivery (mutex_ held).
  bool busy(const StreamItem& item) const noexcept {
    for (const auto& job : jobs_)
      if (job.active && !job.cancel.load() && job.item == item) return true;
    for (size_t slot : ready_order_)
      if (ready_[slot].item == item) return true;
    return false;
  }

  void count_delivery(const ReadySlot& r) {  // mutex_ held
    if (r.item.kind == StreamItem::Kind::tile) {
      const auto* e = directory_.find(r.item.tile);
      const size_t index = static_cast<size_t>(e - directory_.tiles.data());
      if (!delivered_[index]) {
        delivered_[index] = 1;
        ++progress_.tiles_delivered;
        delivered_weight_ += e->weight;
      }
    } else if (!packet_delivered_[r.item.packet]) {
      packet_delivered_[r.item.packet] = 1;
      ++progress_.packets_delivered;
      progress_.components_delivered = std::min(progress_.packets_delivered * 4, directory_.metadata.component_count);
    }
    progress_.converged_fraction = total_weight_ > 0 ? delivered_weight_ / total_weight_
                                                     : static_cast<double>(progress_.tiles_delivered) / std::max<size_t>(1, directory_.tiles.size());
  }

  void record(const StreamItem& item, Status s, bool skipped, std::string message) {  // mutex_ held
    if (events_.size() < kMaxEvents) events_.push_back(PipelineEvent{item, s, skipped, std::move(message)});
  }

  // --- compressed LRU (mutex_ held): fixed storage, no allocation ---
  bool cache_get(uint64_t key, std::vector<uint8_t>& out) {
    const size_t n = compressed_.size_of(key);
    if (n == 0 || n > out.capacity()) return false;
    out.resize(n);  // within the capacity reserved in worker(): no allocation
    return compressed_.get(key, out) == n;
  }
  void cache_put(uint64_t key, std::span<const uint8_t> bytes) {
    const uint64_t before = compressed_.evictions();
    compressed_.put(key, bytes);
    progress_.evictions += compressed_.evictions() - before;
    progress_.compressed_cache_bytes = compressed_.bytes();
  }

  // --- decoded LRU (mutex_ held) ---
  bool decoded_get(uint64_t key, std::vector<float>& out) {
    for (auto& d : decoded_)
      if (d.used && d.key == key) {
        d.stamp = ++clock_;
        std::copy(d.samples.begin(), d.samples.end(), out.begin());
        return true;
      }
    return false;
  }
  void decoded_put(uint64_t key, const std::vector<float>& samples) {
    DecodedSlot* victim = &decoded_[0];
    for (auto& d : decoded_) {
      if (d.used && d.key == key) return;
      if (!d.used || d.stamp < victim->stamp || (victim->used && !d.used)) victim = &d;
    }
    victim->key = key;
    victim->used = true;
    victim->stamp = ++clock_;
    std::copy(samples.begin(), samples.end(), victim->samples.begin());
  }

  // Fetches and verifies one payload into `bytes` (from the cache or the source).
  Status fetch(const StreamItem& item, uint64_t offset, uint32_t size, uint32_t crc, bool ancestor, Job& job,
               std::vector<uint8_t>& bytes, std::string& why) {
    const uint64_t key = item.key();
    {
      // Another worker reading the same payload (a tile fetched as an ancestor while it is also
      // requested itself) is waited for, so every payload crosses the network once.
      std::unique_lock lock(mutex_);
      fetch_done_.wait(lock, [&] { return stopping_ || job.cancel.load() || !fetching_elsewhere(key, job); });
      if (stopping_ || job.cancel.load()) return Status::cancelled;
      if (cache_get(key, bytes)) {
        ++progress_.cache_hits;
        return Status::success;
      }
      ++progress_.fetches;
      if (ancestor) ++progress_.ancestor_fetches;
      job.fetching = true;
      job.fetching_key = key;
    }
    bytes.resize(size);
    auto r = source_.read(offset, bytes, &job.cancel);
    Status s = r ? verify_bsvtf_payload(size, crc, bytes) : r.status();
    if (!r) {
      why = r.message();
    } else if (s != Status::success) {
      why = format_message("payload of %u bytes at %llu fails its checksum %08x", size, static_cast<unsigned long long>(offset), crc);
      s = Status::bad_data;
    }
    {
      std::lock_guard lock(mutex_);
      job.fetching = false;
      if (s == Status::success) {
        progress_.bytes_received += size;
        cache_put(key, bytes);
      }
    }
    fetch_done_.notify_all();
    return s;
  }

  bool fetching_elsewhere(uint64_t key, const Job& self) const {  // mutex_ held
    for (const auto& job : jobs_)
      if (&job != &self && job.fetching && job.fetching_key == key) return true;
    return false;
  }

  // Decodes a tile and its missing ancestors into `out`. Returns the failing status and item.
  Status produce_tile(TileId id, Job& job, TileDecoder& decoder, std::vector<uint8_t>& bytes, std::vector<float>& parent,
                      std::vector<float>& out, StreamItem& failed, std::string& why, bool& checksum, bool& decode_failed) {
    // Walk up until an ancestor's decoded tile is at hand (or the root).
    TileId chain[kMaxTileLevel + 1];
    size_t n = 0;
    chain[n++] = id;
    bool have_parent = false;
    {
      std::lock_guard lock(mutex_);
      for (TileId cur = id; cur.level > 0; cur = cur.parent()) {
        if (decoded_get(cur.parent().key(), parent)) {
          have_parent = true;
          break;
        }
        chain[n++] = cur.parent();
      }
    }
    (void)have_parent;
    for (size_t i = n; i-- > 0;) {
      if (job.cancel.load()) return Status::cancelled;
      const TileId t = chain[i];
      const BsvtfTileEntry* e = directory_.find(t);
      failed = StreamItem::for_tile(t);
      const Status f = fetch(failed, e->offset, e->size, e->crc, i > 0, job, bytes, why);
      if (f != Status::success) {
        checksum = f == Status::bad_data;
        return f;
      }
      const Status d = decoder.decode(bytes, t.level > 0 ? std::span<const float>(parent) : std::span<const float>(), t.x & 1u,
                                      t.y & 1u, out);
      {
        std::lock_guard lock(mutex_);
        ++progress_.decodes;
        if (d == Status::success) decoded_put(t.key(), out);
      }
      if (d != Status::success) {
        why = format_message("tile decoder: %s", decoder.message());
        checksum = false;
        decode_failed = true;  // not retried: the bytes passed their checksum, so they are what the file holds
        return d;
      }
      std::swap(parent, out);
    }
    std::swap(parent, out);  // the requested tile ends in `out`
    return Status::success;
  }

  void worker(Job& job) {
    TileDecoder decoder(layout_);
    std::vector<uint8_t> bytes;
    bytes.reserve(max_payload_);
    std::vector<float> parent(layout_.sample_count()), out(layout_.sample_count());
    std::vector<float> packet;
    packet.reserve(max_packet_floats_);
    std::unique_lock lock(mutex_);
    for (;;) {
      work_.wait(lock, [&] { return stopping_ || next_ < pending_.size(); });
      if (stopping_) return;
      const StreamItem item = pending_[next_++];
      job.item = item;
      job.active = true;
      job.cancel.store(false);
      unsigned attempt = 0;
      for (;;) {  // attempts
        lock.unlock();
        std::string why;
        StreamItem failed = item;
        bool checksum = false, decode_failed = false;
        Status s;
        if (item.kind == StreamItem::Kind::tile) {
          s = produce_tile(item.tile, job, decoder, bytes, parent, out, failed, why, checksum, decode_failed);
        } else {
          const auto& p = directory_.packets[item.packet];
          s = fetch(item, p.offset, p.size, p.crc, false, job, bytes, why);
          checksum = s == Status::bad_data;
          if (s == Status::success) {
            packet.resize(p.size / 2);
            unpack_bsvtf_packet(bytes, packet);
          }
        }
        lock.lock();
        if (s == Status::success) {
          // Wait for a free ready slot (the render thread frees them in deliver()).
          slot_free_.wait(lock, [&] { return stopping_ || job.cancel.load() || !free_ready_.empty(); });
          if (!stopping_ && !job.cancel.load()) {
            const size_t slot = free_ready_.back();
            free_ready_.pop_back();
            ReadySlot& r = ready_[slot];
            r.item = item;
            if (item.kind == StreamItem::Kind::tile) {
              r.samples.swap(out);  // hand over the buffer; the slot's old buffer becomes scratch
              r.weight = directory_.find(item.tile)->weight;
            } else {
              r.packet.swap(packet);
              r.weight = 0;
            }
            ready_order_.push_back(slot);
          }
          break;
        }
        if (s == Status::cancelled) break;
        if (decode_failed) {  // verified bytes that do not decode: skip, no retry
          ++progress_.decode_failures;
          ++progress_.skipped;
          record(failed, Status::bad_data, true, std::move(why));
          break;
        }
        // A fault is counted even when the item was cancelled meanwhile; it is just not retried.
        if (checksum) {
          ++progress_.checksum_failures;
        } else {
          ++progress_.source_errors;
        }
        if (stopping_ || job.cancel.load()) break;
        const bool skip = attempt >= config_.max_retries;
        record(failed, s, skip, std::move(why));
        if (skip) {
          ++progress_.skipped;
          break;
        }
        ++attempt;
        ++progress_.retries;
      }
      job.active = false;
      if (out.size() != layout_.sample_count()) out.resize(layout_.sample_count());
    }
  }

  TileSource& source_;
  PipelineConfig config_;
  BsvtfDirectory directory_;
  TileLayout layout_;

  mutable std::mutex mutex_;
  std::condition_variable work_, slot_free_, fetch_done_;
  bool stopping_ = false;
  std::vector<StreamItem> pending_;
  size_t next_ = 0;
  std::vector<uint64_t> scratch_old_, scratch_new_;
  std::vector<Job> jobs_;
  std::vector<std::thread> workers_;
  std::vector<ReadySlot> ready_;
  std::vector<size_t> free_ready_, ready_order_, delivering_;
  std::vector<DecodedSlot> decoded_;
  uint64_t clock_ = 0;
  PayloadCache compressed_;
  size_t max_payload_ = 0, max_packet_floats_ = 0;
  static constexpr size_t kMaxEvents = 1024;
  std::vector<uint8_t> delivered_, packet_delivered_;
  double total_weight_ = 0, delivered_weight_ = 0;
  PipelineProgress progress_;
  std::vector<PipelineEvent> events_;
};

}  // namespace btflod
