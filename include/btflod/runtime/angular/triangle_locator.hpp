// btflod — exact point location in a triangulation: a uniform grid over the parameter
// square plus one precomputed inverse matrix per triangle (paper 003 §4.2, eq. 8), so that a
// barycentric test is one subtraction and one 2×2 matrix-vector product.
//
// Points outside the triangulated hull (directions beyond the last measured ring) are mapped
// to the NEAREST POINT OF THE HULL in the parameter plane: the result interpolates linearly
// along the closest hull edge (two non-zero weights) or returns a single hull vertex; samples
// are in the canonical form of angular_sample.hpp (each direction named once).
//
// Runtime set-up code on core vectors (no GLM): building a locator allocates; locate() is
// noexcept and allocation-free.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "btflod/core/vec.hpp"
#include "btflod/runtime/angular/angular_sample.hpp"
#include "btflod/runtime/angular/delaunay.hpp"
#include "btflod/runtime/angular/hemisphere_maps.hpp"

namespace btflod {

/// One triangle as stored for location: λ = inverse · (p − v3), λ3 = 1 − λ1 − λ2
/// (paper 003 eq. 8; 9 floats/ids per triangle instead of the paper's 16 because our plane is 2D).
struct LocatorTriangle {
  std::array<float, 4> inverse{};  ///< row-major 2×2 inverse of T = [v1 − v3, v2 − v3]
  Vector2f v3{};
  std::array<uint32_t, 3> index{};  ///< direction indices of v1, v2, v3
};

/// Uniform-grid point locator over [0, 1]². Build once (allocates); locate() is noexcept,
/// allocation-free and thread-safe.
class TriangleGridLocator {
 public:
  /// Weights of a triangle test may be this negative and still count as inside (float noise
  /// on shared edges); they are clamped to 0 and renormalised.
  static constexpr float kInsideTolerance = 1e-5f;

  TriangleGridLocator() = default;

