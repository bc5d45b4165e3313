// btflod — triangle meshes of simple shapes with uv and tangent frames (MeshVertex), for ray
// tracers and rasterisers alike: a subdivided parallelogram, a UV sphere and an axis-aligned
// box seen from inside or outside. Tangents follow MeshVertex's convention: tangent.xyz along
// ∂p/∂u, bitangent = tangent.w · (n × t) along ∂p/∂v. Set-up code: allocates.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/offline/math/math.hpp"
#include "btflod/offline/render/surface.hpp"
#include "btflod/runtime/backend/backend.hpp"

namespace btflod {

/// An owned triangle mesh; mesh(material) gives the SceneMesh view a tracer reads.
struct TriangleMeshData {
  std::vector<MeshVertex> vertices;
  std::vector<uint32_t> indices;
  /// The tracer's view of this mesh (spans into it: valid while it lives and is not resized).
  SceneMesh mesh(uint32_t material) const noexcept { return SceneMesh{vertices, indices, material}; }
  /// Number of triangles (indices / 3).
  size_t triangle_count() const noexcept { return indices.size() / 3; }
  /// Appends another mesh (indices rebased). Allocates; invalidates earlier mesh() views.
  void append(const TriangleMeshData& o) {
    const auto base = static_cast<uint32_t>(vertices.size());
    vertices.insert(vertices.end(), o.vertices.begin(), o.vertices.end());
    for (uint32_t i : o.indices) indices.push_back(base + i);
  }
};

/// One vertex from vectors.
inline MeshVertex make_vertex(glm::vec3 p, glm::vec3 n, glm::vec4 t, glm::vec2 uv) noexcept {
  return MeshVertex{{p.x, p.y, p.z}, {n.x, n.y, n.z}, {t.x, t.y, t.z, t.w}, {uv.x, uv.y}};
}

/// The parallelogram corner + s·edge_u + t·edge_v, s, t ∈ [0, 1], as a grid of
/// `subdivisions`² cells (2 triangles each), facing normalize(edge_u × edge_v), uv = (s, t) ·
/// uv_repeat. Precondition: edges non-zero and not parallel; subdivisions ≥ 1.
inline TriangleMeshData make_quad(glm::vec3 corner, glm::vec3 edge_u, glm::vec3 edge_v, glm::vec2 uv_repeat = {1, 1},
                                  uint32_t subdivisions = 1) {
  TriangleMeshData m;
  const uint32_t n = subdivisions < 1 ? 1 : subdivisions;
  const glm::vec3 normal = glm::normalize(glm::cross(edge_u, edge_v));
  const glm::vec4 tangent(glm::normalize(edge_u), 1.0f);  // n × t points along edge_v
  for (uint32_t j = 0; j <= n; ++j)
    for (uint32_t i = 0; i <= n; ++i) {
      const float s = static_cast<float>(i) / static_cast<float>(n), t = static_cast<float>(j) / static_cast<float>(n);
      m.vertices.push_back(make_vertex(corner + s * edge_u + t * edge_v, normal, tangent, glm::vec2(s, t) * uv_repeat));
    }
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  return m;
}

/// A UV sphere: `segments` around (u = azimuth / 2π), `rings` from pole to pole (v = polar
/// angle / π), outward normals, tangent along increasing azimuth. Pole triangles that would be
/// degenerate are left out. Precondition: segments ≥ 3, rings ≥ 2, radius > 0.
inline TriangleMeshData make_uv_sphere(glm::vec3 center, float radius, uint32_t segments, uint32_t rings,
                                       glm::vec2 uv_repeat = {1, 1}) {
  TriangleMeshData m;
  for (uint32_t j = 0; j <= rings; ++j) {
    const float v = static_cast<float>(j) / static_cast<float>(rings), theta = v * kPi;
    for (uint32_t i = 0; i <= segments; ++i) {
      const float u = static_cast<float>(i) / static_cast<float>(segments), phi = u * kTwoPi;
      const glm::vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      const glm::vec4 t(-std::sin(phi), 0.0f, std::cos(phi), 1.0f);
      m.vertices.push_back(make_vertex(center + radius * n, n, t, glm::vec2(u, v) * uv_repeat));
    }
  }
  const uint32_t row = segments + 1;
  for (uint32_t j = 0; j < rings; ++j)
    for (uint32_t i = 0; i < segments; ++i) {
      const uint32_t a = j * row + i, b = a + 1, c = a + row, d = c + 1;
      if (j != 0) m.indices.insert(m.indices.end(), {a, b, c});
      if (j + 1 != rings) m.indices.insert(m.indices.end(), {b, d, c});
    }
  return m;
}

/// The six faces of the box [lo, hi] (`subdivisions`² cells each); normals point inwards when
/// `inside` (a room), outwards otherwise. Precondition: lo < hi on every axis.
inline TriangleMeshData make_box(glm::vec3 lo, glm::vec3 hi, bool inside, uint32_t subdivisions = 1) {
  TriangleMeshData m;
  const glm::vec3 e = hi - lo;
  const glm::vec3 ex(e.x, 0, 0), ey(0, e.y, 0), ez(0, 0, e.z);
  // Outward-facing faces: corner, edge_u, edge_v with edge_u × edge_v pointing out.
  const glm::vec3 faces[6][3] = {{lo, ex, ez},      {lo + ey, ez, ex}, {lo, ey, ex},
                                 {lo + ez, ex, ey}, {lo, ez, ey},      {lo + ex, ey, ez}};
  for (const auto& f : faces) {
    if (inside)
      m.append(make_quad(f[0], f[2], f[1], {1, 1}, subdivisions));
    else
      m.append(make_quad(f[0], f[1], f[2], {1, 1}, subdivisions));
  }
  return m;
}

}  // namespace btflod
