// btflod — building a `.bsvtf` container from a factorisation: eigen-textures V′ and angular
// matrix U′ (runtime/vt/vt_layout.hpp EigenTextures, from any representation in factor/) → tile
// pyramid with weights w and energies (offline/build/tile_pyramid.hpp, paper 000 §3, eq. 8, §6) →
// residual tile codec → container (runtime/codec/container.hpp). Offline code (allocates, may use the
// thread pool); what `btflod-convert build` and the demo call.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/runtime/codec/container.hpp"

namespace btflod {

/// Every tile of levels [0, level_count) of every virtual texture of a pyramid as float
/// samples with its w and energy, in texture, level, row, column order. `tiles[i].samples`
/// points into `samples[i]`: keep the struct alive (and unmoved-from) while the tiles are used.
struct BsvtfTileInputs {
  std::vector<std::vector<float>> samples;
  std::vector<BsvtfTileInput> tiles;
};

/// Collects the pyramid's tiles as build_bsvtf() inputs. Allocates.
inline BsvtfTileInputs bsvtf_tiles_from_pyramid(const TilePyramid& pyramid, uint32_t level_count) {
  BsvtfTileInputs out;
  const VtLevelTable& levels = pyramid.levels();
  const VtGeometry& g = pyramid.geometry();
  const TileLayout layout{g.tile_size, g.border, 4};
  for (uint32_t k = 0; k < pyramid.texture_count(); ++k)
    for (uint32_t l = 0; l < level_count && l <= levels.finest_level(); ++l)
      for (uint32_t y = 0; y < levels.tiles_y[l]; ++y)
        for (uint32_t x = 0; x < levels.tiles_x[l]; ++x) {
          const uint32_t index = levels.index(l, x, y);
          std::vector<float> texels(layout.sample_count());
          half_to_float(pyramid.tile_texels(k, index), texels);
          out.samples.push_back(std::move(texels));
          BsvtfTileInput t;
          t.id = TileId{k, l, x, y};
          t.weight = pyramid.weights(k)[index].to_float();
          t.energy = pyramid.energies(k)[index].to_float();
          out.tiles.push_back(t);
        }
  for (size_t i = 0; i < out.tiles.size(); ++i) out.tiles[i].samples = out.samples[i];
  return out;
}

/// Container metadata for a pyramid: sizes, levels, C, U's rows and their order (e.row_order),
/// the value encoding, directions. `light_directions` / `view_directions`: xyz triples
/// (light_count resp. view_count of them).
inline BsvtfMetadata bsvtf_metadata_for(const EigenTextures& e, const TilePyramid& pyramid,
                                        std::span<const float> light_directions, std::span<const float> view_directions,
                                        std::string material_name = {}) {
  BsvtfMetadata md;
  md.material_name = std::move(material_name);
  md.width = pyramid.geometry().width;
  md.height = pyramid.geometry().height;
  md.tile_size = pyramid.geometry().tile_size;
  md.border = pyramid.geometry().border;
  md.level_count = pyramid.geometry().level_count();
  md.component_count = e.components();
  md.color_channels = 3;
  md.color_mode = ColorMode::linear_rgb;
  md.u_rows = e.light_count * e.view_count * 3;
  md.u_row_order = e.row_order;
  md.light_directions.assign(light_directions.begin(), light_directions.end());
  md.view_directions.assign(view_directions.begin(), view_directions.end());
  md.value_transform = e.transform;
  return md;
}

/// Options of build_bsvtf_from_eigen_textures().
struct BsvtfFromEigenOptions {
  uint32_t tile_size = kDefaultTileSize;  ///< T
  uint32_t border = kDefaultTileBorder;   ///< B
  TileEdge edge = TileEdge::clamp;        ///< outer tile borders (wrap for repeated materials)
  std::string material_name;
  std::vector<float> light_directions;  ///< xyz per light (e.light_count triples)
  std::vector<float> view_directions;   ///< xyz per view (e.view_count triples)
  std::string light_set, view_set;      ///< the direction sets' names (stored in the container)
  BsvtfBuildOptions build;              ///< quality, tolerances, threads, progress
};

/// Builds the complete container file for one material; U's row order is e.row_order (stored in
/// the container, so readers cannot misread U). Returns the bytes, or invalid_argument
/// (inconsistent eigen-textures, direction counts that do not match, unspecified row order) or
/// the errors of TilePyramid::build / build_bsvtf. Deterministic for any thread count.
inline Result<std::vector<uint8_t>> build_bsvtf_from_eigen_textures(const EigenTextures& e,
                                                                    const BsvtfFromEigenOptions& options) {
  if (e.row_order == AngularRowOrder::unspecified)
    return make_error(Status::invalid_argument,
                      "build_bsvtf_from_eigen_textures: row order must be light- or view-major");
  if (options.light_directions.size() != size_t{e.light_count} * 3 ||
      options.view_directions.size() != size_t{e.view_count} * 3)
    return make_error(
        Status::invalid_argument,
        "build_bsvtf_from_eigen_textures: %zu light and %zu view direction floats for %u lights and %u views",
        options.light_directions.size(), options.view_directions.size(), e.light_count, e.view_count);
  auto pyramid = TilePyramid::build(e, options.tile_size, options.border, options.edge);
  if (!pyramid) return pyramid.error();
  BsvtfMetadata md =
      bsvtf_metadata_for(e, *pyramid, options.light_directions, options.view_directions, options.material_name);
  md.light_set = options.light_set;
  md.view_set = options.view_set;
  const BsvtfTileInputs inputs = bsvtf_tiles_from_pyramid(*pyramid, md.level_count);
  return build_bsvtf(md, e.angular, inputs.tiles, options.build);
}

}  // namespace btflod
