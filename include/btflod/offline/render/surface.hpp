// btflod — what a ray tracer needs to shade a hit on a btflod mesh: the ray and hit records any
// tracer can fill (Embree, OptiX, a BVH of one's own, or BruteForceTracer below), validation of
// triangle meshes before they reach a tracer (degenerate and NaN geometry is rejected with a
// message naming the triangle), the interpolated surface at a hit (position, geometric and
// shading normals, uv) and the tangent frame in which btflod's angular interpolators take
// directions (x along ∂p/∂u, z = shading normal).
//
// Meshes use the library's MeshVertex (runtime/backend/backend.hpp): the GPU backends and a tracer
// read the same vertex buffers. Per-hit functions are noexcept, allocation-free and
// thread-safe on const data.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <span>

#include <glm/glm.hpp>

#include "btflod/core/result.hpp"
#include "btflod/runtime/backend/backend.hpp"

namespace btflod {

/// A ray segment: points origin + t·direction for t ∈ (t_min, t_max). direction is unit length.
struct TraceRay {
  glm::vec3 origin{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};
  float t_min = 0.0f;
  float t_max = std::numeric_limits<float>::infinity();
};

/// The closest hit a tracer reports: which mesh and triangle, the distance and the barycentric
/// coordinates (b1, b2) of vertices 1 and 2 of the triangle (vertex 0 has 1 − b1 − b2), the
/// convention of Embree's (u, v) and of Möller–Trumbore.
struct TraceHit {
  bool hit = false;
  float t = 0.0f;
  uint32_t mesh = 0;
  uint32_t triangle = 0;
  float b1 = 0.0f, b2 = 0.0f;
};

/// What the integrator (offline/render/integrator.hpp) asks of a ray tracer: the closest hit along a
/// segment and an any-hit occlusion query. Both must be noexcept and callable concurrently.
template <class T>
concept RayTracer = requires(const T& tracer, const TraceRay& ray) {
  { tracer.intersect(ray) }
  noexcept->std::same_as<TraceHit>;
  { tracer.occluded(ray) }
  noexcept->std::same_as<bool>;
};

/// One mesh of a scene (spans into caller-owned buffers) and its material index.
struct SceneMesh {
  std::span<const MeshVertex> vertices;
  std::span<const uint32_t> indices;
  uint32_t material = 0;
};

/// Checks a triangle mesh before it is handed to a tracer: a non-empty triangle list with valid
/// indices (validate_mesh), every vertex attribute finite, unit-length-able normals, and every
/// triangle of non-zero area (|e1 × e2| > area_epsilon · max(|e1|², |e2|²), so slivers that
/// would make barycentrics and tangent frames meaningless are refused). Returns
/// invalid_argument naming the vertex or triangle. Safe for untrusted data; allocation-free.
inline VoidResult validate_trace_mesh(const SceneMesh& mesh, float area_epsilon = 1e-7f) {
  if (auto ok = validate_mesh(MeshData{mesh.vertices, mesh.indices}); !ok) return ok.error();
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const MeshVertex& v = mesh.vertices[i];
    bool finite = true;
    for (float f : v.position) finite = finite && std::isfinite(f);
    for (float f : v.normal) finite = finite && std::isfinite(f);
    for (float f : v.tangent) finite = finite && std::isfinite(f);
    for (float f : v.uv) finite = finite && std::isfinite(f);
    if (!finite) return make_error(Status::invalid_argument, "mesh vertex %zu has a NaN or infinite attribute", i);
    const glm::vec3 n(v.normal[0], v.normal[1], v.normal[2]);
    if (!(glm::dot(n, n) > 1e-12f)) return make_error(Status::invalid_argument, "mesh vertex %zu has a zero normal", i);
  }
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const auto p = [&](size_t k) {
      const MeshVertex& v = mesh.vertices[mesh.indices[t + k]];
      return glm::vec3(v.position[0], v.position[1], v.position[2]);
    };
    const glm::vec3 e1 = p(1) - p(0), e2 = p(2) - p(0);
    const float area2 = glm::length(glm::cross(e1, e2));
    const float scale = std::max(glm::dot(e1, e1), glm::dot(e2, e2));
    if (!(area2 > area_epsilon * scale) || !(scale > 0.0f))
      return make_error(Status::invalid_argument, "mesh triangle %zu (vertices %u, %u, %u) is degenerate (zero area)",
                        t / 3, mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]);
  }
  return {};
}

