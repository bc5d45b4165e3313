// btflod — angular interpolators that work in a parameter plane (HemisphereParameterization):
//   ExactGridInterpolator<P>     exact point location, uniform grid + per-triangle inverse (paper 003 §4.2, eq. 8)
//   LookupTableInterpolator<P>   triangulation rasterised into index + barycentric images (paper 000 §4)
//   NearestLookupInterpolator<P> nearest measured direction via a lookup table (paper 001 §3.4)
// Each is built once from a DirectionSet (allocates, returns Result) and then answers
// query(direction) → AngularSample: noexcept, allocation-free, thread-safe. All of them satisfy
// the AngularInterpolator concept. Directions below the horizon are clamped onto it
// (clamp_to_hemisphere); directions outside the triangulated hull map to the nearest hull point.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/vec.hpp"
#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/angular/parameterization.hpp"
#include "btflod/runtime/angular/delaunay.hpp"
#include "btflod/runtime/angular/hemisphere_maps.hpp"
#include "btflod/runtime/angular/lookup_table.hpp"
#include "btflod/runtime/angular/triangle_locator.hpp"

namespace btflod {

/// The direction in double precision: from (θ, φ) in double when they describe d.vector (sets
/// built from angles), else d.vector promoted. noexcept, thread-safe.
inline glm::dvec3 direction_precise(const Direction& d) noexcept {
  return direction_precise(d.theta, d.phi, Vector3f(d.vector));
}

/// Delaunay triangulation of a direction set in the [0, 1]² square of parameterisation P.
/// The parameter points are computed in double (direction_precise, to_square_precise): points
/// that lie on one line of the square in exact arithmetic (a ring's points on one side of the
/// concentric map's square) stay on it, so the triangulation has no sliver triangles.
/// Triangle vertex ids are direction indices. Returns an error for fewer than three distinct,
/// non-collinear directions or non-finite vectors. Allocates; thread-safe.
template <HemisphereParameterization P>
Result<Triangulation> triangulate_directions(const DirectionSet& set) {
  std::vector<Vector2d> pts;
  pts.reserve(set.size());
  for (const Direction& d : set) pts.emplace_back(to_square_precise<P>(direction_precise(d)));
  return delaunay_triangulate(std::span<const Vector2d>(pts));
}

/// Same, from direction vectors given in double precision (e.g. computed by the caller from
/// exact angles). Errors as delaunay_triangulate. Allocates; thread-safe.
template <HemisphereParameterization P>
Result<Triangulation> triangulate_directions(std::span<const glm::dvec3> directions) {
  std::vector<Vector2d> pts;
  pts.reserve(directions.size());
  for (const glm::dvec3& d : directions) pts.emplace_back(to_square_precise<P>(d));
  return delaunay_triangulate(std::span<const Vector2d>(pts));
}

/// Exact barycentric interpolation over the Delaunay triangulation in P's plane, located with
/// a uniform grid and per-triangle inverse matrices (paper 003 §4.2, eq. 8).
template <HemisphereParameterization P>
class ExactGridInterpolator {
 public:
  /// Builds the triangulation and the grid (grid_resolution ≤ 0: automatic). Errors as
  /// triangulate_directions. Allocates; not per-frame.
  static Result<ExactGridInterpolator> build(const DirectionSet& set, int grid_resolution = 0) {
    auto tri = triangulate_directions<P>(set);
    if (!tri) return tri.error();
    ExactGridInterpolator out;
    out.count_ = static_cast<uint32_t>(set.size());
    out.locator_ = TriangleGridLocator(tri.value(), grid_resolution);
    out.triangulation_ = std::move(tri.value());
    return out;
  }

  /// Barycentric weights of the containing triangle of P::to_square(dir). noexcept,
  /// allocation-free, thread-safe; any input (see file comment).
  AngularSample query(glm::vec3 dir) const noexcept { return locator_.locate(P::to_square(dir)); }
  /// Same, for a point already in P's square.
  AngularSample query_square(glm::vec2 st) const noexcept { return locator_.locate(st); }
  uint32_t direction_count() const noexcept { return count_; }
  const Triangulation& triangulation() const noexcept { return triangulation_; }
  const TriangleGridLocator& locator() const noexcept { return locator_; }

