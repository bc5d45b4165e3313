// Tests for offline/render/surface.hpp and offline/render/primitives.hpp: degenerate and NaN geometry is
// rejected with a message naming it; tangent frames are orthonormal with the MeshVertex
// handedness; hits of the brute-force tracer against analytic geometry (plane: exact
// position, normal and uv; sphere: on the sphere within the tessellation error, normal along
// the radius); closed boxes face inwards.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "btflod/offline/render/primitives.hpp"
#include "btflod/offline/render/surface.hpp"

namespace btflod {
namespace {

TEST(RenderSurface, ValidMeshesPass) {
  const auto quad = make_quad({0, 0, 0}, {1, 0, 0}, {0, 0, -1}, {1, 1}, 3);
  EXPECT_TRUE(validate_trace_mesh(quad.mesh(0)));
  const auto sphere = make_uv_sphere({0, 0, 0}, 1.0f, 16, 8);
  EXPECT_TRUE(validate_trace_mesh(sphere.mesh(0)));
  EXPECT_TRUE(validate_trace_mesh(make_box({0, 0, 0}, {1, 1, 1}, true).mesh(0)));
}

TEST(RenderSurface, NanPositionIsRejected) {
  auto quad = make_quad({0, 0, 0}, {1, 0, 0}, {0, 0, -1});
  quad.vertices[2].position[1] = std::nanf("");
  const auto r = validate_trace_mesh(quad.mesh(0));
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::invalid_argument);
  EXPECT_NE(r.message().find("vertex 2"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("NaN"), std::string::npos) << r.message();
}

TEST(RenderSurface, InfiniteUvAndZeroNormalAreRejected) {
  auto quad = make_quad({0, 0, 0}, {1, 0, 0}, {0, 0, -1});
  quad.vertices[1].uv[0] = INFINITY;
  EXPECT_FALSE(validate_trace_mesh(quad.mesh(0)));
  quad = make_quad({0, 0, 0}, {1, 0, 0}, {0, 0, -1});
  quad.vertices[0].normal[0] = quad.vertices[0].normal[1] = quad.vertices[0].normal[2] = 0.0f;
  const auto r = validate_trace_mesh(quad.mesh(0));
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("zero normal"), std::string::npos) << r.message();
}

TEST(RenderSurface, DegenerateTrianglesAreRejected) {
  auto quad = make_quad({0, 0, 0}, {1, 0, 0}, {0, 0, -1});
  // Triangle 1 with a repeated vertex.
  quad.indices[4] = quad.indices[3];
  auto r = validate_trace_mesh(quad.mesh(0));
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("triangle 1"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("degenerate"), std::string::npos) << r.message();
  // Collinear but distinct vertices.
  TriangleMeshData line;
  for (int i = 0; i < 3; ++i) line.vertices.push_back(make_vertex({float(i), 0, 0}, {0, 1, 0}, {1, 0, 0, 1}, {0, 0}));
  line.indices = {0, 1, 2};
  r = validate_trace_mesh(line.mesh(0));
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("degenerate"), std::string::npos) << r.message();
}

TEST(RenderSurface, BadIndicesAndEmptyMeshesAreRejected) {
  auto quad = make_quad({0, 0, 0}, {1, 0, 0}, {0, 0, -1});
  quad.indices[5] = 99;
  EXPECT_FALSE(validate_trace_mesh(quad.mesh(0)));
  quad.indices.pop_back();
  EXPECT_FALSE(validate_trace_mesh(quad.mesh(0)));
  EXPECT_FALSE(validate_trace_mesh(SceneMesh{}));
}

TEST(RenderSurface, TangentFrameIsOrthonormalWithHandedness) {
  const auto f = TangentFrame::from_normal_tangent({0, 2, 0}, {1, 0.5f, 0, 1});
  EXPECT_NEAR(glm::length(f.t), 1, 1e-6);
  EXPECT_NEAR(glm::length(f.b), 1, 1e-6);
  EXPECT_NEAR(glm::dot(f.t, f.n), 0, 1e-6);
  EXPECT_NEAR(glm::dot(f.b, f.n), 0, 1e-6);
  EXPECT_NEAR(f.t.x, 1, 1e-6);   // the tangent's part off the normal
  EXPECT_NEAR(f.b.z, -1, 1e-6);  // n × t = +y × +x = −z for w = +1
  const auto g = TangentFrame::from_normal_tangent({0, 1, 0}, {1, 0, 0, -1});
  EXPECT_NEAR(g.b.z, 1, 1e-6);
  // Round trip.
  const glm::vec3 w = glm::normalize(glm::vec3(0.3f, 0.8f, -0.2f));
  const glm::vec3 back = f.to_world(f.to_local(w));
  EXPECT_NEAR(glm::length(back - w), 0, 1e-6);
  // Tangent parallel to the normal: still orthonormal.
  const auto h = TangentFrame::from_normal_tangent({0, 0, -1}, {0, 0, 1, 1});
  EXPECT_NEAR(glm::dot(h.t, h.n), 0, 1e-6);
  EXPECT_NEAR(glm::length(h.t), 1, 1e-6);
  EXPECT_NEAR(glm::length(glm::cross(h.t, h.b) - h.n), 0, 1e-5);
}

