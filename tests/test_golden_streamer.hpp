// A GPU backend fed by a live Streamer whose materials come and go (shared by test_golden_gl.cpp
// and test_golden_vk.cpp): the engine loop an integrator writes — update(), the outputs applied
// with apply_streamer_outputs(), jobs pumped — with a material removed (its backend material
// destroyed, Backend::destroy_material) and another added into its id and page-table layers.
// After streaming every tile, the layers the new material took over render it exactly as a
// Streamer created with the final set of materials does (PSNR ≥ 60 dB between the two GPU
// images, where the removed material's image is far from either), and the material that stayed
// renders as before. Containers are built from the golden scene's materials (T = 64, B = 4).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/runtime/backend/streamer_outputs.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "test_golden_scene.hpp"

namespace btflod::golden {

/// One golden material as a container in memory, its directory and a blocking source over it.
struct StreamedGoldenMaterial {
  Material material;
  std::vector<uint8_t> file;
  BsvtfDirectory directory;
  std::unique_ptr<MemorySource> source;
  StreamerMaterial streamer() const { return StreamerMaterial{&directory, source.get(), nullptr}; }
};

inline void make_streamed_material(const ShaderConfig& config, uint32_t seed, StreamedGoldenMaterial& out) {
  out.material = make_material(config, kTexture, kTexture, seed);
  const Material& m = out.material;
  const EigenTextures e = eigen_textures_of(m);
  BsvtfFromEigenOptions o;
  o.tile_size = config.vt.tile_size;
  o.border = config.vt.border;
  for (const glm::vec3& d : direction_set(2, 5, 0.3f))
    o.light_directions.insert(o.light_directions.end(), {d.x, d.y, d.z});
  for (const glm::vec3& d : direction_set(2, 4, 0.0f))
    o.view_directions.insert(o.view_directions.end(), {d.x, d.y, d.z});
  auto file = build_bsvtf_from_eigen_textures(e, o);
  ASSERT_TRUE(file.ok()) << file.message();
  out.file = std::move(*file);
  auto dir = read_bsvtf(out.file);
  ASSERT_TRUE(dir.ok()) << dir.message();
  out.directory = std::move(*dir);
  out.source = std::make_unique<MemorySource>(std::span<const uint8_t>(out.file));
}

/// The engine side of one Streamer on one backend: caller-owned outputs, the backend material
/// of each Streamer material id, and every residency event seen.
struct GoldenStreamingEngine {
  Backend* backend = nullptr;
  Streamer* streamer = nullptr;
  std::vector<StreamerTileUpload> tiles;
  std::vector<StreamerPacketUpload> packets;
  std::vector<PageTableWrite> writes = std::vector<PageTableWrite>(4096);
  std::vector<ResidencyEvent> frame_events = std::vector<ResidencyEvent>(64);
  std::vector<ResidencyEvent> events;
  std::vector<MaterialHandle> handles;  // by Streamer material id

