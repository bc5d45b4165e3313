// btflod-soak — hours of streaming, survived and checked. One Streamer serves a world of
// materials (real `.bsvtf` containers built from synthetic eigen-textures) to a camera that pans
// and cuts; its reads go through an engine-owned I/O thread that completes them out of order
// and injects faults (failed reads, corrupted bytes, stalls, refusals); its decode jobs run on
// worker threads. After every frame the engine-side invariants are checked:
//   * every uploaded tile equals a fresh decode of the pristine container (no corrupted or
//     unverified byte ever reaches the GPU);
//   * the engine's page tables, built only from the Streamer's writes, equal a rebuild from the
//     cache wherever the shader reads (resident tiles and the finest level);
//   * the cache's own invariants hold, the resident set stays within the slots and the
//     requests within their budgets;
// and every few seconds the process's resident memory and the heap allocations since warm-up
// are reported. At the end the Streamer is quiesced (reads cancelled, jobs drained) and
// destroyed. Exit 0 when no invariant failed, no allocation happened after warm-up, RSS stayed
// within --rss-tolerance of its post-warm-up value, and every corrupted read was caught.
//
// With --http the containers are served by a private nginx and read through HttpSource (libcurl)
// on the same faulty I/O thread, and the nginx is killed and started again every
// --restart-every seconds: the reads of each outage must fail (detected), reads must succeed
// again afterwards (recovered), and no tile or material may be given up.
//
//   btflod-soak [--seconds N | --minutes N] [--seed S] [--workers N] [--json FILE]
//               [--http [--restart-every SECONDS] [--nginx PATH]]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <new>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "btflod/runtime/streamer.hpp"
#if BTFLOD_SOAK_HTTP
#include "btflod/runtime/stream/http_source.hpp"
#endif
#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/runtime/stream/thread_executor.hpp"
#include "common/arguments.hpp"
#include "faulty_async_io.hpp"  // tests/: the engine's faulty I/O thread, shared with the thread tests
#include "nginx_server.hpp"

