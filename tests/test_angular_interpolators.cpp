// Tests for the angular interpolators (exact grid, lookup tables, nearest table, UBO ring
// search) and the 9-tap combination: weights are a partition of unity, reconstruction is exact
// at the measured directions, the grid locator agrees with brute force, queries outside the
// hull land on the nearest hull point, and ring search agrees with the triangulation where
// the thesis' triangle choice is unambiguous.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/nine_tap.hpp"
#include "btflod/offline/angular/ring_search.hpp"
#include "test_angular_helpers.hpp"

namespace btflod {
namespace {

std::vector<glm::vec3> random_directions(int n, uint32_t seed, float max_theta_deg = 90.0f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<glm::vec3> out;
  const float zmin = std::cos(degrees_to_radians(max_theta_deg));
  for (int i = 0; i < n; ++i) {
    const float z = zmin + (1.0f - zmin) * u(rng);
    const float phi = kTwoPi * u(rng);
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    out.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return out;
}

template <class I>
void expect_partition_of_unity(const I& interp, const char* what) {
  auto dirs = random_directions(3000, 5);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (glm::vec3 extra : {glm::vec3(0, 0, -1), glm::vec3(1, 0, -0.5f), glm::vec3(0.0f), glm::vec3(nan, 1, 1),
                          glm::vec3(0, 0, 1), glm::vec3(1, 0, 0)})
    dirs.push_back(extra);
  for (const glm::vec3& d : dirs) {
    const AngularSample s = interp.query(d);
    float sum = 0.0f;
    for (int k = 0; k < 3; ++k) {
      ASSERT_LT(s.index[k], interp.direction_count()) << what;
      ASSERT_GE(s.weight[k], 0.0f) << what;
      sum += s.weight[k];
    }
    ASSERT_NEAR(sum, 1.0f, 1e-5f) << what << " at " << d.x << "," << d.y << "," << d.z;
  }
}

template <class I>
void expect_exact_at_measured(const I& interp, const DirectionSet& set, float tol, const char* what) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> f(set.size());
  for (float& v : f) v = u(rng);
  for (size_t i = 0; i < set.size(); ++i) {
    const AngularSample s = interp.query(set[i].vector);
    float v = 0.0f;
    for (int k = 0; k < 3; ++k) v += s.weight[k] * f[s.index[k]];
    ASSERT_NEAR(v, f[i], tol) << what << " " << set.name() << " direction " << i;
  }
}

template <class P>
void check_exact_grid(const DirectionSet& set) {
  auto built = ExactGridInterpolator<P>::build(set);
  ASSERT_TRUE(built.ok()) << built.message();
  const auto& interp = *built;
  expect_partition_of_unity(interp, P::kName);
  expect_exact_at_measured(interp, set, 2e-5f, P::kName);
  // Reproduces any function that is linear in the square coordinates (barycentric weights are
  // affine), and agrees with a brute-force search over all triangles (the grid finds the
  // containing triangle).
  const Triangulation& tri = interp.triangulation();
  auto lin = [](glm::dvec2 p) { return 0.3 + 1.7 * p.x - 0.9 * p.y; };
  int inside = 0;
  for (const glm::vec3& d : random_directions(800, 21, 72.0f)) {
    const glm::vec2 st = P::to_square(d);
    const AngularSample s = interp.query(d);
    double v = 0.0;
    for (int k = 0; k < 3; ++k) v += s.weight[k] * lin(tri.points[s.index[k]]);
    ASSERT_NEAR(v, lin(glm::dvec2(st)), 2e-5) << P::kName;
    // Brute force: the triangle with the largest minimal barycentric coordinate.
    double best = -1e9;
    for (const auto& t : tri.triangles) {
      const glm::dvec2 a = tri.points[t[0]], b = tri.points[t[1]], c = tri.points[t[2]], p(st);
      const double den = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
      const double l1 = ((b.x - p.x) * (c.y - p.y) - (c.x - p.x) * (b.y - p.y)) / den;
      const double l2 = ((c.x - p.x) * (a.y - p.y) - (a.x - p.x) * (c.y - p.y)) / den;
      best = std::max(best, std::min({l1, l2, 1.0 - l1 - l2}));
    }
    if (best > 1e-4) {
      ++inside;
      EXPECT_GT(*std::min_element(s.weight.begin(), s.weight.end()), 0.0f);
    }
  }
  EXPECT_GT(inside, 760);
}

TEST(AngularInterpolators, ExactGridAllMapsBothSets) {
  btflod_test::for_each_builtin_set_and_map([]<class Map>(const DirectionSet& set) { check_exact_grid<Map>(set); });
}

TEST(AngularInterpolators, OutsideHullMapsToNearestHullPoint) {
  const DirectionSet set = DirectionSet::ubo2003();
  auto interp = ExactGridInterpolator<ParabolicMap>::build(set);
  ASSERT_TRUE(interp.ok());
  const Triangulation& tri = interp->triangulation();
  int checked = 0;
  for (const glm::vec3& d : random_directions(500, 33, 90.0f)) {
    if (d.z > std::cos(degrees_to_radians(76.0f))) continue;  // beyond the 75° ring only
    const glm::dvec2 st(ParabolicMap::to_square(d));
    // Brute-force nearest point on the hull polygon.
    double best = 1e9;
    glm::dvec2 nearest(0.0);
    for (size_t k = 0; k < tri.hull.size(); ++k) {
      const glm::dvec2 a = tri.points[tri.hull[k]], b = tri.points[tri.hull[(k + 1) % tri.hull.size()]];
      const double u = std::clamp(glm::dot(st - a, b - a) / glm::dot(b - a, b - a), 0.0, 1.0);
      const glm::dvec2 q = a + u * (b - a);
      if (glm::length(q - st) < best) {
        best = glm::length(q - st);
        nearest = q;
      }
    }
    const AngularSample s = interp->query(d);
    glm::dvec2 pos(0.0);
    for (int k = 0; k < 3; ++k) pos += static_cast<double>(s.weight[k]) * glm::dvec2(tri.points[s.index[k]]);
    EXPECT_NEAR(pos.x, nearest.x, 1e-5);
    EXPECT_NEAR(pos.y, nearest.y, 1e-5);
    EXPECT_EQ(s.weight[2], 0.0f);
    ++checked;
  }
  EXPECT_GT(checked, 50);
}

// Outside the hull a sample interpolates along one hull edge (two directions) or returns one
// hull vertex. Its slots must name each direction once: the weighted slots come first with
// distinct indices, padding slots (weight 0) repeat slot 0's index, so code that sums — or
// assigns — weights by index never counts a direction twice or overwrites a weight with 0.
void expect_canonical(const AngularSample& s, const char* what) {
  ASSERT_GT(s.weight[0], 0.0f) << what;
  for (int k = 1; k < 3; ++k) {
    if (s.weight[k] == 0.0f) {
      EXPECT_EQ(s.index[k], s.index[0]) << what << ": padding slot " << k;
      for (int j = k + 1; j < 3; ++j) EXPECT_EQ(s.weight[j], 0.0f) << what << ": weighted slot after padding";
    } else {
      for (int j = 0; j < k; ++j) EXPECT_NE(s.index[j], s.index[k]) << what << ": index repeated in a weighted slot";
    }
  }
  std::map<uint32_t, float> by_index;
  float total = 0.0f;
  for (int k = 0; k < 3; ++k) by_index[s.index[k]] = s.weight[k] > 0.0f ? s.weight[k] : by_index[s.index[k]];
  for (const auto& [i, w] : by_index) total += w;
  EXPECT_NEAR(total, 1.0f, 1e-5f) << what << ": weights assigned by index do not sum to 1";
}

TEST(AngularInterpolators, OutsideHullSamplesNameEachDirectionOnce) {
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    auto para = ExactGridInterpolator<ParabolicMap>::build(set);
    auto conc = ExactGridInterpolator<ElevatedConcentricMap>::build(set);
    auto table = LookupTableInterpolator<ParabolicMap>::build(set, 64);
    ASSERT_TRUE(para.ok() && conc.ok() && table.ok());
    int outside = 0;
    for (const glm::vec3& d : random_directions(2000, 77, 90.0f)) {
      if (d.z > std::cos(degrees_to_radians(76.0f))) continue;  // beyond the 75° ring only
      ++outside;
      expect_canonical(para->query(d), "parabolic exact");
      expect_canonical(conc->query(d), "concentric exact");
      expect_canonical(table->query(d), "parabolic table");
    }
    // Exactly at the square's corners and along the axes (nearest point = a hull vertex).
    for (glm::vec2 st :
         {glm::vec2(0, 0), glm::vec2(1, 1), glm::vec2(0, 1), glm::vec2(1, 0), glm::vec2(0.5f, 0), glm::vec2(1, 0.5f)}) {
      expect_canonical(para->query_square(st), "parabolic corner");
      expect_canonical(conc->query_square(st), "concentric corner");
    }
    EXPECT_GT(outside, 100);
  }
}

TEST(AngularInterpolators, LookupTableMatchesExactAtTexelCentres) {
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    auto lut = LookupTableInterpolator<ParabolicMap>::build(set, 128);
    auto exact = ExactGridInterpolator<ParabolicMap>::build(set);
    ASSERT_TRUE(lut.ok() && exact.ok());
    EXPECT_EQ(lut->index_table().width(), 128);
    EXPECT_EQ(lut->weight_table().channels(), 3);
    expect_partition_of_unity(*lut, "lut");
    for (int y = 0; y < 128; y += 3)
      for (int x = 0; x < 128; x += 5) {
        const glm::vec2 st((x + 0.5f) / 128.0f, (y + 0.5f) / 128.0f);
        const AngularSample a = lut->query_square(st), b = exact->query_square(st);
        for (int k = 0; k < 3; ++k) {
          ASSERT_EQ(a.index[k], b.index[k]);
          ASSERT_EQ(a.weight[k], b.weight[k]);
          ASSERT_EQ(lut->index_table().at(x, y, k), b.index[k]);
        }
      }
    // At a measured direction the table answers with the sample of the texel centre next to
    // it: the interpolated position lies within one texel diagonal of the direction's point.
    auto fine = LookupTableInterpolator<ElevatedConcentricMap>::build(set, 256);
    auto fine_exact = ExactGridInterpolator<ElevatedConcentricMap>::build(set);
    ASSERT_TRUE(fine.ok() && fine_exact.ok());
    const auto& pts = fine_exact->triangulation().points;
    for (size_t i = 0; i < set.size(); ++i) {
      const AngularSample s = fine->query(set[i].vector);
      glm::dvec2 pos(0.0);
      for (int k = 0; k < 3; ++k) pos += static_cast<double>(s.weight[k]) * glm::dvec2(pts[s.index[k]]);
      EXPECT_LT(glm::length(pos - glm::dvec2(pts[i])), std::sqrt(2.0) / 256.0) << set.name() << " direction " << i;
    }
  }
  EXPECT_FALSE(LookupTableInterpolator<ParabolicMap>::build(DirectionSet::ubo2003(), 0).ok());
}

