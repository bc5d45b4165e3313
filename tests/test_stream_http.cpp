// btflod-link: CURL::libcurl
// btflod-label: net threads
// Tests for runtime/stream/http_source.hpp against real servers on 127.0.0.1: Debian's nginx (started
// by the test with a temporary config; the tests skip with a message when nginx is absent) and a
// tiny socket server thread that misbehaves on purpose (drops the connection mid-transfer,
// ignores Range, answers the wrong range, sends too much, stalls).
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/runtime/stream/http_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "loopback_http_server.hpp"
#include "test_runtime_helpers.hpp"

namespace {

using namespace btflod;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

constexpr const char* kNginx = "/usr/sbin/nginx";

int free_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(s);
  return ntohs(a.sin_port);
}

bool port_open(int port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

// A small container: T = 16, B = 4, 3 levels, 4 components, U′ of 2 lights × 2 views × RGB.
std::vector<uint8_t> make_container() {
  BsvtfMetadata md;
  md.material_name = "http";
  md.tile_size = 16;
  md.border = 4;
  md.level_count = 3;
  md.width = md.height = 64;
  md.component_count = 4;
  md.light_directions = {0, 0, 1, 0.6f, 0, 0.8f};
  md.view_directions = {0, 0, 1, 0, 0.6f, 0.8f};
  md.u_rows = 2 * 2 * 3;
  md.u_row_order = AngularRowOrder::light_major;
  std::vector<float> u(size_t{md.u_rows} * md.component_count, 0.25f);
  const TileLayout layout = md.layout();
  std::vector<std::vector<float>> samples;
  std::vector<BsvtfTileInput> tiles;
  for (uint32_t l = 0; l < 3; ++l)
    for (uint32_t y = 0; y < (1u << l); ++y)
      for (uint32_t x = 0; x < (1u << l); ++x) {
        std::vector<float> t(layout.sample_count());
        for (size_t i = 0; i < t.size(); ++i) t[i] = std::sin(0.01f * static_cast<float>(i) + x + 3.0f * y + l);
        samples.push_back(std::move(t));
        tiles.push_back({TileId{0, l, x, y}, {}, 1.0f});
      }
  for (size_t i = 0; i < tiles.size(); ++i) tiles[i].samples = samples[i];
  return build_bsvtf(md, u, tiles).value();
}

// nginx serving a temp folder on 127.0.0.1:port, as a child process.
class Nginx {
 public:
  bool start(const fs::path& root) {
    dir_ = root;
    port_ = free_port();
    fs::create_directories(dir_ / "www");
    fs::create_directories(dir_ / "tmp");
    std::ofstream conf(dir_ / "nginx.conf");
    conf << "worker_processes 1;\nuser root;\nerror_log " << (dir_ / "error.log").string() << " warn;\npid "
         << (dir_ / "nginx.pid").string() << ";\nevents { worker_connections 64; }\nhttp {\n  access_log off;\n"
         << "  client_body_temp_path " << (dir_ / "tmp").string() << ";\n  proxy_temp_path " << (dir_ / "tmp").string()
         << ";\n  fastcgi_temp_path " << (dir_ / "tmp").string() << ";\n  uwsgi_temp_path " << (dir_ / "tmp").string()
         << ";\n  scgi_temp_path " << (dir_ / "tmp").string() << ";\n  server {\n    listen 127.0.0.1:" << port_
         << ";\n    root " << (dir_ / "www").string() << ";\n  }\n}\n";
    conf.close();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::execl(kNginx, kNginx, "-p", dir_.c_str(), "-e", (dir_ / "error.log").c_str(), "-c",
              (dir_ / "nginx.conf").c_str(), "-g", "daemon off;", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    for (int i = 0; i < 500; ++i) {
      if (port_open(port_)) return true;
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return false;
      }
      std::this_thread::sleep_for(10ms);
    }
    return false;
  }
  ~Nginx() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
  }
  std::string url(const std::string& name) const { return "http://127.0.0.1:" + std::to_string(port_) + "/" + name; }
  fs::path www() const { return dir_ / "www"; }

 private:
  fs::path dir_;
  int port_ = 0;
  pid_t pid_ = -1;
};

// A one-thread HTTP server that answers every request according to `mode`.
class BadServer {
 public:
  enum class Mode { drop_mid_transfer, ignore_range, wrong_range, too_much, stall };
  BadServer(std::vector<uint8_t> body, Mode mode)
      : body_(std::move(body)),
        mode_(mode),
        server_([this](int socket, const std::string& request, const std::atomic<bool>& stopping) {
          respond(socket, request, stopping);
        }) {}
  std::string url() const { return server_.url(); }

