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
//   btflod-soak [--seconds N | --minutes N] [--seed S] [--workers N] [--json FILE]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <new>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "btflod/runtime/streamer.hpp"
#include "btflod/stream/thread_executor.hpp"
#include "btflod/vt/bsvtf_build.hpp"

// Heap allocations of the whole process (every thread, every form of operator new), to prove
// that none happen per frame. Not inlined: GCC would otherwise see free() applied to the result
// of a new-expression in every caller (-Wmismatched-new-delete).
static std::atomic<uint64_t> g_allocations{0};
static std::atomic<bool> g_trap{false};  // debugging: abort on the first allocation after warm-up
[[gnu::noinline]] void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (g_trap.load(std::memory_order_relaxed)) std::abort();
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void* operator new[](std::size_t n) { return operator new(n); }
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
[[gnu::noinline]] void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n ? n : 1);
}
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
// The aligned forms (the runtime's default allocator uses them).
[[gnu::noinline]] void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
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

namespace {

using Clock = std::chrono::steady_clock;

struct Options {
  double seconds = 120;
  uint32_t seed = 1;
  uint32_t workers = 2;
  double rss_tolerance = 0.01;
  std::string json;
};

bool parse(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const char* v = i + 1 < argc ? argv[i + 1] : nullptr;
    if (v == nullptr) return std::fprintf(stderr, "btflod-soak: %s needs a value\n", a.c_str()), false;
    char* end = nullptr;
    const double x = std::strtod(v, &end);
    const bool number = end != v && *end == '\0' && std::isfinite(x) && x >= 0;
    if (a == "--json") {
      o.json = v;
    } else if (!number) {
      return std::fprintf(stderr, "btflod-soak: %s takes a number ≥ 0, not '%s'\n", a.c_str(), v), false;
    } else if (a == "--seconds") {
      o.seconds = x;
    } else if (a == "--minutes") {
      o.seconds = 60 * x;
    } else if (a == "--seed") {
      o.seed = static_cast<uint32_t>(x);
    } else if (a == "--workers") {
      o.workers = std::max(1u, static_cast<uint32_t>(x));
    } else if (a == "--rss-tolerance") {
      o.rss_tolerance = x;
    } else {
      return std::fprintf(stderr, "btflod-soak: unknown option %s\n", a.c_str()), false;
    }
    ++i;
  }
  return true;
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
            0.5f + 0.3f * std::sin(0.021f * (x + 1.0f) * (c + 1 + seed)) * std::cos(0.017f * y * (seed + 1)) / (1.0f + c);
  e.light_count = e.view_count = 3;
  e.angular.assign(size_t{3} * 3 * 3 * components, 0.0f);
  for (size_t i = 0; i < e.angular.size(); ++i) e.angular[i] = 0.05f + 0.01f * static_cast<float>((i * 13 + seed) % 40);
  BsvtfFromEigenOptions o;
  o.tile_size = 32;
  o.border = 4;
  o.row_order = AngularRowOrder::light_major;
  o.light_directions = {0, 0, 1, 0.6f, 0, 0.8f, 0, 0.6f, 0.8f};
  o.view_directions = o.light_directions;
  auto file = build_bsvtf_from_eigen_textures(e, o);
  return file ? std::move(*file) : std::vector<uint8_t>{};
}