  /// Builds the grid for `tri` (from delaunay_triangulate over [0, 1]² coordinates).
  /// grid_resolution ≤ 0 picks ⌈√(triangle count)⌉ (about one to two triangles per cell).
  /// Precondition: tri is a valid triangulation with at least one triangle.
  explicit TriangleGridLocator(const Triangulation& tri, int grid_resolution = 0) {
    const size_t nt = tri.triangles.size();
    grid_ = grid_resolution > 0 ? grid_resolution
                                : std::max(4, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(nt)))));
    triangles_.reserve(nt);
    for (const auto& v : tri.triangles) {
      const Vector2d p1 = tri.points[v[0]], p2 = tri.points[v[1]], p3 = tri.points[v[2]];
      const Vector2d c1 = p1 - p3, c2 = p2 - p3;
      const double det = c1.x * c2.y - c2.x * c1.y;  // > 0: CCW, never 0 (no degenerate triangles)
      LocatorTriangle t;
      t.inverse = {static_cast<float>(c2.y / det), static_cast<float>(-c2.x / det), static_cast<float>(-c1.y / det),
                   static_cast<float>(c1.x / det)};
      t.v3 = Vector2f(p3);
      t.index = v;
      triangles_.push_back(t);
    }
    for (size_t k = 0; k < tri.hull.size(); ++k) {
      const uint32_t a = tri.hull[k], b = tri.hull[(k + 1) % tri.hull.size()];
      hull_.push_back({Vector2f(tri.points[a]), Vector2f(tri.points[b]), a, b});
    }
    const size_t cells = static_cast<size_t>(grid_) * static_cast<size_t>(grid_);
    std::vector<std::vector<uint32_t>> tri_lists(cells), hull_lists(cells);
    const double cell = 1.0 / grid_;
    constexpr double kEps = 1e-6;
    for (uint32_t t = 0; t < nt; ++t) {
      const auto& v = tri.triangles[t];
      constexpr double kBig = std::numeric_limits<double>::max();
      Vector2d lo(kBig, kBig), hi(-kBig, -kBig);
      for (uint32_t i : v) {
        lo = min(lo, tri.points[i]);
        hi = max(hi, tri.points[i]);
      }
      const int x0 = cell_of(lo.x - kEps), x1 = cell_of(hi.x + kEps);
      const int y0 = cell_of(lo.y - kEps), y1 = cell_of(hi.y + kEps);
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) tri_lists[static_cast<size_t>(y) * grid_ + x].push_back(t);
    }
    // Hull edges that can be the nearest one for some point of a cell: e is a candidate
    // unless dist(e, centre) − half-diagonal exceeds the smallest max-distance of any edge
    // over the cell (taken at the cell corners, the distance to a segment being convex).
    const double half_diag = 0.5 * std::sqrt(2.0) * cell;
    for (int y = 0; y < grid_; ++y)
      for (int x = 0; x < grid_; ++x) {
        const Vector2d c0(x * cell, y * cell);
        const Vector2d centre = c0 + 0.5 * cell;
        double bound = std::numeric_limits<double>::max();
        for (const auto& e : hull_) {
          double worst = 0.0;
          for (int k = 0; k < 4; ++k) {
            const Vector2d corner = c0 + Vector2d((k & 1) * cell, (k >> 1) * cell);
            worst = std::max(worst, segment_distance(corner, e));
          }
          bound = std::min(bound, worst);
        }
        for (uint32_t e = 0; e < hull_.size(); ++e)
          if (segment_distance(centre, hull_[e]) - half_diag <= bound + kEps)
            hull_lists[static_cast<size_t>(y) * grid_ + x].push_back(e);
      }
    flatten(tri_lists, cell_start_, cell_items_);
    flatten(hull_lists, hull_start_, hull_items_);
  }

  /// Interpolation weights at square coordinate st (clamped to [0, 1]²; NaN → centre).
  /// Inside the hull: the barycentric coordinates of the containing triangle (paper 003 eq. 8).
  /// Outside: linear interpolation at the nearest hull point. Returns a default sample when
  /// the locator is empty. noexcept, allocation-free, thread-safe.
  AngularSample locate(Vector2f st) const noexcept {
    AngularSample out;
    if (triangles_.empty()) return out;
    st = detail::clamp_unit_square(st);
    const size_t cell = static_cast<size_t>(cell_of(st.y)) * grid_ + static_cast<size_t>(cell_of(st.x));
    float best_min = -std::numeric_limits<float>::max();
    Vector3f best_l(1.0f, 0.0f, 0.0f);
    const LocatorTriangle* best = nullptr;
    for (uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
      const LocatorTriangle& t = triangles_[cell_items_[k]];
      const Vector2f d = st - t.v3;  // paper 003 eq. 8: λ = T⁻¹ (r − v3)
      const float l1 = t.inverse[0] * d.x + t.inverse[1] * d.y;
      const float l2 = t.inverse[2] * d.x + t.inverse[3] * d.y;
      const float l3 = 1.0f - l1 - l2;
      const float m = std::min(l1, std::min(l2, l3));
      if (m > best_min) {
        best_min = m;
        best_l = {l1, l2, l3};
        best = &t;
        if (m >= 0.0f) break;
      }
    }
    if (best != nullptr && best_min >= -kInsideTolerance) {
      Vector3f l = max(best_l, Vector3f(0.0f, 0.0f, 0.0f));
      const float s = l.x + l.y + l.z;
      l /= s;
      out.index = best->index;
      out.weight = {l.x, l.y, l.z};
      return canonical_angular_sample(out);
    }
    // Outside the hull: nearest point on the nearest hull edge.
    float best_d = std::numeric_limits<float>::max();
    for (uint32_t k = hull_start_[cell]; k < hull_start_[cell + 1]; ++k) {
      const HullEdge& e = hull_[hull_items_[k]];
      const Vector2f ab = e.b - e.a;
      const float len2 = dot(ab, ab);
      const float u = len2 > 0.0f ? std::min(std::max(dot(st - e.a, ab) / len2, 0.0f), 1.0f) : 0.0f;
      const Vector2f q = e.a + u * ab - st;
      const float d2 = dot(q, q);
      if (d2 < best_d) {
        best_d = d2;
        out.index = {e.ia, e.ib, e.ia};
        out.weight = {1.0f - u, u, 0.0f};
      }
    }
    // One hull vertex (u = 0 or 1) or two edge ends; never {a, b, a} with a weighted padding.
    return canonical_angular_sample(out);
  }

  int grid_resolution() const noexcept { return grid_; }
  size_t triangle_count() const noexcept { return triangles_.size(); }
  /// The per-triangle records (inverse matrix, v3, indices) in triangulation order.
  const std::vector<LocatorTriangle>& triangles() const noexcept { return triangles_; }
  /// CSR grid: triangles of cell c (row-major, grid_resolution² cells) are
  /// cell_items()[cell_start()[c] .. cell_start()[c + 1]).
  const std::vector<uint32_t>& cell_start() const noexcept { return cell_start_; }
  const std::vector<uint32_t>& cell_items() const noexcept { return cell_items_; }

 private:
  struct HullEdge {
    Vector2f a, b;
    uint32_t ia, ib;
  };

  int cell_of(double v) const noexcept {
    const int c = static_cast<int>(std::floor(v * grid_));
    return std::clamp(c, 0, grid_ - 1);
  }

  static double segment_distance(Vector2d p, const HullEdge& e) {
    const Vector2d a(e.a), b(e.b), ab = b - a;
    const double len2 = dot(ab, ab);
    const double u = len2 > 0.0 ? std::clamp(dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
    return length(a + u * ab - p);
  }

  static void flatten(const std::vector<std::vector<uint32_t>>& lists, std::vector<uint32_t>& start,
                      std::vector<uint32_t>& items) {
    start.assign(lists.size() + 1, 0);
    for (size_t c = 0; c < lists.size(); ++c) start[c + 1] = start[c] + static_cast<uint32_t>(lists[c].size());
    items.clear();
    items.reserve(start.back());
    for (const auto& l : lists) items.insert(items.end(), l.begin(), l.end());
  }

  int grid_ = 1;
  std::vector<LocatorTriangle> triangles_;
  std::vector<HullEdge> hull_;
  std::vector<uint32_t> cell_start_{0, 0};
  std::vector<uint32_t> cell_items_;
  std::vector<uint32_t> hull_start_{0, 0};
  std::vector<uint32_t> hull_items_;
};

}  // namespace btflod
