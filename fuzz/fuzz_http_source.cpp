// libFuzzer target for runtime/stream/http_source.hpp's response handling: a fake HTTP server thread on
// 127.0.0.1 answers every connection with a response made from the input, HttpSource (libcurl)
// reads it, and the result is checked.
//   byte 0: bit 0 HEAD (size()) instead of a range read; bit 1 raw mode; bit 2 extra header bytes
//   byte 1: offset of the range read (0..255); byte 2: its length − 1 (1..64 bytes)
//   raw mode: the rest of the input is the whole response, sent verbatim;
//   built mode: byte 3 the status (206, 200, 416, 404, 500, a redirect to the same server,
//     100 Continue then 206, 204, or a raw code from bytes 4–5), byte 6 the Content-Range form
//     (right, wrong start, missing, "*/size", negative start, wrong end, other unit, spacing and
//     case variants, two headers), byte 7 the framing (exact, truncated, extra bytes, no
//     Content-Length, chunked, chunked and truncated, Content-Length smaller or larger than the
//     body, chunked with extra bytes), byte 8 a count for truncation and extra bytes; with bit 2
//     the rest of the input is inserted as extra header bytes.
// Checks: nothing crashes, hangs or writes outside the span; every failure explains itself; in
// built mode without extra header bytes the read succeeds exactly when the response is a 206
// whose Content-Range is "bytes a-b/…" for the requested a and b with exactly b − a + 1 body
// bytes, and the span then holds those bytes; size() succeeds only on a 200 and returns its
// Content-Length.
//
// Every connection (redirects too: CURLOPT_CONNECT_TO through HttpSourceOptions::
// customize_handle) goes to the fake server, and only http:// is allowed, so no input reaches
// the network. Speed is bounded by a loopback TCP connection and libcurl's set-up per input
// (the server closes after each response), a few hundred to a few thousand inputs per second.
// btflod-link: CURL::libcurl
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include "../tests/loopback_http_server.hpp"
#include "btflod/runtime/stream/http_source.hpp"

namespace {
using namespace btflod;

// The loopback server answers every connection with the current input's response (200 ms
// receive timeout: a client that sends no complete request does not hold the server up).
class FakeServer {
 public:
  FakeServer()
      : server_(
            [this](int socket, const std::string&, const std::atomic<bool>&) {
              std::string r;
              {
                std::lock_guard lock(mutex_);
                r = response_;
              }
              test::LoopbackHttpServer::send_all(socket, r);
            },
            200) {}
  int port() const { return server_.port(); }
  const char* connect_to() const { return server_.connect_to(); }
  void set_response(std::string r) {
    std::lock_guard lock(mutex_);
    response_ = std::move(r);
  }

