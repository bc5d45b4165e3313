// Tests for offline/render/integrator.hpp at 64 × 64 with the brute-force tracer: ambient occlusion of
// an unoccluded plane is exactly 1 and of a point deep inside a closed box (radius beyond the
// walls) exactly 0; a tiny area light converges to the matching point light; the RMSE against
// a 1024-frame reference after 64 frames is at most 1/3 of the RMSE after 4 frames; the buffers
// reset exactly on camera, geometry and light-position changes and not on radiance or
// intensity changes (which show at display); replays are bit-identical and do not depend on
// tiling or thread count; mirrors reflect once per bounce; bad scenes are rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "btflod/offline/metrics/image_metrics.hpp"
#include "btflod/offline/render/integrator.hpp"
#include "btflod/offline/render/owned_scene.hpp"
#include "btflod/offline/render/primitives.hpp"

namespace btflod {
namespace {

constexpr uint32_t kSize = 64;

using TestScene = OwnedScene;

/// A 2 × 2 × 2 room (inward faces, white) with a 0.6 × 0.6 ceiling light and a block on the floor.
TestScene cornell_box() {
  TestScene s;
  s.materials = {SurfaceMaterial::lambertian(glm::vec3(0.7f)),
                 SurfaceMaterial::lambertian(glm::vec3(0.6f, 0.3f, 0.2f))};
  s.add(make_box({-1, -1, -1}, {1, 1, 1}, true), 0);
  s.add(make_box({-0.5f, -1.0f, -0.4f}, {0.1f, -0.3f, 0.2f}, false), 1);
  s.areas.push_back(AreaLight{{-0.3f, 0.99f, -0.3f}, {0.6f, 0, 0}, {0, 0, 0.6f}, glm::vec3(5.0f)});
  s.ambient = AmbientLight{glm::vec3(0.3f), 0.5f};
  return s;
}

// A kSize × kSize camera at eye looking at target.
PinholeCamera square_camera(glm::vec3 eye, glm::vec3 target, float fov_y_degrees = PinholeCamera{}.fov_y_degrees) {
  PinholeCamera c;
  c.eye = eye;
  c.target = target;
  c.fov_y_degrees = fov_y_degrees;
  c.width = c.height = kSize;
  return c;
}

PinholeCamera room_camera() { return square_camera({0.0f, 0.0f, 0.95f}, {0.0f, -0.2f, -1.0f}, 75.0f); }

SceneKeys keys_of(const TestScene& s, const PinholeCamera& c, uint64_t geometry = 1) {
  return SceneKeys{hash_camera(c), geometry, hash_light_geometry(s.points, s.areas)};
}

/// Renders `frames` frames; threads > 1 splits the image into tile × tile squares handed out
/// round-robin.
void render(const TestScene& ts, const PinholeCamera& cam, const RenderSettings& settings, ProgressiveAccumulator& acc,
            uint32_t frames, unsigned threads = 1, uint32_t tile = kSize) {
  const RenderScene scene = ts.view();
  BruteForceTracer tracer(scene.meshes);
  for (uint32_t f = 0; f < frames; ++f) {
    acc.begin_frame(keys_of(ts, cam));
    const uint32_t tiles_x = (cam.width + tile - 1) / tile, tiles_y = (cam.height + tile - 1) / tile;
    auto work = [&](unsigned worker) {
      RayCounts counts;
      for (uint32_t t = worker; t < tiles_x * tiles_y; t += threads) {
        const uint32_t x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
        render_pixels(scene, tracer, cam, settings, acc, x0, y0, std::min(x0 + tile, cam.width),
                      std::min(y0 + tile, cam.height), counts);
      }
    };
    std::vector<std::thread> pool;
    for (unsigned w = 1; w < threads; ++w) pool.emplace_back(work, w);
    work(0);
    for (auto& t : pool) t.join();
    acc.end_frame();
  }
}

Image<float> resolved(const TestScene& ts, const ProgressiveAccumulator& acc) {
  Image<float> img(static_cast<int>(acc.width()), static_cast<int>(acc.height()), 3);
  EXPECT_TRUE(acc.resolve(ts.areas, ts.ambient, img.view()));
  return img;
}

TEST(RenderIntegrator, SceneIsValid) { EXPECT_TRUE(validate_render_scene(cornell_box().view())); }

TEST(RenderIntegrator, AmbientOcclusionOfAnUnoccludedPlaneIsOne) {
  TestScene s;
  s.materials = {SurfaceMaterial::lambertian(glm::vec3(0.5f))};
  s.add(make_quad({-4, 0, 4}, {8, 0, 0}, {0, 0, -8}, {1, 1}, 2), 0);
  s.ambient = AmbientLight{glm::vec3(0.8f), 10.0f};
  const PinholeCamera cam = square_camera({0, 2, 0.5f}, {0, 0, 0});
  ProgressiveAccumulator acc;
  ASSERT_TRUE(acc.allocate(kSize, kSize, 0));
  RenderSettings rs;
  render(s, cam, rs, acc, 16);
  const Image<float> img = resolved(s, acc);
  for (uint32_t y = 0; y < kSize; ++y)
    for (uint32_t x = 0; x < kSize; ++x) {
      ASSERT_EQ(acc.ambient_occlusion(x, y), 1.0f) << x << "," << y;
      ASSERT_FLOAT_EQ(img.at(static_cast<int>(x), static_cast<int>(y), 0), 0.5f * 0.8f);
    }
}

TEST(RenderIntegrator, AmbientOcclusionDeepInAClosedBoxIsZero) {
  TestScene s;
  s.materials = {SurfaceMaterial::lambertian(glm::vec3(0.5f))};
  s.add(make_box({-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}, true), 0);
  s.ambient = AmbientLight{glm::vec3(1.0f), 3.0f};  // beyond the farthest wall (√3)
  const PinholeCamera cam = square_camera({0, 0, 0}, {0.2f, -0.3f, -1}, 90.0f);
  ProgressiveAccumulator acc;
  ASSERT_TRUE(acc.allocate(kSize, kSize, 0));
  render(s, cam, RenderSettings{}, acc, 16);
  for (uint32_t y = 0; y < kSize; ++y)
    for (uint32_t x = 0; x < kSize; ++x) ASSERT_EQ(acc.ambient_occlusion(x, y), 0.0f) << x << "," << y;
  // A radius far shorter than the box: every ray escapes except near edges and corners.
  s.ambient.radius = 1e-3f;
  acc.clear();
  render(s, cam, RenderSettings{}, acc, 4);
  EXPECT_EQ(acc.ambient_occlusion(kSize / 2, kSize / 2), 1.0f);
}

TEST(RenderIntegrator, TinyAreaLightConvergesToPointLight) {
  TestScene s;
  s.materials = {SurfaceMaterial::lambertian(glm::vec3(0.6f))};
  s.add(make_quad({-2, 0, 2}, {4, 0, 0}, {0, 0, -4}), 0);
  const glm::vec3 c(0.1f, 1.0f, -0.1f);
  const float side = 0.01f, radiance = 2000.0f;
  // Facing down: edge_u × edge_v = x × z = −y.
  s.areas.push_back(AreaLight{c - glm::vec3(side / 2, 0, side / 2), {side, 0, 0}, {0, 0, side}, glm::vec3(radiance)});
  s.ambient = AmbientLight{glm::vec3(0.0f), 1.0f};
  PinholeCamera cam = square_camera({0.0f, 3.0f, 0.0f}, {0, 0, 0}, 40.0f);
  cam.up = {0, 0, -1};
  RenderSettings rs;
  rs.ambient_occlusion = false;
  ProgressiveAccumulator acc;
  ASSERT_TRUE(acc.allocate(kSize, kSize, 1));
  render(s, cam, rs, acc, 64);
  const Image<float> area = resolved(s, acc);

  // The matching point light: intensity L_e·A along the light's normal; the area light's
  // emission falls off with cos θ_l, the isotropic point light's does not.
  TestScene p = s;
  p.areas.clear();
  p.points.push_back(PointLight{c, glm::vec3(radiance * side * side)});
  ProgressiveAccumulator pacc;
  ASSERT_TRUE(pacc.allocate(kSize, kSize, 0));
  render(p, cam, rs, pacc, 1);
  const Image<float> point = resolved(p, pacc);
  BruteForceTracer tracer(p.meshes);
  int compared = 0;
  for (uint32_t y = 0; y < kSize; ++y)
    for (uint32_t x = 0; x < kSize; ++x) {
      const TraceRay ray = cam.ray(x + 0.5f, y + 0.5f);
      const TraceHit h = tracer.intersect(ray);
      ASSERT_TRUE(h.hit);
      const glm::vec3 pos = ray.origin + h.t * ray.direction;
      const float cos_l = glm::normalize(c - pos).y;
      const float expected = point.at(static_cast<int>(x), static_cast<int>(y), 0) * cos_l;
      ASSERT_GT(expected, 0.0f);
      EXPECT_NEAR(area.at(static_cast<int>(x), static_cast<int>(y), 0), expected, 0.01f * expected) << x << "," << y;
      ++compared;
    }
  EXPECT_EQ(compared, static_cast<int>(kSize * kSize));
}

TEST(RenderIntegrator, ErrorFallsAsOneOverSqrtFrames) {
  const TestScene s = cornell_box();
  const PinholeCamera cam = room_camera();
  ProgressiveAccumulator ref;
  ASSERT_TRUE(ref.allocate(kSize, kSize, 1));
  RenderSettings rs_ref;
  rs_ref.seed = 1234567;
  render(s, cam, rs_ref, ref, 1024, 2, 16);
  const Image<float> reference = resolved(s, ref);
  ProgressiveAccumulator acc;
  ASSERT_TRUE(acc.allocate(kSize, kSize, 1));
  RenderSettings rs;
  rs.seed = 7;
  render(s, cam, rs, acc, 4, 2, 16);
  const double rmse4 = rmse(resolved(s, acc).view(), reference.view());
  render(s, cam, rs, acc, 60, 2, 16);
  ASSERT_EQ(acc.frames(), 64u);
  const double rmse64 = rmse(resolved(s, acc).view(), reference.view());
  EXPECT_GT(rmse4, 0.0);
  EXPECT_LE(rmse64, rmse4 / 3.0) << "rmse(4) " << rmse4 << " rmse(64) " << rmse64;
  // Each term alone converges as well.
  for (int term = 0; term < 2; ++term) {
    RenderSettings only = rs;
    only.area_lights = term == 0;
    only.ambient_occlusion = term == 1;
    RenderSettings only_ref = rs_ref;
    only_ref.area_lights = only.area_lights;
    only_ref.ambient_occlusion = only.ambient_occlusion;
    ProgressiveAccumulator r2, a2;
    ASSERT_TRUE(r2.allocate(kSize, kSize, 1));
    ASSERT_TRUE(a2.allocate(kSize, kSize, 1));
    render(s, cam, only_ref, r2, 256, 2, 16);
    const Image<float> ref2 = resolved(s, r2);
    render(s, cam, only, a2, 4, 2, 16);
    const double e4 = rmse(resolved(s, a2).view(), ref2.view());
    render(s, cam, only, a2, 12, 2, 16);
    const double e16 = rmse(resolved(s, a2).view(), ref2.view());
    EXPECT_LT(e16, e4 * 0.7) << "term " << term;
  }
}

TEST(RenderIntegrator, ResetsExactlyOnCameraGeometryAndLightPosition) {
  TestScene s = cornell_box();
  s.points.push_back(PointLight{{0.5f, 0.5f, 0.0f}, glm::vec3(0.5f)});
  PinholeCamera cam = room_camera();
  ProgressiveAccumulator acc;
  ASSERT_TRUE(acc.allocate(kSize, kSize, 1));
  EXPECT_EQ(acc.begin_frame(keys_of(s, cam)), ResetReason::first_frame);
  acc.end_frame();
  EXPECT_EQ(acc.begin_frame(keys_of(s, cam)), ResetReason::none);
  acc.end_frame();
  EXPECT_EQ(acc.frames(), 2u);
  // Emission changes keep the accumulation.
  s.areas[0].radiance *= 3.0f;
  s.points[0].intensity *= 2.0f;
  s.ambient.radiance *= 0.5f;
  EXPECT_EQ(acc.begin_frame(keys_of(s, cam)), ResetReason::none);
  acc.end_frame();
  EXPECT_EQ(acc.frames(), 3u);
  // A light moves.
  s.areas[0].corner.x += 0.01f;
  EXPECT_EQ(acc.begin_frame(keys_of(s, cam)), ResetReason::light_position);
  EXPECT_EQ(acc.frames(), 0u);
  acc.end_frame();
  s.points[0].position.y -= 0.1f;
  EXPECT_EQ(acc.begin_frame(keys_of(s, cam)), ResetReason::light_position);
  acc.end_frame();
  // Camera and geometry.
  cam.eye.x += 1e-3f;
  EXPECT_EQ(acc.begin_frame(keys_of(s, cam)), ResetReason::camera);
  acc.end_frame();
  EXPECT_EQ(acc.begin_frame(keys_of(s, cam, 2)), ResetReason::geometry);
  acc.end_frame();
  EXPECT_EQ(acc.begin_frame(keys_of(s, cam, 2)), ResetReason::none);
}

TEST(RenderIntegrator, RadianceChangeShowsWithoutReset) {
  TestScene s = cornell_box();
  const PinholeCamera cam = room_camera();
  RenderSettings rs;
  rs.ambient_occlusion = false;
  ProgressiveAccumulator acc;
  ASSERT_TRUE(acc.allocate(kSize, kSize, 1));
  render(s, cam, rs, acc, 8);
  const Image<float> before = resolved(s, acc);
  s.areas[0].radiance *= 2.0f;
  render(s, cam, rs, acc, 8);  // same keys: keeps accumulating
  ASSERT_EQ(acc.frames(), 16u);
  const Image<float> after = resolved(s, acc);
  // Pixels lit only through the area light double (the light itself, seen directly, too).
  double sum_b = 0, sum_a = 0;
  for (size_t i = 0; i < before.size(); ++i) sum_b += before.elements()[i], sum_a += after.elements()[i];
  EXPECT_GT(sum_b, 0.0);
  EXPECT_NEAR(sum_a / sum_b, 2.0, 0.15);  // 16 vs 8 samples: noise, not a reset
}

TEST(RenderIntegrator, ReplaysAreBitIdenticalForAnyThreadCountAndTiling) {
  TestScene s = cornell_box();
  s.points.push_back(PointLight{{0.5f, 0.5f, 0.0f}, glm::vec3(0.5f)});
  const PinholeCamera cam = room_camera();
  RenderSettings rs;
  rs.seed = 99;
  ProgressiveAccumulator a, b, c;
  ASSERT_TRUE(a.allocate(kSize, kSize, 1));
  ASSERT_TRUE(b.allocate(kSize, kSize, 1));
  ASSERT_TRUE(c.allocate(kSize, kSize, 1));
  render(s, cam, rs, a, 6, 1, kSize);
  render(s, cam, rs, b, 6, 1, kSize);
  render(s, cam, rs, c, 6, 3, 8);
  const Image<float> ia = resolved(s, a), ib = resolved(s, b), ic = resolved(s, c);
  ASSERT_EQ(ia.size(), ic.size());
  EXPECT_EQ(std::memcmp(ia.data(), ib.data(), ia.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(ia.data(), ic.data(), ia.size() * sizeof(float)), 0);
  // A different seed changes the noise.
  ProgressiveAccumulator d;
  ASSERT_TRUE(d.allocate(kSize, kSize, 1));
  rs.seed = 100;
  render(s, cam, rs, d, 6, 1, kSize);
  const Image<float> id = resolved(s, d);
  EXPECT_NE(std::memcmp(ia.data(), id.data(), ia.size() * sizeof(float)), 0);
}

TEST(RenderIntegrator, MirrorsReflectOncePerBounce) {
  TestScene s;
  s.materials = {SurfaceMaterial::mirror(glm::vec3(0.5f, 0.25f, 1.0f))};
  s.add(make_quad({-4, 0, 4}, {8, 0, 0}, {0, 0, -8}), 0);
  s.background = glm::vec3(1.0f, 0.8f, 0.6f);
  const PinholeCamera cam = square_camera({0, 1, 1}, {0, 0, 0}, 30.0f);
  ProgressiveAccumulator acc;
  ASSERT_TRUE(acc.allocate(kSize, kSize, 0));
  render(s, cam, RenderSettings{}, acc, 1);
  Image<float> img = resolved(s, acc);
  EXPECT_FLOAT_EQ(img.at(32, 32, 0), 0.5f);
  EXPECT_FLOAT_EQ(img.at(32, 32, 1), 0.2f);
  EXPECT_FLOAT_EQ(img.at(32, 32, 2), 0.6f);
  RenderSettings none;
  none.max_mirror_bounces = 0;
  acc.clear();
  render(s, cam, none, acc, 1);
  img = resolved(s, acc);
  EXPECT_EQ(img.at(32, 32, 0), 0.0f);
}

TEST(RenderIntegrator, BadScenesAreRejected) {
  TestScene s = cornell_box();
  s.data[1].vertices[0].position[0] = std::nanf("");
  auto r = validate_render_scene(s.view());
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("mesh 1"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("NaN"), std::string::npos) << r.message();
  s = cornell_box();
  s.meshes[0].material = 7;
  EXPECT_FALSE(validate_render_scene(s.view()));
  s = cornell_box();
  s.areas[0].edge_v = glm::vec3(0.3f, 0, 0.6f);  // not perpendicular
  EXPECT_FALSE(validate_render_scene(s.view()));
  s = cornell_box();
  s.areas[0].radiance.x = -1.0f;
  EXPECT_FALSE(validate_render_scene(s.view()));
  s = cornell_box();
  s.ambient.radius = std::nanf("");
  EXPECT_FALSE(validate_render_scene(s.view()));
  s = cornell_box();
  s.materials[0] = SurfaceMaterial{SurfaceMaterial::Kind::btf, {}, nullptr, {}};
  EXPECT_FALSE(validate_render_scene(s.view()));
  ProgressiveAccumulator acc;
  EXPECT_FALSE(acc.allocate(0, 4, 0));
  Image<float> wrong(3, 3, 3);
  ASSERT_TRUE(acc.allocate(4, 4, 1));
  EXPECT_FALSE(acc.resolve({}, AmbientLight{}, wrong.view()));
}

}  // namespace
}  // namespace btflod
