// btflod-minimal-engine — what an engine writes to stream BTF materials with btflod: build (or
// load) `.bsvtf` containers, create one Streamer for the world, and once per frame hand it the
// feedback words and copy its outputs to the GPU (plain arrays here; the feedback comes from a
// camera sliding over two materials, where a real engine renders the generated shaders' feedback
// pass, docs/shaders.md). Decode jobs run on btflod's ThreadExecutor, then on the engine's loop
// (StreamerOutputs::runnable_jobs). A third material arrives damaged (its root fails its
// checksum): it fails cleanly, once, and at frame 60 the engine removes it and adds a fourth in
// its place on the running Streamer (ids and layers of the others stay). The second material has
// tiles of 64 texels, the others 32: two cache pools (a cache texture each) serve them.
#include <cmath>
#include <cstdio>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/runtime/backend/streamer_outputs.hpp"
#include "btflod/runtime/stream/thread_executor.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"

using namespace btflod;

namespace {

// 1. Offline: a factorisation (here synthetic eigen-textures V′ and U′) → a .bsvtf file.
std::vector<uint8_t> make_container(uint32_t components, float frequency, uint32_t tile_size = 32) {
  EigenTextures e;
  e.textures.resize(256, 256, static_cast<int>(components));
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x)
      for (int c = 0; c < static_cast<int>(components); ++c)
        e.textures.at(x, y, c) = 0.5f + 0.5f * std::sin(frequency * (x + 2 * y) * (c + 1)) / (1 + c);
  e.light_count = 3;
  e.view_count = 3;
  e.angular.assign(size_t{3} * 3 * 3 * components, 0.1f);
  BsvtfFromEigenOptions options;
  options.tile_size = tile_size;  // T; 4 texels of border (B) by default
  options.light_directions = {0, 0, 1, 0.6f, 0, 0.8f, 0, 0.6f, 0.8f};
  options.view_directions = options.light_directions;
  auto file = build_bsvtf_from_eigen_textures(e, options);
  return file ? std::move(*file) : std::vector<uint8_t>{};
}

// A camera sliding over two side-by-side materials (the bottom rows see the third): each
// feedback texel names the tile (level, x, y) of the material it sees (runtime/lod/feedback.hpp).
std::vector<uint32_t> render_feedback(const Streamer& s, uint32_t frame) {
  std::vector<uint32_t> words;
  for (uint32_t y = 0; y < 45; ++y)
    for (uint32_t x = 0; x < 80; ++x) {
      const float u = (x + frame * 0.5f) / 80.0f;
      const uint32_t m = y >= 40 ? 2u : u < 1.0f ? 0u : 1u;  // the damaged material at the bottom
      const VtLevelTable& lv = s.cache().set().material(m).levels;
      const uint32_t level = std::min(lv.finest_level(), 1 + y / 15);
      const uint32_t n = lv.tiles_x[level];
      const float fu = u - std::floor(u), fv = y / 45.0f;
      words.push_back(pack_feedback({m, level, std::min(n - 1, uint32_t(fu * n)), std::min(n - 1, uint32_t(fv * n))}));
    }
  return words;
}

}  // namespace

