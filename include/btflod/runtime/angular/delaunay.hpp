// btflod — Delaunay triangulation of a direction set in a parameter plane, with exact
// predicates and a deterministic treatment of co-circular points.
//
// Why exact integer predicates instead of Shewchuk's adaptive floating-point ones: the input
// points are floats produced by a hemisphere map, so they carry ~1e-7 error anyway. We snap
// each point onto a fixed grid of 2^-28 (far below float resolution of the map), after which
// orientation and in-circle are evaluated exactly with 128-bit integers (bounds below). This
// is a few lines, has no error-bound analysis to get wrong, gives bit-identical results on
// every platform, and the triangulation is an exact Delaunay triangulation of the snapped
// points. Direction sets made of rings (equal θ) are full of co-circular quadruples (every
// isosceles trapezoid between two rings is cyclic); exact predicates see those ties as ties
// (or as the tiny rounding difference of the map, always the same way), and the rule below
// resolves them deterministically.
//
// Algorithm: points are sorted lexicographically (x, then y, then input index), so each new
// point lies strictly outside the hull built so far; it is connected to every hull edge it
// strictly sees and the new edges are legalised by Lawson flips. A flip happens only when the
// opposite vertex is STRICTLY inside the circumcircle (in-circle > 0), so co-circular ties keep
// the edge created first in this fixed order. No zero-area triangle is ever created. Cost is
// O(n²) in the worst case (hull search); direction sets have at most a few thousand points.
//
// Runtime set-up code (GLM-free, core vectors): an engine triangulates a streamed material's
// directions at load time (runtime/angular/bsvtf_angular_tables.hpp).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <span>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/core/vec.hpp"

namespace btflod {

/// Signed 128-bit integer for the exact predicates (GCC/Clang extension; `__extension__`
/// keeps -Wpedantic quiet). Every platform btflod builds on (GCC, Clang; 64-bit) has it.
__extension__ typedef __int128 ExactInt128;

/// A point snapped to the exact-predicate grid (units of 2^-28).
struct SnappedPoint {
  int64_t x = 0;
  int64_t y = 0;
  friend bool operator==(const SnappedPoint&, const SnappedPoint&) = default;
};

/// Resolution of the snapping grid: 2^28 steps per unit.
inline constexpr double kSnapScale = 268435456.0;
/// Coordinates accepted by the triangulation: [kSnapMin, kSnapMax] (the unit square with margin).
inline constexpr double kSnapMin = -1.0;
inline constexpr double kSnapMax = 2.0;

/// Snaps a coordinate pair onto the exact grid. Precondition: finite, inside
/// [kSnapMin, kSnapMax] (values outside are clamped). noexcept.
inline SnappedPoint snap_point(Vector2d p) noexcept {
  const double x = std::clamp(p.x, kSnapMin, kSnapMax);
  const double y = std::clamp(p.y, kSnapMin, kSnapMax);
  return {static_cast<int64_t>(std::llround(x * kSnapScale)), static_cast<int64_t>(std::llround(y * kSnapScale))};
}

/// Exact sign of the orientation determinant: > 0 when a, b, c turn counter-clockwise,
/// < 0 clockwise, 0 collinear. |coordinate| ≤ 2^29 so every product fits in 2^61.
inline int orient2d_exact(SnappedPoint a, SnappedPoint b, SnappedPoint c) noexcept {
  const ExactInt128 det =
      static_cast<ExactInt128>(b.x - a.x) * (c.y - a.y) - static_cast<ExactInt128>(b.y - a.y) * (c.x - a.x);
  return (det > 0) - (det < 0);
}

/// Exact sign of the in-circle determinant: > 0 when d lies strictly inside the circle
/// through a, b, c (which must be counter-clockwise), 0 on it, < 0 outside. Differences are
/// ≤ 3·2^28 < 2^30, lifts and 2×2 minors ≤ 2^61, each product ≤ 2^122, the sum of three
/// ≤ 2^124: exact in signed 128-bit arithmetic.
inline int incircle_exact(SnappedPoint a, SnappedPoint b, SnappedPoint c, SnappedPoint d) noexcept {
  using I = ExactInt128;
  const I adx = a.x - d.x, ady = a.y - d.y;
  const I bdx = b.x - d.x, bdy = b.y - d.y;
  const I cdx = c.x - d.x, cdy = c.y - d.y;
  const I alift = adx * adx + ady * ady;
  const I blift = bdx * bdx + bdy * bdy;
  const I clift = cdx * cdx + cdy * cdy;
  const I det = alift * (bdx * cdy - bdy * cdx) + blift * (cdx * ady - cdy * adx) + clift * (adx * bdy - ady * bdx);
  return (det > 0) - (det < 0);
}

/// A triangulation of a planar point set. Triangles are counter-clockwise; neighbor[t][i] is
/// the triangle across the edge opposite vertex i (kNoTriangle on the hull).
struct Triangulation {
  static constexpr uint32_t kNoTriangle = 0xffffffffu;

