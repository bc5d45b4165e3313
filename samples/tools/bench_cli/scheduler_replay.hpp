// btflod-bench — replaying a feedback trace through the vote counter, scheduler and tile cache
// (runtime/lod/feedback.hpp, runtime/vt/scheduler.hpp, runtime/vt/tile_cache.hpp) with an immediate tile source, timing
// each frame's CPU work next to one read of the same feedback buffer. Also used by
// bench/bench_scheduler.cpp (--trace).
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/feedback_trace.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "btflod/runtime/vt/scheduler.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"
#include "report.hpp"

namespace btflod::bench {

/// The materials a trace's words refer to (material m of a feedback word = entry m).
struct Materials {
  VtSet set;
  std::vector<std::string> names;
  /// Per material, per tile entry: (texture, flat index, payload bytes); empty for described ones.
  struct TileBytes {
    uint32_t texture, flat, bytes;
  };
  std::vector<TileBytes> tile_bytes;
};

/// Adds a material read from a .bsvtf container: its geometry, virtual texture count, the
/// weights w of its tile index (paper 000 eq. 8) and each tile's payload size.
inline VoidResult add_bsvtf_material(Materials& out, const std::string& path) {
  auto bytes = read_file_bytes(path);
  if (!bytes) return bytes.error();
  auto dir = read_bsvtf(*bytes);
  if (!dir) return make_error(dir.status(), "%s: %s", path.c_str(), dir.message().c_str());
  const BsvtfMetadata& md = dir->metadata;
  const VtGeometry g = VtGeometry::make(md.width, md.height, md.tile_size, md.border);
  if (!g.valid() || g.finest_level + 1 != md.level_count)
    return make_error(Status::unsupported, "%s: %ux%u texels at T = %u need %u levels, the container has %u",
                      path.c_str(), md.width, md.height, md.tile_size, g.finest_level + 1, md.level_count);
  const uint32_t m = out.set.add_material(g, md.texture_count());
  const VtMaterial& mat = out.set.material(m);
  for (const BsvtfTileEntry& e : dir->tiles) {
    if (e.id.texture >= mat.texture_count || !g.contains(e.id)) continue;
    const uint32_t tex = mat.first_texture + e.id.texture;
    const uint32_t flat = mat.levels.index(e.id);
    out.set.weights(tex)[flat] = Half(e.weight);
    out.tile_bytes.push_back({tex, flat, e.size});
  }
  out.names.push_back(md.material_name.empty() ? path : md.material_name);
  return {};
}

/// Adds `count` described materials of side×side texels and `components` eigen-texture
/// components each. Weights fall with the component (SVD ordering: later components matter
/// less) and vary per tile by a fixed hash, so priorities are not all tied.
inline void add_described_materials(Materials& out, uint32_t count, uint32_t side, uint32_t components) {
  const VtGeometry g = VtGeometry::make(side, side);
  const uint32_t textures = (components + 3) / 4;
  for (uint32_t i = 0; i < count; ++i) {
    const uint32_t m = out.set.add_material(g, textures);
    const VtMaterial& mat = out.set.material(m);
    for (uint32_t k = 0; k < textures; ++k) {
      const uint32_t tex = mat.first_texture + k;
      for (uint32_t f = 0; f < mat.levels.tile_count(); ++f) {
        uint32_t h = tex * 7919u + f;
        h ^= h >> 16, h *= 0x7feb352du, h ^= h >> 15;
        const float w = (0.5f + static_cast<float>(h & 0xffu) / 256.0f) / static_cast<float>((k + 1) * (k + 1));
        out.set.weights(tex)[f] = Half(w);
      }
    }
    out.names.push_back("described " + std::to_string(side) + "x" + std::to_string(side) +
                        " C=" + std::to_string(components));
  }
}

// The scheduler's calls take the cache as an argument in newer versions; both forms work here.
template <class S>
std::span<const TileRequest> plan_frame(S& s, TileCache& cache, const VoteCounter& votes, uint64_t frame) noexcept {
  if constexpr (requires { s.plan(cache, votes, frame); })
    return s.plan(cache, votes, frame);
  else
    return s.plan(votes, frame);
}
template <class S>
void apply_frame_uploads(S& s, TileCache& cache) noexcept {
  if constexpr (requires { s.apply_uploads(cache); })
    s.apply_uploads(cache);
  else
    s.apply_uploads();
}
template <class S>
bool set_real_tile_bytes(S& s, const Materials& m) {
  if constexpr (requires { s.set_tile_bytes(0u, 0u, 0u); }) {
    for (const auto& t : m.tile_bytes) s.set_tile_bytes(t.texture, t.flat, t.bytes);
    return true;
  } else {
    return m.tile_bytes.empty();
  }
}

struct ReplayConfig {
  TileCacheConfig cache{16, 16};
  SchedulerConfig scheduler;
  uint32_t window = 0;  ///< vote accumulation frames; 0: decimation² of the trace's first frame
};

/// What one replay of a trace produced.
struct ReplayRun {
  std::vector<double> frame_ns;  ///< CPU time per frame: votes + plan + decode bookkeeping + uploads
  std::vector<double> read_ns;   ///< CPU time of one read (sum) of the same frame's words
  SchedulerCounters total;
  uint64_t digest = 0;  ///< FNV-1a over every request (frame, tile key, slot, bytes) and frame counters
  uint32_t max_lod_bias = 0;
  uint32_t used_slots = 0;
  uint64_t rejected_words = 0;
  bool real_tile_bytes = false;  ///< byte budgets counted container payload sizes
};

inline uint64_t fnv(uint64_t h, uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i) {
    h ^= (v >> (8 * i)) & 0xffu;
    h *= 0x100000001b3ull;
  }
  return h;
}

