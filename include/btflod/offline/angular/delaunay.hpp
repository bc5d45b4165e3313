// btflod — GLM overloads of the Delaunay triangulation of runtime/angular/delaunay.hpp (exact
// integer predicates, deterministic co-circular ties; the algorithm lives there, on core
// vectors, so that engines without GLM triangulate a material's directions at load time).
#pragma once

#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/result.hpp"
#include "btflod/core/vec.hpp"
#include "btflod/runtime/angular/delaunay.hpp"

namespace btflod {

/// delaunay_triangulate over GLM points (copied into core vectors; same result, same errors).
/// Safe for untrusted input; allocates; thread-safe.
inline Result<Triangulation> delaunay_triangulate(std::span<const glm::dvec2> points) {
  const std::vector<Vector2d> d(points.begin(), points.end());
  return delaunay_triangulate(std::span<const Vector2d>(d));
}

/// Convenience overload for float points (promoted to double). Safe for untrusted input;
/// allocates; thread-safe.
inline Result<Triangulation> delaunay_triangulate(std::span<const glm::vec2> points) {
  std::vector<Vector2d> d;
  d.reserve(points.size());
  for (const glm::vec2& p : points) d.emplace_back(p.x, p.y);
  return delaunay_triangulate(std::span<const Vector2d>(d));
}

}  // namespace btflod
