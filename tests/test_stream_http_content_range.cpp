// btflod-link: CURL::libcurl
// btflod-label: unit threads
// Regression tests for runtime/stream/http_source.hpp, failure class "a 206 whose Content-Range does
// not describe the requested range": found by fuzz_http_source (each response below is what
// the fuzzer's fake server sent). A range read must only succeed when the answer is a 206 with
// "Content-Range: bytes a-b/…" for exactly the requested a and b and b − a + 1 body bytes;
// before, a 206 without Content-Range, with another unit, with the wrong last byte, with a
// negative first byte or with the unsatisfied-range form "*/size" was accepted.
// The responses come from a one-connection-at-a-time server thread on 127.0.0.1; every
// connection is pointed at it through HttpSourceOptions::customize_handle.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "btflod/runtime/stream/http_source.hpp"
#include "loopback_http_server.hpp"

namespace {

using namespace btflod;

// Answers connection i with responses[min(i, last)], then closes it.
class CannedServer {
 public:
  explicit CannedServer(std::string response) : CannedServer(std::vector<std::string>{std::move(response)}) {}
  explicit CannedServer(std::vector<std::string> responses)
      : responses_(std::move(responses)), server_([this](int socket, const std::string&, const std::atomic<bool>&) {
          test::LoopbackHttpServer::send_all(socket, responses_[std::min(served_++, responses_.size() - 1)]);
        }) {}
  ~CannedServer() { curl_slist_free_all(list_); }
  std::string url() const { return server_.url(); }
  HttpSourceOptions options() {
    HttpSourceOptions o;
    o.timeout_ms = 5000;
    if (!list_) list_ = curl_slist_append(nullptr, server_.connect_to());
    o.customize_handle = [](CURL* h, void* user) {
      curl_easy_setopt(h, CURLOPT_CONNECT_TO, static_cast<curl_slist*>(user));
    };
    o.customize_user = list_;
    return o;
  }

 private:
  std::vector<std::string> responses_;
  size_t served_ = 0;  // touched by the server thread only
  curl_slist* list_ = nullptr;
  test::LoopbackHttpServer server_;  // last: its thread stops before the members above go
};

// Reads 4 bytes at offset 10 from a server that answers `response`.
VoidResult read_four_at_ten(const std::string& response, std::vector<uint8_t>& out) {
  CannedServer server(response);
  HttpSource http(server.url(), server.options());
  out.assign(4, 0);
  return http.read(10, out);
}

// Expects the read of 4 bytes at offset 10 from a server that answers `response` to fail as
// bad data, with `needle` in the message when one is given.
void expect_bad_data(const std::string& response, const char* needle = nullptr) {
  std::vector<uint8_t> out;
  auto r = read_four_at_ten(response, out);
  EXPECT_EQ(r.status(), Status::bad_data) << r.message();
  if (needle != nullptr) {
    EXPECT_NE(r.message().find(needle), std::string::npos) << r.message();
  }
}

TEST(StreamHttpContentRange, PartialContentWithoutContentRangeIsRejected) {
  expect_bad_data("HTTP/1.1 206 Partial Content\r\nContent-Length: 4\r\n\r\nabcd", "Content-Range");
}

TEST(StreamHttpContentRange, ContentRangeInAnotherUnitIsRejected) {
  expect_bad_data("HTTP/1.1 206 Partial Content\r\nContent-Range: items 10-13/100\r\nContent-Length: 4\r\n\r\nabcd");
}

TEST(StreamHttpContentRange, ContentRangeWithTheWrongLastByteIsRejected) {
  expect_bad_data("HTTP/1.1 206 Partial Content\r\nContent-Range: bytes 10-20/100\r\nContent-Length: 4\r\n\r\nabcd",
                  "20");
}

TEST(StreamHttpContentRange, ContentRangeWithANegativeFirstByteIsRejected) {
  expect_bad_data("HTTP/1.1 206 Partial Content\r\nContent-Range: bytes -3-13/100\r\nContent-Length: 4\r\n\r\nabcd");
}

TEST(StreamHttpContentRange, UnsatisfiedRangeFormInAPartialContentAnswerIsRejected) {
  // "*/size" belongs to a 416; in a 206 it names no bytes (it used to parse as first byte 0).
  CannedServer server("HTTP/1.1 206 Partial Content\r\nContent-Range: bytes */100\r\nContent-Length: 4\r\n\r\nabcd");
  HttpSource http(server.url(), server.options());
  std::vector<uint8_t> out(4);
  auto r = http.read(0, out);
  EXPECT_EQ(r.status(), Status::bad_data) << r.message();
}

TEST(StreamHttpContentRange, CorrectAnswersAreStillAccepted) {
  const char* answers[] = {
      "HTTP/1.1 206 Partial Content\r\nContent-Range: bytes 10-13/100\r\nContent-Length: 4\r\n\r\nabcd",
      "HTTP/1.1 206 Partial Content\r\ncontent-RANGE:   Bytes 10-13/*\r\nContent-Length: 4\r\n\r\nabcd",
      "HTTP/1.1 206 Partial Content\r\nContent-Range: bytes 10-13/100\r\n\r\nabcd",  // ends at close
      "HTTP/1.1 206 Partial Content\r\nContent-Range: bytes 10-13/100\r\nTransfer-Encoding: chunked\r\n\r\n"
      "3\r\nabc\r\n1\r\nd\r\n0\r\n\r\n",
      "HTTP/1.1 100 Continue\r\n\r\nHTTP/1.1 206 Partial Content\r\nContent-Range: bytes 10-13/14\r\nContent-Length: "
      "4\r\n\r\nabcd",
  };
  for (const char* a : answers) {
    std::vector<uint8_t> out;
    auto r = read_four_at_ten(a, out);
    ASSERT_TRUE(r.ok()) << a << "\n" << r.message();
    EXPECT_EQ(std::string(out.begin(), out.end()), "abcd") << a;
  }
}

// Failure class "a folded first header line on a reused handle" (fuzz_http_source, 10-minute
// campaign): libcurl before 8.1.0 unfolds such a line onto the previous transfer's freed last
// header (curl issue #11101), a heap-use-after-free inside libcurl that ASan reports here when
// handles are reused. On those versions HttpSource uses a fresh handle per request by default,
// and the hostile answer is an error instead.
TEST(StreamHttpHostileHeaders, FoldedFirstHeaderOnTheNextReadIsAnErrorNotAUseAfterFree) {
  EXPECT_EQ(HttpSourceOptions{}.reuse_handles, HttpSourceOptions::http_source_handle_reuse_is_safe());
  CannedServer server(std::vector<std::string>{
      "HTTP/1.1 206 Partial Content\r\nContent-Range: bytes 10-13/100\r\nContent-Length: 4\r\n\r\nabcd",
      "HTTP/1.0 206 Partial Content\r\n\t\tX-Folded: chunked\r\nContent-Range: bytes 10-13/100\r\n"
      "Content-Length: 4\r\n\r\nabcd"});
  HttpSource http(server.url(), server.options());
  std::vector<uint8_t> out(4);
  ASSERT_TRUE(http.read(10, out).ok());
  EXPECT_EQ(std::string(out.begin(), out.end()), "abcd");
  auto second = http.read(10, out);
  if (!HttpSourceOptions::http_source_handle_reuse_is_safe()) {
    EXPECT_FALSE(second.ok());
  }
  if (!second.ok()) {
    EXPECT_FALSE(second.message().empty());
  }
}

}  // namespace