int main() {
  // 2. Containers and their sources (a file, an HTTP range source or memory, as here).
  std::vector<std::vector<uint8_t>> files = {make_container(8, 0.05f), make_container(5, 0.09f, 64),
                                             make_container(4, 0.02f), make_container(6, 0.07f)};
  files[2][read_bsvtf(files[2])->find(TileId{0, 0, 0, 0})->offset + 9] ^= 0xff;  // damaged in transit
  std::vector<BsvtfDirectory> directories;
  std::vector<MemorySource> sources;
  sources.reserve(files.size());
  for (const auto& f : files) {
    auto d = read_bsvtf(f);
    if (!d) return std::fprintf(stderr, "container: %s\n", d.message().c_str()), 1;
    directories.push_back(std::move(*d));
    sources.emplace_back(std::span<const uint8_t>(f));
  }
  std::vector<StreamerMaterial> materials;
  for (size_t i = 0; i < files.size(); ++i) materials.push_back({&directories[i], &sources[i], nullptr});

  // 3. One Streamer for the world, with a cache pool per tile size. Each CacheConfig is also the
  // shaders' VirtualTextureConfig of the materials in that pool (a bsvtf program per pool).
  StreamerConfig config;
  const CacheConfig pools[2] = {CacheConfig{8, 8, 1u << 14, 32, 4, 1},   // 64 slots of 40×40 texels
                                CacheConfig{4, 4, 1u << 14, 64, 4, 1}};  // 16 slots of 72×72 texels
  config.pools = pools;  // a material goes to the pool of its tile size (StreamerMaterial::pool)
  config.scheduler.budgets.uploads_per_frame = 8;
  config.vote_window_frames = 1;
  config.decode_workers = 2;                              // the most threads that run jobs at once
  config.failure.startup_attempts = 3;                    // a root that fails 3 times fails its material
  config.capacity = streamer_capacity_for(materials, 3);  // room for any three, added and removed live
  auto created = Streamer::create(std::span<const StreamerMaterial>(materials).first(3), config);
  if (!created) return std::fprintf(stderr, "streamer: %s\n", created.message().c_str()), 1;
  Streamer streamer = std::move(*created);

  // 4. Caller-owned outputs, sized once (nothing allocates per frame).
  std::vector<StreamerTileUpload> tiles(streamer.tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(streamer.packet_uploads_bound());
  std::vector<PageTableWrite> writes(4096);
  std::vector<ResidencyEvent> events(64);
  std::vector<uint32_t> jobs(64);  // decode jobs update() claims for the engine
  // The engine's side of the GPU, what the shaders read: per cache pool its texture (one RGBA16F
  // tile per slot), per virtual texture its page table (all levels) and U′ packet.
  std::vector<std::vector<std::vector<uint16_t>>> gpu_pools;
  std::vector<std::vector<uint32_t>> page_tables;
  std::vector<std::vector<uint16_t>> u_packets;
  const StreamerGpuLayout layout = streamer.gpu_layout();  // the shapes to allocate
  for (uint32_t p = 0; p < layout.pool_count; ++p) gpu_pools.emplace_back(layout.pools[p].slots);
  for (uint32_t t = 0; t < layout.page_table_layers; ++t)
    page_tables.emplace_back(streamer.cache().set().levels_of(t).tile_count(), 0u);
  u_packets.resize(layout.u_packets);

  // 5. The frame loop: feedback in, outputs copied to the GPU.
  unsigned long long uploads = 0, page_writes = 0;
  auto frame_update = [&](uint32_t frame) -> Status {
    const std::vector<uint32_t> feedback = render_feedback(streamer, frame);  // GPU readback
    StreamerOutputs out{tiles, packets, writes, events, jobs};
    if (const Status st = streamer.update(feedback, out); st != Status::success) return st;
    // Tiles first, then U′, then the page-table texels (runtime/backend/streamer_outputs.hpp; with a
    // btflod::Backend this is apply_streamer_outputs(backend, out, material_handles)).
    const Status applied = forward_streamer_outputs(
        out,
        [&](std::span<const TileUpload> batch) noexcept {  // glTexSubImage3D / vkCmdCopyBufferToImage
          for (const TileUpload& t : batch) gpu_pools[t.pool][t.slot].assign(t.texels.begin(), t.texels.end());
          return Status::success;
        },
        [&](std::span<const PageTableWrite> texels) noexcept {  // one R32UI texel each
          for (const PageTableWrite& w : texels)
            page_tables[w.tile.texture][streamer.cache().set().levels_of(w.tile.texture).index(w.tile)] = w.entry;
          return Status::success;
        },
        [&](const StreamerPacketUpload& p) noexcept {  // U′: rows × 4 halves, light-major
          u_packets[p.texture].assign(p.halves.begin(), p.halves.end());
          return Status::success;
        });
    if (applied != Status::success) return applied;
    for (size_t i = 0; i < out.event_count; ++i) {
      const ResidencyEvent& e = events[i];
      const char* what = e.kind == ResidencyEventKind::material_ready ? "ready (roots and U' loaded)"
                         : e.kind == ResidencyEventKind::material_failed
                             ? "failed: tiles not requested"  // retry_material()
                         : e.kind == ResidencyEventKind::material_removed ? "removed: its layers and slots are free"
                                                                          : nullptr;
      if (what) std::printf("frame %3u: material %u %s (%s)\n", frame, e.material, what, status_name(e.status));
    }
    for (size_t i = 0; i < out.runnable_job_count; ++i) streamer.run_job(jobs[i]);  // the engine's workers
    uploads += out.tile_upload_count;
    page_writes += out.page_table_write_count;
    // (the engine renders here: its bsvtf_feedback colour pass also writes next frame's feedback)
    return Status::success;
  };
  {
    ThreadExecutor workers(streamer.jobs(), 2);
    for (uint32_t frame = 0; frame < 120; ++frame) {
      if (frame_update(frame) != Status::success) return 1;
      if (frame != 60) continue;  // a level change: the damaged material goes, a new one comes
      uint32_t id = 0;
      const char* why = "";  // add_material()'s reason when it refuses
      if (streamer.remove_material(2) != Status::success ||
          streamer.add_material(materials[3], id, &why) != Status::success)
        return std::fprintf(stderr, "add: %s\n", why), 1;
      for (uint32_t t = streamer.first_texture(id); t < streamer.first_texture(id) + streamer.texture_count(id); ++t)
        page_tables[t].assign(streamer.cache().set().levels_of(t).tile_count(), 0u);  // the layer's new shape
      std::printf("frame %3u: material %u added (id %u, layers from %u)\n", frame, 3u, id, streamer.first_texture(id));
    }
  }  // the workers stop with the executor
  // The camera stops: frames go on, decode jobs now run on this thread (Streamer::pump), until
  // every requested tile of the last view has arrived (how long the workers took above varies).
  for (uint32_t frame = 120; frame < 400; ++frame) {
    while (!streamer.idle()) streamer.pump();
    const uint64_t before = uploads + page_writes;
    if (frame_update(119) != Status::success) return 1;
    if (uploads + page_writes == before && streamer.idle()) break;
  }

  // 6. Check: a resident tile's slot holds texels, its page-table texel names that slot in its pool.
  uint32_t bad = 0, resident = 0;
  const TileCache& cache = streamer.cache();
  for (uint32_t t = 0; t < cache.set().texture_count(); ++t) {
    const VtLevelTable& lv = cache.set().levels_of(t);
    for (uint32_t i = 0; i < lv.tile_count(); ++i) {
      const uint32_t slot = cache.slot_of(lv.tile(t, i));
      if (slot == kNoSlot) continue;
      ++resident;
      const uint32_t local = cache.pool_local_slot(slot);
      bad += gpu_pools[cache.pool_of_slot(slot)][local].empty() ||
             page_tables[t][i] != pack_page_entry(local, lv.tile(t, i).level);
    }
  }
  const bool ready = streamer.material_ready(0) && streamer.material_ready(1) && streamer.material_ready(2);
  const StreamerStats st = streamer.stats();  // cheap enough for every frame
  std::printf("%llu tile uploads, %llu page-table writes, %u resident tiles, %u slots of %u used\n", uploads,
              page_writes, resident, cache.used_count(), cache.slot_count());
  for (uint32_t p = 0; p < st.pool_count; ++p)
    std::printf("pool %u (T = %u): %u of %u slots used by %u materials, %.2f MiB of tiles\n", p,
                streamer.pool_config(p).tile_size, st.pools[p].slots_used, st.pools[p].slots,
                st.pools[p].materials_live, st.pools[p].resident_bytes / 1048576.0);
  std::printf("memory %.2f MiB (jobs %.2f, decoders %.2f); %u failed tile reads\n", st.memory.total / 1048576.0,
              st.memory.job_buffers / 1048576.0, st.memory.decoders / 1048576.0, unsigned(st.tile_failures));
  std::printf("converged: %s\n", ready && bad == 0 && resident > 2 * cache.set().texture_count() ? "yes" : "no");
  return ready && bad == 0 ? 0 : 1;
}
