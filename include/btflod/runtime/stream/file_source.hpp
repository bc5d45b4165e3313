// btflod — file and throttled byte sources (POSIX positional reads, a simulated link). Kept out
// of runtime/stream/tile_source.hpp so the runtime headers include no POSIX or thread header.
#pragma once

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <utility>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "btflod/core/result.hpp"
#include "btflod/runtime/stream/tile_source.hpp"

namespace btflod {

/// Positional reads (pread) from a file; one descriptor shared by all threads.
class FileSource final : public TileSource {
 public:
  /// Opens `path` read-only. Returns io_error with the errno text on failure.
  static Result<std::unique_ptr<FileSource>> open(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return make_error(Status::io_error, "%s: cannot open: %s", path.c_str(), std::strerror(errno));
    return std::unique_ptr<FileSource>(new FileSource(fd, path));
  }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;
  ~FileSource() override { ::close(fd_); }

  Result<uint64_t> size() override {
    struct stat st {};
    if (::fstat(fd_, &st) != 0)
      return make_error(Status::io_error, "%s: fstat: %s", path_.c_str(), std::strerror(errno));
    return static_cast<uint64_t>(st.st_size);
  }
  VoidResult read(uint64_t offset, std::span<uint8_t> out, const std::atomic<bool>* cancel = nullptr) override {
    size_t done = 0;
    while (done < out.size()) {
      if (cancel && cancel->load(std::memory_order_relaxed))
        return make_error(Status::cancelled, "%s: read cancelled", path_.c_str());
      const ssize_t n = ::pread(fd_, out.data() + done, out.size() - done, static_cast<off_t>(offset + done));
      if (n < 0) {
        if (errno == EINTR) continue;
        return make_error(Status::io_error, "%s: pread at %llu: %s", path_.c_str(),
                          static_cast<unsigned long long>(offset + done), std::strerror(errno));
      }
      if (n == 0)
        return make_error(Status::short_output, "%s: file ends at %llu, wanted %zu bytes at %llu", path_.c_str(),
                          static_cast<unsigned long long>(offset + done), out.size(),
                          static_cast<unsigned long long>(offset));
      done += static_cast<size_t>(n);
    }
    return {};
  }
  std::string describe() const override { return path_; }

 private:
  FileSource(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  int fd_;
  std::string path_;
};

/// Bandwidth and latency simulation around another source, for tests and the demo: every read
/// waits `latency` and then its share of a link of `bytes_per_second` shared by all threads
/// (requests queue behind each other like on one connection). Waits poll `cancel` every
/// millisecond, so a cancelled read never waits out a slow transfer.
class ThrottledSource final : public TileSource {
 public:
  /// `inner` must outlive this object. bytes_per_second ≤ 0 means unlimited bandwidth.
  ThrottledSource(TileSource& inner, double bytes_per_second, std::chrono::microseconds latency)
      : inner_(inner), bytes_per_second_(bytes_per_second), latency_(latency) {}

  Result<uint64_t> size() override { return inner_.size(); }
  VoidResult read(uint64_t offset, std::span<uint8_t> out, const std::atomic<bool>* cancel = nullptr) override {
    using Clock = std::chrono::steady_clock;
    const auto now = Clock::now();
    Clock::time_point done_at = now + latency_;
    if (bytes_per_second_ > 0) {
      const auto transfer =
          std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(out.size() / bytes_per_second_));
      std::lock_guard lock(mutex_);
      const auto start = std::max(link_free_at_, now + latency_);
      link_free_at_ = start + transfer;
      done_at = link_free_at_;
    }
    while (Clock::now() < done_at) {
      if (cancel && cancel->load(std::memory_order_relaxed))
        return make_error(Status::cancelled, "throttled read cancelled");
      std::this_thread::sleep_for(std::min<Clock::duration>(std::chrono::milliseconds(1), done_at - Clock::now()));
    }
    return inner_.read(offset, out, cancel);
  }
  std::string describe() const override { return "throttled(" + inner_.describe() + ")"; }

 private:
  TileSource& inner_;
  double bytes_per_second_;
  std::chrono::microseconds latency_;
  std::mutex mutex_;
  std::chrono::steady_clock::time_point link_free_at_{};
};

}  // namespace btflod