 private:
  uint32_t count_ = 0;
  Triangulation triangulation_;
  TriangleGridLocator locator_;
};

/// The triangulation rasterised into two resolution × resolution tables (paper 000 §4; layout in
/// runtime/angular/lookup_table.hpp, rasterise_angular_lookup).
template <HemisphereParameterization P>
class LookupTableInterpolator {
 public:
  /// Rasterises the triangulation of `set` at `resolution` (1 … 8192). Errors: bad resolution,
  /// or as triangulate_directions. Allocates; not per-frame.
  static Result<LookupTableInterpolator> build(const DirectionSet& set, int resolution = 256) {
    if (auto ok = detail::check_lookup_resolution("lookup table", resolution); !ok) return ok.error();
    auto exact = ExactGridInterpolator<P>::build(set);
    if (!exact) return exact.error();
    auto images = rasterise_angular_lookup(exact->locator(), resolution);
    if (!images) return images.error();
    LookupTableInterpolator out;
    out.count_ = exact->direction_count();
    out.resolution_ = resolution;
    out.indices_ = std::move(images->indices);
    out.weights_ = std::move(images->weights);
    return out;
  }

  /// The sample of the texel containing P::to_square(dir) (nearest filtering, as a shader
  /// with GL_NEAREST). noexcept, allocation-free, thread-safe.
  AngularSample query(glm::vec3 dir) const noexcept { return query_square(P::to_square(dir)); }
  AngularSample query_square(glm::vec2 st) const noexcept {
    if (resolution_ <= 0) return AngularSample{};  // default-constructed: no table
    st = detail::clamp_unit_square(st);
    const float r = static_cast<float>(resolution_);
    const int x = glm::min(static_cast<int>(st.x * r), resolution_ - 1);
    const int y = glm::min(static_cast<int>(st.y * r), resolution_ - 1);
    AngularSample s;
    const size_t base = (static_cast<size_t>(y) * static_cast<size_t>(resolution_) + static_cast<size_t>(x)) * 3;
    for (int c = 0; c < 3; ++c) {
      s.index[c] = indices_.data()[base + c];
      s.weight[c] = weights_.data()[base + c];
    }
    return s;
  }
  uint32_t direction_count() const noexcept { return count_; }
  int resolution() const noexcept { return resolution_; }
  /// Raw tables for upload: R × R × 3 direction indices and R × R × 3 weights.
  const Image<uint32_t>& index_table() const noexcept { return indices_; }
  const Image<float>& weight_table() const noexcept { return weights_; }

 private:
  uint32_t count_ = 0;
  int resolution_ = 0;
  Image<uint32_t> indices_;
  Image<float> weights_;
};

/// Nearest measured direction through a lookup table (paper 001 §3.4): each texel of an
/// R × R table over P's square stores the index of the direction with the largest dot product
/// with P::from_square(texel centre). The sample has one index with weight 1.
template <HemisphereParameterization P>
class NearestLookupInterpolator {
 public:
  /// Builds the table (resolution 1 … 8192). Errors: empty set, bad resolution. Allocates.
  static Result<NearestLookupInterpolator> build(const DirectionSet& set, int resolution = 256) {
    if (auto ok = detail::check_lookup_resolution("nearest table", resolution); !ok) return ok.error();
    if (set.empty()) return make_error(Status::invalid_argument, "nearest table: the direction set is empty");
    NearestLookupInterpolator out;
    out.count_ = static_cast<uint32_t>(set.size());
    out.resolution_ = resolution;
    out.table_ = Image<uint32_t>(resolution, resolution, 1);
    detail::for_each_texel_centre(resolution, [&](int x, int y, glm::vec2 st) {
      out.table_.at(x, y) = static_cast<uint32_t>(set.nearest(P::from_square(st)));
    });
    return out;
  }

  /// {nearest index ×3, weights {1, 0, 0}} from the texel containing P::to_square(dir).
  /// noexcept, allocation-free, thread-safe.
  AngularSample query(glm::vec3 dir) const noexcept {
    if (resolution_ <= 0) return AngularSample{};  // default-constructed: no table
    const glm::vec2 st = P::to_square(dir);
    const float r = static_cast<float>(resolution_);
    const int x = glm::clamp(static_cast<int>(st.x * r), 0, resolution_ - 1);
    const int y = glm::clamp(static_cast<int>(st.y * r), 0, resolution_ - 1);
    const uint32_t i =
        table_.data()[static_cast<size_t>(y) * static_cast<size_t>(resolution_) + static_cast<size_t>(x)];
    AngularSample s;
    s.index = {i, i, i};
    s.weight = {1.0f, 0.0f, 0.0f};
    return s;
  }
  uint32_t direction_count() const noexcept { return count_; }
  int resolution() const noexcept { return resolution_; }
  /// Raw R × R × 1 table of direction indices.
  const Image<uint32_t>& table() const noexcept { return table_; }

 private:
  uint32_t count_ = 0;
  int resolution_ = 0;
  Image<uint32_t> table_;
};

static_assert(AngularInterpolator<ExactGridInterpolator<ParabolicMap>>);
static_assert(AngularInterpolator<LookupTableInterpolator<ElevatedConcentricMap>>);
static_assert(AngularInterpolator<NearestLookupInterpolator<ParabolicMap>>);

}  // namespace btflod
