// btflod web: the AsyncTileSource of a WebAssembly build whose I/O belongs to JavaScript.
// start_read() only records the read (ticket, material, byte range, destination in the wasm
// heap) in a bounded queue; JavaScript takes the queue after the Streamer's update(), fetches the
// ranges in any order, copies the bytes to their destinations and reports each read with
// Streamer::complete_read(). A full queue refuses the read, and the Streamer retries it on a later
// update. No allocation after construction.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "btflod/runtime/stream/tile_source.hpp"

namespace btflod::web {

/// One read JavaScript is asked to perform (all uint32 for a flat Uint32Array view).
struct ReadRequest {
  uint32_t ticket_lo, ticket_hi;
  uint32_t material;
  uint32_t offset_lo, offset_hi;
  uint32_t size;
  uint32_t destination;  ///< heap address of `size` bytes
};
static_assert(sizeof(ReadRequest) == 7 * sizeof(uint32_t));

/// The reads recorded since JavaScript last took them, at most `capacity`.
class JsReadQueue {
 public:
  explicit JsReadQueue(size_t capacity) {
    reads_.reserve(capacity);
    taken_.reserve(capacity);
  }
  bool push(const ReadRequest& r) noexcept {
    if (reads_.size() == reads_.capacity()) return false;
    reads_.push_back(r);
    return true;
  }
  /// Moves the recorded reads to taken() and returns their count.
  size_t take() noexcept {
    taken_.assign(reads_.begin(), reads_.end());  // same capacity: no allocation
    reads_.clear();
    return taken_.size();
  }
  const std::vector<ReadRequest>& taken() const noexcept { return taken_; }

 private:
  std::vector<ReadRequest> reads_, taken_;
};

/// The AsyncTileSource of material `material`: records its reads in `queue`.
class JsSource final : public AsyncTileSource {
 public:
  JsSource(JsReadQueue& queue, uint32_t material) : queue_(queue), material_(material) {}
  bool start_read(uint64_t offset, std::span<uint8_t> out, uint64_t ticket) noexcept override {
    return queue_.push(ReadRequest{static_cast<uint32_t>(ticket), static_cast<uint32_t>(ticket >> 32), material_,
                                   static_cast<uint32_t>(offset), static_cast<uint32_t>(offset >> 32),
                                   static_cast<uint32_t>(out.size()),
                                   static_cast<uint32_t>(reinterpret_cast<uintptr_t>(out.data()))});
  }

 private:
  JsReadQueue& queue_;
  uint32_t material_;
};

}  // namespace btflod::web