TEST(RenderSurface, PlaneHitsMatchAnalyticGeometry) {
  // Quad y = 0.5 over x ∈ [−2, 2], z ∈ [−2, 2] (normal +y), 4 × 4 cells, uv repeat 2.
  const auto quad = make_quad({-2, 0.5f, 2}, {4, 0, 0}, {0, 0, -4}, {2, 2}, 4);
  const SceneMesh meshes[] = {quad.mesh(3)};
  BruteForceTracer tracer(meshes);
  for (int i = 0; i < 64; ++i) {
    const glm::vec3 o(-1.5f + 0.05f * i, 3.0f, 1.0f - 0.03f * i);
    const glm::vec3 d = glm::normalize(glm::vec3(0.1f, -1.0f, -0.05f * (i % 7)));
    const TraceHit h = tracer.intersect(TraceRay{o, d});
    ASSERT_TRUE(h.hit);
    const float t = (0.5f - o.y) / d.y;
    EXPECT_NEAR(h.t, t, 1e-4f);
    const SurfacePoint s = interpolate_surface(meshes[h.mesh], h, d);
    const glm::vec3 p = o + t * d;
    EXPECT_NEAR(glm::length(s.position - p), 0.0f, 1e-4f);
    EXPECT_NEAR(s.geometric_normal.y, 1.0f, 1e-6f);
    EXPECT_NEAR(s.frame.n.y, 1.0f, 1e-6f);
    EXPECT_NEAR(s.uv.x, (p.x + 2.0f) / 4.0f * 2.0f, 1e-4f);
    EXPECT_NEAR(s.uv.y, (2.0f - p.z) / 4.0f * 2.0f, 1e-4f);
    EXPECT_EQ(s.material, 3u);
  }
  // From below the normal flips towards the ray; misses miss.
  const TraceHit below = tracer.intersect(TraceRay{{0, -1, 0}, {0, 1, 0}});
  ASSERT_TRUE(below.hit);
  EXPECT_NEAR(interpolate_surface(meshes[0], below, {0, 1, 0}).geometric_normal.y, -1.0f, 1e-6f);
  EXPECT_FALSE(tracer.intersect(TraceRay{{5, 3, 0}, {0, -1, 0}}).hit);
  EXPECT_FALSE(tracer.intersect(TraceRay{{0, 3, 0}, {0, -1, 0}, 0.0f, 2.0f}).hit);  // t_max before the plane
  EXPECT_TRUE(tracer.occluded(TraceRay{{0, 3, 0}, {0, -1, 0}, 0.0f, 3.0f}));
  EXPECT_FALSE(tracer.occluded(TraceRay{{0, 3, 0}, {0, 1, 0}}));
}

TEST(RenderSurface, SphereHitsMatchAnalyticGeometry) {
  const glm::vec3 c(0.2f, -0.1f, 0.3f);
  const float r = 1.3f;
  const auto sphere = make_uv_sphere(c, r, 128, 64);
  const SceneMesh meshes[] = {sphere.mesh(0)};
  BruteForceTracer tracer(meshes);
  // Chord error of the tessellation: r·(1 − cos(π/64)) ≈ 1.6e-3.
  const float tess = r * (1.0f - std::cos(kPi / 64.0f)) * 1.05f;
  int hits = 0;
  for (int i = 0; i < 16; ++i)
    for (int j = 0; j < 16; ++j) {
      const glm::vec3 o(c.x - 1.5f + 3.0f * (i + 0.5f) / 16, c.y - 1.5f + 3.0f * (j + 0.5f) / 16, c.z + 5.0f);
      const glm::vec3 d(0, 0, -1);
      const TraceHit h = tracer.intersect(TraceRay{o, d});
      const glm::vec2 q(o.x - c.x, o.y - c.y);
      const float q2 = glm::dot(q, q);
      if (q2 > (r - 2 * tess) * (r - 2 * tess) && q2 < (r + 2 * tess) * (r + 2 * tess)) continue;  // silhouette band
      ASSERT_EQ(h.hit, q2 < r * r) << i << " " << j;
      if (!h.hit) continue;
      ++hits;
      const SurfacePoint s = interpolate_surface(meshes[0], h, d);
      const float analytic_t = 5.0f - std::sqrt(r * r - q2);
      EXPECT_NEAR(h.t, analytic_t, tess / std::max(0.2f, std::sqrt(1.0f - q2 / (r * r))));
      EXPECT_NEAR(glm::length(s.position - c), r, tess);
      const glm::vec3 radial = glm::normalize(s.position - c);
      EXPECT_GT(glm::dot(s.frame.n, radial), 0.9995f);
      EXPECT_GT(glm::dot(s.geometric_normal, radial), 0.995f);
      EXPECT_NEAR(glm::dot(s.frame.t, s.frame.n), 0.0f, 1e-5f);
    }
  EXPECT_GT(hits, 100);
}

TEST(RenderSurface, InsideBoxFacesInwards) {
  const auto box = make_box({-1, -1, -1}, {1, 1, 1}, true, 2);
  const SceneMesh meshes[] = {box.mesh(0)};
  BruteForceTracer tracer(meshes);
  const glm::vec3 dirs[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const glm::vec3& d : dirs) {
    const TraceHit h = tracer.intersect(TraceRay{{0.1f, 0.2f, -0.15f}, d});
    ASSERT_TRUE(h.hit);
    const MeshVertex& v = box.vertices[box.indices[h.triangle * 3]];
    EXPECT_NEAR(glm::dot(glm::vec3(v.normal[0], v.normal[1], v.normal[2]), d), -1.0f, 1e-6f);
  }
}

}  // namespace
}  // namespace btflod