  void attach(Backend& be, Streamer& s) {
    backend = &be;
    streamer = &s;
    tiles.resize(s.tile_uploads_bound());
    packets.resize(s.packet_uploads_bound());
    handles.assign(s.material_count(), MaterialHandle{});
  }
  /// Creates the backend's BSVTF material for Streamer material `id`, reading its Streamer pool's
  /// cache. False (test failed) on error.
  bool create_material(uint32_t id, const Material& m) {
    FmfMaterialData d = m.data(false);
    d.cache_pool = streamer->material_pool(id);
    auto h = backend->create_material(d);
    EXPECT_TRUE(h.ok()) << h.message();
    if (h.ok()) handles[id] = *h;
    return h.ok();
  }
  /// Every finest tile of every live material, voted each frame (the whole texture in view).
  std::vector<uint32_t> feedback() const {
    std::vector<uint32_t> words;
    for (uint32_t m = 0; m < streamer->material_count(); ++m) {
      if (!streamer->material_live(m)) continue;
      const VtLevelTable& lv = streamer->cache().set().material(m).levels;
      const uint32_t L = lv.finest_level();
      for (uint32_t y = 0; y < lv.tiles_y[L]; ++y)
        for (uint32_t x = 0; x < lv.tiles_x[L]; ++x) words.push_back(pack_feedback(FeedbackTile{m, L, x, y}));
    }
    return words;
  }
  /// update() → apply_streamer_outputs() → pump(), until nothing was uploaded or written for
  /// three frames and no job is left. Returns the frames it took (fails the test past 400).
  uint32_t converge() {
    uint32_t quiet = 0, f = 0;
    for (; f < 400 && quiet < 3; ++f) {
      StreamerOutputs out{tiles, packets, writes, frame_events};
      const std::vector<uint32_t> words = feedback();
      EXPECT_EQ(streamer->update(words, out), Status::success);
      EXPECT_EQ(apply_streamer_outputs(*backend, out, handles), Status::success);
      events.insert(events.end(), frame_events.begin(),
                    frame_events.begin() + static_cast<std::ptrdiff_t>(out.event_count));
      streamer->pump();
      const bool busy = out.tile_upload_count + out.packet_upload_count + out.page_table_write_count > 0;
      quiet = busy || !streamer->idle() ? 0 : quiet + 1;
    }
    EXPECT_LT(f, 400u) << "streaming did not settle";
    return f;
  }
  bool saw(ResidencyEventKind kind, uint32_t material) const {
    return std::any_of(events.begin(), events.end(),
                       [&](const ResidencyEvent& e) { return e.kind == kind && e.material == material; });
  }
  /// The plane drawn with material id `m`'s BSVTF (its page-table layers and U′; its finest
  /// level, which its pool's tile size sets).
  Image<float> render(MeshHandle mesh, uint32_t m) {
    ShaderParams p = golden_params(golden_camera());
    p.ids = glm::uvec4(streamer->first_texture(m), m, 0u, 0u);
    p.vt_extent.z = static_cast<float>(streamer->cache().set().material(m).levels.finest_level());
    return render_frame(*backend, ShaderProgram::bsvtf, mesh, handles[m], p);
  }
};

inline ShaderConfig golden_streaming_config() {
  ShaderConfig c = golden_config();
  c.vt.slots_x = 16;  // 128 slots: every tile of the two live materials (2 × 2 × 21)
  c.vt.slots_y = 8;
  return c;
}

inline StreamerConfig golden_streamer_config(const ShaderConfig& c) {
  StreamerConfig sc;
  sc.cache = static_cast<const CacheConfig&>(c.vt);
  sc.vote_window_frames = 1;
  return sc;
}

inline void golden_streamer_materials_come_and_go(BackendFactory make) {
  const ShaderConfig config = golden_streaming_config();
  StreamedGoldenMaterial mats[3];
  for (uint32_t i = 0; i < 3; ++i) {
    make_streamed_material(config, 7u + 5u * i, mats[i]);
    if (::testing::Test::HasFatalFailure()) return;
  }

  // World A: materials 0 and 1 at creation, room for any two of the three live at once.
  const StreamerMaterial all[3] = {mats[0].streamer(), mats[1].streamer(), mats[2].streamer()};
  StreamerConfig sc = golden_streamer_config(config);
  sc.capacity = streamer_capacity_for(all, 2);
  auto a = Streamer::create(std::span<const StreamerMaterial>(all, 2), sc);
  ASSERT_TRUE(a.ok()) << a.message();
  const std::unique_ptr<Backend> be = start_backend(make, config, a->gpu_layout().page_table_layers);
  if (!be) return;
  auto mesh = create_plane_mesh(*be);
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  GoldenStreamingEngine ea;
  ea.attach(*be, *a);
  for (uint32_t m = 0; m < 2; ++m) ASSERT_TRUE(ea.create_material(m, mats[m].material));
  ea.converge();
  ASSERT_TRUE(a->material_ready(0) && a->material_ready(1));
  const Image<float> a_m0 = ea.render(*mesh, 0);

  // Material 0 leaves: its backend material is destroyed; material 2 arrives in its id and layers.
  const uint32_t old_first = a->first_texture(0);
  ASSERT_EQ(a->remove_material(0), Status::success);
  ASSERT_EQ(be->destroy_material(ea.handles[0]), Status::success);
  EXPECT_EQ(be->destroy_material(ea.handles[0]), Status::invalid_argument);
  EXPECT_EQ(be->destroy_material(MaterialHandle{}), Status::invalid_argument);
  {
    ShaderParams p = golden_params(golden_camera());
    ASSERT_EQ(be->begin_frame(backend_frame()), Status::success);
    EXPECT_EQ(be->draw(ShaderProgram::bsvtf, *mesh, ea.handles[0], p), Status::invalid_argument);
    ASSERT_EQ(be->end_frame(), Status::success);
  }
  uint32_t id = 99;
  ASSERT_EQ(a->add_material(all[2], id), Status::success);
  EXPECT_EQ(id, 0u) << "nothing of material 0 was in flight: its id is free at once";
  EXPECT_EQ(a->first_texture(id), old_first) << "the new material takes the freed layers";
  ASSERT_TRUE(ea.create_material(id, mats[2].material));
  ea.events.clear();
  ea.converge();
  EXPECT_TRUE(ea.saw(ResidencyEventKind::material_removed, 0));
  EXPECT_TRUE(ea.saw(ResidencyEventKind::material_released, 0));
  EXPECT_TRUE(ea.saw(ResidencyEventKind::material_ready, id));
  ASSERT_TRUE(a->material_ready(id));
  const Image<float> a_m2 = ea.render(*mesh, id), a_m1 = ea.render(*mesh, 1);

  // World B: a fresh Streamer and backend with materials 1 and 2 (other ids, layers and slots).
  std::string why;
  std::unique_ptr<Backend> be_b = make(why);
  ASSERT_TRUE(be_b) << why;
  const StreamerMaterial final_set[2] = {mats[1].streamer(), mats[2].streamer()};
  auto b = Streamer::create(final_set, golden_streamer_config(config));
  ASSERT_TRUE(b.ok()) << b.message();
  ASSERT_TRUE(be_b->init(config, b->gpu_layout().page_table_layers).ok());
  auto mesh_b = create_plane_mesh(*be_b);
  ASSERT_TRUE(mesh_b.ok()) << mesh_b.message();
  GoldenStreamingEngine eb;
  eb.attach(*be_b, *b);
  for (uint32_t m = 0; m < 2; ++m) ASSERT_TRUE(eb.create_material(m, mats[1 + m].material));
  eb.converge();
  const Image<float> b_m1 = eb.render(*mesh_b, 0), b_m2 = eb.render(*mesh_b, 1);

  for (const Image<float>* img : {&a_m0, &a_m2, &a_m1, &b_m1, &b_m2}) expect_content(*img);
  const double same_new = psnr_rgb(b_m2, a_m2), same_kept = psnr_rgb(b_m1, a_m1), stale = psnr_rgb(a_m0, a_m2);
  std::printf(
      "[ %s ] materials come and go: added material vs a fresh Streamer %.2f dB, kept material %.2f dB, "
      "removed material's image vs the added one %.2f dB\n",
      be->name(), same_new, same_kept, stale);
  EXPECT_GE(same_new, 60.0);
  EXPECT_GE(same_kept, 60.0);
  EXPECT_LT(stale, 40.0) << "the materials must differ for the test to see stale layers";
}

/// The CPU reference of a streamed material: a single-pool Streamer of `cache`'s shape streams it
/// on the CPU (every finest tile voted until nothing changes) into a CpuCacheTexture, and
/// cpu_render() samples V′ through that cache's page tables.
inline Image<float> streamed_cpu_reference(const StreamedGoldenMaterial& mat, const CacheConfig& cache,
                                           const ShaderParams& params) {
  StreamerConfig sc;
  sc.cache = cache;
  sc.vote_window_frames = 1;
  const StreamerMaterial one[1] = {mat.streamer()};
  auto r = Streamer::create(one, sc);
  EXPECT_TRUE(r.ok()) << r.message();
  if (!r.ok()) return Image<float>(kSize, kSize, 4);
  Streamer& s = *r;
  CpuCacheTexture cpu(s.cache());
  std::vector<StreamerTileUpload> tiles(s.tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(s.packet_uploads_bound());
  std::vector<PageTableWrite> writes(4096);
  std::vector<ResidencyEvent> events(64);
  std::vector<uint32_t> words;
  const VtLevelTable& lv = s.cache().set().material(0).levels;
  const uint32_t L = lv.finest_level();
  for (uint32_t y = 0; y < lv.tiles_y[L]; ++y)
    for (uint32_t x = 0; x < lv.tiles_x[L]; ++x) words.push_back(pack_feedback(FeedbackTile{0, L, x, y}));
  for (uint32_t f = 0, quiet = 0; f < 400 && quiet < 3; ++f) {
    StreamerOutputs out{tiles, packets, writes, events};
    EXPECT_EQ(s.update(words, out), Status::success);
    for (size_t i = 0; i < out.tile_upload_count; ++i) {
      const StreamerTileUpload& u = out.tile_uploads[i];
      EXPECT_TRUE(cpu.upload(s.cache(), u.slot, u.texels, u.unorm8, u.map, u.bc5));
    }
    s.pump();
    quiet = out.tile_upload_count > 0 || !s.idle() ? 0 : quiet + 1;
  }
  const uint32_t first = s.first_texture(0), textures = s.texture_count(0);
  return cpu_render(mat.material, params, [&](const SurfaceHit& h, float* out) {
    for (uint32_t k = 0; k < textures; ++k) cpu.sample(s.cache(), first + k, h.texcoord.x, h.texcoord.y, out + 4 * k);
  });
}

/// Two materials in two cache pools of one Streamer — the golden T = 64 cache (pool 0) and a
/// T = 32 cache (pool 1) — on one backend: the backend keeps a cache texture and a bsvtf
/// program per pool (Backend::add_cache_pool), each material draws from its pool's, and each
/// image matches the CPU reference of its material streamed alone (≥ 40 dB), not the other's.
inline void golden_streamer_pools(BackendFactory make) {
  ShaderConfig config = golden_streaming_config();
  config.vt.finest_level = 3;  // the T = 32 material: 8 × 8 finest tiles
  ShaderConfig config32 = config;
  config32.vt.tile_size = 32;
  CacheConfig pool32 = static_cast<const CacheConfig&>(config32.vt);
  pool32.slots_x = pool32.slots_y = 16;  // 256 slots: 2 × 85 tiles
  StreamedGoldenMaterial mats[2];
  make_streamed_material(config, 11u, mats[0]);
  if (::testing::Test::HasFatalFailure()) return;
  make_streamed_material(config32, 23u, mats[1]);
  if (::testing::Test::HasFatalFailure()) return;
  const CacheConfig pools[2] = {static_cast<const CacheConfig&>(config.vt), pool32};
  StreamerConfig sc = golden_streamer_config(config);
  sc.pools = pools;
  const StreamerMaterial both[2] = {mats[0].streamer(), mats[1].streamer()};
  auto s = Streamer::create(both, sc);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(s->material_pool(0), 0u);
  ASSERT_EQ(s->material_pool(1), 1u);
  const std::unique_ptr<Backend> be = start_backend(make, config, s->gpu_layout().page_table_layers);
  if (!be) return;
  auto added = be->add_cache_pool(s->gpu_layout().pools[1].cache);
  ASSERT_TRUE(added.ok()) << added.message();
  EXPECT_EQ(*added, 1u);
  EXPECT_EQ(be->cache_pool_count(), 2u);
  {
    FmfMaterialData missing = mats[0].material.data(false);
    missing.cache_pool = 2;
    EXPECT_FALSE(be->create_material(missing).ok()) << "a material naming a pool the backend does not have";
  }
  auto mesh = create_plane_mesh(*be);
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  GoldenStreamingEngine e;
  e.attach(*be, *s);
  for (uint32_t m = 0; m < 2; ++m) ASSERT_TRUE(e.create_material(m, mats[m].material));
  e.converge();
  ASSERT_TRUE(s->material_ready(0) && s->material_ready(1));
  EXPECT_GT(s->stats().pools[1].slots_used, 100u) << "the T = 32 material streamed its finest tiles";
  Image<float> img[2], ref[2];
  for (uint32_t m = 0; m < 2; ++m) {
    img[m] = e.render(*mesh, m);
    ShaderParams p = golden_params(golden_camera());
    p.vt_extent.z = static_cast<float>(s->cache().set().material(m).levels.finest_level());
    ref[m] = streamed_cpu_reference(mats[m], pools[m], p);
    if (::testing::Test::HasFatalFailure()) return;
  }
  for (uint32_t m = 0; m < 2; ++m) {
    const GoldenPsnr psnr = expect_golden_match(ref[m], img[m], ref[1 - m]);
    std::printf("[ %s ] cache pools: material %u (T = %u, pool %u) vs CPU reference %.2f dB (vs the other %.2f dB)\n",
                be->name(), m, pools[m].tile_size, m, psnr.ref, psnr.wrong);
  }
}

}  // namespace btflod::golden