  std::vector<Vector2d> points;                    ///< input points (unsnapped), by input index
  std::vector<SnappedPoint> snapped;               ///< the points the predicates saw
  std::vector<std::array<uint32_t, 3>> triangles;  ///< vertex indices into points, CCW
  std::vector<std::array<uint32_t, 3>> neighbors;  ///< neighbor[t][i]: across edge (v[i+1], v[i+2])
  std::vector<uint32_t> hull;                      ///< hull vertices, counter-clockwise
  std::vector<uint32_t> representative;            ///< points[i] == points[representative[i]]; i for unique points

  /// Number of input points that are vertices (duplicates are merged into their first copy).
  size_t vertex_count() const noexcept {
    size_t n = 0;
    for (size_t i = 0; i < representative.size(); ++i) n += representative[i] == i;
    return n;
  }
};

namespace detail {

class DelaunayBuilder {
 public:
  explicit DelaunayBuilder(Triangulation& tri) : t_(tri) {}

  const SnappedPoint& p(uint32_t i) const { return t_.snapped[i]; }

  uint32_t add_triangle(uint32_t a, uint32_t b, uint32_t c) {
    t_.triangles.push_back({a, b, c});
    t_.neighbors.push_back({Triangulation::kNoTriangle, Triangulation::kNoTriangle, Triangulation::kNoTriangle});
    return static_cast<uint32_t>(t_.triangles.size() - 1);
  }

  // Index k in triangle t of the edge (a, b) in either direction, i.e. the vertex opposite it.
  int opposite_slot(uint32_t tri, uint32_t a, uint32_t b) const {
    const auto& v = t_.triangles[tri];
    for (int i = 0; i < 3; ++i) {
      const uint32_t e0 = v[(i + 1) % 3], e1 = v[(i + 2) % 3];
      if ((e0 == a && e1 == b) || (e0 == b && e1 == a)) return i;
    }
    return -1;
  }

  void replace_neighbor(uint32_t tri, uint32_t old_n, uint32_t new_n) {
    if (tri == Triangulation::kNoTriangle) return;
    for (auto& n : t_.neighbors[tri])
      if (n == old_n) {
        n = new_n;
        return;
      }
  }