 private:
  void respond(int c, const std::string& request, const std::atomic<bool>& stopping) const {
    size_t a = 0, b = body_.size() - 1;
    if (const size_t p = request.find("Range: bytes="); p != std::string::npos)
      std::sscanf(request.c_str() + p + 13, "%zu-%zu", &a, &b);
    b = std::min(b, body_.size() - 1);
    const size_t n = b - a + 1;
    std::string head;
    std::string_view payload(reinterpret_cast<const char*>(body_.data()) + a, n);
    switch (mode_) {
      case Mode::drop_mid_transfer:
        head = "HTTP/1.1 206 Partial Content\r\nContent-Range: bytes " + std::to_string(a) + "-" + std::to_string(b) +
               "/" + std::to_string(body_.size()) + "\r\nContent-Length: " + std::to_string(n) + "\r\n\r\n";
        payload = payload.substr(0, n / 2);  // then close: the transfer is cut
        break;
      case Mode::ignore_range:
        head = "HTTP/1.1 200 OK\r\nContent-Length: " + std::to_string(body_.size()) + "\r\n\r\n";
        payload = std::string_view(reinterpret_cast<const char*>(body_.data()), body_.size());
        break;
      case Mode::wrong_range:
        head = "HTTP/1.1 206 Partial Content\r\nContent-Range: bytes " + std::to_string(a + 1) + "-" +
               std::to_string(b + 1) + "/" + std::to_string(body_.size()) + "\r\nContent-Length: " + std::to_string(n) +
               "\r\n\r\n";
        payload = std::string_view(reinterpret_cast<const char*>(body_.data()) + a + 1, n);
        break;
      case Mode::too_much:
        head = "HTTP/1.1 206 Partial Content\r\nContent-Range: bytes " + std::to_string(a) + "-" +
               std::to_string(b + 100) + "/" + std::to_string(body_.size()) +
               "\r\nContent-Length: " + std::to_string(n + 100) + "\r\n\r\n";
        payload = std::string_view(reinterpret_cast<const char*>(body_.data()) + a, n + 100);
        break;
      case Mode::stall:
        head = "HTTP/1.1 206 Partial Content\r\nContent-Length: " + std::to_string(n) + "\r\n\r\n";
        payload = {};
        break;
    }
    test::LoopbackHttpServer::send_all(c, head);
    test::LoopbackHttpServer::send_all(c, payload);
    if (mode_ == Mode::stall) {
      for (int i = 0; i < 300 && !stopping; ++i) std::this_thread::sleep_for(10ms);
    }
  }
  std::vector<uint8_t> body_;
  Mode mode_;
  test::LoopbackHttpServer server_;  // last: its thread stops before body_ goes
};

class StreamHttp : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { container_ = new std::vector<uint8_t>(make_container()); }
  static void TearDownTestSuite() {
    delete container_;
    container_ = nullptr;
  }
  void start_nginx() {
    if (!fs::exists(kNginx))
      GTEST_SKIP() << "nginx not installed (" << kNginx << "): skipping the HTTP test against a real server";
    const fs::path dir = fs::path(BTFLOD_TEST_TMP_DIR) / ("nginx_" + std::to_string(::getpid()));
    ASSERT_TRUE(nginx_.start(dir)) << "nginx did not start; see " << (dir / "error.log");
    ASSERT_TRUE(write_file_bytes((nginx_.www() / "material.bsvtf").string(), *container_).ok());
  }
  static std::vector<uint8_t>* container_;
  Nginx nginx_;
};
std::vector<uint8_t>* StreamHttp::container_ = nullptr;

TEST_F(StreamHttp, RangeReadsFromNginxMatchTheFile) {
  start_nginx();
  if (IsSkipped()) return;
  HttpSource http(nginx_.url("material.bsvtf"));
  auto size = http.size();
  ASSERT_TRUE(size.ok()) << size.message();
  EXPECT_EQ(size.value(), container_->size());
  for (uint64_t offset : {uint64_t{0}, uint64_t{1}, uint64_t{777}, uint64_t{container_->size() - 300}}) {
    std::vector<uint8_t> out(300);
    auto r = http.read(offset, out);
    ASSERT_TRUE(r.ok()) << r.message();
    EXPECT_EQ(0, std::memcmp(out.data(), container_->data() + offset, out.size())) << offset;
  }
  std::vector<uint8_t> beyond(10);
  EXPECT_EQ(http.read(container_->size() + 5, beyond).status(), Status::short_output);
  HttpSource missing(nginx_.url("nope.bsvtf"));
  EXPECT_EQ(missing.size().status(), Status::io_error);
}

// A cache with room for every tile of the container (21), for the Streamer tests below.
StreamerConfig whole_material_config() {
  StreamerConfig c;
  c.cache = CacheConfig{8, 4, 1u << 12, 16, 4, 1};
  c.vote_window_frames = 1;
  c.decode_workers = 1;
  return c;
}

