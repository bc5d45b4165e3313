// An engine's I/O thread for runtime/streamer.hpp that misbehaves on purpose, shared by the
// Streamer's thread tests (test_runtime_threads.cpp) and the soak (samples/tools/soak/). One thread
// serves the reads every material's AsyncTileSource queued, in random order, and per read may
// fail it (io_error), damage one byte while reporting success (only the Streamer's checksum can
// catch that), stall it, or delay it a little; start_read() may refuse (the Streamer retries).
// The bytes come from memory (the pristine container) or from a blocking TileSource, e.g. an
// HttpSource whose server is restarted under it; the source's own failures are reported as
// io_error and counted apart. Nothing allocates after construction (a fixed ring of reads and a
// fixed table of recently faulted reads), so a run can prove the frame loop allocation-free.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <random>
#include <span>
#include <thread>
#include <vector>

#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"

namespace btflod_test {

/// What goes wrong, per read (probabilities in [0, 1]).
struct FaultyIoConfig {
  uint32_t seed = 1;
  size_t capacity = 4096;  ///< reads queued at most; start_read() refuses beyond
  double fail = 0.01;      ///< completed with io_error, nothing copied
  double corrupt = 0.01;   ///< one byte damaged, success reported
  double stall = 0.002;    ///< served only after stall_ms
  uint32_t stall_ms = 40;
  double delay = 0;  ///< served after a random delay of up to max_delay_us
  uint32_t max_delay_us = 0;
  double refuse = 0.003;         ///< start_read() returns false …
  size_t refuse_from_depth = 0;  ///< … when at least this many reads are queued
  /// A read that failed or was damaged is served intact the next time (same source and offset),
  /// so a root or U′ packet never exhausts the Streamer's start-up attempts.
  bool intact_after_fault = false;
};

class FaultyAsyncIo {
 public:
  /// A material's source. `bytes` is the file in memory; when `blocking` is set the bytes are
  /// read from it instead (its failures count as `source_failed`).
  struct Source final : btflod::AsyncTileSource {
    FaultyAsyncIo* io = nullptr;
    std::span<const uint8_t> bytes;
    btflod::TileSource* blocking = nullptr;
    bool start_read(uint64_t offset, std::span<uint8_t> out, uint64_t ticket) noexcept override {
      return io->enqueue(this, offset, out, ticket);
    }
  };
  struct Counters {
    std::atomic<uint64_t> reads{0};          ///< served (any status except cancelled)
    std::atomic<uint64_t> failed{0};         ///< injected io_error
    std::atomic<uint64_t> source_failed{0};  ///< the blocking source's own failures (io_error)
    std::atomic<uint64_t> source_ok{0};      ///< successful reads of the blocking source
    std::atomic<uint64_t> corrupted{0}, stalled{0}, delayed{0}, refused{0}, cancelled{0};
  };
  /// Called on the I/O thread after every completion with the job it made runnable (or kNoJob).
  using CompleteFn = void (*)(void* user, uint32_t job);

  explicit FaultyAsyncIo(FaultyIoConfig config)
      : config_(config),
        ring_(std::max<size_t>(config.capacity, 1)),
        enqueue_rng_(config.seed),
        serve_rng_(config.seed * 2654435761u + 1) {}
  ~FaultyAsyncIo() { stop(); }
  FaultyAsyncIo(const FaultyAsyncIo&) = delete;
  FaultyAsyncIo& operator=(const FaultyAsyncIo&) = delete;

  /// A source of this I/O thread serving `bytes` (kept by the caller).
  Source source(std::span<const uint8_t> bytes, btflod::TileSource* blocking = nullptr) {
    Source s;
    s.io = this;
    s.bytes = bytes;
    s.blocking = blocking;
    return s;
  }

  /// Starts the thread serving `streamer`'s reads (it must stay at its address until stop()).
  void start(btflod::Streamer& streamer, CompleteFn on_complete, void* user) {
    streamer_ = &streamer;
    on_complete_ = on_complete;
    user_ = user;
    thread_ = std::thread([this] { loop(); });
  }
  /// Completes every queued read with Status::cancelled (quiescing). Reads being served finish.
  void cancel_queued() {
    for (Read r; pop_front(r);) cancel(r);
  }
  /// Cancels whatever is still queued and joins the thread. Idempotent.
  void stop() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  /// Reads started and not yet completed.
  size_t outstanding() const {
    std::lock_guard lock(mutex_);
    return count_ + serving_;
  }

  Counters counters;

 private:
  struct Read {
    const Source* source = nullptr;
    uint64_t offset = 0;
    std::span<uint8_t> out;
    uint64_t ticket = 0;
  };
  struct Key {
    const Source* source = nullptr;
    uint64_t offset = 0;
  };
  static constexpr size_t kFaultMemory = 256;