  // Lawson flip of the edge opposite slot 0 of `tri` (slot 0 always holds the new point).
  // Iterative with an explicit stack so hostile inputs cannot overflow the call stack.
  void legalize(uint32_t start) {
    stack_.clear();
    stack_.push_back(start);
    while (!stack_.empty()) {
      const uint32_t t = stack_.back();
      stack_.pop_back();
      const uint32_t u = t_.neighbors[t][0];
      if (u == Triangulation::kNoTriangle) continue;
      const auto tv = t_.triangles[t];  // (p, a, b)
      const uint32_t pp = tv[0], a = tv[1], b = tv[2];
      const int j = opposite_slot(u, a, b);
      const uint32_t q = t_.triangles[u][j];
      if (incircle_exact(p(pp), p(a), p(b), p(q)) <= 0) continue;  // ties keep the edge: deterministic
      const auto un = t_.neighbors[u];
      const uint32_t t_bp = t_.neighbors[t][1];  // across (b, p)
      const uint32_t t_pa = t_.neighbors[t][2];  // across (p, a)
      // u = (q, b, a) with q at slot j: across (a, q) is opposite b, across (q, b) is opposite a.
      const uint32_t u_aq = un[(j + 1) % 3];
      const uint32_t u_qb = un[(j + 2) % 3];
      t_.triangles[t] = {pp, a, q};
      t_.neighbors[t] = {u_aq, u, t_pa};
      t_.triangles[u] = {pp, q, b};
      t_.neighbors[u] = {u_qb, t_bp, t};
      replace_neighbor(u_aq, u, t);
      replace_neighbor(t_bp, t, u);
      stack_.push_back(t);
      stack_.push_back(u);
    }
  }

  // The hull triangle holding directed edge (a, b) (CCW order inside that triangle).
  uint32_t triangle_with_edge(uint32_t a, uint32_t b) const {
    for (uint32_t t = 0; t < t_.triangles.size(); ++t) {
      const auto& v = t_.triangles[t];
      for (int i = 0; i < 3; ++i)
        if (v[i] == a && v[(i + 1) % 3] == b) return t;
    }
    return Triangulation::kNoTriangle;
  }

  void add_outside_point(uint32_t pt) {
    auto& hull = t_.hull;
    const size_t h = hull.size();
    std::vector<char> visible(h);
    size_t any = h;
    for (size_t k = 0; k < h; ++k) {
      visible[k] = orient2d_exact(p(hull[k]), p(hull[(k + 1) % h]), p(pt)) < 0;
      if (visible[k]) any = k;
    }
    if (any == h) return;  // cannot happen for a lexicographically larger point; defensive
    size_t first = any;
    while (visible[(first + h - 1) % h] && ((first + h - 1) % h) != any) first = (first + h - 1) % h;
    size_t count = 0;
    while (count < h && visible[(first + count) % h]) ++count;
    uint32_t prev = Triangulation::kNoTriangle;
    std::vector<uint32_t> created;
    for (size_t c = 0; c < count; ++c) {
      const uint32_t a = hull[(first + c) % h], b = hull[(first + c + 1) % h];
      const uint32_t outer = triangle_with_edge(a, b);
      const uint32_t nt = add_triangle(pt, b, a);
      t_.neighbors[nt][0] = outer;
      if (outer != Triangulation::kNoTriangle) {
        const int s = opposite_slot(outer, a, b);
        t_.neighbors[outer][s] = nt;
      }
      t_.neighbors[nt][1] = prev;                                          // across (a, p)
      if (prev != Triangulation::kNoTriangle) t_.neighbors[prev][2] = nt;  // prev's (p, a) edge
      prev = nt;
      created.push_back(nt);
    }
    // New hull: ... hull[first], pt, hull[first + count] ...
    std::vector<uint32_t> next;
    next.reserve(h + 1);
    for (size_t k = 0; k + count < h + 1; ++k) next.push_back(hull[(first + count + k) % h]);
    next.push_back(pt);
    hull = std::move(next);
    for (uint32_t nt : created) legalize(nt);
  }