/// The in-run baseline of both replays: appends, per frame of the trace, the thread CPU time of
/// one read (sum) of its words to `read_ns`.
inline void time_trace_reads(const FeedbackTrace& trace, std::vector<double>& read_ns) {
  for (size_t i = 0; i < trace.frame_count(); ++i) {
    const auto words = trace.frame_words(i);
    const double t0 = thread_cpu_ns();
    uint64_t sum = 0;
    for (const uint32_t w : words) sum += w;
    asm volatile("" : : "r"(sum) : "memory");  // keep the read
    read_ns.push_back(thread_cpu_ns() - t0);
  }
}

/// Replays every frame of the trace once with fresh cache and scheduler state. `read_first`
/// alternates the order of the read baseline and the scheduler pass between repetitions.
/// Returns invalid_argument/insufficient_space from cache or scheduler creation.
inline Result<ReplayRun> replay_trace(const Materials& materials, const FeedbackTrace& trace,
                                      const ReplayConfig& config, bool read_first) {
  auto cache = TileCache::create(materials.set, config.cache);
  if (!cache) return cache.error();
  auto sched = Scheduler::create(*cache, config.scheduler);
  if (!sched) return sched.error();
  ReplayRun run;
  run.real_tile_bytes = set_real_tile_bytes(*sched, materials);
  uint32_t window = config.window;
  if (window == 0) window = trace.frame_count() ? trace.frames[0].decimation * trace.frames[0].decimation : 1;
  VoteCounter votes(vote_layouts(materials.set), VoteWindowConfig{window, 0});
  std::vector<uint32_t> waiting;
  waiting.reserve(config.scheduler.budgets.requests_in_flight);
  run.frame_ns.reserve(trace.frame_count());
  run.read_ns.reserve(trace.frame_count());
  uint64_t digest = 0xcbf29ce484222325ull;
  if (read_first) time_trace_reads(trace, run.read_ns);
  for (size_t i = 0; i < trace.frame_count(); ++i) {
    const uint64_t frame = trace.frames[i].frame_index;
    const double t0 = thread_cpu_ns();
    votes.accumulate(trace.frame_words(i), 1, sched->lod_bias());
    const std::span<const TileRequest> requests = plan_frame(*sched, *cache, votes, frame);
    for (const TileRequest& r : requests) waiting.push_back(r.id);
    size_t keep = 0;
    for (const uint32_t id : waiting) {
      if (sched->begin_decode(id))
        sched->finish_decode(id);
      else
        waiting[keep++] = id;
    }
    waiting.resize(keep);
    apply_frame_uploads(*sched, *cache);
    run.frame_ns.push_back(thread_cpu_ns() - t0);
    for (const TileRequest& r : requests) {
      digest = fnv(digest, frame);
      digest = fnv(digest, r.tile.key());
      digest = fnv(digest, r.slot);
      digest = fnv(digest, r.bytes);
    }
    const SchedulerCounters& c = sched->frame();
    for (const uint64_t v : {c.adds, c.swaps, c.uploads, c.bytes_requested, c.budget_hits(), c.visible_missing,
                             static_cast<uint64_t>(sched->lod_bias())})
      digest = fnv(digest, v);
    run.max_lod_bias = std::max(run.max_lod_bias, sched->lod_bias());
  }
  if (!read_first) time_trace_reads(trace, run.read_ns);
  run.total = sched->total();
  run.digest = digest;
  run.used_slots = cache->used_count();
  run.rejected_words = votes.rejected();
  return run;
}

