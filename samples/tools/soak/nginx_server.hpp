// A private nginx for btflod-soak's HTTP mode: one process (master_process off) serving a folder
// on 127.0.0.1, which the soak kills (SIGKILL: a crash, or SIGTERM: a fast shutdown) and starts
// again on the same port while the Streamer reads through HttpSource.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>

extern char** environ;

namespace soak {

class NginxServer {
 public:
  ~NginxServer() {
    stop(SIGTERM);
    if (!dir_.empty()) {
      std::error_code ec;
      std::filesystem::remove_all(dir_, ec);
    }
  }

  /// Writes the configuration for a free port and serves `dir`/www. False (with `why`) when
  /// nginx does not start within 5 s.
  bool start(const std::string& nginx, const std::filesystem::path& dir, std::string& why) {
    nginx_ = nginx;
    dir_ = dir;
    std::filesystem::create_directories(dir_ / "www");
    std::filesystem::create_directories(dir_ / "tmp");
    port_ = free_port();
    if (port_ == 0) return why = "no free port on 127.0.0.1", false;
    std::FILE* f = std::fopen((dir_ / "nginx.conf").c_str(), "w");
    if (f == nullptr) return why = "cannot write " + (dir_ / "nginx.conf").string(), false;
    const std::string d = dir_.string();
    std::fprintf(f,
                 "daemon off;\nmaster_process off;\nworker_processes 1;\n%serror_log %s/error.log warn;\n"
                 "pid %s/nginx.pid;\nevents { worker_connections 256; }\nhttp {\n  access_log off;\n"
                 "  keepalive_requests 1000000;\n  client_body_temp_path %s/tmp;\n  proxy_temp_path %s/tmp;\n"
                 "  fastcgi_temp_path %s/tmp;\n  uwsgi_temp_path %s/tmp;\n  scgi_temp_path %s/tmp;\n"
                 "  server {\n    listen 127.0.0.1:%d;\n    root %s/www;\n  }\n}\n",
                 ::geteuid() == 0 ? "user root;\n" : "", d.c_str(), d.c_str(), d.c_str(), d.c_str(), d.c_str(),
                 d.c_str(), d.c_str(), port_, d.c_str());
    std::fclose(f);
    if (!spawn()) return why = "nginx did not start; see " + (dir_ / "error.log").string(), false;
    return true;
  }

  /// Ends the process with `signal` and waits for it.
  void stop(int signal) {
    if (pid_ <= 0) return;
    ::kill(pid_, signal);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

  /// Starts it again on the same port; false when it does not listen within 5 s.
  bool spawn() {
    const std::string prefix = dir_.string(), error_log = (dir_ / "error.log").string(),
                      conf = (dir_ / "nginx.conf").string();
    const char* argv[] = {nginx_.c_str(), "-p", prefix.c_str(), "-e", error_log.c_str(), "-c", conf.c_str(), nullptr};
    if (::posix_spawn(&pid_, nginx_.c_str(), nullptr, nullptr, const_cast<char* const*>(argv), environ) != 0) {
      pid_ = -1;
      return false;
    }
    for (int i = 0; i < 1000; ++i) {
      if (listening()) return true;
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return false;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }

  std::string url(const std::string& name) const { return "http://127.0.0.1:" + std::to_string(port_) + "/" + name; }
  std::filesystem::path www() const { return dir_ / "www"; }

 private:
  static sockaddr_in loopback(int port) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    return a;
  }
  // A free port below Linux's ephemeral range (ip_local_port_range, 32768 and up by default): the
  // server is restarted on the same port, and while it is down an ephemeral port could be handed
  // to any outgoing connection on the machine (a browser test, this process's own curl), so that
  // the restart would fail to listen. The search starts at a place that differs between
  // processes, so that concurrent runs rarely probe the same ports.
  static int free_port() {
    const int span = 12000, first = 20000;
    const int start = static_cast<int>((static_cast<unsigned>(::getpid()) * 2654435761u) % span);
    for (int i = 0; i < span; ++i) {
      const int port = first + (start + i) % span;
      const int s = ::socket(AF_INET, SOCK_STREAM, 0);
      if (s < 0) return 0;
      const int one = 1;
      ::setsockopt(s, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);  // as nginx binds it
      sockaddr_in a = loopback(port);
      const bool free = ::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
      ::close(s);
      if (free) return port;
    }
    return 0;
  }
  bool listening() const {
    const int s = ::socket(AF_INET, SOCK_STREAM, 0);
    if (s < 0) return false;
    sockaddr_in a = loopback(port_);
    const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    ::close(s);
    return ok;
  }

  std::string nginx_;
  std::filesystem::path dir_;
  int port_ = 0;
  pid_t pid_ = -1;
};

}  // namespace soak
