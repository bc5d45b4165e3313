// Tests for offline/render/shading.hpp: a BtfMaterial built on each representation (FMF, PCA-k,
// Laplacian PCA, local PCA) returns exactly the representation's value at measured directions
// (one tap of weight 1) and the 9-tap blend between them; uv wraps to texels; directions below
// the horizon give 0; the interactive quality changes only representations with an LOD knob;
// Lambertian and mirror materials; a BTF-textured plane rendered through the integrator.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/laplacian_pca.hpp"
#include "btflod/offline/factor/local_pca.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/pca_views.hpp"
#include "btflod/offline/render/integrator.hpp"
#include "btflod/offline/render/primitives.hpp"
#include "btflod/offline/render/shading.hpp"

namespace btflod {
namespace {

/// A tiny synthesised stone BTF (8 × 8 texels, 13 directions) and its five representations.
std::vector<std::shared_ptr<const AnyFactorization>> representations() {
  static std::vector<std::shared_ptr<const AnyFactorization>> cache;
  if (!cache.empty()) return cache;
  SynthesisOptions so;
  so.views = small_direction_set(3, 6, "test-13");
  so.lights = so.views;
  auto btf = synthesize_material(SynthMaterial::stone, 8, 8, 3, so);
  EXPECT_TRUE(btf) << btf.message();
  FmfOptions fo;
  fo.components = 4;
  PcaViewsOptions po;
  po.components = 4;
  LaplacianPcaOptions lo;
  lo.components = {4, 1, 1};
  LocalPcaOptions co;
  co.clusters = 2;
  co.components = 2;
  cache.push_back(std::make_shared<AnyFactorization>(factorize_fmf(*btf, fo).value()));
  cache.push_back(std::make_shared<AnyFactorization>(factorize_pca_views(*btf, po).value()));
  cache.push_back(std::make_shared<AnyFactorization>(factorize_laplacian_pca(*btf, lo).value()));
  cache.push_back(std::make_shared<AnyFactorization>(factorize_local_pca(*btf, co).value()));
  SpmmOptions sp;
  sp.clusters = 2;
  sp.representatives = 2;
  sp.lobes_per_representative = 1;
  sp.residual_components = 2;
  cache.push_back(std::make_shared<AnyFactorization>(factorize_spmm(*btf, sp).value()));
  return cache;
}

glm::vec3 measured(const AnyFactorization& f, int x, int y, uint32_t view, uint32_t light) {
  return std::visit(
      [&](const auto& r) -> glm::vec3 {
        if constexpr (requires { r.evaluate_measured(x, y, view, light, 0.0f); })
          return r.evaluate_measured(x, y, view, light, 0.0f);
        else
          return r.evaluate_measured(x, y, view, light);
      },
      f);
}

TEST(RenderShading, MeasuredDirectionsGiveTheRepresentationsValue) {
  for (const auto& rep : representations()) {
    auto m = BtfMaterial::build(rep);
    ASSERT_TRUE(m) << m.message();
    const BtfShape& shape = factorization_shape(*rep);
    EXPECT_EQ(m->width(), 8);
    for (uint32_t v = 0; v < shape.view_count(); v += 3)
      for (uint32_t l = 0; l < shape.light_count(); l += 2) {
        const glm::vec3 wl = shape.lights[l].vector, wv = shape.views[v].vector;
        // uv (x + 0.5)/8 picks texel x; +3 repeats.
        const glm::vec2 uv(3.0f + 5.5f / 8.0f, -1.0f + 2.5f / 8.0f);
        const glm::vec3 got = m->evaluate(uv, wl, wv);
        const glm::vec3 want = measured(*rep, 5, 2, v, l);
        EXPECT_NEAR(got.x, want.x, 1e-4f * (1.0f + std::abs(want.x)))
            << factorization_name(*rep) << " v" << v << " l" << l;
        EXPECT_NEAR(got.z, want.z, 1e-4f * (1.0f + std::abs(want.z))) << factorization_name(*rep);
      }
  }
}

TEST(RenderShading, BetweenDirectionsTheNineTapsBlend) {
  auto m = BtfMaterial::build(representations()[0]);
  ASSERT_TRUE(m);
  const glm::vec3 wl = glm::normalize(glm::vec3(0.31f, -0.2f, 0.8f)), wv = glm::normalize(glm::vec3(-0.4f, 0.1f, 0.7f));
  const NineTapSample taps = m->taps(wl, wv);
  float total = 0;
  glm::vec3 want(0.0f);
  for (int k = 0; k < 9; ++k) {
    total += taps.weight[k];
    if (taps.weight[k] > 0)
      want += taps.weight[k] * measured(m->representation(), 1, 1, taps.view_index[k], taps.light_index[k]);
  }
  EXPECT_NEAR(total, 1.0f, 1e-5f);
  const glm::vec3 got = m->evaluate(glm::vec2(1.5f / 8, 1.5f / 8), wl, wv);
  EXPECT_NEAR(got.y, want.y, 1e-5f);
}

TEST(RenderShading, BelowTheHorizonIsBlack) {
  auto m = BtfMaterial::build(representations()[1]);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->evaluate({0.1f, 0.1f}, {0, 0.1f, -0.9f}, {0, 0, 1}), glm::vec3(0.0f));
  EXPECT_EQ(m->evaluate({0.1f, 0.1f}, {0, 0, 1}, {0.1f, 0, -1}), glm::vec3(0.0f));
  EXPECT_NE(m->evaluate({0.1f, 0.1f}, {0, 0, 1}, {0, 0, 1}), glm::vec3(0.0f));
  // NaN uv picks texel 0 instead of reading out of bounds.
  EXPECT_EQ(BtfMaterial::wrap_index(std::nanf(""), 8), 0);
  EXPECT_EQ(BtfMaterial::wrap_index(-0.01f, 8), 7);
  EXPECT_EQ(BtfMaterial::wrap_index(1.0f, 8), 0);
}

TEST(RenderShading, InteractiveQualityChangesOnlyLodRepresentations) {
  const glm::vec3 wl = glm::normalize(glm::vec3(0.2f, 0.1f, 0.9f)), wv = glm::normalize(glm::vec3(-0.3f, 0.2f, 0.8f));
  for (const auto& rep : representations()) {
    auto m = BtfMaterial::build(rep);
    ASSERT_TRUE(m);
    const glm::vec3 full = m->evaluate({0.3f, 0.6f}, wl, wv, ShadeQuality::full);
    const glm::vec3 fast = m->evaluate({0.3f, 0.6f}, wl, wv, ShadeQuality::interactive);
    if (rep->index() == 2) {
      EXPECT_NE(full, fast) << "laplacian";
    } else if (const Spmm* spmm = std::get_if<Spmm>(rep.get())) {
      // paper 003 §5.4: the analytic mixture alone, exactly what evaluate() gives without the
      // residual at the same nine taps.
      SpmmEvalOptions no_residual;
      no_residual.residual = false;
      const int x = BtfMaterial::wrap_index(0.3f, m->width()), y = BtfMaterial::wrap_index(0.6f, m->height());
      const AngularSample l = m->light_sample(wl), v = m->view_sample(wv);
      EXPECT_EQ(fast, spmm->evaluate(x, y, l, v, no_residual)) << "spmm";
      EXPECT_NE(full, fast) << "spmm";
    } else {
      EXPECT_EQ(full, fast) << factorization_name(*rep);
    }
  }
}

TEST(RenderShading, LambertianAndMirror) {
  const SurfaceMaterial lam = SurfaceMaterial::lambertian(glm::vec3(0.5f));
  const glm::vec3 l = glm::normalize(glm::vec3(0.3f, 0.0f, 0.6f));
  EXPECT_NEAR(shade_reflectance_cos(lam, {}, l, {0, 0, 1}).x, 0.5f / kPi * l.z, 1e-7f);
  EXPECT_EQ(ambient_reflectance(lam, {}, {0, 0, 1}), glm::vec3(0.5f));
  const SurfaceMaterial mir = SurfaceMaterial::mirror(glm::vec3(0.8f));
  EXPECT_EQ(shade_reflectance_cos(mir, {}, l, {0, 0, 1}), glm::vec3(0.0f));
  const glm::vec3 r = reflect_direction(glm::normalize(glm::vec3(1, -1, 0)), {0, 1, 0});
  EXPECT_NEAR(r.x, std::sqrt(0.5f), 1e-6f);
  EXPECT_NEAR(r.y, std::sqrt(0.5f), 1e-6f);
}

TEST(RenderShading, EmptyRepresentationIsRejected) {
  EXPECT_FALSE(BtfMaterial::build(nullptr));
  EXPECT_FALSE(BtfMaterial::build(std::make_shared<AnyFactorization>(Fmf{})));
}

TEST(RenderShading, BtfPlaneUnderAPointLightMatchesTheMaterial) {
  // Camera straight above a BTF plane, point light at the camera: every pixel is
  // value(uv, l, v) · I / d² with the directions of that pixel.
  for (const auto& rep : representations()) {
    auto btf = BtfMaterial::build(rep);
    ASSERT_TRUE(btf);
    const std::vector<SurfaceMaterial> mats = {SurfaceMaterial::textured(*btf)};
    const TriangleMeshData quad = make_quad({-1, 0, 1}, {2, 0, 0}, {0, 0, -2}, {2, 2});
    const std::vector<SceneMesh> meshes = {quad.mesh(0)};
    const std::vector<PointLight> lights = {PointLight{{0.0f, 2.0f, 0.0f}, glm::vec3(4.0f)}};
    RenderScene scene{meshes, mats, lights, {}, AmbientLight{}, glm::vec3(0.0f)};
    ASSERT_TRUE(validate_render_scene(scene));
    PinholeCamera cam;
    cam.eye = {0, 2, 0};
    cam.target = {0, 0, 0};
    cam.up = {0, 0, -1};
    cam.fov_y_degrees = 40;
    cam.width = cam.height = 16;
    ProgressiveAccumulator acc;
    ASSERT_TRUE(acc.allocate(16, 16, 0));
    BruteForceTracer tracer(meshes);
    RenderSettings rs;
    RayCounts counts;
    acc.begin_frame(SceneKeys{});
    render_pixels(scene, tracer, cam, rs, acc, 0, 0, 16, 16, counts);
    acc.end_frame();
    EXPECT_EQ(counts.primary, 256u);
    EXPECT_EQ(counts.shadow, 256u);
    Image<float> img(16, 16, 3);
    ASSERT_TRUE(acc.resolve({}, AmbientLight{}, img.view()));
    for (int y = 0; y < 16; y += 5)
      for (int x = 0; x < 16; x += 5) {
        const TraceRay ray = cam.ray(x + 0.5f, y + 0.5f);
        const TraceHit h = tracer.intersect(ray);
        const SurfacePoint s = interpolate_surface(meshes[0], h, ray.direction);
        const glm::vec3 o = s.position + s.geometric_normal * rs.ray_offset;
        const glm::vec3 to = lights[0].position - o;
        const glm::vec3 want =
            btf->evaluate(s.uv, s.frame.to_local(glm::normalize(to)), s.frame.to_local(-ray.direction)) *
            lights[0].intensity / glm::dot(to, to);
        EXPECT_NEAR(img.at(x, y, 1), want.y, 1e-5f + 1e-4f * std::abs(want.y)) << factorization_name(*rep);
      }
  }
}

}  // namespace
}  // namespace btflod
