// A scripted HTTP server on 127.0.0.1 for runtime/stream/http_source.hpp's tests and its fuzz target.
//
// One thread accepts connections one at a time, reads each request's head (up to the blank line;
// a receive timeout keeps a client that never finishes its request from blocking the server),
// hands it to the caller's responder, then closes the connection (FIN after the answer, so a
// response without Content-Length ends there). What the server answers — canned bytes, a
// misbehaving range, a response built from fuzz input — is entirely the responder's.
//
// `connect_to()` is a CURLOPT_CONNECT_TO entry that sends every host and port to this server:
// with HttpSourceOptions::customize_handle a redirect cannot leave the loopback interface.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <string_view>
#include <thread>

namespace btflod::test {

class LoopbackHttpServer {
 public:
  /// Writes the answer to `socket` (see send_all). `stopping` turns true when the server is
  /// being destroyed: a responder that stalls on purpose polls it.
  using Responder = std::function<void(int socket, const std::string& request, const std::atomic<bool>& stopping)>;

  /// Listens on an ephemeral port of 127.0.0.1 and starts serving. Aborts when the socket cannot
  /// be bound (a test machine without loopback cannot run these tests meaningfully).
  explicit LoopbackHttpServer(Responder responder, int receive_timeout_ms = 1000)
      : responder_(std::move(responder)), receive_timeout_ms_(receive_timeout_ms) {
    listener_ = ::socket(AF_INET, SOCK_STREAM, 0);
    int one = 1;
    ::setsockopt(listener_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (listener_ < 0 || ::bind(listener_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listener_, 16) != 0) {
      std::perror("LoopbackHttpServer: cannot listen on 127.0.0.1");
      std::abort();
    }
    socklen_t len = sizeof a;
    ::getsockname(listener_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    connect_to_ = "::127.0.0.1:" + std::to_string(port_);
    thread_ = std::thread([this] { serve(); });
  }
  LoopbackHttpServer(const LoopbackHttpServer&) = delete;
  LoopbackHttpServer& operator=(const LoopbackHttpServer&) = delete;
  ~LoopbackHttpServer() {
    stopping_ = true;
    ::shutdown(listener_, SHUT_RDWR);
    ::close(listener_);
    thread_.join();
  }

  int port() const { return port_; }
  std::string url(std::string_view path = "/material.bsvtf") const {
    return "http://127.0.0.1:" + std::to_string(port_) + std::string(path);
  }
  /// "::127.0.0.1:<port>": the CURLOPT_CONNECT_TO entry that routes every connection here.
  const char* connect_to() const { return connect_to_.c_str(); }

  /// Sends every byte (or stops at the first error: the client may have gone away).
  static void send_all(int socket, std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t n = ::send(socket, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) return;
      bytes.remove_prefix(static_cast<size_t>(n));
    }
  }

 private:
  void serve() {
    while (!stopping_) {
      const int c = ::accept(listener_, nullptr, nullptr);
      if (c < 0) {
        if (stopping_) return;
        continue;
      }
      timeval tv{receive_timeout_ms_ / 1000, (receive_timeout_ms_ % 1000) * 1000};
      ::setsockopt(c, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
      std::string request;
      char buf[4096];
      while (request.find("\r\n\r\n") == std::string::npos) {
        const ssize_t n = ::recv(c, buf, sizeof buf, 0);
        if (n <= 0) break;
        request.append(buf, static_cast<size_t>(n));
      }
      responder_(c, request, stopping_);
      ::shutdown(c, SHUT_WR);
      ::close(c);
    }
  }

  Responder responder_;
  int receive_timeout_ms_;
  int listener_ = -1;
  int port_ = 0;
  std::string connect_to_;
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

}  // namespace btflod::test
