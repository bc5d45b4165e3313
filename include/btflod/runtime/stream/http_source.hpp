// btflod — a TileSource over HTTP range requests (libcurl). A material is one static `.bsvtf`
// file on any web server or CDN that supports `Range:` (nginx, Apache, S3, …); no custom server.
//
// LINKING: this header calls libcurl. A consumer that includes it must link libcurl itself
// (CMake: `find_package(CURL)` and `target_link_libraries(app PRIVATE CURL::libcurl)`); the
// btflod target does not, which is why btflod.hpp does not include this header.
//
// Every read is one `GET` with `Range: bytes=a-b`; the answer must be `206 Partial Content`
// whose Content-Range is `bytes a-b/<size or *>`, with exactly b − a + 1 bytes. Anything
// else is an error with a message: a server that ignores Range (200), a 206 without that exact
// Content-Range (bad_data), a server that sends more or fewer bytes, closes the connection
// mid-transfer (short_output) or times out. Reads are cancellable through the
// caller's cancel flag (libcurl's progress callback polls it). Curl handles are pooled so
// that keep-alive connections are reused (see HttpSourceOptions::reuse_handles for the libcurl
// versions where that is not safe); read() is thread-safe.
#pragma once

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include <curl/curl.h>

#include "btflod/core/result.hpp"
#include "btflod/runtime/stream/tile_source.hpp"

namespace btflod {

/// Timeouts of an HttpSource.
struct HttpSourceOptions {
  long connect_timeout_ms = 5000;  ///< TCP + TLS connect
  long timeout_ms = 60000;         ///< whole request
  long low_speed_bytes = 1;        ///< abort when slower than this many bytes/s …
  long low_speed_seconds = 20;     ///< … for this long (a stalled server)
  /// Called on every curl handle after btflod's own options are set, right before the transfer
  /// (nullptr: not called). A seam for tests and fuzz targets, e.g. CURLOPT_CONNECT_TO to send
  /// every connection (redirects included) to an in-process server, or CURLOPT_PROTOCOLS_STR.
  /// It must not replace the write, header or progress callbacks or their data pointers. Runs
  /// on the thread calling size() or read(), possibly on several threads at once.
  void (*customize_handle)(CURL* handle, void* user) = nullptr;
  void* customize_user = nullptr;  ///< passed to customize_handle
  /// Reuse curl handles (and so keep-alive connections) across reads. libcurl before 8.1.0
  /// (Debian 12 ships 7.88.1) reads freed memory when a response on a reused handle starts its
  /// headers with a folded line (curl issue #11101: a pointer to the previous transfer's last
  /// header is left dangling), so a hostile server could crash the client: on those versions
  /// the default is a fresh handle (and connection) per request. Set true to reuse anyway,
  /// e.g. for a trusted server.
  bool reuse_handles = http_source_handle_reuse_is_safe();

  /// True when the libcurl in use (checked at run time) is 8.1.0 or newer.
  static bool http_source_handle_reuse_is_safe() noexcept {
    const curl_version_info_data* v = curl_version_info(CURLVERSION_NOW);
    return v != nullptr && v->version_num >= 0x080100;
  }
};

class HttpSource final : public TileSource {
 public:
  /// `url` of the static file (http:// or https://). No I/O happens until size() or read().
  explicit HttpSource(std::string url, HttpSourceOptions options = {}) : url_(std::move(url)), options_(options) {
    static const bool initialised = curl_global_init(CURL_GLOBAL_DEFAULT) == CURLE_OK;  // once, thread-safe
    (void)initialised;
  }
  HttpSource(const HttpSource&) = delete;
  HttpSource& operator=(const HttpSource&) = delete;
  ~HttpSource() override {
    for (CURL* h : idle_) curl_easy_cleanup(h);
  }

  /// The file size from a HEAD request (cached after the first success). io_error when the
  /// server is unreachable or answers other than 200, unsupported when it sends no length.
  Result<uint64_t> size() override {
    {
      std::lock_guard lock(mutex_);
      if (size_known_) return size_;
    }
    CURL* h = acquire();
    if (!h) return make_error(Status::io_error, "%s: curl_easy_init failed", url_.c_str());
    char error[CURL_ERROR_SIZE] = {};
    configure(h, error, nullptr);
    curl_easy_setopt(h, CURLOPT_NOBODY, 1L);
    const CURLcode rc = curl_easy_perform(h);
    long code = 0;
    curl_off_t length = -1;
    curl_easy_getinfo(h, CURLINFO_RESPONSE_CODE, &code);
    curl_easy_getinfo(h, CURLINFO_CONTENT_LENGTH_DOWNLOAD_T, &length);
    release(h);
    if (rc != CURLE_OK)
      return make_error(Status::io_error, "%s: HEAD failed: %s", url_.c_str(),
                        error[0] ? error : curl_easy_strerror(rc));
    if (code != 200)
      return make_error(Status::io_error, "%s: HEAD answered HTTP %ld, expected 200", url_.c_str(), code);
    if (length < 0) return make_error(Status::unsupported, "%s: server sent no Content-Length", url_.c_str());
    std::lock_guard lock(mutex_);
    size_ = static_cast<uint64_t>(length);
    size_known_ = true;
    return size_;
  }