TEST(AngularInterpolators, NearestTableFindsNearestDirection) {
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    auto nn = NearestLookupInterpolator<ElevatedConcentricMap>::build(set, 128);
    ASSERT_TRUE(nn.ok());
    expect_partition_of_unity(*nn, "nearest");
    expect_exact_at_measured(*nn, set, 0.0f, "nearest");
    int same = 0, total = 0;
    for (const glm::vec3& d : random_directions(2000, 44)) {
      const uint32_t got = nn->query(d).index[0];
      const size_t truth = set.nearest(d);
      ++total;
      same += got == truth;
      // Never much worse than the true nearest: texel quantisation only.
      EXPECT_GT(glm::dot(set[got].vector, d), glm::dot(set[truth].vector, d) - 0.02f);
    }
    EXPECT_GT(same, total * 90 / 100) << set.name() << ": " << same << " of " << total;
  }
}

TEST(AngularInterpolators, RingSearchDetectsRings) {
  auto r3 = RingSearchInterpolator::build(DirectionSet::ubo2003());
  ASSERT_TRUE(r3.ok()) << r3.message();
  ASSERT_EQ(r3->rings().size(), 6u);
  EXPECT_EQ(r3->rings()[0].count, 1u);
  EXPECT_EQ(r3->rings()[5].count, 24u);
  auto r14 = RingSearchInterpolator::build(DirectionSet::ubo2014());
  ASSERT_TRUE(r14.ok()) << r14.message();
  ASSERT_EQ(r14->rings().size(), 10u);
  EXPECT_NEAR(radians_to_degrees(r14->rings()[8].phi0), 7.5f, 1e-3f);
  // A set that is not made of evenly spaced rings is rejected with a message.
  std::vector<std::pair<float, float>> tp = {{0.3f, 0.0f}, {0.3f, 1.0f}, {0.3f, 1.5f}};
  auto bad = RingSearchInterpolator::build(DirectionSet::from_radians("odd", tp));
  EXPECT_EQ(bad.status(), Status::invalid_argument);
  EXPECT_NE(bad.message().find("azimuth"), std::string::npos) << bad.message();
}

