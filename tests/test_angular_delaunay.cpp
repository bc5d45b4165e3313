// Tests for offline/angular/delaunay.hpp: exact predicates, validity (every point used, CCW,
// consistent adjacency, hull covered), the empty-circumcircle property, determinism under
// co-circular ties (rings, square grids), and rejection of bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include "btflod/offline/angular/delaunay.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/parameterization.hpp"
#include "test_angular_helpers.hpp"

namespace btflod {
namespace {

ExactInt128 twice_area(SnappedPoint a, SnappedPoint b, SnappedPoint c) {
  return static_cast<ExactInt128>(b.x - a.x) * (c.y - a.y) - static_cast<ExactInt128>(b.y - a.y) * (c.x - a.x);
}

// Checks everything a valid Delaunay triangulation of the snapped points must satisfy.
void expect_valid_delaunay(const Triangulation& t) {
  const size_t n = t.points.size();
  ASSERT_EQ(t.triangles.size(), t.neighbors.size());
  // Every distinct point is a vertex; merged duplicates are not.
  std::vector<int> used(n, 0);
  for (const auto& tri : t.triangles)
    for (uint32_t v : tri) {
      ASSERT_LT(v, n);
      ++used[v];
    }
  for (size_t i = 0; i < n; ++i) {
    if (t.representative[i] == i)
      EXPECT_GT(used[i], 0) << "point " << i << " unused";
    else
      EXPECT_EQ(used[i], 0) << "duplicate " << i << " used";
  }
  // Counter-clockwise, non-degenerate; adjacency symmetric and edges matching.
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  ExactInt128 area = 0;
  for (uint32_t k = 0; k < t.triangles.size(); ++k) {
    const auto& v = t.triangles[k];
    const ExactInt128 a2 = twice_area(t.snapped[v[0]], t.snapped[v[1]], t.snapped[v[2]]);
    ASSERT_GT(a2, 0) << "triangle " << k << " is not strictly CCW";
    area += a2;
    for (int i = 0; i < 3; ++i) {
      const uint32_t a = v[(i + 1) % 3], b = v[(i + 2) % 3];
      ASSERT_EQ((directed[{a, b}]++), 0) << "directed edge used twice";
      const uint32_t nb = t.neighbors[k][i];
      if (nb == Triangulation::kNoTriangle) continue;
      const auto& w = t.triangles[nb];
      bool found = false;
      for (int j = 0; j < 3; ++j)
        if (w[(j + 1) % 3] == b && w[(j + 2) % 3] == a) {
          found = true;
          EXPECT_EQ(t.neighbors[nb][j], k);
        }
      EXPECT_TRUE(found) << "neighbor " << nb << " of " << k << " does not share edge";
    }
  }
  // Boundary edges (no neighbor) are exactly the hull edges, and the triangles' total area
  // equals the hull polygon's area: the triangulation covers the convex hull, no overlap.
  std::set<std::pair<uint32_t, uint32_t>> hull_edges;
  ExactInt128 hull_area = 0;
  for (size_t k = 0; k < t.hull.size(); ++k) {
    const uint32_t a = t.hull[k], b = t.hull[(k + 1) % t.hull.size()];
    hull_edges.insert({a, b});
    hull_area += twice_area(t.snapped[t.hull[0]], t.snapped[a], t.snapped[b]);
    // Convex: no hull vertex strictly inside-turn.
    const uint32_t c = t.hull[(k + 2) % t.hull.size()];
    EXPECT_GE(orient2d_exact(t.snapped[a], t.snapped[b], t.snapped[c]), 0) << "hull not convex";
  }
  EXPECT_TRUE(area == hull_area) << "triangles do not tile the hull";
  for (const auto& [e, c] : directed) {
    const bool interior = directed.count({e.second, e.first}) > 0;
    EXPECT_EQ(!interior, hull_edges.count(e) > 0) << "edge " << e.first << "-" << e.second;
  }
  // Empty circumcircles (exact): no vertex strictly inside any triangle's circle.
  for (const auto& v : t.triangles)
    for (size_t i = 0; i < n; ++i) {
      if (t.representative[i] != i) continue;
      ASSERT_LE(incircle_exact(t.snapped[v[0]], t.snapped[v[1]], t.snapped[v[2]], t.snapped[i]), 0)
          << "point " << i << " inside circumcircle of (" << v[0] << "," << v[1] << "," << v[2] << ")";
    }
}

std::vector<std::array<uint32_t, 3>> canonical(const Triangulation& t, const std::vector<uint32_t>& to_original) {
  std::vector<std::array<uint32_t, 3>> out;
  for (auto v : t.triangles) {
    for (auto& i : v) i = to_original[i];
    std::rotate(v.begin(), std::min_element(v.begin(), v.end()), v.end());
    out.push_back(v);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(AngularDelaunay, PredicatesAreExact) {
  const SnappedPoint a{0, 0}, b{1 << 28, 0}, c{0, 1 << 28};
  EXPECT_EQ(orient2d_exact(a, b, c), 1);
  EXPECT_EQ(orient2d_exact(a, c, b), -1);
  EXPECT_EQ(orient2d_exact(a, b, {5 << 20, 0}), 0);
  // (1,1) lies exactly on the circle through (0,0), (1,0), (0,1).
  EXPECT_EQ(incircle_exact(a, b, c, {1 << 28, 1 << 28}), 0);
  EXPECT_EQ(incircle_exact(a, b, c, {(1 << 28) - 1, (1 << 28) - 1}), 1);
  EXPECT_EQ(incircle_exact(a, b, c, {(1 << 28) + 1, 1 << 28}), -1);
  // Extreme coordinates (the bound in the header): no overflow, sign still right.
  const int64_t m = static_cast<int64_t>(2.0 * kSnapScale), lo = static_cast<int64_t>(-1.0 * kSnapScale);
  EXPECT_EQ(incircle_exact({lo, lo}, {m, lo}, {lo, m}, {m, m}), 0);
  EXPECT_EQ(incircle_exact({lo, lo}, {m, lo}, {lo, m}, {m - 1, m - 1}), 1);
  // A case plain double arithmetic gets wrong: nearly collinear points far apart.
  EXPECT_EQ(orient2d_exact({0, 0}, {m, m - 1}, {m - 1, m - 2}), -1);
}

template <class P>
void check_set(const DirectionSet& set) {
  auto t = triangulate_directions<P>(set);
  ASSERT_TRUE(t.ok()) << t.message();
  expect_valid_delaunay(*t);
  EXPECT_EQ(t->vertex_count(), set.size());
  // Euler: T = 2n − 2 − h for a triangulation of n points with h on the hull boundary.
  EXPECT_EQ(t->triangles.size(), 2 * set.size() - 2 - t->hull.size()) << P::kName << " " << set.name();
  // The hull is the last ring (a circle in the parabolic and orthographic planes; in the
  // concentric square the ring becomes a square whose edge points are only nearly collinear,
  // so some of them fall just inside the hull).
  if (std::string(P::kName) != "concentric")
    EXPECT_EQ(t->hull.size(), 24u) << P::kName << " " << set.name();
  else
    EXPECT_GE(t->hull.size(), 4u);
}

TEST(AngularDelaunay, Ubo2003AllMapsValid) {
  check_set<ParabolicMap>(DirectionSet::ubo2003());
  check_set<ElevatedConcentricMap>(DirectionSet::ubo2003());
  check_set<OrthographicMap>(DirectionSet::ubo2003());
}

TEST(AngularDelaunay, Ubo2014AllMapsValid) {
  check_set<ParabolicMap>(DirectionSet::ubo2014());
  check_set<ElevatedConcentricMap>(DirectionSet::ubo2014());
  check_set<OrthographicMap>(DirectionSet::ubo2014());
}

TEST(AngularDelaunay, CocircularGridIsDeterministicAndValid) {
  // A square grid: every cell is four co-circular points, the worst case for ties.
  std::vector<glm::dvec2> pts;
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 9; ++x) pts.emplace_back(x / 8.0, y / 8.0);
  auto t = delaunay_triangulate(std::span<const glm::dvec2>(pts));
  ASSERT_TRUE(t.ok()) << t.message();
  expect_valid_delaunay(*t);
  EXPECT_EQ(t->triangles.size(), 2u * 8u * 8u);
  // Same result, in the same order, from any input permutation (the sort decides, not the
  // caller's order).
  std::vector<uint32_t> ident(pts.size());
  std::iota(ident.begin(), ident.end(), 0u);
  const auto reference = canonical(*t, ident);
  std::mt19937 rng(3);
  for (int round = 0; round < 5; ++round) {
    std::vector<uint32_t> perm(pts.size());
    std::iota(perm.begin(), perm.end(), 0u);
    std::shuffle(perm.begin(), perm.end(), rng);
    std::vector<glm::dvec2> shuffled;
    for (uint32_t i : perm) shuffled.push_back(pts[i]);
    auto s = delaunay_triangulate(std::span<const glm::dvec2>(shuffled));
    ASSERT_TRUE(s.ok());
    EXPECT_EQ(canonical(*s, perm), reference);
  }
}

TEST(AngularDelaunay, RingSetIsPermutationInvariant) {
  const DirectionSet set = DirectionSet::ubo2014();
  std::vector<glm::dvec2> pts;
  for (const auto& d : set) pts.emplace_back(ParabolicMap::to_square(d.vector));
  auto t = delaunay_triangulate(std::span<const glm::dvec2>(pts));
  ASSERT_TRUE(t.ok());
  std::vector<uint32_t> ident(pts.size());
  std::iota(ident.begin(), ident.end(), 0u);
  std::vector<uint32_t> perm(ident);
  std::reverse(perm.begin(), perm.end());
  std::vector<glm::dvec2> rev;
  for (uint32_t i : perm) rev.push_back(pts[i]);
  auto r = delaunay_triangulate(std::span<const glm::dvec2>(rev));
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(canonical(*r, perm), canonical(*t, ident));
}

TEST(AngularDelaunay, RandomPointsAndCollinearPrefix) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<glm::dvec2> pts;
  // Ten points on the line x = 0 come first in sorted order (collinear prefix), then a cloud.
  for (int i = 0; i < 10; ++i) pts.emplace_back(0.0, i / 9.0);
  for (int i = 0; i < 400; ++i) pts.emplace_back(0.001 + u(rng), u(rng));
  auto t = delaunay_triangulate(std::span<const glm::dvec2>(pts));
  ASSERT_TRUE(t.ok()) << t.message();
  expect_valid_delaunay(*t);
  // Points on a circle (exactly representable: a 3-4-5 family) plus its centre.
  std::vector<glm::dvec2> circle = {{0.5, 0.5}};
  for (auto [dx, dy] : {std::pair{3, 4},
                        {4, 3},
                        {-3, 4},
                        {-4, 3},
                        {3, -4},
                        {4, -3},
                        {-3, -4},
                        {-4, -3},
                        {5, 0},
                        {0, 5},
                        {-5, 0},
                        {0, -5}})
    circle.emplace_back(0.5 + dx / 16.0, 0.5 + dy / 16.0);
  auto c = delaunay_triangulate(std::span<const glm::dvec2>(circle));
  ASSERT_TRUE(c.ok());
  expect_valid_delaunay(*c);
  EXPECT_EQ(c->triangles.size(), 12u);  // every triangle uses the centre
}

TEST(AngularDelaunay, DuplicatesAreMergedIntoFirstCopy) {
  std::vector<glm::dvec2> pts = {{0, 0}, {1, 0}, {0, 1}, {1, 0}, {0.4, 0.4}, {0, 0}};
  auto t = delaunay_triangulate(std::span<const glm::dvec2>(pts));
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(t->representative[3], 1u);
  EXPECT_EQ(t->representative[5], 0u);
  EXPECT_EQ(t->vertex_count(), 4u);
  expect_valid_delaunay(*t);
}

TEST(AngularDelaunay, RejectsBadInput) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<glm::dvec2> few = {{0, 0}, {1, 1}};
  EXPECT_EQ(delaunay_triangulate(std::span<const glm::dvec2>(few)).status(), Status::invalid_argument);
  std::vector<glm::dvec2> line = {{0, 0}, {0.5, 0.5}, {1, 1}, {0.25, 0.25}};
  auto l = delaunay_triangulate(std::span<const glm::dvec2>(line));
  EXPECT_EQ(l.status(), Status::invalid_argument);
  EXPECT_NE(l.message().find("collinear"), std::string::npos);
  std::vector<glm::dvec2> bad = {{0, 0}, {1, 0}, {nan, 1}};
  auto b = delaunay_triangulate(std::span<const glm::dvec2>(bad));
  EXPECT_EQ(b.status(), Status::invalid_argument);
  EXPECT_NE(b.message().find("point 2"), std::string::npos) << b.message();
  std::vector<glm::dvec2> far = {{0, 0}, {1, 0}, {0, 1e9}};
  EXPECT_FALSE(delaunay_triangulate(std::span<const glm::dvec2>(far)).ok());
}

}  // namespace
}  // namespace btflod