// The engine's I/O: reads queued by the Streamer (any material), served by one thread in random
// order after random delays, with faults. A fixed ring: nothing allocates after start-up.
class FaultyIo {
 public:
  struct Counters {
    std::atomic<uint64_t> reads{0}, failed{0}, corrupted{0}, stalled{0}, refused{0};
  };
  FaultyIo(const std::vector<std::vector<uint8_t>>& files, uint32_t seed, size_t capacity)
      : files_(files), ring_(capacity), rng_(seed) {}
  ~FaultyIo() { stop(); }
  void start(Streamer& s, ThreadExecutor& executor) {
    streamer_ = &s;
    executor_ = &executor;
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
  // start_read of material m's source (update thread).
  bool enqueue(size_t m, uint64_t offset, std::span<uint8_t> out, uint64_t ticket) {
    std::lock_guard lock(mutex_);
    if (refuse_(rng_) || count_ == ring_.size()) {
      ++counters.refused;
      return false;
    }
    ring_[(head_ + count_) % ring_.size()] = Read{m, offset, out, ticket, Clock::now()};
    ++count_;
    cv_.notify_one();
    return true;
  }
  // Cancels every queued read (quiescing): reported as Status::cancelled.
  void cancel_all() {
    std::lock_guard lock(mutex_);
    for (; count_ > 0; --count_, head_ = (head_ + 1) % ring_.size())
      streamer_->complete_read(ring_[head_].ticket, Status::cancelled);
  }
  size_t pending() const {
    std::lock_guard lock(mutex_);
    return count_ + serving_;
  }
  Counters counters;

 private:
  struct Read {
    size_t material = 0;
    uint64_t offset = 0;
    std::span<uint8_t> out;
    uint64_t ticket = 0;
    Clock::time_point queued;
  };
  void loop() {
    std::unique_lock lock(mutex_);
    for (;;) {
      cv_.wait_for(lock, std::chrono::milliseconds(1), [&] { return stopping_ || count_ > 0; });
      if (stopping_) return;
      if (count_ == 0) continue;
      // Out of order: a random queued read, swapped to the front.
      const size_t pick = (head_ + std::uniform_int_distribution<size_t>(0, count_ - 1)(rng_)) % ring_.size();
      std::swap(ring_[pick], ring_[head_]);
      Read r = ring_[head_];
      head_ = (head_ + 1) % ring_.size();
      --count_;
      ++serving_;
      const double u = unit_(rng_);
      lock.unlock();
      Status status = Status::success;
      if (u < 0.002) {  // a stall: this read takes 40 ms
        ++counters.stalled;
        std::this_thread::sleep_for(std::chrono::milliseconds(40));
      }
      if (u >= 0.002 && u < 0.012) {
        ++counters.failed;
        status = Status::io_error;
      } else {
        std::memcpy(r.out.data(), files_[r.material].data() + r.offset, r.out.size());
        if (u >= 0.012 && u < 0.022 && !r.out.empty()) {  // bytes damaged on the way
          r.out[r.out.size() / 3] ^= 0x10;
          ++counters.corrupted;
        }
      }
      ++counters.reads;
      const uint32_t job = streamer_->complete_read(r.ticket, status);
      if (job != Streamer::kNoJob) executor_->notify();  // the job it made runnable
      lock.lock();
      --serving_;
    }
  }
  const std::vector<std::vector<uint8_t>>& files_;
  std::vector<Read> ring_;
  size_t head_ = 0, count_ = 0, serving_ = 0;
  std::mt19937 rng_;
  std::uniform_real_distribution<double> unit_{0.0, 1.0};
  std::bernoulli_distribution refuse_{0.003};
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::thread thread_;
  Streamer* streamer_ = nullptr;
  ThreadExecutor* executor_ = nullptr;
};

struct MaterialSource final : AsyncTileSource {
  FaultyIo* io = nullptr;
  size_t material = 0;
  bool start_read(uint64_t offset, std::span<uint8_t> out, uint64_t ticket) noexcept override {
    return io->enqueue(material, offset, out, ticket);
  }
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
    if (e == nullptr ||
        dec.decode(std::span<const uint8_t>(file.data() + e->offset, e->size),
                   l > 0 ? std::span<const float>(a) : std::span<const float>(), t.x & 1u, t.y & 1u, b) != Status::success)
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
  FaultyIo io(files, opt.seed, 4096);
  std::vector<MaterialSource> sources(4);
  std::vector<StreamerMaterial> materials;
  for (uint32_t m = 0; m < 4; ++m) {
    sources[m].io = &io;
    sources[m].material = m;
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
  for (uint32_t t = 0; t < set.texture_count(); ++t) page_tables.emplace_back(set.levels_of(t).tile_count(), 0xffffffffu);
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
  std::printf("btflod-soak: %u materials, %u slots, %u workers, %.0f s (seed %u)\n", 4u, cache.slot_count(),
              opt.workers, opt.seconds, opt.seed);
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
    io.start(streamer, workers);
    for (;;) {
      const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
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
        unavailable += e.kind == ResidencyEventKind::tile_unavailable || e.kind == ResidencyEventKind::packet_unavailable;
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
    // Quiesce: nothing new starts, the engine cancels its queued reads, jobs drain.
    streamer.quiesce();
    const auto drain_deadline = Clock::now() + std::chrono::seconds(30);
    while (!streamer.idle() && Clock::now() < drain_deadline) {
      io.cancel_all();
      workers.notify();
      StreamerOutputs out{tiles, packets, writes, events};
      streamer.update({}, out);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    io.stop();
  }
  const bool drained = streamer.idle() && io.pending() == 0;
  const StreamerStats st = streamer.stats();
  const uint64_t corrupted = io.counters.corrupted.load();
  // Every corrupted read was caught: no wrong upload, and corruption produced bad_data
  // failures (a job reads up to L + 1 payloads, so several damaged reads can fail one job).
  const bool caught = wrong_uploads == 0 && (corrupted == 0 || bad_data_events > 0) && bad_data_events <= corrupted;
  const double rss_growth = rss_warm > 0 ? static_cast<double>(rss_max) / static_cast<double>(rss_warm) - 1.0 : 0.0;
  const bool ok = wrong_uploads == 0 && wrong_page_texels == 0 && budget_breaches == 0 && cache_breaches == 0 &&
                  allocations_after_warmup == 0 && rss_growth <= opt.rss_tolerance && caught && drained && warm;
  std::printf(
      "frames %llu, uploads %llu; reads %llu: %llu failed, %llu corrupted, %llu stalled, %llu refused; "
      "events: %llu bad_data, %llu io_error, %llu given up, %llu materials failed; retries %llu, cancelled %llu\n",
      static_cast<unsigned long long>(frame), static_cast<unsigned long long>(uploads),
      static_cast<unsigned long long>(io.counters.reads.load()), static_cast<unsigned long long>(io.counters.failed.load()),
      static_cast<unsigned long long>(corrupted), static_cast<unsigned long long>(io.counters.stalled.load()),
      static_cast<unsigned long long>(io.counters.refused.load()), static_cast<unsigned long long>(bad_data_events),
      static_cast<unsigned long long>(io_error_events), static_cast<unsigned long long>(unavailable),
      static_cast<unsigned long long>(material_failures), static_cast<unsigned long long>(st.retries),
      static_cast<unsigned long long>(st.cancelled));
  std::printf("invariants: %llu wrong uploads, %llu wrong page-table texels, %llu budget breaches, %llu cache checks "
              "failed; memory: Streamer %.2f MiB, RSS %.1f MiB after warm-up, max %.1f (%+.2f %%), %llu allocations "
              "after warm-up; drained: %s\n",
              static_cast<unsigned long long>(wrong_uploads), static_cast<unsigned long long>(wrong_page_texels),
              static_cast<unsigned long long>(budget_breaches), static_cast<unsigned long long>(cache_breaches),
              static_cast<double>(st.memory.total) / 1048576.0, static_cast<double>(rss_warm) / 1048576.0,
              static_cast<double>(rss_max) / 1048576.0, 100.0 * rss_growth,
              static_cast<unsigned long long>(allocations_after_warmup), drained ? "yes" : "no");
  if (!opt.json.empty()) {
    if (std::FILE* f = std::fopen(opt.json.c_str(), "w")) {
      std::fprintf(f,
                   "{\"seconds\": %.1f, \"frames\": %llu, \"uploads\": %llu, \"reads\": %llu, \"corrupted\": %llu, "
                   "\"failed_reads\": %llu, \"bad_data_events\": %llu, \"wrong_uploads\": %llu, "
                   "\"wrong_page_texels\": %llu, \"allocations_after_warmup\": %llu, \"rss_warm\": %llu, "
                   "\"rss_max\": %llu, \"ok\": %s}\n",
                   opt.seconds, static_cast<unsigned long long>(frame), static_cast<unsigned long long>(uploads),
                   static_cast<unsigned long long>(io.counters.reads.load()),
                   static_cast<unsigned long long>(corrupted),
                   static_cast<unsigned long long>(io.counters.failed.load()),
                   static_cast<unsigned long long>(bad_data_events), static_cast<unsigned long long>(wrong_uploads),
                   static_cast<unsigned long long>(wrong_page_texels),
                   static_cast<unsigned long long>(allocations_after_warmup), static_cast<unsigned long long>(rss_warm),
                   static_cast<unsigned long long>(rss_max), ok ? "true" : "false");
      std::fclose(f);
    }
  }
  std::printf("soak: %s\n", ok ? "passed" : "FAILED");
  return ok ? 0 : 1;
}