/// Replays the trace through the runtime object (runtime/streamer.hpp): per frame one
/// Streamer::update() with the frame's words, then pump() runs every decode job on this thread
/// (a memory source: reads are memcpy). frame_ns is update + pump (decoding included);
/// update_ns (in read_ns's place when `update_only`) is update() alone. Containers in
/// `containers` (file bytes) are the materials, in trace order. Errors of Streamer::create.
struct RuntimeRun {
  std::vector<double> frame_ns, update_ns, read_ns;
  SchedulerCounters total;
  uint64_t digest = 0, tile_uploads = 0, page_table_writes = 0, bytes_read = 0;
};
inline Result<RuntimeRun> replay_trace_runtime(const std::vector<std::vector<uint8_t>>& containers,
                                               const FeedbackTrace& trace, const ReplayConfig& config,
                                               bool read_first) {
  std::vector<BsvtfDirectory> dirs;
  std::vector<std::unique_ptr<MemorySource>> sources;
  for (const auto& bytes : containers) {
    auto d = read_bsvtf(bytes);
    if (!d) return d.error();
    dirs.push_back(std::move(*d));
    sources.push_back(std::make_unique<MemorySource>(std::span<const uint8_t>(bytes)));
  }
  if (dirs.empty()) return make_error(Status::invalid_argument, "runtime replay: no containers");
  std::vector<StreamerMaterial> mats(dirs.size());
  for (size_t i = 0; i < dirs.size(); ++i) {
    mats[i].directory = &dirs[i];
    mats[i].source = sources[i].get();
    mats[i].assumed_row_order = AngularRowOrder::light_major;
  }
  StreamerConfig sc;
  sc.cache.slots_x = config.cache.slots_x;
  sc.cache.slots_y = config.cache.slots_y;
  sc.cache.tile_size = dirs[0].metadata.tile_size;
  sc.cache.border = dirs[0].metadata.border;
  sc.scheduler = config.scheduler;
  const uint32_t d = trace.frame_count() ? trace.frames[0].decimation : 1;
  sc.vote_window_frames = config.window ? config.window : d * d;
  auto streamer = Streamer::create(mats, sc);
  if (!streamer) return streamer.error();
  std::vector<StreamerTileUpload> tiles(streamer->tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(streamer->packet_uploads_bound());
  std::vector<PageTableWrite> writes(1u << 16);
  std::vector<ResidencyEvent> events(256);
  RuntimeRun run;
  uint64_t digest = 0xcbf29ce484222325ull;
  if (read_first) time_trace_reads(trace, run.read_ns);
  streamer->pump();  // the pinned roots and U' packets queued by create()
  for (size_t i = 0; i < trace.frame_count(); ++i) {
    StreamerOutputs out{tiles, packets, writes, events};
    const double t0 = thread_cpu_ns();
    if (const Status st = streamer->update(trace.frame_words(i), out); st != Status::success)
      return make_error(st, "runtime replay: update() of frame %zu failed", i);
    const double t1 = thread_cpu_ns();
    streamer->pump();
    run.frame_ns.push_back(thread_cpu_ns() - t0);
    run.update_ns.push_back(t1 - t0);
    for (size_t k = 0; k < out.tile_upload_count; ++k) {
      digest = fnv(digest, out.tile_uploads[k].slot);
      digest = fnv(digest, out.tile_uploads[k].tile.key());
    }
    digest = fnv(digest, out.page_table_write_count);
    run.tile_uploads += out.tile_upload_count;
    run.page_table_writes += out.page_table_write_count;
  }
  if (!read_first) time_trace_reads(trace, run.read_ns);
  run.total = streamer->scheduler().total();
  run.digest = digest;
  run.bytes_read = streamer->bytes_read();
  return run;
}

}  // namespace btflod::bench
