// Frame time of BSVTF vs FMF rendering of the same scene and view, on the GL backend (llvmpipe
// on CI) and the Vulkan backend (lavapipe). FMF is the in-run baseline (paper 000 Table 2:
// BSVTF ≈ 28% slower); the counters give the texture memory each path keeps for V'.
// Each iteration: begin_frame, one full-screen draw, end_frame, wait_idle (so the GPU work is
// inside the timing). BSVTF runs with levels 0..2 resident and the finest level over the left
// half of the texture (the quad is shown at about one texel per pixel at 512²).
// BM_*_Pairs interleave the two programs and report the median per-pair frame-rate ratio.
// BM_*_ScenePasses time the demo's scene geometry with the colour and feedback passes apart.
// BM_*_CacheFormatPairs interleave BSVTF frames from an rgba16f and an rgba8_affine cache holding
// the same tiles and report the median per-pair frame-rate ratio (runtime/vt/cache_format.hpp).
// BM_Gl_CacheFormatScene draws the demo scene from rgba16f, rgba8_affine and bc5_affine caches
// holding the same tiles, interleaved in a rotating order, and reports the ratios to rgba16f.
// btflod-link: btflod_gl_backend btflod_vk_backend
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "../samples/scene/demo_scene.hpp"
#include "../tests/test_shader_scene.hpp"
#include "bench_gpu.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"

using namespace btflod;
using namespace btflod::bench;
using namespace btflod::test_scene;