// Heap allocations of the whole process (every thread, every form of operator new), to prove
// that none happen per frame. Not inlined: GCC would otherwise see free() applied to the result
// of a new-expression in every caller (-Wmismatched-new-delete).
static std::atomic<uint64_t> g_allocations{0};
static std::atomic<bool> g_trap{false};  // debugging: abort on the first allocation after warm-up
// Set on a thread while it runs code that is the engine's, not btflod's runtime: the HTTP
// client's reads (HttpSource builds error messages, libcurl keeps connections) and the
// restarts of the server. Their allocations are not counted.
static thread_local bool t_uncounted = false;
[[gnu::noinline]] void* operator new(std::size_t n) {
  if (!t_uncounted) g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (!t_uncounted && g_trap.load(std::memory_order_relaxed)) std::abort();
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void* operator new[](std::size_t n) { return operator new(n); }
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
[[gnu::noinline]] void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  if (!t_uncounted) g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n ? n : 1);
}
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
// The aligned forms (the runtime's default allocator uses them).
[[gnu::noinline]] void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  if (!t_uncounted) g_allocations.fetch_add(1, std::memory_order_relaxed);
  const std::size_t al = std::max(static_cast<std::size_t>(a), sizeof(void*));
  return std::aligned_alloc(al, (std::max<std::size_t>(n, 1) + al - 1) / al * al);
}
[[gnu::noinline]] void* operator new(std::size_t n, std::align_val_t a) {
  if (void* p = operator new(n, a, std::nothrow)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }

using namespace btflod;
using btflod_test::FaultyAsyncIo;
using btflod_test::FaultyIoConfig;

namespace {

using Clock = std::chrono::steady_clock;
// The shortest frame of an HTTP run (see the failure policy in main).
constexpr auto kHttpFrame = std::chrono::milliseconds(1);

struct Options {
  double seconds = 120;
  uint32_t seed = 1;
  uint32_t workers = 2;
  double rss_tolerance = 0.01;
  std::string json;
  bool http = false;          // read through HttpSource from a private nginx, restarted
  double restart_every = 10;  // seconds between nginx restarts (--http)
  std::string nginx = "/usr/sbin/nginx";
};

bool parse(int argc, char** argv, Options& o) {
  samples::Arguments args("btflod-soak", argc, argv);
  o.http = args.flag("http");
  o.json = args.string("json", o.json);
  o.nginx = args.string("nginx", o.nginx);
  o.seconds = args.number("seconds", o.seconds, 0.0, 1e9);
  if (const auto minutes = args.optional_number("minutes", 0.0, 1e7)) o.seconds = 60 * *minutes;
  o.seed = args.integer_as("seed", o.seed, 0, 0xffffffffll);
  o.workers = args.integer_as("workers", o.workers, 1, 256);
  o.restart_every = args.number("restart-every", o.restart_every, 0.5, 1e9);
  o.rss_tolerance = args.number("rss-tolerance", o.rss_tolerance, 0.0, 1e9);
  return args.finish(0);
}

// Resident set size of this process (bytes), from /proc/self/statm.
uint64_t rss_bytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (f == nullptr) return 0;
  unsigned long size = 0, resident = 0;
  const int n = std::fscanf(f, "%lu %lu", &size, &resident);
  std::fclose(f);
  return n == 2 ? uint64_t{resident} * 4096 : 0;
}

// A material: eigen-textures with structure at every level, so every tile codes something.
std::vector<uint8_t> make_container(uint32_t size, uint32_t components, uint32_t seed) {
  EigenTextures e;
  e.textures.resize(static_cast<int>(size), static_cast<int>(size), static_cast<int>(components));
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x)
      for (uint32_t c = 0; c < components; ++c)
        e.textures.at(static_cast<int>(x), static_cast<int>(y), static_cast<int>(c)) =
            0.5f +
            0.3f * std::sin(0.021f * (x + 1.0f) * (c + 1 + seed)) * std::cos(0.017f * y * (seed + 1)) / (1.0f + c);
  e.light_count = e.view_count = 3;
  e.angular.assign(size_t{3} * 3 * 3 * components, 0.0f);
  for (size_t i = 0; i < e.angular.size(); ++i) e.angular[i] = 0.05f + 0.01f * static_cast<float>((i * 13 + seed) % 40);
  BsvtfFromEigenOptions o;
  o.tile_size = 32;
  o.border = 4;
  o.light_directions = {0, 0, 1, 0.6f, 0, 0.8f, 0, 0.6f, 0.8f};
  o.view_directions = o.light_directions;
  auto file = build_bsvtf_from_eigen_textures(e, o);
  return file ? std::move(*file) : std::vector<uint8_t>{};
}

#if BTFLOD_SOAK_HTTP
// HttpSource as the engine's I/O thread uses it: what it and libcurl allocate is the engine's
// business, not the runtime's, so those allocations are not counted.
struct EngineHttpSource final : TileSource {
  HttpSource http;
  EngineHttpSource(std::string url, HttpSourceOptions o) : http(std::move(url), o) {}
  Result<uint64_t> size() override { return http.size(); }
  VoidResult read(uint64_t offset, std::span<uint8_t> out, const std::atomic<bool>* cancel) override {
    t_uncounted = true;
    VoidResult r = http.read(offset, out, cancel);
    t_uncounted = false;
    return r;
  }
  std::string describe() const override { return http.describe(); }
};
#else
struct EngineHttpSource final : TileSource {};  // built without libcurl: --http is skipped
#endif

// Restarts the nginx every `every` seconds: it is killed (SIGKILL and SIGTERM in turn), stays
// down for 50–300 ms, and is started again on the same port. Per restart: the HTTP reads
// attempted while it was down must have failed (detected: each is reported to the Streamer as
// io_error), and a read must succeed again after it is back (recovered) within 10 s.
class Restarter {
 public:
  std::atomic<uint64_t> restarts{0}, idle{0}, undetected{0}, recovered{0}, start_failures{0}, outage_failures{0};
  std::atomic<uint64_t> max_recovery_us{0}, total_recovery_us{0};

