// btflod — the angular lookup tables of a streamed material (paper 000 §4) from its `.bsvtf`
// container's own light and view directions: what a renderer binds as angular_index and
// angular_weight next to the tile cache and the page table. The container carries the measured
// directions but not the tables (they depend on the shader's parameterisation and resolution,
// ShaderConfig::angular), so every engine streaming a container builds them once at load time.
//
// Runtime set-up code (no GLM: core vectors only, so an engine linking btflod::runtime builds
// them): a Delaunay triangulation per direction set, rasterised into the tables (allocates, may
// take milliseconds per set). Thread-safe (no shared state).
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/core/vec.hpp"
#include "btflod/runtime/angular/delaunay.hpp"
#include "btflod/runtime/angular/hemisphere_maps.hpp"
#include "btflod/runtime/angular/lookup_table.hpp"
#include "btflod/runtime/angular/triangle_locator.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod {

/// Angular lookup tables of one material, owned, with the views a Backend takes
/// (AngularTablesData) and the RGBA textures a shader reads (pack_angular_tables_rgba layout:
/// 2 layers, light then view, res² texels each; indices RGBA32UI, weights RGBA32F, .w = 0).
struct BsvtfAngularTables {
  uint32_t resolution = 0;
  uint32_t light_count = 0, view_count = 0;
  std::vector<uint32_t> light_index, view_index;  ///< res² · 3
  std::vector<float> light_weight, view_weight;   ///< res² · 3
  std::vector<uint32_t> index_rgba;               ///< 2 · res² · 4 (texture angular_index)
  std::vector<float> weight_rgba;                 ///< 2 · res² · 4 (texture angular_weight)

  /// The tables as a Backend material's AngularTablesData (views into this object).
  AngularTablesData data() const noexcept {
    return AngularTablesData{resolution, light_index, light_weight, view_index, view_weight};
  }
};

namespace detail {
/// The parameter-plane points of a list of directions (x, y, z floats each, not necessarily
/// unit length): each direction becomes (θ, φ), then the float unit vector of a direction set
/// built from those angles, then its double-precision form (direction_precise) mapped by the
/// parameterisation. Returns invalid_argument for an empty or ragged list or a non-finite or
/// zero direction.
inline Result<std::vector<Vector2d>> angular_square_points(const char* what, std::span<const float> xyz,
                                                           DirectionParameterisation parameterisation) {
  if (xyz.empty() || xyz.size() % 3 != 0)
    return make_error(Status::invalid_argument, "angular tables: %s: %zu floats, expected a non-empty multiple of 3",
                      what, xyz.size());
  std::vector<Vector2d> points;
  points.reserve(xyz.size() / 3);
  for (size_t i = 0; i < xyz.size(); i += 3) {
    const float x = xyz[i], y = xyz[i + 1], z = xyz[i + 2];
    const float len = std::sqrt(x * x + y * y + z * z);
    if (!(len > 1e-6f) || !std::isfinite(len))
      return make_error(Status::invalid_argument, "angular tables: %s: direction %zu is not a finite non-zero vector",
                        what, i / 3);
    const float theta = std::acos(std::fmin(1.0f, std::fmax(-1.0f, z / len)));
    const float phi = std::atan2(y, x);
    const Vector3d d = direction_precise(theta, phi, unit_vector_from_spherical(theta, phi));
    points.push_back(direction_to_square_precise(parameterisation, d));
  }
  return points;
}

/// Triangulates `points` and rasterises the triangulation into `index` and `weight`
/// (resolution² · 3 each). Errors: a resolution outside [1, 8192], or the triangulation's.
inline VoidResult rasterise_tables(std::span<const Vector2d> points, int resolution, std::vector<uint32_t>& index,
                                   std::vector<float>& weight) {
  if (auto ok = check_lookup_resolution("lookup table", resolution); !ok) return ok.error();
  auto tri = delaunay_triangulate(points);
  if (!tri) return tri.error();
  auto images = rasterise_angular_lookup(TriangleGridLocator(*tri), resolution);
  if (!images) return images.error();
  index.assign(images->indices.elements().begin(), images->indices.elements().end());
  weight.assign(images->weights.elements().begin(), images->weights.elements().end());
  return {};
}
}  // namespace detail

/// Builds the angular lookup tables of a container's light and view directions for the
/// shader configuration `angular` (parameterisation and resolution; AngularLookup::nearest
/// uses the same tables). Returns invalid_argument for a metadata without directions or with
/// a non-finite or zero direction, or the triangulation's error (e.g. fewer than 3 directions
/// that span the hemisphere). Safe for untrusted metadata. Allocates (set-up time).
inline Result<BsvtfAngularTables> build_bsvtf_angular_tables(const BsvtfMetadata& metadata,
                                                             const AngularTableConfig& angular) {
  auto lights = detail::angular_square_points("light directions", metadata.light_directions, angular.parameterisation);
  if (!lights) return lights.error();
  auto views = detail::angular_square_points("view directions", metadata.view_directions, angular.parameterisation);
  if (!views) return views.error();
  BsvtfAngularTables t;
  t.resolution = angular.resolution;
  t.light_count = static_cast<uint32_t>(lights->size());
  t.view_count = static_cast<uint32_t>(views->size());
  const int res = static_cast<int>(angular.resolution);
  if (auto r = detail::rasterise_tables(*lights, res, t.light_index, t.light_weight); !r) return r.error();
  if (auto r = detail::rasterise_tables(*views, res, t.view_index, t.view_weight); !r) return r.error();
  pack_angular_tables_rgba(t.data(), t.index_rgba, t.weight_rgba);
  return t;
}

}  // namespace btflod