 private:
  Triangulation& t_;
  std::vector<uint32_t> stack_;
};

}  // namespace detail

/// Delaunay triangulation of `points` (coordinates in [−1, 2]², normally the [0, 1]² square
/// of a HemisphereParameterization).
/// Returns an error when a coordinate is not finite or outside [−1, 2], or when fewer than
/// three distinct, non-collinear points are given. Exactly coincident points (after
/// snapping) are merged: representative[i] names the first copy, which is the only one used
/// as a vertex. Every other point is a vertex of at least one triangle; the union of the
/// triangles is the convex hull; no circumcircle strictly contains a point (ties allowed).
/// Deterministic: the same input gives the same triangles on every platform.
/// Safe for untrusted input; allocates; not for per-frame use. Thread-safe (no shared state).
inline Result<Triangulation> delaunay_triangulate(std::span<const Vector2d> points) {
  Triangulation tri;
  const size_t n = points.size();
  if (n > 0x3fffffffu) return make_error(Status::invalid_argument, "delaunay: %zu points is too many", n);
  tri.points.assign(points.begin(), points.end());
  tri.snapped.resize(n);
  tri.representative.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Vector2d q = points[i];
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || q.x < kSnapMin || q.x > kSnapMax || q.y < kSnapMin ||
        q.y > kSnapMax)
      return make_error(Status::invalid_argument, "delaunay: point %zu = (%g, %g) is not finite or outside [%g, %g]", i,
                        q.x, q.y, kSnapMin, kSnapMax);
    tri.snapped[i] = snap_point(q);
  }
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    const auto& pa = tri.snapped[a];
    const auto& pb = tri.snapped[b];
    if (pa.x != pb.x) return pa.x < pb.x;
    if (pa.y != pb.y) return pa.y < pb.y;
    return a < b;
  });
  // Merge duplicates: the smallest input index of equal points represents them.
  std::vector<uint32_t> unique;
  unique.reserve(n);
  for (size_t k = 0; k < n; ++k) {
    const uint32_t i = order[k];
    if (!unique.empty() && tri.snapped[unique.back()] == tri.snapped[i]) {
      tri.representative[i] = unique.back();
    } else {
      tri.representative[i] = i;
      unique.push_back(i);
    }
  }
  if (unique.size() < 3)
    return make_error(Status::invalid_argument, "delaunay: need at least 3 distinct points, found %zu", unique.size());
  // Collinear prefix: the first point off the line through unique[0], unique[1].
  size_t m = 2;
  while (m < unique.size() &&
         orient2d_exact(tri.snapped[unique[0]], tri.snapped[unique[1]], tri.snapped[unique[m]]) == 0)
    ++m;
  if (m == unique.size())
    return make_error(Status::invalid_argument, "delaunay: all %zu distinct points are collinear", unique.size());
  detail::DelaunayBuilder builder(tri);
  const uint32_t apex = unique[m];
  const bool ccw = orient2d_exact(tri.snapped[unique[0]], tri.snapped[unique[1]], tri.snapped[apex]) > 0;
  // Fan from the apex over the collinear chain (sorted along the line). Fan edges are
  // Delaunay: the next chain point lies on the chord's line outside the chord.
  uint32_t prev = Triangulation::kNoTriangle;
  for (size_t k = 0; k + 1 < m; ++k) {
    const uint32_t a = unique[k], b = unique[k + 1];
    // Slot 0 = apex; CCW order (apex, a, b) when ccw... orient(a, b, apex) > 0 ⇔ (apex, a, b) CCW.
    const uint32_t t = ccw ? builder.add_triangle(apex, a, b) : builder.add_triangle(apex, b, a);
    if (prev != Triangulation::kNoTriangle) {
      // Shared edge (apex, a).
      const int s_prev = builder.opposite_slot(prev, apex, a);
      const int s_cur = builder.opposite_slot(t, apex, a);
      tri.neighbors[prev][s_prev] = t;
      tri.neighbors[t][s_cur] = prev;
    }
    prev = t;
  }
  if (ccw) {
    for (size_t k = 0; k < m; ++k) tri.hull.push_back(unique[k]);
  } else {
    for (size_t k = m; k-- > 0;) tri.hull.push_back(unique[k]);
  }
  tri.hull.push_back(apex);
  for (size_t k = m + 1; k < unique.size(); ++k) builder.add_outside_point(unique[k]);
  return tri;
}

}  // namespace btflod
