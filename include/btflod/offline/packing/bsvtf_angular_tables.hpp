// btflod — the angular lookup tables of a streamed material (paper 000 §4) from its `.bsvtf`
// container's own light and view directions: what a renderer binds as angular_index and
// angular_weight next to the tile cache and the page table. The container carries the measured
// directions but not the tables (they depend on the shader's parameterisation and resolution,
// ShaderConfig::angular), so every engine streaming a container builds them once at load time.
//
// Set-up code: builds a Delaunay triangulation per direction set and rasterises it (allocates,
// may take milliseconds per set). Thread-safe (no shared state).
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/parameterization.hpp"
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
inline Result<DirectionSet> direction_set_from_xyz(const char* what, std::span<const float> xyz) {
  if (xyz.empty() || xyz.size() % 3 != 0)
    return make_error(Status::invalid_argument, "angular tables: %s: %zu floats, expected a non-empty multiple of 3",
                      what, xyz.size());
  std::vector<std::pair<float, float>> tp;
  tp.reserve(xyz.size() / 3);
  for (size_t i = 0; i < xyz.size(); i += 3) {
    const float x = xyz[i], y = xyz[i + 1], z = xyz[i + 2];
    const float len = std::sqrt(x * x + y * y + z * z);
    if (!(len > 1e-6f) || !std::isfinite(len))
      return make_error(Status::invalid_argument, "angular tables: %s: direction %zu is not a finite non-zero vector",
                        what, i / 3);
    tp.emplace_back(std::acos(std::fmin(1.0f, std::fmax(-1.0f, z / len))), std::atan2(y, x));
  }
  return DirectionSet::from_radians(what, tp);
}

template <class Map>
VoidResult rasterise_tables(const DirectionSet& set, int resolution, std::vector<uint32_t>& index,
                            std::vector<float>& weight) {
  auto table = LookupTableInterpolator<Map>::build(set, resolution);
  if (!table) return table.error();
  index.assign(table->index_table().elements().begin(), table->index_table().elements().end());
  weight.assign(table->weight_table().elements().begin(), table->weight_table().elements().end());
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
  auto lights = detail::direction_set_from_xyz("light directions", metadata.light_directions);
  if (!lights) return lights.error();
  auto views = detail::direction_set_from_xyz("view directions", metadata.view_directions);
  if (!views) return views.error();
  BsvtfAngularTables t;
  t.resolution = angular.resolution;
  t.light_count = static_cast<uint32_t>(lights->size());
  t.view_count = static_cast<uint32_t>(views->size());
  const int res = static_cast<int>(angular.resolution);
  const bool parabolic = angular.parameterisation == DirectionParameterisation::parabolic;
  for (int k = 0; k < 2; ++k) {
    const DirectionSet& set = k == 0 ? *lights : *views;
    std::vector<uint32_t>& idx = k == 0 ? t.light_index : t.view_index;
    std::vector<float>& wt = k == 0 ? t.light_weight : t.view_weight;
    VoidResult r = parabolic ? detail::rasterise_tables<ParabolicMap>(set, res, idx, wt)
                             : detail::rasterise_tables<ElevatedConcentricMap>(set, res, idx, wt);
    if (!r) return r.error();
  }
  pack_angular_tables_rgba(t.data(), t.index_rgba, t.weight_rgba);
  return t;
}

}  // namespace btflod