/// An orthonormal frame: t (tangent), b (bitangent), n (normal).
struct TangentFrame {
  glm::vec3 t{1, 0, 0}, b{0, 1, 0}, n{0, 0, 1};

  /// World → local (x = t, y = b, z = n), the frame btflod's angular interpolators expect.
  glm::vec3 to_local(glm::vec3 w) const noexcept { return {glm::dot(w, t), glm::dot(w, b), glm::dot(w, n)}; }
  /// Local → world.
  glm::vec3 to_world(glm::vec3 l) const noexcept { return l.x * t + l.y * b + l.z * n; }

  /// Gram–Schmidt frame from a normal and a tangent (tangent.w = handedness: b = w·(n × t), the
  /// MikkTSpace / glTF convention of MeshVertex). When the tangent is (nearly) parallel to the
  /// normal an arbitrary perpendicular is used (Duff et al. 2017), so the result is always
  /// orthonormal. Precondition: n non-zero.
  static TangentFrame from_normal_tangent(glm::vec3 n, glm::vec4 tangent) noexcept {
    TangentFrame f;
    f.n = glm::normalize(n);
    glm::vec3 t = glm::vec3(tangent) - glm::dot(glm::vec3(tangent), f.n) * f.n;
    const float len2 = glm::dot(t, t);
    if (len2 > 1e-12f) {
      t /= std::sqrt(len2);
    } else {
      const float sign = std::copysign(1.0f, f.n.z);
      const float a = -1.0f / (sign + f.n.z), bb = f.n.x * f.n.y * a;
      t = glm::vec3(1.0f + sign * f.n.x * f.n.x * a, sign * bb, -sign * f.n.x);
    }
    f.t = t;
    f.b = glm::cross(f.n, t) * (tangent.w < 0.0f ? -1.0f : 1.0f);
    return f;
  }
};

/// The surface at a hit, as a shader sees it.
struct SurfacePoint {
  glm::vec3 position{0.0f};
  glm::vec3 geometric_normal{0, 0, 1};  ///< unit, faces the incoming ray
  TangentFrame frame;                   ///< shading frame, n on the same side as geometric_normal
  glm::vec2 uv{0.0f};                   ///< interpolated texture coordinates (not wrapped)
  uint32_t material = 0;
};

/// Interpolates the hit's vertex attributes with its barycentrics. Normals and tangents are
/// interpolated then orthonormalised; both normals are flipped to face the ray (two-sided
/// surfaces). The position is recomputed from the barycentrics (more accurate than o + t·d).
/// Preconditions: the mesh passed validate_trace_mesh(), hit.triangle < triangle count.
inline SurfacePoint interpolate_surface(const SceneMesh& mesh, const TraceHit& hit, glm::vec3 ray_direction) noexcept {
  const size_t base = static_cast<size_t>(hit.triangle) * 3;
  const MeshVertex& a = mesh.vertices[mesh.indices[base]];
  const MeshVertex& b = mesh.vertices[mesh.indices[base + 1]];
  const MeshVertex& c = mesh.vertices[mesh.indices[base + 2]];
  const float w0 = 1.0f - hit.b1 - hit.b2, w1 = hit.b1, w2 = hit.b2;
  const auto lerp3 = [&](const float* pa, const float* pb, const float* pc) {
    return glm::vec3(w0 * pa[0] + w1 * pb[0] + w2 * pc[0], w0 * pa[1] + w1 * pb[1] + w2 * pc[1],
                     w0 * pa[2] + w1 * pb[2] + w2 * pc[2]);
  };
  SurfacePoint s;
  s.material = mesh.material;
  s.position = lerp3(a.position, b.position, c.position);
  const glm::vec3 pa(a.position[0], a.position[1], a.position[2]);
  const glm::vec3 pb(b.position[0], b.position[1], b.position[2]);
  const glm::vec3 pc(c.position[0], c.position[1], c.position[2]);
  glm::vec3 ng = glm::normalize(glm::cross(pb - pa, pc - pa));
  if (glm::dot(ng, ray_direction) > 0.0f) ng = -ng;
  s.geometric_normal = ng;
  glm::vec3 ns = lerp3(a.normal, b.normal, c.normal);
  if (!(glm::dot(ns, ns) > 1e-12f)) ns = ng;
  if (glm::dot(ns, ng) < 0.0f) ns = -ns;
  const glm::vec3 tan = lerp3(a.tangent, b.tangent, c.tangent);
  const float w = w0 * a.tangent[3] + w1 * b.tangent[3] + w2 * c.tangent[3];
  s.frame = TangentFrame::from_normal_tangent(ns, glm::vec4(tan, w));
  s.uv = glm::vec2(w0 * a.uv[0] + w1 * b.uv[0] + w2 * c.uv[0], w0 * a.uv[1] + w1 * b.uv[1] + w2 * c.uv[1]);
  return s;
}