  /// One range request for out.size() bytes at `offset`; see the file comment for the checks.
  VoidResult read(uint64_t offset, std::span<uint8_t> out, const std::atomic<bool>* cancel = nullptr) override {
    if (out.empty()) return {};
    CURL* h = acquire();
    if (!h) return make_error(Status::io_error, "%s: curl_easy_init failed", url_.c_str());
    char error[CURL_ERROR_SIZE] = {};
    Transfer t{out.data(), out.size(), 0, false, false, 0, 0, cancel};
    configure(h, error, &t);
    char range[64];
    std::snprintf(range, sizeof range, "%llu-%llu", static_cast<unsigned long long>(offset),
                  static_cast<unsigned long long>(offset + out.size() - 1));
    curl_easy_setopt(h, CURLOPT_RANGE, range);
    const CURLcode rc = curl_easy_perform(h);
    long code = 0;
    curl_easy_getinfo(h, CURLINFO_RESPONSE_CODE, &code);
    release(h);
    const auto at = static_cast<unsigned long long>(offset);
    if (rc == CURLE_ABORTED_BY_CALLBACK || (cancel && cancel->load()))
      return make_error(Status::cancelled, "%s: range %s cancelled", url_.c_str(), range);
    // Error statuses first: their bodies (error pages) may be longer than the span.
    if (code == 416)
      return make_error(Status::short_output, "%s: range %s not satisfiable (file shorter)", url_.c_str(), range);
    if (code >= 400) return make_error(Status::io_error, "%s: range %s answered HTTP %ld", url_.c_str(), range, code);
    if (t.overflow || (rc == CURLE_WRITE_ERROR && t.got >= t.capacity))
      return make_error(Status::bad_data, "%s: range %s: server sent more than the %zu requested bytes (HTTP %ld)",
                        url_.c_str(), range, out.size(), code);
    if (rc == CURLE_PARTIAL_FILE || rc == CURLE_RECV_ERROR || rc == CURLE_GOT_NOTHING)
      return make_error(Status::short_output, "%s: range %s: connection closed after %zu of %zu bytes (%s)",
                        url_.c_str(), range, t.got, out.size(), error[0] ? error : curl_easy_strerror(rc));
    if (rc != CURLE_OK)
      return make_error(Status::io_error, "%s: range %s: %s", url_.c_str(), range,
                        error[0] ? error : curl_easy_strerror(rc));
    if (code == 200)
      return make_error(Status::unsupported, "%s: server ignored the Range header (HTTP 200 instead of 206)",
                        url_.c_str());
    if (code != 206)
      return make_error(Status::io_error, "%s: range %s answered HTTP %ld, expected 206", url_.c_str(), range, code);
    if (!t.range_valid)
      return make_error(Status::bad_data,
                        "%s: range %s: 206 without a Content-Range of the form \"bytes first-last/size\"", url_.c_str(),
                        range);
    if (t.range_first != offset)
      return make_error(Status::bad_data, "%s: Content-Range starts at %llu, requested %llu", url_.c_str(),
                        static_cast<unsigned long long>(t.range_first), at);
    if (t.range_last != offset + out.size() - 1)
      return make_error(Status::bad_data, "%s: Content-Range ends at %llu, requested %llu", url_.c_str(),
                        static_cast<unsigned long long>(t.range_last),
                        static_cast<unsigned long long>(offset + out.size() - 1));
    if (t.got != out.size())
      return make_error(Status::short_output, "%s: range %s: received %zu of %zu bytes", url_.c_str(), range, t.got,
                        out.size());
    return {};
  }

  std::string describe() const override { return url_; }

 private:
  struct Transfer {
    uint8_t* dst;
    size_t capacity;
    size_t got;
    bool overflow;
    bool range_valid;      // a well-formed "bytes first-last/…" Content-Range was received
    uint64_t range_first;  // its first and last byte (valid when range_valid)
    uint64_t range_last;
    const std::atomic<bool>* cancel;
  };

