// btflod — byte-range sources for streaming a `.bsvtf` container: the blocking interface
// (TileSource) and a memory source, plus the asynchronous interface (AsyncTileSource: request +
// completion, for engines that own their I/O). The file source (positional reads) and the
// throttled wrapper that simulates bandwidth and latency live in runtime/stream/file_source.hpp (POSIX,
// threads), the HTTP range-request source in runtime/stream/http_source.hpp (libcurl). All of them serve byte ranges of
// one static file, so any web server, CDN or disk can hold a material (paper 000 §6 streams
// tiles from a server; plain byte ranges, no custom server).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "btflod/core/result.hpp"

namespace btflod {

/// A random-access byte source. Implementations must allow concurrent read() calls from several
/// threads (the engine's decode workers). `cancel`, when given, is polled by slow sources; once it
/// reads true they return Status::cancelled as soon as they can.
class TileSource {
 public:
  virtual ~TileSource() = default;
  /// Total size of the resource in bytes. May perform I/O. Thread-safe.
  virtual Result<uint64_t> size() = 0;
  /// Reads exactly out.size() bytes at `offset`. Returns success, short_output (the resource
  /// ended early or the transfer was cut), io_error, bad_data (the server sent something else
  /// than the requested range) or cancelled; `out` is unspecified on failure. Thread-safe.
  virtual VoidResult read(uint64_t offset, std::span<uint8_t> out, const std::atomic<bool>* cancel = nullptr) = 0;
  /// A short description for messages (path, URL, "memory"). Thread-safe.
  virtual std::string describe() const = 0;
};

/// Serves bytes held in memory; either owned (vector constructor) or borrowed (span
/// constructor: the bytes must outlive the source). Never fails except for out-of-range reads.
class MemorySource final : public TileSource {
 public:
  explicit MemorySource(std::vector<uint8_t> bytes) : owned_(std::move(bytes)), bytes_(owned_) {}
  explicit MemorySource(std::span<const uint8_t> bytes) : bytes_(bytes) {}

  Result<uint64_t> size() override { return static_cast<uint64_t>(bytes_.size()); }
  VoidResult read(uint64_t offset, std::span<uint8_t> out, const std::atomic<bool>* = nullptr) override {
    if (offset > bytes_.size() || out.size() > bytes_.size() - offset)
      return make_error(Status::short_output, "memory: range %llu+%zu beyond the %zu-byte buffer",
                        static_cast<unsigned long long>(offset), out.size(), bytes_.size());
    if (!out.empty()) std::memcpy(out.data(), bytes_.data() + offset, out.size());
    return {};
  }
  std::string describe() const override { return "memory"; }

 private:
  std::vector<uint8_t> owned_;
  std::span<const uint8_t> bytes_;
};

/// Asynchronous byte source: the engine's I/O system serves reads and reports completion,
/// nothing blocks. The runtime calls start_read() from its update thread; the engine later calls
/// the completion the runtime documents (Streamer::complete_read(ticket, status)) from any
/// thread, once `out` holds the bytes or the read failed. `out` stays valid and untouched by
/// the runtime until then.
class AsyncTileSource {
 public:
  virtual ~AsyncTileSource() = default;
  /// Starts reading out.size() bytes at `offset` into `out`; `ticket` identifies the read in
  /// the completion. Returns false when the source cannot take another read now (the runtime
  /// retries on a later update). Must not call the completion from inside start_read().
  virtual bool start_read(uint64_t offset, std::span<uint8_t> out, uint64_t ticket) noexcept = 0;
};

}  // namespace btflod
