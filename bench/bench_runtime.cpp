// One Streamer::update (runtime/streamer.hpp: votes of paper 000 eq. 9, the scheduler's plan,
// page-table writes derived from the frame's operations, and the hand-off of decode jobs) for
// 100 materials × 25 virtual textures (C = 100, 2048² texels, T = 64, L = 5) with a 3136-slot
// cache (56×56), at feedback buffers of 320×180 and 1280×720 words — next to one read of the
// same feedback buffer (summing its words), measured in the same run; also at 80×45 words, a
// 1280×720 screen's feedback at 1/16 resolution (the operating point of Unreal's and id Tech 5's
// feedback buffers; goal ≤ 30 µs). The feedback is
// bench_scheduler.cpp's moving camera over a grid of materials (eight frames, cycled).
//
// The containers are real `.bsvtf` files (one, shared by the 100 materials) whose tiles all
// carry the same valid payload of a zero residual, so the decode jobs — run between updates,
// outside the timing — succeed cheaply and the cache reaches its steady state of swaps.
// Targets: ≤ 0.1 ms per update at 320×180; ≤ 3× one read at 1280×720. jobs_cpu_us is the
// CPU time of the frame's decode jobs (pump()), with and without the decoded-ancestor cache.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <ctime>
#include <memory>
#include <vector>

#include "bench_feedback.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"

using namespace btflod;
using btflod::bench::cpu_ns;
using btflod::bench::make_feedback;
using btflod::bench::read_once_ns;

