// btflod samples — turning a built tile pyramid into the inputs of the .bsvtf container writer.
// Shared by `btflod-convert build` and the demo so both write the same container from the same
// pyramid.
#pragma once

#include <cstdint>
#include <vector>

#include "btflod/btf/directions.hpp"
#include "btflod/codec/container.hpp"
#include "btflod/core/half.hpp"
#include "btflod/vt/tile_pyramid.hpp"

namespace btflod::samples {

/// Every tile of every virtual texture of the pyramid, as float samples with its eq. 8 weight.
/// `tiles[i].samples` points into `samples[i]`: keep the struct alive (and unmoved-from) while
/// the tiles are used.
struct BsvtfTileInputs {
  std::vector<std::vector<float>> samples;
  std::vector<BsvtfTileInput> tiles;
};

/// Collects the tiles of levels [0, level_count) in texture, level, row, column order.
inline BsvtfTileInputs bsvtf_tiles_from_pyramid(const TilePyramid& pyramid, uint32_t level_count, uint32_t tile_size,
                                                uint32_t border) {
  BsvtfTileInputs out;
  const VtLevelTable& levels = pyramid.levels();
  const TileLayout layout{tile_size, border, 4};
  for (uint32_t k = 0; k < pyramid.texture_count(); ++k)
    for (uint32_t l = 0; l < level_count; ++l)
      for (uint32_t y = 0; y < levels.tiles_y[l]; ++y)
        for (uint32_t x = 0; x < levels.tiles_x[l]; ++x) {
          const uint32_t index = levels.index(l, x, y);
          std::vector<float> texels(layout.sample_count());
          half_to_float(pyramid.tile_texels(k, index), texels);
          out.samples.push_back(std::move(texels));
          out.tiles.push_back({TileId{k, l, x, y}, {}, pyramid.weights(k)[index].to_float()});
        }
  for (size_t i = 0; i < out.tiles.size(); ++i) out.tiles[i].samples = out.samples[i];
  return out;
}

/// Fills the direction-set names and unit vectors of the container metadata.
inline void set_bsvtf_directions(BsvtfMetadata& md, const DirectionSet& lights, const DirectionSet& views) {
  md.light_set = lights.name();
  md.view_set = views.name();
  for (const Direction& d : lights)
    for (int k = 0; k < 3; ++k) md.light_directions.push_back(d.vector[k]);
  for (const Direction& d : views)
    for (int k = 0; k < 3; ++k) md.view_directions.push_back(d.vector[k]);
}

}  // namespace btflod::samples