TEST(AngularInterpolators, RingSearchWeightsAndExactness) {
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    auto r = RingSearchInterpolator::build(set);
    ASSERT_TRUE(r.ok());
    expect_partition_of_unity(*r, "ring");
    expect_exact_at_measured(*r, set, 1e-4f, "ring");
  }
}

TEST(AngularInterpolators, RingSearchAgreesWithTriangulationWhereUnambiguous) {
  // The thesis picks ABC or BCD from the quad A, B (lower ring), C, D (upper ring). Where the
  // Delaunay triangulation splits that quad along the same diagonal BC and the direction is
  // well inside one of the two triangles (all barycentric weights ≥ 0.1 in the parabolic
  // plane) and clearly closer to A or to D (dot products differ by ≥ 0.02; the thesis' d′ rule
  // is only a proxy for the side of BC, and with a 0.01 margin one UBO2014 query in ~570 differs), the thesis' choice
  // is unambiguous: both methods must pick the same triangle, and their weights describe nearly the same point.
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    auto ring = RingSearchInterpolator::build(set);
    auto tri = ExactGridInterpolator<ParabolicMap>::build(set);
    ASSERT_TRUE(ring.ok() && tri.ok());
    int cases = 0, agree = 0;
    for (const glm::vec3& d : random_directions(4000, 77, 74.0f)) {
      std::array<uint32_t, 4> q;
      if (!ring->bracket(d, q) || q[0] == q[1]) continue;
      const AngularSample t = tri->query(d);
      if (*std::min_element(t.weight.begin(), t.weight.end()) < 0.1f) continue;
      std::set<uint32_t> ts(t.index.begin(), t.index.end());
      const std::set<uint32_t> abc = {q[0], q[1], q[2]}, bcd = {q[1], q[2], q[3]};
      if (ts != abc && ts != bcd) continue;  // Delaunay uses another diagonal or other points
      const float da = glm::dot(d, set[q[0]].vector), dd = glm::dot(d, set[q[3]].vector);
      if (std::abs(da - dd) < 0.02f) continue;  // the d′ test is a proxy: keep clear cases
      ++cases;
      const AngularSample s = ring->query(d);
      std::set<uint32_t> rs(s.index.begin(), s.index.end());
      if (rs == ts) {
        ++agree;
        for (int k = 0; k < 3; ++k) {
          const int j = static_cast<int>(std::find(t.index.begin(), t.index.end(), s.index[k]) - t.index.begin());
          EXPECT_NEAR(s.weight[k], t.weight[j], 0.1f);
        }
      }
    }
    EXPECT_GT(cases, 200) << set.name();
    EXPECT_EQ(agree, cases) << set.name();
  }
}

