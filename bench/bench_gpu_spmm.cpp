// The cost of SPMM's scattered texture access on the GPU (paper 003 §1, §4.1: SPMM "requires
// scattered non-coalesced memory accesses"): frame time of the spmm program (paper 003 eq. 1–3)
// with the full residual, N_PCA = 1 and no residual, next to the fmf program (paper 000 eq. 5,
// C = 8) drawn on the same full-screen quad in the same run, on the GL backend (llvmpipe) and the
// Vulkan backend (lavapipe). Programs are interleaved per iteration (order alternating), so
// load from other processes hits them alike; the counters are median frame times and the median
// per-pair ratio t_spmm / t_fmf, and the texture fetches per fragment of each program:
// spmm_fragment_fetches() averaged over the texels (9 residual tap pairs), FMF 4 + ⌈C/4⌉ + 9·C,
// and the median time of a frame without a draw (clear, submit, wait: the part both share).
//
// The SPMM is fitted once (a 32×32 low-rank BTF, 9 views × 11 lights, K = 4, up to 4 basis
// functions per texel, N_PCA = 4 stored); the FMF material is test_shader_scene's (same
// directions, C = 8). Each iteration: begin_frame, one draw, end_frame, wait_idle.
//
//   build-x/bench/bench_gpu_spmm --benchmark_filter=Gl
// btflod-link: btflod_gl_backend btflod_vk_backend
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "../tests/test_shader_scene.hpp"
#include "bench_gpu.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/spmm.hpp"
#include "btflod/offline/packing/spmm_packing.hpp"

using namespace btflod;
using namespace btflod::bench;
using namespace btflod::test_scene;

namespace {

struct SpmmScene {
  std::unique_ptr<Backend> backend;
  MeshHandle mesh;
  MaterialHandle fmf, spmm;
  ShaderParams params;
  FrameDesc frame;
  double fetches_full = 0, fetches_one = 0, fetches_none = 0, fetches_fmf = 0;
  std::string error;
};

SpmmScene make_scene(bool vulkan) {
  SpmmScene s;
  ShaderConfig c;
  c.components = 8;
  c.angular.resolution = 32;
  s.backend = create_initialised_backend(vulkan, c, 1, s.error);
  if (!s.backend) return s;
  static const Material fmf = make_material(c, 256, 256);
  // The SPMM over 11 lights × 9 views (as the FMF material), its own angular tables.
  static const BtfFloat btf = make_low_rank_btf(32, 32, small_direction_set(3, 4, "views"),
                                                small_direction_set(3, 5, "lights"), 4, 0.7f, 0.01f, 11, 0.5f);
  SpmmOptions opt;
  opt.clusters = 4;
  opt.max_basis_per_texel = 4;
  opt.residual_components = 4;
  static const Spmm spmm = factorize_spmm(btf, opt).value();
  static const PackedSpmm packed = pack_spmm_material(spmm).value();
  static std::vector<uint32_t> light_index, view_index;
  static std::vector<float> light_weight, view_weight;
  std::vector<glm::vec3> ld, vd;
  for (size_t i = 0; i < btf.light_count(); ++i) ld.push_back(btf.lights()[i].vector);
  for (size_t i = 0; i < btf.view_count(); ++i) vd.push_back(btf.views()[i].vector);
  build_table(ld, c.angular.parameterisation, c.angular.resolution, light_index, light_weight);
  build_table(vd, c.angular.parameterisation, c.angular.resolution, view_index, view_weight);
  const SpmmMaterialData data =
      packed.data(AngularTablesData{c.angular.resolution, light_index, light_weight, view_index, view_weight});
  const auto verts = quad_vertices();
  const auto idx = quad_indices();
  s.mesh = *s.backend->create_mesh(MeshData{verts, idx});
  s.fmf = *s.backend->create_material(fmf.data(true));
  auto m = s.backend->create_spmm_material(data);
  if (!m) {
    s.error = m.message();
    s.backend.reset();
    return s;
  }
  s.spmm = *m;
  s.params = make_params();
  for (uint32_t y = 0; y < data.height; ++y)
    for (uint32_t x = 0; x < data.width; ++x) {
      s.fetches_full += spmm_fragment_fetches(data, x, y, 9, spmm_residual_mode(true, -1)).total();
      s.fetches_one += spmm_fragment_fetches(data, x, y, 9, spmm_residual_mode(true, 1)).total();
      s.fetches_none += spmm_fragment_fetches(data, x, y, 9, spmm_residual_mode(false, -1)).total();
    }
  const double n = static_cast<double>(data.width) * data.height;
  s.fetches_full /= n;
  s.fetches_one /= n;
  s.fetches_none /= n;
  s.fetches_fmf = 4.0 + c.component_groups() + 9.0 * c.components;
  return s;
}

// One SPMM residual switch interleaved with FMF.
void pairs(benchmark::State& state, bool vulkan, uint32_t mode) {
  static SpmmScene scenes[2];
  SpmmScene* const found = scene_or_skip(state, scenes, vulkan, [](bool v) { return make_scene(v); });
  if (!found) return;
  SpmmScene& s = *found;
  s.frame.width = s.frame.height = static_cast<uint32_t>(state.range(0));
  const auto one = [&](bool spmm, bool draw = true) {
    ShaderParams p = s.params;
    p.ids.w = mode;
    return time_frame_ms(*s.backend, s.frame, [&] {
      if (draw) s.backend->draw(spmm ? ShaderProgram::spmm : ShaderProgram::fmf, s.mesh, spmm ? s.spmm : s.fmf, p);
    });
  };
  std::vector<double> te;
  const PairTimes t = time_interleaved_pairs(
      state, [&] { return one(false); }, [&] { return one(true); }, [&] { te.push_back(one(false, false)); });
  state.counters["ms_fmf"] = median_of(t.a);
  state.counters["ms_spmm"] = median_of(t.b);
  state.counters["ms_no_draw"] = median_of(te);  // clear + submit + wait: the fixed part of both
  state.counters["spmm_time_over_fmf"] = median_of(per_pair_ratios(t.b, t.a));
  state.counters["fetches_spmm"] = mode == 1u ? s.fetches_none : mode == 0u ? s.fetches_full : s.fetches_one;
  state.counters["fetches_fmf"] = s.fetches_fmf;
}

void BM_Gl_SpmmFull(benchmark::State& st) { pairs(st, false, spmm_residual_mode(true, -1)); }
void BM_Gl_SpmmOnePca(benchmark::State& st) { pairs(st, false, spmm_residual_mode(true, 1)); }
void BM_Gl_SpmmNoResidual(benchmark::State& st) { pairs(st, false, spmm_residual_mode(false, -1)); }
void BM_Vk_SpmmFull(benchmark::State& st) { pairs(st, true, spmm_residual_mode(true, -1)); }
void BM_Vk_SpmmOnePca(benchmark::State& st) { pairs(st, true, spmm_residual_mode(true, 1)); }
void BM_Vk_SpmmNoResidual(benchmark::State& st) { pairs(st, true, spmm_residual_mode(false, -1)); }

}  // namespace

BENCHMARK(BM_Gl_SpmmFull)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Gl_SpmmOnePca)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Gl_SpmmNoResidual)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Vk_SpmmFull)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Vk_SpmmOnePca)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Vk_SpmmNoResidual)->Arg(256)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(1.0);
BENCHMARK_MAIN();