 private:
  std::mutex mutex_;
  std::string response_;
  test::LoopbackHttpServer server_;  // last: its thread stops before the response goes
};

FakeServer& server() {
  static FakeServer s;
  return s;
}

void customize(CURL* h, void*) {
  static curl_slist* connect_to = curl_slist_append(nullptr, server().connect_to());
  curl_easy_setopt(h, CURLOPT_CONNECT_TO, connect_to);
  curl_easy_setopt(h, CURLOPT_PROTOCOLS_STR, "http");
  curl_easy_setopt(h, CURLOPT_REDIR_PROTOCOLS_STR, "http");
}

HttpSourceOptions fuzz_options() {
  HttpSourceOptions o;
  o.connect_timeout_ms = 2000;
  o.timeout_ms = 3000;
  o.low_speed_seconds = 3;
  o.customize_handle = &customize;
  return o;
}

std::string url() { return "http://127.0.0.1:" + std::to_string(server().port()) + "/material.bsvtf"; }

uint8_t body_byte(uint64_t at) { return static_cast<uint8_t>(at * 31 + 7); }

struct Built {
  std::string response;
  bool read_ok = false;           // a correct answer to the range request
  long status = 0;                // final status
  long long content_length = -1;  // the one Content-Length sent, −1 when none
};

Built build(const uint8_t* d, size_t n, uint64_t offset, size_t count, bool extra) {
  auto at = [&](size_t i) -> uint8_t { return i < n ? d[i] : 0; };
  Built b;
  static const long kStatus[] = {206, 200, 416, 404, 500, 301, 100, 204};
  const uint8_t s = at(3);
  long status = s < 8 ? kStatus[s] : 100 + (at(4) | at(5) << 8) % 900;
  if (s >= 16 && s < 128) status = 206;  // favour the interesting case
  const uint8_t cr = at(6) % 10, framing = at(7) % 9, k = at(8);
  const uint64_t first = offset, last = offset + count - 1, total = 4096;
  std::string head;
  if (status == 100) head += "HTTP/1.1 100 Continue\r\n\r\n", status = 206;
  const bool redirect = status == 301;
  if (redirect) {
    // A redirect to the same server, answered with this same response: ends in too many redirects.
    b.response = "HTTP/1.1 301 Moved\r\nLocation: http://example.invalid/elsewhere\r\nContent-Length: 0\r\n\r\n";
    b.status = 301;
    return b;
  }
  head += "HTTP/1.1 " + std::to_string(status) + " Reason\r\n";
  bool range_ok = false;
  const std::string a = std::to_string(first), z = std::to_string(last), t = std::to_string(total);
  switch (cr) {
    case 0:
      head += "Content-Range: bytes " + a + "-" + z + "/" + t + "\r\n", range_ok = true;
      break;
    case 1:
      head += "Content-Range: bytes " + std::to_string(first + 1 + k % 8) + "-" + z + "/" + t + "\r\n";
      break;
    case 2:
      break;  // missing
    case 3:
      head += "Content-Range: bytes */" + t + "\r\n";
      break;
    case 4:
      head += "Content-Range: bytes -" + std::to_string(1 + k % 8) + "-" + z + "/" + t + "\r\n";
      break;
    case 5:
      head += "Content-Range: bytes " + a + "-" + std::to_string(last + 1 + k % 8) + "/" + t + "\r\n";
      break;
    case 6:
      head += "Content-Range: items " + a + "-" + z + "/" + t + "\r\n";
      break;
    case 7:
      head += "content-RANGE:   bytes " + a + "-" + z + "/*\r\n", range_ok = true;
      break;
    case 8:
      head += "Content-Range: bytes " + a + "-" + z + "/" + t + "\r\n", range_ok = true;
      break;
    case 9:
      head += "Content-Range: bytes " + a + "-" + z + "/" + t + "\r\nContent-Range: bytes " + a + "-" + z + "/" + t +
              "\r\n";
      range_ok = true;
      break;
  }
  std::string body;
  for (uint64_t i = 0; i < count; ++i) body.push_back(static_cast<char>(body_byte(first + i)));
  const size_t extra_n = 1 + k % 16, cut = 1 + k % count;
  bool framing_ok = false;
  std::string payload;
  auto chunked = [&](const std::string& data, bool terminate) {
    std::string out;
    for (size_t i = 0; i < data.size(); i += 7) {
      const size_t m = std::min<size_t>(7, data.size() - i);
      char len[16];
      std::snprintf(len, sizeof len, "%zx\r\n", m);
      out += len + data.substr(i, m) + "\r\n";
    }
    if (terminate) out += "0\r\n\r\n";
    return out;
  };
  switch (framing) {
    case 0:
      head += "Content-Length: " + std::to_string(count) + "\r\n", payload = body, framing_ok = true;
      b.content_length = static_cast<long long>(count);
      break;
    case 1:
      head += "Content-Length: " + std::to_string(count) + "\r\n", payload = body.substr(0, count - cut);
      b.content_length = static_cast<long long>(count);
      break;
    case 2:
      head += "Content-Length: " + std::to_string(count + extra_n) + "\r\n", payload = body + std::string(extra_n, 'x');
      b.content_length = static_cast<long long>(count + extra_n);
      break;
    case 3:
      payload = body, framing_ok = true;
      break;  // close-delimited
    case 4:
      head += "Transfer-Encoding: chunked\r\n", payload = chunked(body, true), framing_ok = true;
      break;
    case 5:
      head += "Transfer-Encoding: chunked\r\n", payload = chunked(body.substr(0, count - cut), false);
      break;
    case 6:
      head += "Content-Length: " + std::to_string(count - cut) + "\r\n", payload = body;
      b.content_length = static_cast<long long>(count - cut);
      break;
    case 7:
      head += "Content-Length: " + std::to_string(count + extra_n) + "\r\n", payload = body;
      b.content_length = static_cast<long long>(count + extra_n);
      break;
    case 8:
      head += "Transfer-Encoding: chunked\r\n", payload = chunked(body + std::string(extra_n, 'x'), true);
      break;
  }
  if (extra && n > 9) head.append(reinterpret_cast<const char*>(d + 9), n - 9);
  b.response = head + "\r\n" + payload;
  b.status = status;
  b.read_ok = status == 206 && range_ok && framing_ok;
  return b;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 3) return 0;
  const bool head = data[0] & 1, raw = data[0] & 2, extra = data[0] & 4;
  const uint64_t offset = data[1];
  const size_t count = 1 + data[2] % 64;
  Built b;
  if (raw)
    b.response.assign(reinterpret_cast<const char*>(data + 3), size - 3);
  else
    b = build(data, size, offset, count, extra);
  server().set_response(b.response);
  const bool strict = !raw && !extra;
  if (head) {
    HttpSource source(url(), fuzz_options());
    auto r = source.size();
    if (!r) {
      if (r.message().empty()) std::abort();
      return 0;
    }
    // HEAD answered: the response must have been a 200 with the Content-Length returned.
    if (strict && (b.status != 200 || b.content_length < 0 || *r != static_cast<uint64_t>(b.content_length)))
      std::abort();
    return 0;
  }
  static HttpSource source(url(), fuzz_options());
  static std::vector<uint8_t> buffer(64);
  std::vector<uint8_t>& out = buffer;
  std::fill(out.begin(), out.end(), uint8_t{0});
  const std::span<uint8_t> span(out.data() + (64 - count), count);  // ends at the allocation's end
  auto r = source.read(offset, span);
  if (!r) {
    if (r.message().empty()) std::abort();
    if (strict && b.read_ok) std::abort();  // a correct 206 was refused
    return 0;
  }
  if (strict) {
    if (!b.read_ok) std::abort();  // an incorrect response was accepted
    for (size_t i = 0; i < count; ++i)
      if (span[i] != body_byte(offset + i)) std::abort();
  }
  return 0;
}