  bool enqueue(const Source* source, uint64_t offset, std::span<uint8_t> out, uint64_t ticket) {
    {
      std::lock_guard lock(mutex_);
      const bool refuse = count_ >= config_.refuse_from_depth && enqueue_unit_(enqueue_rng_) < config_.refuse;
      if (refuse || count_ == ring_.size()) {
        ++counters.refused;
        return false;
      }
      ring_[(head_ + count_) % ring_.size()] = Read{source, offset, out, ticket};
      ++count_;
    }
    cv_.notify_one();
    return true;
  }

  // Takes the oldest queued read out of the ring; false when none. Completions run without
  // mutex_ held, so no lock of the Streamer or the engine's workers is ever taken inside it.
  bool pop_front(Read& r) {
    std::lock_guard lock(mutex_);
    if (count_ == 0) return false;
    r = ring_[head_];
    head_ = (head_ + 1) % ring_.size();
    --count_;
    return true;
  }
  void cancel(const Read& r) {
    const uint32_t job = streamer_->complete_read(r.ticket, btflod::Status::cancelled);
    ++counters.cancelled;
    if (on_complete_ != nullptr) on_complete_(user_, job);
  }

  // Whether (source, offset) faulted last time; forgets it (I/O thread only).
  bool faulted_before(const Read& r) {
    for (size_t i = 0; i < faulted_count_; ++i)
      if (faulted_[i].source == r.source && faulted_[i].offset == r.offset) {
        faulted_[i] = faulted_[--faulted_count_];
        return true;
      }
    return false;
  }
  void remember_fault(const Read& r) {
    if (faulted_count_ == kFaultMemory) {  // full: forget the oldest half (rare; only costs a second fault)
      std::copy(faulted_ + kFaultMemory / 2, faulted_ + kFaultMemory, faulted_);
      faulted_count_ = kFaultMemory / 2;
    }
    faulted_[faulted_count_++] = Key{r.source, r.offset};
  }

  void loop() {
    std::unique_lock lock(mutex_);
    for (;;) {
      cv_.wait(lock, [&] { return stopping_ || count_ > 0; });
      if (stopping_) {
        lock.unlock();
        cancel_queued();
        return;
      }
      // Out of order: a random queued read, swapped to the front.
      const size_t pick = (head_ + std::uniform_int_distribution<size_t>(0, count_ - 1)(serve_rng_)) % ring_.size();
      std::swap(ring_[pick], ring_[head_]);
      const Read r = ring_[head_];
      head_ = (head_ + 1) % ring_.size();
      --count_;
      ++serving_;
      lock.unlock();
      const uint32_t job = streamer_->complete_read(r.ticket, serve(r));
      ++counters.reads;
      if (on_complete_ != nullptr) on_complete_(user_, job);
      lock.lock();
      --serving_;
    }
  }

  btflod::Status serve(const Read& r) {
    if (config_.stall > 0 && unit_(serve_rng_) < config_.stall) {
      ++counters.stalled;
      std::this_thread::sleep_for(std::chrono::milliseconds(config_.stall_ms));
    } else if (config_.delay > 0 && unit_(serve_rng_) < config_.delay) {
      ++counters.delayed;
      std::this_thread::sleep_for(std::chrono::microseconds(serve_rng_() % (config_.max_delay_us + 1)));
    }
    const bool spare = config_.intact_after_fault && faulted_before(r);
    const double u = spare ? 1.0 : unit_(serve_rng_);
    if (u < config_.fail) {
      ++counters.failed;
      if (config_.intact_after_fault) remember_fault(r);
      return btflod::Status::io_error;
    }
    if (r.source->blocking != nullptr) {
      if (!r.source->blocking->read(r.offset, r.out)) {
        ++counters.source_failed;
        return btflod::Status::io_error;
      }
      ++counters.source_ok;
    } else if (r.offset > r.source->bytes.size() || r.out.size() > r.source->bytes.size() - r.offset) {
      return btflod::Status::io_error;  // outside the file: the Streamer asked for what is not there
    } else {
      std::memcpy(r.out.data(), r.source->bytes.data() + r.offset, r.out.size());
    }
    if (u < config_.fail + config_.corrupt && !r.out.empty()) {  // damaged on the way
      r.out[serve_rng_() % r.out.size()] ^= static_cast<uint8_t>(1u + serve_rng_() % 255);
      ++counters.corrupted;
      if (config_.intact_after_fault) remember_fault(r);
    }
    return btflod::Status::success;
  }

  const FaultyIoConfig config_;
  std::vector<Read> ring_;
  size_t head_ = 0, count_ = 0, serving_ = 0;
  std::mt19937 enqueue_rng_;  // under mutex_
  std::mt19937 serve_rng_;    // I/O thread only
  std::uniform_real_distribution<double> enqueue_unit_{0.0, 1.0}, unit_{0.0, 1.0};
  Key faulted_[kFaultMemory];  // I/O thread only
  size_t faulted_count_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::thread thread_;
  btflod::Streamer* streamer_ = nullptr;
  CompleteFn on_complete_ = nullptr;
  void* user_ = nullptr;
};

}  // namespace btflod_test
