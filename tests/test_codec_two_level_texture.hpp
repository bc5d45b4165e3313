// Shared by the tolerance and rendered-error tests (test_codec_perceptual.cpp,
// test_codec_rendered_rate.cpp): one small texture of two levels, its U′ and its tiles' samples.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"

namespace btflod_test {

// One 32 × 32 texture of 4 components in tiles of T = 16, B = 4: level 0 (the root) and the
// four level-1 tiles, in that order in `tiles` (level-1 tile (x, y) at 1 + x + 2y). U′ has
// u_rows rows of 4 columns, all 0; the caller fills it and sets the directions.
struct TwoLevelTexture {
  btflod::BsvtfMetadata md;
  std::vector<float> u;
  std::vector<std::vector<float>> samples;
  std::vector<btflod::BsvtfTileInput> tiles;

  explicit TwoLevelTexture(uint32_t u_rows) {
    md.tile_size = 16;
    md.border = 4;
    md.level_count = 2;
    md.width = md.height = 32;
    md.component_count = 4;
    md.u_rows = u_rows;
    u.assign(size_t{md.u_rows} * 4, 0.0f);
  }

  // Adds the five tiles with the samples tile_samples(index) gives, index 0 for the root and
  // 1 + x + 2y for level-1 tile (x, y), at scale 1.
  template <class TileSamples>
  void add_tiles(TileSamples&& tile_samples) {
    const auto add = [&](btflod::TileId id, uint32_t index) {
      samples.push_back(tile_samples(index));
      tiles.push_back({id, {}, 1.0f});
    };
    add({0, 0, 0, 0}, 0);
    for (uint32_t y = 0; y < 2; ++y)
      for (uint32_t x = 0; x < 2; ++x) add({0, 1, x, y}, 1 + x + 2 * y);
    for (size_t i = 0; i < tiles.size(); ++i) tiles[i].samples = samples[i];
  }

  const btflod::BsvtfTileInput& level1(uint32_t x, uint32_t y) const { return tiles[1 + x + 2 * y]; }
};

}  // namespace btflod_test