  Restarter(soak::NginxServer& server, const FaultyAsyncIo& io, double every, uint32_t seed)
      : server_(server), io_(io), every_(every), rng_(seed ^ 0x9e3779b9u) {}
  ~Restarter() { stop(); }
  void start() {
    thread_ = std::thread([this] { loop(); });
  }
  void stop() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  bool wait(std::chrono::microseconds d) {  // false when stopping
    std::unique_lock lock(mutex_);
    return !cv_.wait_for(lock, d, [&] { return stopping_; });
  }
  void loop() {
    t_uncounted = true;  // the engine's operations, not the runtime
    const auto& c = io_.counters;
    while (wait(std::chrono::microseconds(static_cast<int64_t>(every_ * 1e6)))) {
      const uint64_t failed0 = c.source_failed.load(), ok0 = c.source_ok.load();
      server_.stop(restarts.load() % 2 == 0 ? SIGKILL : SIGTERM);
      std::this_thread::sleep_for(std::chrono::milliseconds(50 + rng_() % 251));
      if (!server_.spawn()) {
        ++start_failures;
        return;
      }
      const auto up = Clock::now();
      const uint64_t failed1 = c.source_failed.load(), ok1 = c.source_ok.load();
      // Reads attempted while it was down (a read that began before the kill may still have
      // succeeded): some must have failed.
      const uint64_t attempts = failed1 - failed0 + ok1 - ok0, failures = failed1 - failed0;
      idle += attempts == 0;
      undetected += attempts > 0 && failures == 0;
      outage_failures += failures;
      bool back = false, stopping = false;
      while (!back && !stopping && Clock::now() - up < std::chrono::seconds(10)) {
        stopping = !wait(std::chrono::microseconds(200));
        back = c.source_ok.load() > ok1;
      }
      if (stopping && !back) return;  // the run ended before a read was due: not counted
      if (back) {
        ++recovered;
        const auto us =
            static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - up).count());
        total_recovery_us += us;
        if (us > max_recovery_us.load()) max_recovery_us = us;
      }
      ++restarts;
      if (!back) return;  // stopping, or it did not come back: the run fails
    }
  }
  soak::NginxServer& server_;
  const FaultyAsyncIo& io_;
  double every_;
  std::mt19937 rng_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::thread thread_;
};

// A camera over a 2×2 grid of materials: pans, zooms, and cuts to a new place every 240 frames.
void render_feedback(const Streamer& s, uint64_t frame, std::mt19937& rng, float cam[3], std::vector<uint32_t>& out) {
  if (frame % 240 == 0) {
    std::uniform_real_distribution<float> u(0.0f, 2.0f);
    cam[0] = u(rng), cam[1] = u(rng), cam[2] = 0.25f + 0.5f * u(rng);  // a cut
  }
  cam[0] += 0.004f, cam[1] += 0.0017f;
  out.clear();
  for (uint32_t y = 0; y < 45; ++y)
    for (uint32_t x = 0; x < 80; ++x) {
      const float gx = std::fmod(cam[0] + cam[2] * x / 80.0f, 2.0f), gy = std::fmod(cam[1] + cam[2] * y / 45.0f, 2.0f);
      const uint32_t m = (gy >= 1.0f ? 2u : 0u) + (gx >= 1.0f ? 1u : 0u);
      const VtLevelTable& lv = s.cache().set().material(m).levels;
      const float texels_per_pixel = cam[2] * static_cast<float>(lv.geometry.width) / 80.0f;
      const uint32_t drop = static_cast<uint32_t>(std::max(0.0f, std::log2(std::max(texels_per_pixel, 1.0f))));
      const uint32_t level = lv.finest_level() - std::min(drop, lv.finest_level());
      const float fx = gx - std::floor(gx), fy = gy - std::floor(gy);
      const uint32_t tx = std::min(lv.tiles_x[level] - 1, static_cast<uint32_t>(fx * lv.tiles_x[level]));
      const uint32_t ty = std::min(lv.tiles_y[level] - 1, static_cast<uint32_t>(fy * lv.tiles_y[level]));
      out.push_back(pack_feedback(FeedbackTile{m, level, tx, ty}));
    }
}

