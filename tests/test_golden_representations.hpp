// Golden-image cases for the laplacian (paper 001 eq. 7), lpca (paper 002 §6.2) and pca_views
// (paper 004 §6.3) programs, shared by test_golden_gl.cpp and test_golden_vk.cpp: the scene of
// test_golden_scene.hpp (tilted plane, perspective camera, directional light) drawn by a GPU
// backend with a material packed by offline/packing/representation_packing.hpp must agree with the CPU
// reference — the same ray-cast scene shaded through the representation's own CPU evaluator
// (LaplacianPca / LocalPca / PcaViews::evaluate*) — at PSNR ≥ 40 dB, 256×256. Materials are
// tiny (16×16 texels, 11 lights × 9 views) so each case takes well under a second to build.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/spmm.hpp"
#include "btflod/offline/packing/representation_packing.hpp"
#include "btflod/offline/packing/spmm_packing.hpp"
#include "test_golden_scene.hpp"

namespace btflod::golden {

inline constexpr int kRepTexels = 16;

/// A small BTF of known low rank plus noise: 16×16 texels, 9 views, 11 lights.
inline BtfFloat representation_btf() {
  return make_low_rank_btf(kRepTexels, kRepTexels, small_direction_set(3, 4, "views"),
                           small_direction_set(3, 5, "lights"), 4, 0.7f, 0.01f, 11, 0.5f);
}

/// Angular tables over the BTF's own directions (test_scene::build_table), kept alive here.
struct RepresentationTables {
  std::vector<uint32_t> light_index, view_index;
  std::vector<float> light_weight, view_weight;
  AngularTablesData data;
};

inline void make_tables(const BtfFloat& btf, DirectionParameterisation p, uint32_t res, RepresentationTables& t) {
  std::vector<glm::vec3> lights, views;
  for (size_t i = 0; i < btf.light_count(); ++i) lights.push_back(btf.lights()[i].vector);
  for (size_t i = 0; i < btf.view_count(); ++i) views.push_back(btf.views()[i].vector);
  build_table(lights, p, res, t.light_index, t.light_weight);
  build_table(views, p, res, t.view_index, t.view_weight);
  t.data = AngularTablesData{res, t.light_index, t.light_weight, t.view_index, t.view_weight};
}

/// Draws the golden plane with `program` and `material` on a fresh frame; returns the image.
inline Image<float> draw_plane(Backend& be, ShaderProgram program, MaterialHandle material,
                               const ShaderParams& params) {
  Image<float> img(kSize, kSize, 4);
  auto mesh = create_plane_mesh(be);
  EXPECT_TRUE(mesh.ok()) << mesh.message();
  if (!mesh) return img;
  EXPECT_EQ(be.begin_frame(backend_frame()), Status::success);
  // A representation material draws only with its own program.
  EXPECT_EQ(be.draw(ShaderProgram::bsvtf, *mesh, material, params), Status::invalid_argument);
  EXPECT_EQ(be.draw(program, *mesh, material, params), Status::success);
  EXPECT_EQ(be.end_frame(), Status::success);
  EXPECT_EQ(be.read_color(img.view()), Status::success);
  return img;
}

/// Laplacian-pyramid PCA, λmax = 2, components (4, 2, 2): λ = log2(d·lod.z) spans ~[0.6, 1.2]
/// over the plane, so eq. 7 blends levels 0–1 and 1–2 with fractional weights. A renderer that
/// used ⌊λ⌋ only (no blending) must not pass.
inline void golden_laplacian(BackendFactory make) {
  const ShaderConfig config = golden_config();
  const std::unique_ptr<Backend> be = start_backend(make, config, 1);
  if (!be) return;
  const BtfFloat btf = representation_btf();
  LaplacianPcaOptions opt;
  opt.mip_count = 2;
  opt.components = {4, 2, 2};
  auto lap = factorize_laplacian_pca(btf, opt);
  ASSERT_TRUE(lap.ok()) << lap.message();
  ASSERT_EQ(lap->lambda_max(), 2);
  RepresentationTables tables;
  make_tables(btf, config.angular.parameterisation, config.angular.resolution, tables);
  auto packed = pack_laplacian_material(*lap);
  ASSERT_TRUE(packed.ok()) << packed.message();
  EXPECT_EQ(packed->info.components, 8u);
  auto mat = be->create_laplacian_material(packed->data(tables.data));
  ASSERT_TRUE(mat.ok()) << mat.message();
  // lod.z from the eye distances of the visible plane: λ = 0.6 at the nearest pixel.
  ShaderParams params = golden_params(golden_camera());
  float dmin = 1e30f, dmax = 0.0f;
  (void)cpu_render_with(params, [&](const SurfaceHit& h, glm::vec3, glm::vec3) {
    const float d = glm::length(glm::vec3(params.camera_pos) - h.position);
    dmin = std::min(dmin, d);
    dmax = std::max(dmax, d);
    return glm::vec3(0.0f);
  });
  params.lod.z = std::exp2(0.6f) / dmin;
  const float lambda_far = std::log2(dmax * params.lod.z);
  EXPECT_GT(lambda_far, 1.05f) << "the view must blend across the level-1 boundary";
  const Image<float> img = draw_plane(*be, ShaderProgram::laplacian, *mat, params);
  auto reference = [&](bool blend) {
    return cpu_render_with(params, [&](const SurfaceHit& h, glm::vec3 wl, glm::vec3 wv) {
      float d = glm::length(glm::vec3(params.camera_pos) - h.position) * params.lod.z;
      if (!blend) d = std::exp2(std::floor(std::log2(d)));  // ⌊λ⌋: no eq. 7 blending
      return reference_laplacian(*lap, tables.data, config.angular.parameterisation, h.texcoord, wl, wv, d);
    });
  };
  const GoldenPsnr psnr = expect_golden_match(reference(true), img, reference(false));
  std::printf(
      "[ %s ] golden laplacian (lambda 0.60..%.2f) vs CPU reference: PSNR %.2f dB (vs no level blending %.2f dB)\n",
      be->name(), static_cast<double>(lambda_far), psnr.ref, psnr.wrong);
}

/// Local PCA, K = 3 clusters, C = 3, 8-bit eigen-BRDFs, R = 8 grid, elevated concentric map; the
/// GPU volume is snorm8 with the scales in the weights (paper 002 §6.3). The image must match
/// the CPU twin on that quantised material and the float LocalPca::evaluate oracle (≥ 40 dB
/// each). A renderer that ignored the per-texel cluster (cluster 0 everywhere) must not pass.
inline void golden_lpca(BackendFactory make) {
  const ShaderConfig config = golden_config();
  const std::unique_ptr<Backend> be = start_backend(make, config, 1);
  if (!be) return;
  const BtfFloat btf = representation_btf();
  LocalPcaOptions opt;
  opt.clusters = 3;
  opt.components = 3;
  opt.max_iterations = 4;
  auto lpca = factorize_local_pca(btf, opt);
  ASSERT_TRUE(lpca.ok()) << lpca.message();
  ASSERT_TRUE(lpca->quantized);
  std::set<uint16_t> used(lpca->cluster_of.begin(), lpca->cluster_of.end());
  ASSERT_GE(used.size(), 2u) << "the material must use more than one cluster";
  constexpr auto kParam = DirectionParameterisation::elevated_concentric;
  constexpr uint32_t kGrid = 8;
  RepresentationTables tables;
  make_tables(btf, kParam, config.angular.resolution, tables);
  auto packed = pack_lpca_material(*lpca, kGrid, kParam, tables.data);
  ASSERT_TRUE(packed.ok()) << packed.message();
  auto mat = be->create_lpca_material(packed->data());
  ASSERT_TRUE(mat.ok()) << mat.message();
  const ShaderParams params = golden_params(golden_camera());
  const Image<float> img = draw_plane(*be, ShaderProgram::lpca, *mat, params);
  std::set<uint16_t> seen;
  const LpcaMaterialData packed_data = packed->data();
  // The CPU twin on the quantised (snorm8, paper 002 §6.3) material the GPU samples ...
  const Image<float> ref = cpu_render_with(params, [&](const SurfaceHit& h, glm::vec3 wl, glm::vec3 wv) {
    const glm::ivec2 t = representation_texel(h.texcoord, kRepTexels, kRepTexels);
    seen.insert(lpca->cluster_of[static_cast<size_t>(t.y * kRepTexels + t.x)]);
    return reference_lpca_packed(packed_data, h.texcoord, wl, wv);
  });
  // ... and the float oracle on LocalPca::evaluate (what an unquantised volume would give).
  const Image<float> oracle = cpu_render_with(params, [&](const SurfaceHit& h, glm::vec3 wl, glm::vec3 wv) {
    return reference_lpca(*lpca, kGrid, kParam, tables.data, false, h.texcoord, wl, wv);
  });
  LocalPca one_cluster = *lpca;
  std::fill(one_cluster.cluster_of.begin(), one_cluster.cluster_of.end(), uint16_t{0});
  const Image<float> wrong = cpu_render_with(params, [&](const SurfaceHit& h, glm::vec3 wl, glm::vec3 wv) {
    return reference_lpca(one_cluster, kGrid, kParam, tables.data, false, h.texcoord, wl, wv);
  });
  EXPECT_GE(seen.size(), 2u) << "the view must show texels of several clusters";
  expect_content(ref);
  expect_content(img);
  const double psnr = psnr_rgb(ref, img), psnr_oracle = psnr_rgb(oracle, img), psnr_wrong = psnr_rgb(wrong, img);
  const size_t float_bytes = packed->volume.size() * sizeof(float);  // the RGBA32F volume it replaces
  std::printf(
      "[ %s ] golden lpca (%zu clusters visible, R = %u, 8-bit volume %zu B vs %zu B float) vs CPU twin on the "
      "quantised data: PSNR %.2f dB; vs float LocalPca::evaluate oracle %.2f dB (vs one cluster %.2f dB)\n",
      be->name(), seen.size(), kGrid, packed->volume.size(), float_bytes, psnr, psnr_oracle, psnr_wrong);
  EXPECT_GE(psnr, 40.0);
  EXPECT_GE(psnr_oracle, 40.0);
  EXPECT_LT(psnr_wrong, psnr_oracle - 3.0);
}

/// PCA over groups of k = 3 of the 9 views (1 < k < all), C = 4, barycentric 3 × 3 taps.
/// Shading every view with group 0's L and R (k = all with the wrong basis) must not pass.
inline void golden_pca_views(BackendFactory make) {
  const ShaderConfig config = golden_config();
  const std::unique_ptr<Backend> be = start_backend(make, config, 1);
  if (!be) return;
  const BtfFloat btf = representation_btf();
  PcaViewsOptions opt;
  opt.views_per_group = 3;
  opt.components = 4;
  auto pca = factorize_pca_views(btf, opt);
  ASSERT_TRUE(pca.ok()) << pca.message();
  ASSERT_EQ(pca->groups.size(), 3u);
  RepresentationTables tables;
  make_tables(btf, config.angular.parameterisation, config.angular.resolution, tables);
  auto packed = pack_pca_views_material(*pca);
  ASSERT_TRUE(packed.ok()) << packed.message();
  auto mat = be->create_pca_views_material(packed->data(tables.data));
  ASSERT_TRUE(mat.ok()) << mat.message();
  const ShaderParams params = golden_params(golden_camera());
  const Image<float> img = draw_plane(*be, ShaderProgram::pca_views, *mat, params);
  std::set<uint32_t> groups_seen;
  const Image<float> ref = cpu_render_with(params, [&](const SurfaceHit& h, glm::vec3 wl, glm::vec3 wv) {
    const AngularSample vs = angular_table_sample(tables.data, 1, config.angular.parameterisation, false, wv);
    for (size_t i = 0; i < 3; ++i)
      if (vs.weight[i] > 0.0f) groups_seen.insert(vs.index[i] / 3);
    return reference_pca_views(*pca, tables.data, config.angular.parameterisation, false, h.texcoord, wl, wv);
  });
  const Image<float> wrong = cpu_render_with(params, [&](const SurfaceHit& h, glm::vec3 wl, glm::vec3 wv) {
    const glm::ivec2 t = representation_texel(h.texcoord, kRepTexels, kRepTexels);
    const AngularSample ls = angular_table_sample(tables.data, 0, config.angular.parameterisation, false, wl);
    AngularSample vs = angular_table_sample(tables.data, 1, config.angular.parameterisation, false, wv);
    for (auto& v : vs.index) v %= 3;  // every view mapped into group 0
    return pca->evaluate(t.x, t.y, ls, vs);
  });
  EXPECT_GE(groups_seen.size(), 2u) << "the view must use several view groups";
  const GoldenPsnr psnr = expect_golden_match(ref, img, wrong);
  std::printf(
      "[ %s ] golden pca_views (k = 3 of 9 views, %zu groups used) vs CPU reference: PSNR %.2f dB (vs group 0 only "
      "%.2f dB)\n",
      be->name(), groups_seen.size(), psnr.ref, psnr.wrong);
}

/// SPMM (paper 003 eq. 1–3): K = 3 clusters, up to 4 basis functions per texel, N_PCA = 3 stored.
/// Drawn three times with the residual switch of ShaderParams::ids.w: every component, N_PCA = 1
/// and no residual (paper 003 §5.2); each image must match Spmm::evaluate with the same switch
/// (analytic part at the exact directions, residual through the tables' 3 × 3 taps) at ≥ 40 dB.
/// A renderer that skipped the residual, or read the residual of cluster 0 everywhere, must not
/// pass the full-residual comparison.
inline void golden_spmm(BackendFactory make) {
  const ShaderConfig config = golden_config();
  const std::unique_ptr<Backend> be = start_backend(make, config, 1);
  if (!be) return;
  const BtfFloat btf = representation_btf();
  SpmmOptions opt;
  opt.clusters = 3;
  opt.representatives = 2;
  opt.lobes_per_representative = 2;
  opt.max_basis_per_texel = 4;
  opt.residual_components = 3;
  opt.lm_evaluations = 60;
  auto spmm = factorize_spmm(btf, opt);
  ASSERT_TRUE(spmm.ok()) << spmm.message();
  std::set<uint16_t> used(spmm->cluster_of.begin(), spmm->cluster_of.end());
  ASSERT_GE(used.size(), 2u) << "the material must use more than one cluster";
  ASSERT_GT(spmm->mean_basis_per_texel(), 1.0);
  RepresentationTables tables;
  make_tables(btf, config.angular.parameterisation, config.angular.resolution, tables);
  auto packed = pack_spmm_material(*spmm);
  ASSERT_TRUE(packed.ok()) << packed.message();
  const SpmmMaterialData data = packed->data(tables.data);
  ASSERT_TRUE(validate_material(data, config).ok()) << validate_material(data, config).message();
  auto mat = be->create_spmm_material(data);
  ASSERT_TRUE(mat.ok()) << mat.message();
  const auto param = config.angular.parameterisation;
  auto reference = [&](const Spmm& p, const ShaderParams& params, const SpmmEvalOptions& o) {
    return cpu_render_with(params, [&](const SurfaceHit& h, glm::vec3 wl, glm::vec3 wv) {
      return reference_spmm(p, tables.data, param, false, h.texcoord, wl, wv, o);
    });
  };
  const struct {
    const char* what;
    SpmmEvalOptions options;
  } modes[] = {{"full residual", {true, -1}}, {"N_PCA = 1", {true, 1}}, {"no residual", {false, -1}}};
  for (const auto& m : modes) {
    ShaderParams params = golden_params(golden_camera());
    params.ids.w = spmm_residual_mode(m.options.residual, m.options.pca_components);
    const Image<float> img = draw_plane(*be, ShaderProgram::spmm, *mat, params);
    const Image<float> ref = reference(*spmm, params, m.options);
    expect_content(ref);
    expect_content(img);
    const double psnr = psnr_rgb(ref, img);
    if (m.options.residual && m.options.pca_components < 0) {
      const Image<float> no_res = reference(*spmm, params, SpmmEvalOptions{false, -1});
      Spmm one_cluster = *spmm;  // the residual of cluster 0 everywhere (the analytic part unchanged)
      const size_t d = spmm->angular_size(), pc = static_cast<size_t>(spmm->residual_components);
      for (size_t c = 1; c < static_cast<size_t>(spmm->clusters()); ++c) {
        std::copy_n(spmm->residual_mean.begin(), d,
                    one_cluster.residual_mean.begin() + static_cast<std::ptrdiff_t>(c * d));
        std::copy_n(spmm->residual_basis.begin(), d * pc,
                    one_cluster.residual_basis.begin() + static_cast<std::ptrdiff_t>(c * d * pc));
      }
      const Image<float> wrong_cluster = reference(one_cluster, params, m.options);
      const double psnr_no_res = psnr_rgb(no_res, img), psnr_cluster = psnr_rgb(wrong_cluster, img);
      std::printf(
          "[ %s ] golden spmm (%zu clusters, #BF %.2f, N_PCA %d) %s vs Spmm::evaluate: PSNR %.2f dB (vs no residual "
          "%.2f dB, vs cluster 0's residual %.2f dB)\n",
          be->name(), used.size(), spmm->mean_basis_per_texel(), spmm->residual_components, m.what, psnr, psnr_no_res,
          psnr_cluster);
      EXPECT_LT(psnr_no_res, psnr - 3.0);
      EXPECT_LT(psnr_cluster, psnr - 3.0);
    } else {
      std::printf("[ %s ] golden spmm %s vs Spmm::evaluate: PSNR %.2f dB\n", be->name(), m.what, psnr);
    }
    EXPECT_GE(psnr, 40.0) << m.what;
  }
}

}  // namespace btflod::golden