/// A tracer without acceleration structure: every ray is tested against every triangle
/// (Möller–Trumbore). O(triangles) per ray — for tests and as an oracle for a real tracer on
/// small scenes. Holds spans to caller-owned meshes; intersect()/occluded() are noexcept,
/// allocation-free and thread-safe. Satisfies RayTracer.
class BruteForceTracer {
 public:
  /// Traces `meshes` (not copied: they must outlive the tracer).
  explicit BruteForceTracer(std::span<const SceneMesh> meshes) noexcept : meshes_(meshes) {}

  /// Closest hit in (t_min, t_max).
  TraceHit intersect(const TraceRay& ray) const noexcept {
    TraceHit best;
    float t_max = ray.t_max;
    for (uint32_t m = 0; m < meshes_.size(); ++m) {
      const SceneMesh& mesh = meshes_[m];
      for (uint32_t tri = 0; tri * 3 + 2 < mesh.indices.size(); ++tri) {
        float t, b1, b2;
        if (intersect_triangle(mesh, tri, ray, t_max, t, b1, b2)) {
          best = TraceHit{true, t, m, tri, b1, b2};
          t_max = t;
        }
      }
    }
    return best;
  }
  /// True when anything lies in (t_min, t_max).
  bool occluded(const TraceRay& ray) const noexcept {
    for (const SceneMesh& mesh : meshes_)
      for (uint32_t tri = 0; tri * 3 + 2 < mesh.indices.size(); ++tri) {
        float t, b1, b2;
        if (intersect_triangle(mesh, tri, ray, ray.t_max, t, b1, b2)) return true;
      }
    return false;
  }

 private:
  bool intersect_triangle(const SceneMesh& mesh, uint32_t tri, const TraceRay& ray, float t_max, float& t, float& b1,
                          float& b2) const noexcept {
    const auto p = [&](int k) {
      const MeshVertex& v = mesh.vertices[mesh.indices[static_cast<size_t>(tri) * 3 + static_cast<size_t>(k)]];
      return glm::vec3(v.position[0], v.position[1], v.position[2]);
    };
    const glm::vec3 p0 = p(0), e1 = p(1) - p0, e2 = p(2) - p0;
    const glm::vec3 pv = glm::cross(ray.direction, e2);
    const float det = glm::dot(e1, pv);
    if (std::abs(det) < 1e-12f) return false;
    const float inv = 1.0f / det;
    const glm::vec3 tv = ray.origin - p0;
    b1 = glm::dot(tv, pv) * inv;
    if (b1 < 0.0f || b1 > 1.0f) return false;
    const glm::vec3 qv = glm::cross(tv, e1);
    b2 = glm::dot(ray.direction, qv) * inv;
    if (b2 < 0.0f || b1 + b2 > 1.0f) return false;
    t = glm::dot(e2, qv) * inv;
    return t > ray.t_min && t < t_max;
  }

  std::span<const SceneMesh> meshes_;
};

}  // namespace btflod