// The reference of an upload: its chain decoded from the pristine container.
bool matches_fresh_decode(const std::vector<uint8_t>& file, const BsvtfDirectory& d, TileId local, TileDecoder& dec,
                          std::vector<float>& a, std::vector<float>& b, std::vector<uint16_t>& halves,
                          std::span<const uint16_t> uploaded) {
  for (uint32_t l = 0; l <= local.level; ++l) {
    const TileId t = local.ancestor(l);
    const BsvtfTileEntry* e = d.find(t);
    if (e == nullptr || dec.decode(std::span<const uint8_t>(file.data() + e->offset, e->size),
                                   l > 0 ? std::span<const float>(a) : std::span<const float>(), t.x & 1u, t.y & 1u,
                                   b) != Status::success)
      return false;
    std::swap(a, b);
  }
  float_to_half(a, halves);
  return uploaded.size() == halves.size() && std::equal(halves.begin(), halves.end(), uploaded.begin());
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse(argc, argv, opt)) return 2;
  // The world: four materials of different sizes and component counts.
  const uint32_t sizes[4] = {512, 256, 384, 512}, comps[4] = {8, 4, 12, 6};
  std::vector<std::vector<uint8_t>> files;
  std::vector<BsvtfDirectory> dirs;
  for (uint32_t m = 0; m < 4; ++m) {
    files.push_back(make_container(sizes[m], comps[m], opt.seed + m));
    auto d = read_bsvtf(files.back());
    if (!d) return std::fprintf(stderr, "btflod-soak: container: %s\n", d.message().c_str()), 1;
    dirs.push_back(std::move(*d));
  }
  // --http: the containers are served by a private nginx and read through HttpSource (the
  // directory stays the one read from memory); the nginx is restarted every --restart-every s.
  soak::NginxServer nginx;
  std::vector<std::unique_ptr<EngineHttpSource>> http_sources;
  if (opt.http) {
#if !BTFLOD_SOAK_HTTP
    std::printf("btflod-soak: built without libcurl (HttpSource): soak: skipped\n");
    return 0;
#else
    if (::access(opt.nginx.c_str(), X_OK) != 0) {
      std::printf("btflod-soak: no nginx at %s (Debian: nginx-light): soak: skipped\n", opt.nginx.c_str());
      return 0;
    }
    std::string why;
    const auto dir = std::filesystem::temp_directory_path() / ("btflod-soak-" + std::to_string(::getpid()));
    if (!nginx.start(opt.nginx, dir, why)) return std::fprintf(stderr, "btflod-soak: %s\n", why.c_str()), 1;
    HttpSourceOptions ho;
    // A server we run ourselves: handles (keep-alive connections) are reused, so every restart
    // also leaves the client with dead connections to notice.
    ho.reuse_handles = true;
    ho.connect_timeout_ms = 2000;
    ho.timeout_ms = 10000;
    ho.low_speed_seconds = 5;
    for (uint32_t m = 0; m < 4; ++m) {
      const std::string name = "material" + std::to_string(m) + ".bsvtf";
      std::FILE* f = std::fopen((nginx.www() / name).c_str(), "wb");
      const bool written = f != nullptr && std::fwrite(files[m].data(), 1, files[m].size(), f) == files[m].size();
      if (f != nullptr) std::fclose(f);
      if (!written) return std::fprintf(stderr, "btflod-soak: cannot write %s\n", name.c_str()), 1;
      http_sources.push_back(std::make_unique<EngineHttpSource>(nginx.url(name), ho));
    }
#endif
  }
  StreamerConfig config;
  config.cache = CacheConfig{12, 12, 1u << 14, 32, 4, 1};  // 144 slots: swaps all the time
  config.scheduler.budgets.uploads_per_frame = 8;
  config.scheduler.budgets.requests_in_flight = 24;
  config.vote_window_frames = 1;
  config.decode_workers = opt.workers;
  // Small caches of compressed and decoded ancestors, so that reads (and their faults) go on
  // all the time instead of being served from memory after the first minute.
  config.payload_cache_bytes = 64u << 10;
  config.decoded_cache_tiles = 4;
  if (opt.http) {
    // An engine streaming over the network retries through an outage: with the back-off capped
    // at 120 frames, 16 consecutive failures span about 1,300 frames. The back-off counts
    // frames and an outage lasts wall-clock time (50–300 ms), so the HTTP run paces its frames
    // at 1 ms at least (kHttpFrame, still 16× a 60 Hz engine's rate): 1,300 frames are then
    // 1.3 s or more whatever the machine's speed (unpaced, a fast machine ran 7,500 frames a
    // second and gave tiles up within one outage).
    config.failure.tile_attempts = config.failure.startup_attempts = config.failure.packet_attempts = 16;
  }
  // The engine's I/O thread (tests/faulty_async_io.hpp), per read: 1 % fail, 1 % arrive with a
  // damaged byte, 0.2 % stall for 40 ms; 0.3 % of start_read calls are refused.
  FaultyIoConfig io_config;
  io_config.seed = opt.seed;
  io_config.capacity = 4096;
  io_config.fail = 0.01;
  io_config.corrupt = 0.01;
  io_config.stall = 0.002;
  io_config.stall_ms = 40;
  io_config.refuse = 0.003;
  FaultyAsyncIo io(io_config);
  std::vector<FaultyAsyncIo::Source> sources;
  for (uint32_t m = 0; m < 4; ++m) sources.push_back(io.source(files[m], opt.http ? http_sources[m].get() : nullptr));
  Restarter restarter(nginx, io, opt.restart_every, opt.seed);
  std::vector<StreamerMaterial> materials;
  for (uint32_t m = 0; m < 4; ++m) {
    materials.push_back(StreamerMaterial{&dirs[m], nullptr, &sources[m]});
  }
  auto created = Streamer::create(materials, config);
  if (!created) return std::fprintf(stderr, "btflod-soak: %s\n", created.message().c_str()), 1;
  Streamer streamer = std::move(*created);
  const TileCache& cache = streamer.cache();
  const VtSet& set = cache.set();

  // The engine's GPU-side state and every buffer of the frame loop, sized once.
  std::vector<StreamerTileUpload> tiles(streamer.tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(streamer.packet_uploads_bound());
  std::vector<PageTableWrite> writes(1u << 16);
  std::vector<ResidencyEvent> events(256);
  std::vector<std::vector<uint32_t>> page_tables;
  for (uint32_t t = 0; t < set.texture_count(); ++t)
    page_tables.emplace_back(set.levels_of(t).tile_count(), 0xffffffffu);
  std::vector<uint32_t> feedback;
  feedback.reserve(80 * 45);
  const TileLayout layout{32, 4, 4};
  TileDecoder reference(layout);
  std::vector<float> fa(layout.sample_count()), fb(layout.sample_count());
  std::vector<uint16_t> halves(layout.sample_count());
  std::mt19937 camera_rng(opt.seed);
  float cam[3] = {0, 0, 0.5f};

  uint64_t frame = 0, uploads = 0, wrong_uploads = 0, wrong_page_texels = 0, budget_breaches = 0, cache_breaches = 0;
  uint64_t bad_data_events = 0, io_error_events = 0, unavailable = 0, material_failures = 0;
  uint64_t allocations_after_warmup = 0, checker_allocations = 0, rss_warm = 0, rss_max = 0, rss_last = 0;
  const double warmup_seconds = std::min(10.0, opt.seconds / 6);
  bool warm = false;
  uint64_t allocations_at_warmup = 0;
  const auto start = Clock::now();
  auto last_report = start;
  std::printf("btflod-soak: %u materials, %u slots, %u workers, %.0f s (seed %u)%s\n", 4u, cache.slot_count(),
              opt.workers, opt.seconds, opt.seed, opt.http ? ", over HTTP from a restarted nginx" : "");
  std::printf("%8s %9s %9s %8s %9s %8s %8s %8s %10s\n", "seconds", "frames", "uploads", "rss_MiB", "allocs", "bad_data",
              "io_err", "retries", "invariants");
  const auto print_row = [&](double elapsed) {
    const StreamerStats st = streamer.stats();
    std::printf("%8.0f %9llu %9llu %8.1f %9llu %8llu %8llu %8llu %10llu\n", elapsed,
                static_cast<unsigned long long>(frame), static_cast<unsigned long long>(uploads),
                static_cast<double>(rss_bytes()) / 1048576.0, static_cast<unsigned long long>(allocations_after_warmup),
                static_cast<unsigned long long>(bad_data_events), static_cast<unsigned long long>(io_error_events),
                static_cast<unsigned long long>(st.retries),
                static_cast<unsigned long long>(wrong_uploads + wrong_page_texels + budget_breaches + cache_breaches));
    std::fflush(stdout);
  };
  {
    ThreadExecutor workers(streamer.jobs(), opt.workers);
    // When a completion makes a job runnable, wake the workers with it.
    io.start(
        streamer,
        [](void* w, uint32_t job) {
          if (job != Streamer::kNoJob) static_cast<ThreadExecutor*>(w)->notify();
        },
        &workers);
    if (opt.http) restarter.start();
    auto frame_start = Clock::now();
    for (;;) {
      if (opt.http) std::this_thread::sleep_until(frame_start + kHttpFrame);
      frame_start = Clock::now();
      const double elapsed = std::chrono::duration<double>(frame_start - start).count();
      if (elapsed >= opt.seconds) break;
      render_feedback(streamer, frame, camera_rng, cam, feedback);
      StreamerOutputs out{tiles, packets, writes, events};
      if (streamer.update(feedback, out) != Status::success) return std::fprintf(stderr, "update failed\n"), 1;
      ++frame;
      // Tiles: each must be the pristine container's texels.
      for (size_t i = 0; i < out.tile_upload_count; ++i) {
        const StreamerTileUpload& u = tiles[i];
        const uint32_t m = set.material_of(u.tile.texture);
        const TileId local{u.tile.texture - streamer.first_texture(m), u.tile.level, u.tile.x, u.tile.y};
        wrong_uploads += !matches_fresh_decode(files[m], dirs[m], local, reference, fa, fb, halves, u.texels);
        ++uploads;
      }
      for (size_t i = 0; i < out.page_table_write_count; ++i) {
        const PageTableWrite& w = writes[i];
        page_tables[w.tile.texture][set.levels_of(w.tile.texture).index(w.tile)] = w.entry;
      }
      for (size_t i = 0; i < out.event_count; ++i) {
        const ResidencyEvent& e = events[i];
        if (e.kind == ResidencyEventKind::tile_failed || e.kind == ResidencyEventKind::packet_failed) {
          bad_data_events += e.status == Status::bad_data;
          io_error_events += e.status == Status::io_error;
        }
        unavailable +=
            e.kind == ResidencyEventKind::tile_unavailable || e.kind == ResidencyEventKind::packet_unavailable;
        material_failures += e.kind == ResidencyEventKind::material_failed;
      }
      // The page table the engine built from the writes alone equals a rebuild from the cache.
      if (streamer.pending_page_table_writes() == 0)
        for (uint32_t t = 0; t < set.texture_count(); ++t) {
          const VtLevelTable& lv = set.levels_of(t);
          for (uint32_t i = 0; i < lv.tile_count(); ++i) {
            const TileId id = lv.tile(t, i);
            if ((cache.resident(id) || id.level == lv.finest_level()) && page_tables[t][i] != gpu_page_entry(cache, id))
              ++wrong_page_texels;
          }
        }
      const SchedulerBudgets& b = config.scheduler.budgets;
      budget_breaches += streamer.scheduler().requests_in_flight() > b.requests_in_flight ||
                         streamer.scheduler().bytes_in_flight() > b.bytes_in_flight ||
                         cache.used_count() > cache.slot_count();
      if (frame % 64 == 0) {  // TileCache::check_invariants() is a test helper: its allocations don't count
        const bool trap = g_trap.exchange(false);
        const uint64_t before = g_allocations.load();
        if (!cache.check_invariants()) ++cache_breaches;
        checker_allocations += g_allocations.load() - before;
        g_trap = trap;
      }
      // Memory: after warm-up nothing may allocate and the resident set stays flat.
      const auto now = Clock::now();
      if (!warm && elapsed >= warmup_seconds) {
        warm = true;
        allocations_at_warmup = g_allocations.load();
        checker_allocations = 0;
        g_trap = std::getenv("BTFLOD_SOAK_TRAP") != nullptr;
        rss_warm = rss_max = rss_bytes();
      }
      if (warm) {
        allocations_after_warmup = g_allocations.load() - allocations_at_warmup - checker_allocations;
        if (frame % 256 == 0) rss_max = std::max(rss_max, rss_last = rss_bytes());
      }
      if (std::chrono::duration<double>(now - last_report).count() >= std::max(5.0, opt.seconds / 24)) {
        last_report = now;
        print_row(elapsed);
      }
    }
    print_row(std::chrono::duration<double>(Clock::now() - start).count());
    restarter.stop();
    // Quiesce: nothing new starts, the engine cancels its queued reads, jobs drain.
    streamer.quiesce();
    const auto drain_deadline = Clock::now() + std::chrono::seconds(30);
    while (!streamer.idle() && Clock::now() < drain_deadline) {
      io.cancel_queued();
      workers.notify();
      StreamerOutputs out{tiles, packets, writes, events};
      streamer.update({}, out);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    io.stop();
  }
  const bool drained = streamer.idle() && io.outstanding() == 0;
  const StreamerStats st = streamer.stats();
  if (!drained)  // what kept it busy: a job still reading with no read left at the I/O thread never ends
    std::printf(
        "not drained 30 s after quiesce(): %u jobs reading, %u runnable, %u running; %zu reads at the I/O "
        "thread\n",
        st.jobs_reading, st.jobs_runnable, st.jobs_running, io.outstanding());
  const uint64_t corrupted = io.counters.corrupted.load();
  // Every corrupted read was caught: no wrong upload, and corruption produced bad_data
  // failures (a job reads up to L + 1 payloads, so several damaged reads can fail one job).
  const bool caught = wrong_uploads == 0 && (corrupted == 0 || bad_data_events > 0) && bad_data_events <= corrupted;
  const double rss_growth = rss_warm > 0 ? static_cast<double>(rss_max) / static_cast<double>(rss_warm) - 1.0 : 0.0;
  // --http: every restart during which reads were attempted was detected (they failed), every
  // restart recovered (reads succeeded again), and the outages cost no tile and no material.
  const uint64_t restarts = restarter.restarts.load();
  const bool http_ok = !opt.http || (restarter.undetected.load() == 0 && restarter.recovered.load() == restarts &&
                                     restarter.start_failures.load() == 0 && unavailable == 0 &&
                                     material_failures == 0 && (restarts > 0 || opt.seconds < opt.restart_every + 2) &&
                                     (restarter.outage_failures.load() == 0 || io_error_events > 0));
  const bool ok = wrong_uploads == 0 && wrong_page_texels == 0 && budget_breaches == 0 && cache_breaches == 0 &&
                  allocations_after_warmup == 0 && rss_growth <= opt.rss_tolerance && caught && drained && warm &&
                  http_ok;
  std::printf(
      "frames %llu, uploads %llu; reads %llu: %llu failed, %llu corrupted, %llu stalled, %llu refused; "
      "events: %llu bad_data, %llu io_error, %llu given up, %llu materials failed; retries %llu, cancelled %llu\n",
      static_cast<unsigned long long>(frame), static_cast<unsigned long long>(uploads),
      static_cast<unsigned long long>(io.counters.reads.load()),
      static_cast<unsigned long long>(io.counters.failed.load()), static_cast<unsigned long long>(corrupted),
      static_cast<unsigned long long>(io.counters.stalled.load()),
      static_cast<unsigned long long>(io.counters.refused.load()), static_cast<unsigned long long>(bad_data_events),
      static_cast<unsigned long long>(io_error_events), static_cast<unsigned long long>(unavailable),
      static_cast<unsigned long long>(material_failures), static_cast<unsigned long long>(st.retries),
      static_cast<unsigned long long>(st.cancelled));
  std::printf(
      "invariants: %llu wrong uploads, %llu wrong page-table texels, %llu budget breaches, %llu cache checks "
      "failed; memory: Streamer %.2f MiB, RSS %.1f MiB after warm-up, max %.1f (%+.2f %%), %llu allocations "
      "after warm-up; drained: %s\n",
      static_cast<unsigned long long>(wrong_uploads), static_cast<unsigned long long>(wrong_page_texels),
      static_cast<unsigned long long>(budget_breaches), static_cast<unsigned long long>(cache_breaches),
      static_cast<double>(st.memory.total) / 1048576.0, static_cast<double>(rss_warm) / 1048576.0,
      static_cast<double>(rss_max) / 1048576.0, 100.0 * rss_growth,
      static_cast<unsigned long long>(allocations_after_warmup), drained ? "yes" : "no");
  if (opt.http)
    std::printf(
        "http: %llu nginx restarts (SIGKILL and SIGTERM in turn, 50-300 ms down): %llu with reads during "
        "the outage, %llu of them without a failed read; %llu HTTP reads failed in outages, %llu in all; %llu "
        "recovered "
        "(first good read %.1f ms after the restart on average, %.1f ms at most); %llu failed to start\n",
        static_cast<unsigned long long>(restarts), static_cast<unsigned long long>(restarts - restarter.idle.load()),
        static_cast<unsigned long long>(restarter.undetected.load()),
        static_cast<unsigned long long>(restarter.outage_failures.load()),
        static_cast<unsigned long long>(io.counters.source_failed.load()),
        static_cast<unsigned long long>(restarter.recovered.load()),
        restarter.recovered.load() > 0 ? static_cast<double>(restarter.total_recovery_us.load()) / 1e3 /
                                             static_cast<double>(restarter.recovered.load())
                                       : 0.0,
        static_cast<double>(restarter.max_recovery_us.load()) / 1e3,
        static_cast<unsigned long long>(restarter.start_failures.load()));
  if (!opt.json.empty()) {
    if (std::FILE* f = std::fopen(opt.json.c_str(), "w")) {
      std::fprintf(
          f,
          "{\"seconds\": %.1f, \"frames\": %llu, \"uploads\": %llu, \"reads\": %llu, \"corrupted\": %llu, "
          "\"failed_reads\": %llu, \"bad_data_events\": %llu, \"wrong_uploads\": %llu, "
          "\"wrong_page_texels\": %llu, \"allocations_after_warmup\": %llu, \"rss_warm\": %llu, "
          "\"rss_max\": %llu, \"http\": %s, \"restarts\": %llu, \"restarts_undetected\": %llu, "
          "\"restarts_recovered\": %llu, \"http_reads_failed\": %llu, \"tiles_given_up\": %llu, \"ok\": %s}\n",
          opt.seconds, static_cast<unsigned long long>(frame), static_cast<unsigned long long>(uploads),
          static_cast<unsigned long long>(io.counters.reads.load()), static_cast<unsigned long long>(corrupted),
          static_cast<unsigned long long>(io.counters.failed.load()), static_cast<unsigned long long>(bad_data_events),
          static_cast<unsigned long long>(wrong_uploads), static_cast<unsigned long long>(wrong_page_texels),
          static_cast<unsigned long long>(allocations_after_warmup), static_cast<unsigned long long>(rss_warm),
          static_cast<unsigned long long>(rss_max), opt.http ? "true" : "false",
          static_cast<unsigned long long>(restarts), static_cast<unsigned long long>(restarter.undetected.load()),
          static_cast<unsigned long long>(restarter.recovered.load()),
          static_cast<unsigned long long>(io.counters.source_failed.load()),
          static_cast<unsigned long long>(unavailable), ok ? "true" : "false");
      std::fclose(f);
    }
  }
  std::printf("soak: %s\n", ok ? "passed" : "FAILED");
  return ok ? 0 : 1;
}
