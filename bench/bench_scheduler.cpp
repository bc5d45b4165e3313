// One scheduler frame (votes of paper 000 eq. 9 + add/swap decisions + cache updates) for 1, 10
// and 100 materials (C = 100 → 25 virtual textures each, 2048² texels, L = 5) with a 3136-slot
// cache (56×56) and feedback buffers of 160×90, 320×180 and 1280×720 words — next to the time to
// read the same buffer once (summing its words), measured in the same run.
//
// The feedback imitates a camera moving over a grid of materials: each material occupies a
// screen cell, texels per pixel grow smoothly with the row (distance: levels L … L−4), and the
// texture coordinates scroll a little every frame so tiles keep entering and leaving (eight
// pre-generated frames, cycled).
// Targets (issue 5): ≤ 0.25 ms per frame at 320×180 with 100 materials; ≤ 5× the read at 1280×720.
#include <benchmark/benchmark.h>

#include <ctime>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "btflod/lod/feedback.hpp"
#include "btflod/vt/scheduler.hpp"

using namespace btflod;

namespace {

constexpr uint32_t kTexturesPerMaterial = 25;  // C = 100 components, 4 per RGBA texel
constexpr int kFrames = 8;

uint32_t hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

std::vector<std::vector<uint32_t>> make_feedback(uint32_t materials, uint32_t width, uint32_t height, uint32_t L) {
  std::vector<std::vector<uint32_t>> frames(kFrames);
  const uint32_t cells = static_cast<uint32_t>(std::ceil(std::sqrt(static_cast<double>(materials))));
  for (int f = 0; f < kFrames; ++f) {
    auto& words = frames[f];
    words.resize(static_cast<size_t>(width) * height);
    for (uint32_t y = 0; y < height; ++y)
      for (uint32_t x = 0; x < width; ++x) {
        const uint32_t cx = x * cells / width, cy = y * cells / height;
        const uint32_t m = cy * cells + cx;
        if (m >= materials) {
          words[static_cast<size_t>(y) * width + x] = kFeedbackNone;
          continue;
        }
        // Cell-local texel coordinates: near rows show ~1 texel per pixel, far rows up to 8
        // (the texture repeats over the surface, as on the paper's tori); coordinates scroll a
        // little every frame and each cell starts at its own offset.
        const double ly = (y - cy * height / cells) / double(height / cells);  // 0 … 1 inside the cell
        const double rho = std::ldexp(1.0, static_cast<int>(cy * 4 / cells)) * (1.0 + 1.5 * ly);
        const double texels = 2048.0;
        const double u = std::fmod(((x - cx * width / cells) * rho + 37.0 * m + 11.0 * f) / texels, 1.0);
        const double v = std::fmod(((y - cy * height / cells) * rho + 53.0 * m) / texels, 1.0);
        const uint32_t level = L - std::min<uint32_t>(L, static_cast<uint32_t>(std::ceil(std::log2(rho) - 1e-9)));
        const uint32_t n = 1u << level;
        words[static_cast<size_t>(y) * width + x] =
            pack_feedback({m, level, std::min(n - 1, uint32_t(u * n)), std::min(n - 1, uint32_t(v * n))});
      }
  }
  return frames;
}

struct Setup {
  VtSet set;
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<Scheduler> scheduler;
  std::unique_ptr<VoteCounter> votes;
  std::vector<std::vector<uint32_t>> frames;
};

std::unique_ptr<Setup> make_setup(uint32_t materials, uint32_t width, uint32_t height) {
  auto s = std::make_unique<Setup>();
  const VtGeometry g = VtGeometry::make(2048, 2048);
  for (uint32_t m = 0; m < materials; ++m) s->set.add_material(g, kTexturesPerMaterial);
  for (uint32_t t = 0; t < s->set.texture_count(); ++t) {
    const VtLevelTable& lv = s->set.levels_of(t);
    const uint32_t k = t % kTexturesPerMaterial;  // later components matter less (SVD ordering)
    for (uint32_t i = 0; i < lv.tile_count(); ++i) {
      const float w = (0.5f + (hash32(t * 7919u + i) & 0xffu) / 256.0f) / static_cast<float>((k + 1) * (k + 1));
      s->set.weights(t)[i] = Half(w);
      s->set.energies(t)[i] = Half(w * 4.0f);
    }
  }
  s->cache = std::make_unique<TileCache>(std::move(TileCache::create(s->set, {56, 56}).value()));
  s->scheduler = std::make_unique<Scheduler>(std::move(Scheduler::create(*s->cache).value()));
  s->votes = std::make_unique<VoteCounter>(vote_layouts(s->set));
  s->frames = make_feedback(materials, width, height, g.finest_level);
  return s;
}

// Thread CPU time: the machine is shared, so wall time would charge other processes to us.
double cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

// The baseline: read the same buffer once (sum of its words), mean CPU time over 200 reads.
double read_once_ns(const std::vector<uint32_t>& words) {
  const int reads = 200;
  const double t0 = cpu_ns();
  for (int r = 0; r < reads; ++r) {
    uint64_t sum = 0;
    for (uint32_t w : words) sum += w;
    benchmark::DoNotOptimize(sum);
  }
  return (cpu_ns() - t0) / reads;
}

void BM_SchedulerFrame(benchmark::State& state) {
  const uint32_t materials = static_cast<uint32_t>(state.range(0));
  const uint32_t width = static_cast<uint32_t>(state.range(1)), height = width * 9 / 16;
  auto s = make_setup(materials, width, height);
  uint64_t frame = 0;
  // Warm up until the cache is full and the schedule is in its steady state.
  for (int i = 0; i < 200; ++i, ++frame) {
    s->votes->count(s->frames[frame % kFrames]);
    s->scheduler->run_frame(*s->cache, *s->votes, frame);
  }
  const SchedulerCounters before = s->scheduler->total();
  uint64_t iterations = 0;
  const double t0 = cpu_ns();
  for (auto _ : state) {
    s->votes->count(s->frames[frame % kFrames]);
    s->scheduler->run_frame(*s->cache, *s->votes, frame);
    ++frame;
    ++iterations;
  }
  const double frame_ns = (cpu_ns() - t0) / double(iterations);
  const double read_ns = read_once_ns(s->frames[0]);
  const SchedulerCounters& after = s->scheduler->total();
  state.counters["read_us"] = read_ns / 1000.0;
  state.counters["frame_cpu_us"] = frame_ns / 1000.0;
  state.counters["x_read"] = frame_ns / read_ns;  // frame CPU time / one read of the buffer
  state.counters["ops_per_frame"] =
      static_cast<double>(after.adds + after.swaps - before.adds - before.swaps) / static_cast<double>(iterations);
  state.counters["used_slots"] = s->cache->used_count();
  state.counters["vts"] = s->set.texture_count();
  state.SetItemsProcessed(static_cast<int64_t>(iterations) * width * height);
}

}  // namespace

BENCHMARK(BM_SchedulerFrame)
    ->ArgNames({"materials", "width"})
    ->ArgsProduct({{1, 10, 100}, {160, 320, 1280}})
    ->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