  /// Parses a Content-Range value `bytes first-last/size` (or `/*`), surrounding blanks and the
  /// unit's case ignored. False for anything else: another unit, `*/size`, signs, missing or
  /// non-digit fields, last < first, values beyond 2^63, trailing garbage. Untrusted input.
  static bool parse_content_range(const char* p, const char* end, uint64_t& first, uint64_t& last) noexcept {
    auto blanks = [&] {
      while (p < end && (*p == ' ' || *p == '\t')) ++p;
    };
    auto number = [&](uint64_t& v) {
      const char* start = p;
      v = 0;
      while (p < end && *p >= '0' && *p <= '9') {
        if (v > (uint64_t{1} << 59)) return false;  // > 2^63 after the next digit: not a file offset
        v = v * 10 + static_cast<uint64_t>(*p++ - '0');
      }
      return p != start;
    };
    blanks();
    static constexpr char kUnit[] = "bytes";
    for (size_t i = 0; i < 5; ++i, ++p)
      if (p >= end || std::tolower(static_cast<unsigned char>(*p)) != kUnit[i]) return false;
    if (p >= end || (*p != ' ' && *p != '\t')) return false;
    blanks();
    if (!number(first) || p >= end || *p++ != '-' || !number(last) || last < first) return false;
    if (p >= end || *p++ != '/') return false;
    uint64_t size = 0;
    if (p < end && *p == '*')
      ++p;
    else if (!number(size) || size <= last)
      return false;
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')) ++p;
    return p == end;
  }

  static size_t on_write(char* data, size_t size, size_t count, void* user) {
    auto* t = static_cast<Transfer*>(user);
    const size_t n = size * count;
    if (n > t->capacity - t->got) {  // never write past the caller's span
      t->overflow = true;
      return 0;
    }
    std::memcpy(t->dst + t->got, data, n);
    t->got += n;
    return n;
  }
  static size_t on_header(char* data, size_t size, size_t count, void* user) {
    auto* t = static_cast<Transfer*>(user);
    const size_t n = size * count;
    static constexpr char kName[] = "content-range:";
    constexpr size_t kLen = sizeof kName - 1;
    if (n > kLen) {
      bool match = true;
      for (size_t i = 0; i < kLen && match; ++i) match = std::tolower(static_cast<unsigned char>(data[i])) == kName[i];
      if (match) t->range_valid = parse_content_range(data + kLen, data + n, t->range_first, t->range_last);
    } else if (n >= 5 && std::strncmp(data, "HTTP/", 5) == 0) {
      t->range_valid = false;  // a new response (redirect, 1xx): forget the previous one's headers
    }
    return n;
  }
  static int on_progress(void* user, curl_off_t, curl_off_t, curl_off_t, curl_off_t) {
    auto* t = static_cast<Transfer*>(user);
    return (t->cancel && t->cancel->load(std::memory_order_relaxed)) ? 1 : 0;
  }

  void configure(CURL* h, char* error, Transfer* t) {
    curl_easy_setopt(h, CURLOPT_URL, url_.c_str());
    curl_easy_setopt(h, CURLOPT_ERRORBUFFER, error);
    curl_easy_setopt(h, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(h, CURLOPT_FOLLOWLOCATION, 1L);
    curl_easy_setopt(h, CURLOPT_MAXREDIRS, 5L);
    curl_easy_setopt(h, CURLOPT_CONNECTTIMEOUT_MS, options_.connect_timeout_ms);
    curl_easy_setopt(h, CURLOPT_TIMEOUT_MS, options_.timeout_ms);
    curl_easy_setopt(h, CURLOPT_LOW_SPEED_LIMIT, options_.low_speed_bytes);
    curl_easy_setopt(h, CURLOPT_LOW_SPEED_TIME, options_.low_speed_seconds);
    curl_easy_setopt(h, CURLOPT_ACCEPT_ENCODING, nullptr);  // identity: byte offsets are of the file itself
    if (t) {
      curl_easy_setopt(h, CURLOPT_WRITEFUNCTION, &HttpSource::on_write);
      curl_easy_setopt(h, CURLOPT_WRITEDATA, t);
      curl_easy_setopt(h, CURLOPT_HEADERFUNCTION, &HttpSource::on_header);
      curl_easy_setopt(h, CURLOPT_HEADERDATA, t);
      curl_easy_setopt(h, CURLOPT_XFERINFOFUNCTION, &HttpSource::on_progress);
      curl_easy_setopt(h, CURLOPT_XFERINFODATA, t);
      curl_easy_setopt(h, CURLOPT_NOPROGRESS, 0L);
    }
    if (options_.customize_handle) options_.customize_handle(h, options_.customize_user);
  }
  CURL* acquire() {
    if (options_.reuse_handles) {
      std::lock_guard lock(mutex_);
      if (!idle_.empty()) {
        CURL* h = idle_.back();
        idle_.pop_back();
        curl_easy_reset(h);  // keeps the connection cache
        return h;
      }
    }
    return curl_easy_init();
  }
  void release(CURL* h) {
    std::lock_guard lock(mutex_);
    if (options_.reuse_handles && idle_.size() < 16) {
      idle_.push_back(h);
      return;
    }
    curl_easy_cleanup(h);
  }

  std::string url_;
  HttpSourceOptions options_;
  std::mutex mutex_;
  std::vector<CURL*> idle_;
  bool size_known_ = false;
  uint64_t size_ = 0;
};

}  // namespace btflod
