// Fuzz target: Delaunay triangulation + grid locator + ring search on hostile point sets.
// Input: pairs of little-endian u16 → points on a 65535² lattice of [0, 1]² (so duplicates,
// collinear runs and co-circular quadruples are frequent), at most 256 points. Checks the
// invariants the tests check (CCW, every distinct point used, triangles tile the hull, empty
// circumcircles) and that every query returns a partition of unity.
//
// Speed: the empty-circumcircle property is checked locally — the adjacency is checked to be
// reciprocal (each shared edge seen from both sides, boundary edges exactly the hull's), and
// across every shared edge the opposite vertex must not lie inside the circumcircle (a proper
// triangulation that is locally Delaunay is Delaunay) — which is O(triangles) instead of
// O(triangles × points); the global test against every point is kept for 4 triangles per input.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "btflod/offline/angular/delaunay.hpp"
#include "btflod/offline/angular/ring_search.hpp"
#include "btflod/runtime/angular/triangle_locator.hpp"

using namespace btflod;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const size_t n = std::min<size_t>(size / 4, 256);
  std::vector<glm::dvec2> pts(n);
  for (size_t i = 0; i < n; ++i) {
    const uint16_t x = static_cast<uint16_t>(data[4 * i] | (data[4 * i + 1] << 8));
    const uint16_t y = static_cast<uint16_t>(data[4 * i + 2] | (data[4 * i + 3] << 8));
    pts[i] = {x / 65535.0, y / 65535.0};
  }
  auto r = delaunay_triangulate(std::span<const glm::dvec2>(pts));
  if (!r) return 0;
  const Triangulation& t = *r;
  std::vector<char> used(n, 0);
  ExactInt128 area = 0, hull_area = 0;
  for (const auto& v : t.triangles) {
    const ExactInt128 a2 =
        static_cast<ExactInt128>(t.snapped[v[1]].x - t.snapped[v[0]].x) * (t.snapped[v[2]].y - t.snapped[v[0]].y) -
        static_cast<ExactInt128>(t.snapped[v[1]].y - t.snapped[v[0]].y) * (t.snapped[v[2]].x - t.snapped[v[0]].x);
    if (a2 <= 0) std::abort();
    area += a2;
    for (uint32_t i : v) used[i] = 1;
  }
  // Reciprocal adjacency and local Delaunay across every shared edge.
  if (t.neighbors.size() != t.triangles.size()) std::abort();
  size_t boundary = 0;
  for (size_t k = 0; k < t.triangles.size(); ++k) {
    const auto& v = t.triangles[k];
    for (int i = 0; i < 3; ++i) {
      const uint32_t a = v[(i + 1) % 3], b = v[(i + 2) % 3], nb = t.neighbors[k][i];
      if (nb == Triangulation::kNoTriangle) {
        ++boundary;
        continue;
      }
      if (nb >= t.triangles.size()) std::abort();
      const auto& w = t.triangles[nb];
      int j = 0;
      while (j < 3 && !(w[(j + 1) % 3] == b && w[(j + 2) % 3] == a)) ++j;
      if (j == 3 || t.neighbors[nb][j] != k) std::abort();
      if (incircle_exact(t.snapped[v[0]], t.snapped[v[1]], t.snapped[v[2]], t.snapped[w[j]]) > 0) std::abort();
    }
  }
  if (!t.triangles.empty() && boundary != t.hull.size()) std::abort();
  for (size_t s = 0; s < 4 && !t.triangles.empty(); ++s) {
    const auto& v = t.triangles[(data[s % size] * 131u + s * 977u) % t.triangles.size()];
    for (size_t i = 0; i < n; ++i)
      if (incircle_exact(t.snapped[v[0]], t.snapped[v[1]], t.snapped[v[2]], t.snapped[i]) > 0) std::abort();
  }
  for (size_t i = 0; i < n; ++i)
    if ((t.representative[i] == i) != (used[i] != 0)) std::abort();
  for (size_t k = 0; k < t.hull.size(); ++k) {
    const SnappedPoint a = t.snapped[t.hull[0]], b = t.snapped[t.hull[k]],
                       c = t.snapped[t.hull[(k + 1) % t.hull.size()]];
    hull_area += static_cast<ExactInt128>(b.x - a.x) * (c.y - a.y) - static_cast<ExactInt128>(b.y - a.y) * (c.x - a.x);
  }
  if (area != hull_area) std::abort();
  const TriangleGridLocator loc(t);
  for (size_t i = 0; i < n; ++i) {
    const AngularSample s = loc.locate(glm::vec2(pts[n - 1 - i].y, pts[i].x));
    const float sum = s.weight[0] + s.weight[1] + s.weight[2];
    if (!(sum > 0.999f && sum < 1.001f)) std::abort();
    for (int k = 0; k < 3; ++k)
      if (s.weight[k] < 0.0f || s.index[k] >= n) std::abort();
  }
  // Ring detection on the same points read as (θ, φ): must either fail cleanly or answer.
  std::vector<std::pair<float, float>> tp;
  for (const auto& p : pts) tp.emplace_back(static_cast<float>(p.x) * 1.5f, static_cast<float>(p.y) * 6.3f);
  auto ring = RingSearchInterpolator::build(DirectionSet::from_radians("fuzz", tp));
  if (ring) {
    const AngularSample s = ring->query(glm::vec3(pts[0].x - 0.5, pts[0].y - 0.5, 0.3));
    if (s.index[0] >= n || s.index[1] >= n || s.index[2] >= n) std::abort();
  }
  return 0;
}