namespace {

constexpr uint32_t kMaterials = 100;
constexpr uint32_t kComponents = 100;  // 25 virtual textures per material
constexpr uint32_t kSize = 2048;
constexpr int kFrames = bench::kFeedbackFrames;

// A container of kComponents components whose every tile is the zero tile: the root payload
// codes zeros, every other payload a zero residual against its parent.
std::vector<uint8_t> make_container() {
  const TileLayout layout{64, 4, 4};
  TileEncoder enc(layout, 6);
  std::vector<float> zeros(layout.sample_count(), 0.0f);
  const float tolerance[4] = {1e-3f, 1e-3f, 1e-3f, 1e-3f};
  std::vector<uint8_t> buf(enc.bound());
  size_t n = 0;
  enc.encode(zeros, {}, 0, 0, tolerance, buf, n);
  const std::vector<uint8_t> root(buf.begin(), buf.begin() + static_cast<ptrdiff_t>(n));
  enc.encode(zeros, zeros, 0, 0, tolerance, buf, n);
  const std::vector<uint8_t> child(buf.begin(), buf.begin() + static_cast<ptrdiff_t>(n));
  BsvtfMetadata md;
  md.material_name = "bench";
  md.width = md.height = kSize;
  md.tile_size = 64;
  md.border = 4;
  md.level_count = 6;
  md.component_count = kComponents;
  md.u_rows = 2 * 2 * 3;
  md.light_directions = {0, 0, 1, 0.6f, 0, 0.8f};
  md.view_directions = {0, 0, 1, 0, 0.6f, 0.8f};
  md.component_ranges.assign(kComponents, 1.0f);
  md.component_scales.assign(kComponents, 1.0f);
  const VtLevelTable lv(VtGeometry::make(kSize, kSize, 64, 4));
  std::vector<BsvtfEncodedTile> tiles;
  for (uint32_t k = 0; k < kComponents / 4; ++k)
    for (uint32_t i = 0; i < lv.tile_count(); ++i) {
      const TileId id = lv.tile(k, i);
      // Later components matter less (SVD ordering); w varies per tile.
      const float w = bench::bench_tile_weight(k, i, k);
      tiles.push_back(BsvtfEncodedTile{id, id.level == 0 ? root : child, w, 4.0f * w});
    }
  std::vector<float> u(size_t{md.u_rows} * kComponents, 0.1f);
  return write_bsvtf(md, u, tiles).value();
}

struct Setup {
  std::vector<uint8_t> file;
  BsvtfDirectory dir;
  std::unique_ptr<MemorySource> source;
  Streamer streamer;
  std::vector<StreamerTileUpload> tiles;
  std::vector<StreamerPacketUpload> packets;
  std::vector<PageTableWrite> writes;
  std::vector<ResidencyEvent> events;
  std::vector<std::vector<uint32_t>> frames;
  std::vector<StreamerMaterial> materials;
  StreamerConfig config;
  StreamerOutputs outputs() { return StreamerOutputs{tiles, packets, writes, events}; }
};

std::unique_ptr<Setup> make_setup(uint32_t width, uint32_t height, uint32_t decoded_cache_tiles) {
  auto s = std::make_unique<Setup>();
  s->file = make_container();
  s->dir = read_bsvtf(s->file).value();
  s->source = std::make_unique<MemorySource>(std::span<const uint8_t>(s->file));
  std::vector<StreamerMaterial> materials(kMaterials, StreamerMaterial{&s->dir, s->source.get(), nullptr});
  StreamerConfig cfg;
  cfg.cache = CacheConfig{56, 56, 1u << 16, 64, 4, 1};
  cfg.vote_window_frames = 1;
  cfg.root_jobs = 64;
  cfg.packet_jobs = 4;
  cfg.decoded_cache_tiles = decoded_cache_tiles;
  s->streamer = std::move(Streamer::create(materials, cfg).value());
  s->materials = materials;
  s->config = cfg;
  s->tiles.resize(s->streamer.tile_uploads_bound());
  s->packets.resize(s->streamer.packet_uploads_bound());
  s->writes.resize(1u << 20);
  s->events.resize(1024);
  s->frames = make_feedback(kMaterials, width, height, 5);
  return s;
}

void BM_RuntimeUpdate(benchmark::State& state) {
  const uint32_t width = static_cast<uint32_t>(state.range(0)), height = width * 9 / 16;
  auto s = make_setup(width, height, static_cast<uint32_t>(state.range(1)));
  uint64_t frame = 0;
  // Warm up: roots and packets loaded, cache full, the schedule in its steady state.
  for (int i = 0; i < 300; ++i, ++frame) {
    StreamerOutputs o = s->outputs();
    s->streamer.update(s->frames[frame % kFrames], o);
    s->streamer.pump();
  }
  const SchedulerCounters before = s->streamer.scheduler().total();
  uint64_t iterations = 0, writes = 0, uploads = 0;
  double update_ns = 0, pump_ns = 0;
  const uint64_t bytes_before = s->streamer.bytes_read();
  for (auto _ : state) {
    StreamerOutputs o = s->outputs();
    const double t0 = cpu_ns();
    s->streamer.update(s->frames[frame % kFrames], o);
    update_ns += cpu_ns() - t0;
    writes += o.page_table_write_count;
    uploads += o.tile_upload_count;
    state.PauseTiming();
    const double p0 = cpu_ns();
    s->streamer.pump();  // decode jobs: the engine's workers, outside the update's timing
    pump_ns += cpu_ns() - p0;
    state.ResumeTiming();
    ++frame;
    ++iterations;
  }
  const double per_update = update_ns / double(iterations);
  const double read_ns = read_once_ns(s->frames[0]);
  const SchedulerCounters& after = s->streamer.scheduler().total();
  state.counters["read_us"] = read_ns / 1000.0;
  state.counters["update_cpu_us"] = per_update / 1000.0;
  state.counters["x_read"] = per_update / read_ns;
  state.counters["ops_per_frame"] =
      static_cast<double>(after.adds + after.swaps - before.adds - before.swaps) / static_cast<double>(iterations);
  state.counters["uploads_per_frame"] = static_cast<double>(uploads) / static_cast<double>(iterations);
  state.counters["pt_writes_per_frame"] = static_cast<double>(writes) / static_cast<double>(iterations);
  state.counters["jobs_cpu_us"] = pump_ns / double(iterations) / 1000.0;
  state.counters["read_kib_per_frame"] =
      static_cast<double>(s->streamer.bytes_read() - bytes_before) / double(iterations) / 1024.0;
  state.counters["used_slots"] = s->streamer.cache().used_count();
  state.counters["vts"] = s->streamer.cache().set().texture_count();
  const StreamerMemory mem = s->streamer.stats().memory;
  state.counters["memory_mib"] = static_cast<double>(mem.total) / (1 << 20);
  state.counters["decoder_mib"] = static_cast<double>(mem.decoders) / (1 << 20);
  state.counters["job_buffer_mib"] = static_cast<double>(mem.job_buffers) / (1 << 20);
}

// A level change on the running world: one material removed and another added in its place
// (remove_material + add_material, then the next update(), which queues the new material's
// page-table texels, and the jobs of its roots and U′ packets), against re-creating the whole
// Streamer for the same world (what changing the material set cost without live materials).
void BM_RuntimeAddRemove(benchmark::State& state) {
  auto s = make_setup(320, 180, 16);
  uint64_t frame = 0;
  for (int i = 0; i < 300; ++i, ++frame) {
    StreamerOutputs o = s->outputs();
    s->streamer.update(s->frames[frame % kFrames], o);
    s->streamer.pump();
  }
  double remove_ns = 0, add_ns = 0, next_update_ns = 0, jobs_ns = 0;
  uint64_t iterations = 0, writes = 0, failures = 0;
  for (auto _ : state) {
    const uint32_t m = static_cast<uint32_t>(frame % kMaterials);
    const double t0 = cpu_ns();
    failures += s->streamer.remove_material(m) != Status::success;
    const double t1 = cpu_ns();
    uint32_t id = 0;
    failures += s->streamer.add_material(s->materials[m], id) != Status::success;
    const double t2 = cpu_ns();
    StreamerOutputs o = s->outputs();
    s->streamer.update(s->frames[frame % kFrames], o);
    const double t3 = cpu_ns();
    remove_ns += t1 - t0;
    add_ns += t2 - t1;
    next_update_ns += t3 - t2;
    writes += o.page_table_write_count;
    state.PauseTiming();
    const double p0 = cpu_ns();
    s->streamer.pump();
    jobs_ns += cpu_ns() - p0;
    state.ResumeTiming();
    ++frame;
    ++iterations;
  }
  const double t0 = cpu_ns();
  auto recreated = Streamer::create(s->materials, s->config);
  const double recreate_ns = cpu_ns() - t0;
  const double n = static_cast<double>(iterations);
  state.counters["remove_us"] = remove_ns / n / 1000.0;
  state.counters["add_us"] = add_ns / n / 1000.0;
  state.counters["next_update_us"] = next_update_ns / n / 1000.0;
  state.counters["pt_writes_next_update"] = static_cast<double>(writes) / n;
  state.counters["jobs_cpu_us"] = jobs_ns / n / 1000.0;
  state.counters["recreate_ms"] = recreate_ns / 1e6;
  state.counters["x_recreate"] = (remove_ns + add_ns) / n / recreate_ns;
  state.counters["failures"] = static_cast<double>(failures);
  if (!recreated.ok()) state.SkipWithError(recreated.message().c_str());
}

}  // namespace

BENCHMARK(BM_RuntimeAddRemove)->Unit(benchmark::kMicrosecond)->Iterations(50);

// Second argument: StreamerConfig::decoded_cache_tiles (0: every job decodes its chain from the
// root; jobs_cpu_us and read_kib_per_frame show what the decoded-ancestor cache saves).
BENCHMARK(BM_RuntimeUpdate)
    ->ArgNames({"width", "decoded_cache"})
    ->Args({80, 16})
    ->Args({320, 16})
    ->Args({1280, 16})
    ->Args({320, 0})
    ->Unit(benchmark::kMicrosecond)
    ->Iterations(200);

BENCHMARK_MAIN();