namespace {

constexpr int kTextureSize = 512;  // M = N, T = 64 → L = 3

struct Scene {
  std::unique_ptr<Backend> backend;
  MeshHandle mesh;
  std::vector<MeshHandle> scene_meshes;  // samples/scene/demo_scene.hpp: ground plane and four tori
  MaterialHandle fmf, bsvtf;
  ShaderParams params;
  FrameDesc frame;
  double fmf_bytes = 0, bsvtf_bytes = 0;
  std::string error;
};

Scene make_scene(bool vulkan, CacheFormat format = CacheFormat::rgba16f) {
  Scene s;
  ShaderConfig c;
  c.components = 8;
  c.angular.resolution = 32;
  c.vt.slots_x = 16;  // the demo's 128-slot cache (samples/demo/stream_render.hpp)
  c.vt.slots_y = 8;
  c.vt.finest_level = 3;
  c.vt.format = format;
  s.backend = create_initialised_backend(vulkan, c, 2, s.error);
  if (!s.backend) return s;
  static const Material m = make_material(c, kTextureSize, kTextureSize);
  const auto verts = quad_vertices();
  const auto idx = quad_indices();
  s.mesh = *s.backend->create_mesh(MeshData{verts, idx});
  for (const scene::SceneObject& o : scene::make_demo_scene(5))
    s.scene_meshes.push_back(*s.backend->create_mesh(MeshData{o.vertices, o.indices}));
  s.fmf = *s.backend->create_material(m.data(true));
  s.bsvtf = *s.backend->create_material(m.data(false));
  // Levels 0..2 resident everywhere, the finest level (3) over the left half: 2 × 53 slots.
  static const Pyramid pyr = build_pyramid(m, 3);
  CacheFill fill = fill_cache(pyr, c.vt, kTextureSize, kTextureSize);
  // rgba8_affine, bc5_affine: the same tiles encoded as the Streamer encodes them.
  std::vector<std::vector<uint8_t>> unorm8, bc5;
  if (format == CacheFormat::rgba8_affine) {
    unorm8.reserve(fill.uploads.size());
    std::vector<float> scratch;
    for (TileUpload& u : fill.uploads) {
      scratch.resize(u.texels.size());
      std::vector<uint8_t>& q = unorm8.emplace_back(u.texels.size());
      u.map = encode_cache_tile_unorm8(u.texels, scratch, q);
      u.unorm8 = q;
      u.texels = {};
    }
  } else if (format == CacheFormat::bc5_affine) {
    bc5.reserve(fill.uploads.size());
    std::vector<float> values;
    std::vector<uint8_t> scratch;
    const uint32_t side = c.vt.padded_tile_size();
    for (TileUpload& u : fill.uploads) {
      values.resize(u.texels.size());
      scratch.resize(u.texels.size());
      half_to_float(u.texels, values);
      std::vector<uint8_t>& b = bc5.emplace_back(cache_bc5_tile_bytes(side));
      u.map = encode_cache_tile_bc5(values, side, scratch, b);
      u.bc5 = b;
      u.texels = {};
    }
  }
  if (s.backend->upload_tiles(fill.uploads) != Status::success) {
    s.error = "upload_tiles failed";
    s.backend.reset();
    return s;
  }
  s.backend->apply_page_table_writes(fill.deltas);
  s.params = make_params();
  s.params.vt_extent = glm::vec4(kTextureSize, kTextureSize, 3, 0);
  // V' memory: FMF keeps the whole eigen-texture array (RGBA32F, ⌈C/4⌉ layers, mips ≈ 4/3);
  // BSVTF keeps the resident tiles (RGBA16F, (T + 2B)² each) and the page tables.
  s.fmf_bytes = 16.0 * kTextureSize * kTextureSize * c.component_groups() * 4.0 / 3.0;
  s.bsvtf_bytes = c.vt.texel_bytes() * c.vt.padded_tile_size() * c.vt.padded_tile_size() *
                      static_cast<double>(fill.uploads.size()) +
                  (cache_format_has_slot_map(format) ? 32.0 * static_cast<double>(fill.uploads.size()) : 0.0) +
                  4.0 * 2 * (64 + 16 + 4 + 1);
  return s;
}

void render(benchmark::State& state, bool vulkan, ShaderProgram program) {
  const int size = static_cast<int>(state.range(0));
  static Scene scenes[2];  // one backend per API, built once per process
  Scene* const found = scene_or_skip(state, scenes, vulkan, [](bool v) { return make_scene(v); });
  if (!found) return;
  Scene& s = *found;
  const MaterialHandle mat = program == ShaderProgram::fmf ? s.fmf : s.bsvtf;
  s.frame.width = s.frame.height = static_cast<uint32_t>(size);
  for (int warm = 0; warm < 2; ++warm) {  // JIT of the shader variant and target (re)creation
    s.backend->begin_frame(s.frame);
    s.backend->draw(program, s.mesh, mat, s.params);
    s.backend->end_frame();
    s.backend->wait_idle();
  }
  for (auto _ : state) {
    s.backend->begin_frame(s.frame);
    s.backend->draw(program, s.mesh, mat, s.params);
    s.backend->end_frame();
    s.backend->wait_idle();
  }
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["V_MiB"] = (program == ShaderProgram::fmf ? s.fmf_bytes : s.bsvtf_bytes) / (1024.0 * 1024.0);
}

// FMF and BSVTF frames interleaved (order alternating per iteration), so that load from other
// processes hits both alike: the ratio counter is the median over iterations of the per-pair
// BSVTF/FMF frame-rate ratio (t_fmf / t_bsvtf), next to each program's median frame time.
void render_pairs(benchmark::State& state, bool vulkan) {
  const int size = static_cast<int>(state.range(0));
  static Scene scenes[2];
  Scene* const found = scene_or_skip(state, scenes, vulkan, [](bool v) { return make_scene(v); });
  if (!found) return;
  Scene& s = *found;
  s.frame.width = s.frame.height = static_cast<uint32_t>(size);
  const auto one = [&](ShaderProgram program) {
    return time_frame_ms(*s.backend, s.frame, [&] {
      s.backend->draw(program, s.mesh, program == ShaderProgram::fmf ? s.fmf : s.bsvtf, s.params);
    });
  };
  const PairTimes t = time_interleaved_pairs(
      state, [&] { return one(ShaderProgram::fmf); }, [&] { return one(ShaderProgram::bsvtf); });
  state.counters["ms_fmf"] = median_of(t.a);
  state.counters["ms_bsvtf"] = median_of(t.b);
  state.counters["bsvtf_fps_over_fmf"] = median_of(per_pair_ratios(t.a, t.b));
}

// The demo's scene geometry (a 12 × 12 ground plane and four 96 × 48 tori, samples/scene/
// demo_scene.hpp) at the demo's 480 × 270 with its feedback pass at 1/4 per axis, every object
// with the bench material, seen from the demo's camera path at frame 120 of 200. Per iteration,
// in a rotating order, five frames each timed from begin_frame to the colour read-back (as the
// demo times them): FMF; the BSVTF colour pass alone; the feedback pass alone; a BSVTF frame
// with a separate feedback pass (feedback pass, then colour pass: `--feedback-pass` in the
// demo); the demo's BSVTF frame (bsvtf_feedback: the colour pass writes the feedback words).
// Counters: the median frame times, the medians of the per-iteration ratios t_FMF / t_BSVTF
// (colour alone, with the separate pass, with bsvtf_feedback) and the median marginal cost of
// the separate feedback pass (t_frame − t_colour).
// BSVTF frames from two backends of one API, one with an rgba16f cache and one with an
// rgba8_affine cache holding the same tiles, interleaved (order alternating per iteration):
// counters are each format's median frame time and the median per-pair frame-rate ratio
// rgba8 / rgba16f (t_rgba16f / t_rgba8; above 1: the compact cache renders faster).
void render_cache_format_pairs(benchmark::State& state, bool vulkan) {
  const int size = static_cast<int>(state.range(0));
  static Scene wide[2], compact[2];
  Scene& a = wide[vulkan ? 1 : 0];
  Scene& b = compact[vulkan ? 1 : 0];
  if (!a.backend && a.error.empty()) a = make_scene(vulkan, CacheFormat::rgba16f);
  if (!b.backend && b.error.empty()) b = make_scene(vulkan, CacheFormat::rgba8_affine);
  if (!a.backend || !b.backend) {
    state.SkipWithError(("backend unavailable: " + a.error + b.error).c_str());
    return;
  }
  const auto one = [&](Scene& s) {
    s.frame.width = s.frame.height = static_cast<uint32_t>(size);
    return time_frame_ms(*s.backend, s.frame,
                         [&] { s.backend->draw(ShaderProgram::bsvtf, s.mesh, s.bsvtf, s.params); });
  };
  const PairTimes t = time_interleaved_pairs(
      state, [&] { return one(a); }, [&] { return one(b); });
  state.counters["ms_rgba16f"] = median_of(t.a);
  state.counters["ms_rgba8"] = median_of(t.b);
  state.counters["rgba8_fps_over_rgba16f"] = median_of(per_pair_ratios(t.a, t.b));
  state.counters["cache_MiB_rgba16f"] = a.bsvtf_bytes / (1024.0 * 1024.0);
  state.counters["cache_MiB_rgba8"] = b.bsvtf_bytes / (1024.0 * 1024.0);
}

// The demo scene (samples/scene/demo_scene.hpp: ground plane and four tori, every object with
// the bench material) at the demo's 480 × 270 from its camera path at frame 120 of 200, drawn
// with the BSVTF program from three GL backends whose caches hold the same tiles as rgba16f,
// rgba8_affine and bc5_affine (encoded as the Streamer encodes them). Per iteration one frame of
// each, in an order rotating by one per iteration (load from other processes hits all alike),
// each timed from begin_frame to the colour read-back as the demo times them. Counters: each
// format's median frame time and the medians of the per-iteration frame-rate ratios to rgba16f
// (t_rgba16f / t_format; above 1: faster than rgba16f), and each cache's resident bytes.
void render_cache_format_scene(benchmark::State& state) {
  static Scene scenes[3];
  constexpr CacheFormat kFormats[3] = {CacheFormat::rgba16f, CacheFormat::rgba8_affine, CacheFormat::bc5_affine};
  std::string error;
  for (int f = 0; f < 3; ++f) {
    if (!scenes[f].backend && scenes[f].error.empty()) scenes[f] = make_scene(false, kFormats[f]);
    error += scenes[f].error;
  }
  if (!scenes[0].backend || !scenes[1].backend || !scenes[2].backend) {
    state.SkipWithError(("backend unavailable: " + error).c_str());
    return;
  }
  const scene::View view = scene::camera_path(120, 200, 480, 270);
  ShaderParams p = scene::view_params(view, glm::vec3(0.4f, 1.0f, 0.3f), glm::vec3(3.0f));
  p.vt_extent = scenes[0].params.vt_extent;
  FrameDesc desc;
  desc.width = view.width;
  desc.height = view.height;
  Image<float> color(static_cast<int>(view.width), static_cast<int>(view.height), 4);
  const auto one = [&](int f) {
    Scene& s = scenes[f];
    const auto t0 = std::chrono::steady_clock::now();
    s.backend->begin_frame(desc);
    for (MeshHandle m : s.scene_meshes) s.backend->draw(ShaderProgram::bsvtf, m, s.bsvtf, p);
    s.backend->end_frame();
    s.backend->read_color(color.view());
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  for (int warm = 0; warm < 2; ++warm)
    for (int f = 0; f < 3; ++f) one(f);
  std::vector<double> t[3], r8, r5;
  int rot = 0;
  for (auto _ : state) {
    double ms[3];
    for (int k = 0; k < 3; ++k) {
      const int f = (k + rot) % 3;
      ms[f] = one(f);
    }
    ++rot;
    for (int f = 0; f < 3; ++f) t[f].push_back(ms[f]);
    r8.push_back(ms[0] / ms[1]);
    r5.push_back(ms[0] / ms[2]);
  }
  state.counters["ms_rgba16f"] = median_of(t[0]);
  state.counters["ms_rgba8"] = median_of(t[1]);
  state.counters["ms_bc5"] = median_of(t[2]);
  state.counters["rgba8_fps_over_rgba16f"] = median_of(r8);
  state.counters["bc5_fps_over_rgba16f"] = median_of(r5);
  state.counters["cache_MiB_rgba16f"] = scenes[0].bsvtf_bytes / (1024.0 * 1024.0);
  state.counters["cache_MiB_rgba8"] = scenes[1].bsvtf_bytes / (1024.0 * 1024.0);
  state.counters["cache_MiB_bc5"] = scenes[2].bsvtf_bytes / (1024.0 * 1024.0);
}

void render_scene_passes(benchmark::State& state, bool vulkan) {
  static Scene scenes[2];
  Scene* const found = scene_or_skip(state, scenes, vulkan, [](bool v) { return make_scene(v); });
  if (!found) return;
  Scene& s = *found;
  const scene::View view = scene::camera_path(120, 200, 480, 270);
  ShaderParams p = scene::view_params(view, glm::vec3(0.4f, 1.0f, 0.3f), glm::vec3(3.0f));
  p.vt_extent = s.params.vt_extent;
  FrameDesc desc;
  desc.width = view.width;
  desc.height = view.height;
  constexpr uint32_t kShift = 2;
  desc.feedback_width = (view.width + 3) >> kShift;
  desc.feedback_height = (view.height + 3) >> kShift;
  desc.feedback_sample_x = 1;  // bsvtf_feedback frames: pixel (1, 2) of every 4 × 4 block
  desc.feedback_sample_y = 2;
  ShaderParams pf = p;
  pf.lod.y = static_cast<float>(kShift);
  Image<float> color(static_cast<int>(view.width), static_cast<int>(view.height), 4);
  enum Pass { fmf, colour, feedback, frame, words, kPasses };
  const auto one = [&](int pass) {
    const auto t0 = std::chrono::steady_clock::now();
    s.backend->begin_frame(desc);
    if (pass == feedback || pass == frame)
      for (MeshHandle m : s.scene_meshes) s.backend->draw_feedback(m, pf);
    if (pass == words)
      for (MeshHandle m : s.scene_meshes) s.backend->draw(ShaderProgram::bsvtf_feedback, m, s.bsvtf, p);
    else if (pass != feedback)
      for (MeshHandle m : s.scene_meshes)
        s.backend->draw(pass == fmf ? ShaderProgram::fmf : ShaderProgram::bsvtf, m, pass == fmf ? s.fmf : s.bsvtf, p);
    s.backend->end_frame();
    if (pass != feedback)
      s.backend->read_color(color.view());
    else
      s.backend->wait_idle();
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    s.backend->wait_idle();
    FeedbackFrame fb;
    while (s.backend->poll_feedback(fb)) {
    }
    return ms;
  };
  for (int warm = 0; warm < 2; ++warm)
    for (int pass = 0; pass < kPasses; ++pass) one(pass);
  std::vector<double> t[kPasses], r_colour, r_frame, r_words, marginal;
  int rot = 0;
  for (auto _ : state) {
    double ms[kPasses];
    for (int k = 0; k < kPasses; ++k) {
      const int pass = (k + rot) % kPasses;
      ms[pass] = one(pass);
    }
    ++rot;
    for (int k = 0; k < kPasses; ++k) t[k].push_back(ms[k]);
    r_colour.push_back(ms[fmf] / ms[colour]);
    r_frame.push_back(ms[fmf] / ms[frame]);
    r_words.push_back(ms[fmf] / ms[words]);
    marginal.push_back(ms[frame] - ms[colour]);
  }
  state.counters["ms_fmf"] = median_of(t[fmf]);
  state.counters["ms_bsvtf_colour"] = median_of(t[colour]);
  state.counters["ms_feedback_alone"] = median_of(t[feedback]);
  state.counters["ms_bsvtf_frame"] = median_of(t[frame]);
  state.counters["ms_feedback_marginal"] = median_of(marginal);
  state.counters["colour_fps_over_fmf"] = median_of(r_colour);
  state.counters["frame_fps_over_fmf"] = median_of(r_frame);
  state.counters["ms_bsvtf_colour_words"] = median_of(t[words]);
  state.counters["colour_words_fps_over_fmf"] = median_of(r_words);
}

void BM_Gl_Fmf(benchmark::State& st) { render(st, false, ShaderProgram::fmf); }
void BM_Gl_Bsvtf(benchmark::State& st) { render(st, false, ShaderProgram::bsvtf); }
void BM_Vk_Fmf(benchmark::State& st) { render(st, true, ShaderProgram::fmf); }
void BM_Vk_Bsvtf(benchmark::State& st) { render(st, true, ShaderProgram::bsvtf); }
void BM_Gl_Pairs(benchmark::State& st) { render_pairs(st, false); }
void BM_Vk_Pairs(benchmark::State& st) { render_pairs(st, true); }
void BM_Gl_ScenePasses(benchmark::State& st) { render_scene_passes(st, false); }
void BM_Gl_CacheFormatPairs(benchmark::State& st) { render_cache_format_pairs(st, false); }
void BM_Vk_CacheFormatPairs(benchmark::State& st) { render_cache_format_pairs(st, true); }
void BM_Gl_CacheFormatScene(benchmark::State& st) { render_cache_format_scene(st); }
void BM_Vk_ScenePasses(benchmark::State& st) { render_scene_passes(st, true); }

}  // namespace

BENCHMARK(BM_Gl_Fmf)->Arg(256)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Gl_Bsvtf)->Arg(256)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Vk_Fmf)->Arg(256)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Vk_Bsvtf)->Arg(256)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime();
// 240² (and 362² ≈ 512/√2): the quad is minified by a non-power of two, so lambda has a
// fractional part and FMF's hardware trilinear fetch really blends two mips; at 256² lambda is
// an integer (2:1) and llvmpipe samples only one mip for FMF, while BSVTF's shader fetches both
// levels it may blend (docs/demo.md, "frame rate").
static void pair_sizes(benchmark::internal::Benchmark* b) { b->Arg(240)->Arg(256)->Arg(362)->Arg(512); }
BENCHMARK(BM_Gl_Pairs)->Apply(pair_sizes)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_Vk_Pairs)->Apply(pair_sizes)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_Gl_ScenePasses)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_Gl_CacheFormatPairs)->Arg(362)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_Vk_CacheFormatPairs)->Arg(362)->Arg(512)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_Gl_CacheFormatScene)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(15.0);
BENCHMARK(BM_Vk_ScenePasses)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK_MAIN();