TEST_F(StreamHttp, StreamerStreamsAWholeMaterialFromNginx) {
  start_nginx();
  if (IsSkipped()) return;
  HttpSource http(nginx_.url("material.bsvtf"));
  btflod_test::World w;  // the directory is parsed from memory; every payload comes from nginx
  w.add(*container_);
  w.finish();
  w.materials[0].source = &http;
  auto s = Streamer::create(w.materials, whole_material_config());
  ASSERT_TRUE(s) << s.error().message;
  btflod_test::Engine e(s.value());
  const std::vector<uint32_t> all = btflod_test::full_feedback(s.value());
  const uint32_t tiles = s.value().cache().set().levels_of(0).tile_count();
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (s.value().cache().used_count() < tiles && std::chrono::steady_clock::now() < deadline)
    btflod_test::run(s.value(), e, all, 1);  // the decode jobs read through HTTP on this thread
  btflod_test::run(s.value(), e, all, 2);    // the last uploads and page-table texels
  ASSERT_EQ(s.value().cache().used_count(), tiles);
  ASSERT_TRUE(s.value().material_ready(0));
  // Every slot holds exactly the texels of a fresh decode of the same container in memory.
  btflod_test::check_engine(w, s.value(), e);
  const StreamerStats st = s.value().stats();
  EXPECT_EQ(st.tile_failures + st.packet_failures, 0u);
  uint64_t payload = 0;  // each payload read once (the payload cache keeps the ancestors)
  for (const BsvtfTileEntry& t : w.dirs[0].tiles) payload += t.size;
  for (const BsvtfPacketEntry& p : w.dirs[0].packets) payload += p.size;
  EXPECT_EQ(st.bytes_read, payload);
}

TEST_F(StreamHttp, ServerDroppingTheConnectionMidTransferIsShortOutput) {
  BadServer server(*container_, BadServer::Mode::drop_mid_transfer);
  HttpSource http(server.url());
  std::vector<uint8_t> out(4000);
  auto r = http.read(100, out);
  EXPECT_EQ(r.status(), Status::short_output) << r.message();
  EXPECT_NE(r.message().find("closed after 2000 of 4000"), std::string::npos) << r.message();
}

TEST_F(StreamHttp, StreamerFailsTheMaterialWhenTheServerDropsEveryTransfer) {
  // The directory comes from memory; every payload read is cut mid-transfer: the root and the
  // U′ packet fail startup_attempts times each, then the material fails once and for all.
  BadServer server(*container_, BadServer::Mode::drop_mid_transfer);
  HttpSource http(server.url());
  btflod_test::World w;
  w.add(*container_);
  w.finish();
  w.materials[0].source = &http;
  StreamerConfig c = whole_material_config();
  c.failure.startup_attempts = 2;
  c.failure.first_backoff_frames = 0;
  auto s = Streamer::create(w.materials, c);
  ASSERT_TRUE(s) << s.error().message;
  btflod_test::Engine e(s.value());
  const std::vector<uint32_t> all = btflod_test::full_feedback(s.value());
  uint32_t failed_events = 0, uploads = 0;
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  for (int f = 0; f < 40 && std::chrono::steady_clock::now() < deadline; ++f) {
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.value().update(all, o), Status::success);
    uploads += static_cast<uint32_t>(o.tile_upload_count);
    for (size_t i = 0; i < o.event_count; ++i)
      if (o.events[i].kind == ResidencyEventKind::material_failed) {
        ++failed_events;
        EXPECT_EQ(o.events[i].status, Status::short_output);
      }
    s.value().pump();
  }
  EXPECT_EQ(failed_events, 1u);
  EXPECT_TRUE(s.value().material_failed(0));
  EXPECT_EQ(uploads, 0u);  // nothing unverified reached the cache
  const StreamerStats st = s.value().stats();
  EXPECT_GE(st.tile_failures + st.packet_failures, 2u);
  EXPECT_LE(st.tile_failures + st.packet_failures, 4u);  // root and packet, 2 attempts each at most
  EXPECT_EQ(s.value().jobs_in_flight(), 0u);             // its children were never scheduled
}

TEST_F(StreamHttp, MisbehavingServersAreDetected) {
  std::vector<uint8_t> out(1000);
  {
    BadServer server(*container_, BadServer::Mode::ignore_range);
    HttpSource http(server.url());
    EXPECT_EQ(http.read(10, out).status(), Status::bad_data) << "a 200 with the whole file overflows the span";
  }
  {
    BadServer server(*container_, BadServer::Mode::wrong_range);
    HttpSource http(server.url());
    auto r = http.read(10, out);
    EXPECT_EQ(r.status(), Status::bad_data) << r.message();
    EXPECT_NE(r.message().find("Content-Range starts at 11"), std::string::npos) << r.message();
  }
  {
    BadServer server(*container_, BadServer::Mode::too_much);
    HttpSource http(server.url());
    EXPECT_EQ(http.read(10, out).status(), Status::bad_data);
  }
  {
    HttpSource nobody("http://127.0.0.1:" + std::to_string(free_port()) + "/x");
    EXPECT_EQ(nobody.read(0, out).status(), Status::io_error);
  }
}

TEST_F(StreamHttp, StalledTransferIsCancellable) {
  BadServer server(*container_, BadServer::Mode::stall);
  HttpSource http(server.url());
  std::atomic<bool> cancel{false};
  std::thread canceller([&] {
    std::this_thread::sleep_for(50ms);
    cancel = true;
  });
  std::vector<uint8_t> out(1000);
  auto r = http.read(0, out, &cancel);
  canceller.join();
  EXPECT_EQ(r.status(), Status::cancelled) << r.message();
}

}  // namespace
