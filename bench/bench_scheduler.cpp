// One scheduler frame (votes of paper 000 eq. 9 + add/swap decisions + cache updates) for 1, 10
// and 100 materials (C = 100 → 25 virtual textures each, 2048² texels, L = 5) with a 3136-slot
// cache (56×56) and feedback buffers of 160×90, 320×180 and 1280×720 words — next to the time to
// read the same buffer once (summing its words), measured in the same run.
//
// The feedback imitates a camera moving over a grid of materials: each material occupies a
// screen cell, texels per pixel grow smoothly with the row (distance: levels L … L−4), and the
// texture coordinates scroll a little every frame so tiles keep entering and leaving (eight
// pre-generated frames, cycled).
// Real data: `bench_scheduler --trace FILE (--bsvtf FILE ... | --materials N [--texture S]
// [--components C]) [--slots N] [--uploads U]` replays a recorded feedback trace
// (runtime/lod/feedback_trace.hpp; same inputs as `btflod-bench scheduler`) as BM_TraceReplay, one frame
// per iteration, cycling through the trace; then 5 randomly interleaved repetitions with medians
// are the defaults (--benchmark_* flags override them).
// Targets: ≤ 0.25 ms per frame at 320×180 with 100 materials; ≤ 5× the read at 1280×720.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "../samples/tools/bench_cli/scheduler_replay.hpp"
#include "bench_feedback.hpp"
#include "bench_main.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/feedback_trace.hpp"
#include "btflod/runtime/vt/scheduler.hpp"

using namespace btflod;
using btflod::bench::cpu_ns;
using btflod::bench::make_feedback;
using btflod::bench::read_once_ns;

namespace {

constexpr uint32_t kTexturesPerMaterial = 25;  // C = 100 components, 4 per RGBA texel
constexpr int kFrames = bench::kFeedbackFrames;

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
      const float w = bench::bench_tile_weight(t, i, k);
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

// What recording a feedback trace costs an engine per frame: FeedbackTraceWriter::encode_frame
// (deflate level 1 + CRCs) on the same synthetic buffers, next to one read of the buffer and one
// scheduler frame (votes + plan + cache updates) over the same buffer, measured in the same run.
void BM_TraceRecordFrame(benchmark::State& state) {
  const uint32_t materials = static_cast<uint32_t>(state.range(0));
  const uint32_t width = static_cast<uint32_t>(state.range(1)), height = width * 9 / 16;
  auto s = make_setup(materials, width, height);
  FeedbackTraceWriterConfig wc;
  wc.max_frame_words = width * height;
  auto writer = FeedbackTraceWriter::create(wc);
  if (!writer) {
    state.SkipWithError(writer.message().c_str());
    return;
  }
  uint64_t frame = 0, bytes = 0, iterations = 0;
  const double t0 = cpu_ns();
  for (auto _ : state) {
    FeedbackFrameInfo info;
    info.frame_index = frame;
    info.width = width;
    info.height = height;
    std::span<const uint8_t> out;
    if (writer->encode_frame(info, s->frames[frame % kFrames], out) != Status::success) {
      state.SkipWithError("encode_frame failed");
      return;
    }
    bytes += out.size();
    ++frame;
    ++iterations;
  }
  const double record_ns = (cpu_ns() - t0) / double(iterations);
  // One scheduler frame on the same buffers (after a warm-up to the steady state).
  for (int i = 0; i < 200; ++i) {
    s->votes->count(s->frames[static_cast<size_t>(i) % kFrames]);
    s->scheduler->run_frame(*s->cache, *s->votes, static_cast<uint64_t>(i));
  }
  const int sched_frames = 50;
  const double t1 = cpu_ns();
  for (int i = 0; i < sched_frames; ++i) {
    s->votes->count(s->frames[static_cast<size_t>(i) % kFrames]);
    s->scheduler->run_frame(*s->cache, *s->votes, static_cast<uint64_t>(200 + i));
  }
  const double sched_ns = (cpu_ns() - t1) / sched_frames;
  const double read_ns = read_once_ns(s->frames[0]);
  state.counters["record_us"] = record_ns / 1000.0;
  state.counters["read_us"] = read_ns / 1000.0;
  state.counters["x_read"] = record_ns / read_ns;        // recording / one read of the buffer
  state.counters["x_scheduler"] = record_ns / sched_ns;  // recording / one scheduler frame
  state.counters["bytes_per_frame"] = double(bytes) / double(iterations);
  state.counters["ratio"] = double(width) * height * 4.0 / (double(bytes) / double(iterations));
}

}  // namespace