namespace btflod {
namespace {

// No triangle of a built-in direction set's triangulation is degenerate, in any of the three
// maps. The inputs are computed in double (triangulate_directions): from float parameter points
// the concentric map's outermost ring drifts off the square's sides by float rounding and the
// triangulation gains sliver triangles of area ~1e-9 (12 for UBO2003, 5 for UBO2014).
template <class P>
void expect_no_degenerate_triangle(const DirectionSet& set) {
  auto tri = triangulate_directions<P>(set);
  ASSERT_TRUE(tri.ok()) << tri.message();
  // A regular triangulation of n points in the unit square has triangles of area ~1/(2n);
  // 1e-6 is three orders below the smallest of them and three above the slivers.
  size_t small = 0;
  double smallest = 1.0;
  for (const auto& t : tri->triangles) {
    const glm::dvec2 a = tri->points[t[0]], b = tri->points[t[1]], c = tri->points[t[2]];
    const double area = 0.5 * ((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
    EXPECT_GT(area, 0.0) << P::kName << " " << set.name();
    smallest = std::min(smallest, area);
    small += area < 1e-6;
  }
  EXPECT_EQ(small, 0u) << P::kName << " " << set.name() << ": " << small << " sliver triangles, smallest area "
                       << smallest;
}

TEST(DelaunayDirectionSets, NoDegenerateTriangleInAnyBuiltInSetAndMap) {
  btflod_test::for_each_builtin_set_and_map(
      []<class Map>(const DirectionSet& set) { expect_no_degenerate_triangle<Map>(set); });
}

TEST(DelaunayDirectionSets, DoublePrecisionPathMatchesTheFloatMapToFloatPrecision) {
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    for (const Direction& d : set) {
      const glm::dvec2 p = to_square_precise<ElevatedConcentricMap>(direction_precise(d));
      const glm::vec2 f = ElevatedConcentricMap::to_square(d.vector);
      EXPECT_NEAR(p.x, f.x, 2e-6);
      EXPECT_NEAR(p.y, f.y, 2e-6);
      const glm::dvec2 q = to_square_precise<ParabolicMap>(direction_precise(d));
      EXPECT_NEAR(q.x, ParabolicMap::to_square(d.vector).x, 2e-6);
    }
    // The span overload gives the same triangulation as the set overload.
    std::vector<glm::dvec3> dirs;
    for (const Direction& d : set) dirs.push_back(direction_precise(d));
    auto a = triangulate_directions<ElevatedConcentricMap>(set);
    auto b = triangulate_directions<ElevatedConcentricMap>(std::span<const glm::dvec3>(dirs));
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->triangles, b->triangles);
  }
}

}  // namespace
}  // namespace btflod