TEST(AngularInterpolators, DefaultConstructedAreSafe) {
  // Never built: queries must not read out of bounds and still return a partition of unity.
  const ExactGridInterpolator<ParabolicMap> a;
  const LookupTableInterpolator<ElevatedConcentricMap> b;
  const NearestLookupInterpolator<ParabolicMap> c;
  const RingSearchInterpolator d;
  for (const AngularSample& s : {a.query({0, 0, 1}), b.query({0, 0, 1}), c.query({1, 0, 0}), d.query({0, 1, 1})}) {
    EXPECT_EQ(s.weight[0] + s.weight[1] + s.weight[2], 1.0f);
    EXPECT_EQ(s.index[0], 0u);
  }
}

TEST(AngularInterpolators, NineTapMultipliesWeights) {
  AngularSample l{{1, 2, 3}, {0.5f, 0.3f, 0.2f}};
  AngularSample v{{7, 8, 9}, {0.6f, 0.4f, 0.0f}};
  const NineTapSample n = combine_nine_tap(l, v);
  float sum = 0.0f;
  for (int k = 0; k < 9; ++k) {
    EXPECT_EQ(n.light_index[k], l.index[k / 3]);
    EXPECT_EQ(n.view_index[k], v.index[k % 3]);
    EXPECT_FLOAT_EQ(n.weight[k], l.weight[k / 3] * v.weight[k % 3]);
    sum += n.weight[k];
  }
  EXPECT_NEAR(sum, 1.0f, 1e-6f);
  int fetches = 0;
  const float r = evaluate_nine_tap(n, [&](uint32_t a, uint32_t b) noexcept {
    ++fetches;
    return static_cast<float>(a * 10 + b);
  });
  EXPECT_EQ(fetches, 6);  // zero-weight taps are skipped
  float expect = 0.0f;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) expect += l.weight[i] * v.weight[j] * static_cast<float>(l.index[i] * 10 + v.index[j]);
  EXPECT_NEAR(r, expect, 1e-4f);
  // Light × view interpolation of a table is exact at measured pairs.
  const DirectionSet set = DirectionSet::ubo2003();
  auto interp = ExactGridInterpolator<ParabolicMap>::build(set);
  ASSERT_TRUE(interp.ok());
  auto table = [&](uint32_t a, uint32_t b) noexcept { return glm::vec3(a, b, a * 0.5f + b); };
  for (uint32_t a = 0; a < set.size(); a += 7)
    for (uint32_t b = 0; b < set.size(); b += 5) {
      const glm::vec3 got = interpolate_light_view(*interp, *interp, set[a].vector, set[b].vector, table);
      EXPECT_NEAR(got.x, static_cast<float>(a), 2e-3f);
      EXPECT_NEAR(got.y, static_cast<float>(b), 2e-3f);
    }
}

}  // namespace
}  // namespace btflod