BENCHMARK(BM_SchedulerFrame)
    ->ArgNames({"materials", "width"})
    ->ArgsProduct({{1, 10, 100}, {160, 320, 1280}})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_TraceRecordFrame)
    ->ArgNames({"materials", "width"})
    ->ArgsProduct({{100}, {160, 320, 1280}})
    ->Unit(benchmark::kMicrosecond);

namespace {
struct TraceInputs {
  btflod::bench::Materials materials;
  FeedbackTrace trace;
  TileCacheConfig cache{16, 16};
  SchedulerConfig config;
};

// One frame of the recorded trace per iteration (votes + plan + decode bookkeeping + uploads),
// cycling through the trace with increasing frame numbers; counters as BM_SchedulerFrame.
void BM_TraceReplay(benchmark::State& state, const TraceInputs* in) {
  auto cache = TileCache::create(in->materials.set, in->cache);
  if (!cache) return state.SkipWithError(cache.message().c_str());
  auto sched = Scheduler::create(*cache, in->config);
  if (!sched) return state.SkipWithError(sched.message().c_str());
  btflod::bench::set_real_tile_bytes(*sched, in->materials);
  const FeedbackTrace& t = in->trace;
  const uint32_t d = t.frames[0].decimation;
  VoteCounter votes(vote_layouts(in->materials.set), VoteWindowConfig{d * d, 0});
  uint64_t frame = 0, ops = 0;
  double t0 = cpu_ns();
  for (auto _ : state) {
    const size_t i = frame % t.frame_count();
    votes.accumulate(t.frame_words(i), 1, sched->lod_bias());
    const SchedulerCounters& c = sched->run_frame(*cache, votes, frame);
    ops += c.adds + c.swaps;
    ++frame;
  }
  const double frame_ns = (cpu_ns() - t0) / static_cast<double>(std::max<uint64_t>(frame, 1));
  double read_ns = 0;
  for (size_t i = 0; i < t.frame_count(); ++i) {
    std::vector<uint32_t> words(t.frame_words(i).begin(), t.frame_words(i).end());
    read_ns += read_once_ns(words);
  }
  read_ns /= static_cast<double>(t.frame_count());
  state.counters["frame_cpu_us"] = frame_ns / 1000.0;
  state.counters["read_us"] = read_ns / 1000.0;
  state.counters["x_read"] = frame_ns / read_ns;
  state.counters["ops_per_frame"] = static_cast<double>(ops) / static_cast<double>(std::max<uint64_t>(frame, 1));
}
}  // namespace

int main(int argc, char** argv) {
  // Our inputs are taken out before Google Benchmark parses the rest.
  static TraceInputs in;
  std::string trace_path;
  uint32_t described = 0, texture = 2048, components = 32, slots = 256;
  std::vector<char*> args{argv[0]};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 < argc && (a == "--trace" || a == "--bsvtf" || a == "--materials" || a == "--texture" ||
                         a == "--components" || a == "--slots" || a == "--uploads")) {
      const char* v = argv[++i];
      const uint32_t n = static_cast<uint32_t>(std::strtoul(v, nullptr, 10));
      if (a == "--trace")
        trace_path = v;
      else if (a == "--bsvtf") {
        if (auto r = btflod::bench::add_bsvtf_material(in.materials, v); !r) {
          std::fprintf(stderr, "bench_scheduler: %s\n", r.message().c_str());
          return 2;
        }
      } else if (a == "--materials")
        described = n;
      else if (a == "--texture")
        texture = std::max(n, 64u);
      else if (a == "--components")
        components = std::max(n, 1u);
      else if (a == "--slots")
        slots = std::max(n, 1u);
      else
        in.config.budgets.uploads_per_frame = std::max(n, 1u);
      continue;
    }
    args.push_back(argv[i]);
  }
  if (!trace_path.empty()) {
    auto t = read_feedback_trace_file(trace_path);
    if (!t) {
      std::fprintf(stderr, "bench_scheduler: %s\n", t.message().c_str());
      return 2;
    }
    if (t->frame_count() == 0)
      return std::fprintf(stderr, "bench_scheduler: %s has no frames\n", trace_path.c_str()), 2;
    in.trace = std::move(*t);
    if (described) btflod::bench::add_described_materials(in.materials, described, texture, components);
    if (in.materials.set.material_count() == 0) {
      std::fprintf(stderr, "bench_scheduler: --trace needs --bsvtf FILE ... or --materials N\n");
      return 2;
    }
    const uint32_t x = static_cast<uint32_t>(std::ceil(std::sqrt(static_cast<double>(slots))));
    in.cache = TileCacheConfig{x, (slots + x - 1) / x};
    benchmark::RegisterBenchmark("BM_TraceReplay", BM_TraceReplay, &in)->Unit(benchmark::kMicrosecond);
    btflod::bench::add_steady_repetitions(args);
  }
  return btflod::bench::run_benchmarks(args);
}
