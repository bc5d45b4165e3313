// btflod samples — per-tile tolerance helpers and direction names for the .bsvtf writer, shared
// by `btflod-convert build` and the demo. Building the container itself is the library's
// (offline/build/bsvtf_build.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/quantize.hpp"

namespace btflod::samples {

/// The library's container inputs (offline/build/bsvtf_build.hpp); kept under the samples' names.
using BsvtfTileInputs = btflod::BsvtfTileInputs;

/// Collects the tiles of levels [0, level_count) (offline/build/bsvtf_build.hpp bsvtf_tiles_from_pyramid;
/// tile size and border are the pyramid's).
inline BsvtfTileInputs bsvtf_tiles_from_pyramid(const TilePyramid& pyramid, uint32_t level_count,
                                                uint32_t /*tile_size*/, uint32_t /*border*/) {
  return btflod::bsvtf_tiles_from_pyramid(pyramid, level_count);
}

/// Per-tile perceptual tolerance (ToleranceReference is unchanged; this sets each tile's
/// BsvtfTileInput::tolerance_scale, which the tile header stores as the product, so the format
/// and readers are unchanged). The first FMF component (texture 0, channel 0) is the mean-like
/// one: the BTF at a texel is Σ_c U[r, c] v_c, and |v_0| times the (texel-independent) typical
/// |U[r, 0]| is the radiance the texel shows averaged over directions (paper 000 eq. 4–5). As
/// only ratios enter, the U factor cancels and is not needed. For every tile position (level,
/// x, y):
///     y_tile = the `percentile` (0..1) of |v_0| over the tile's interior texels (a LOW
///              percentile: the dark texels are where an absolute error is most visible),
///     y_peak = the largest |v_0| of the material (≈ component 0's range),
///     scale  = luminance_tolerance_scale(y_tile, y_peak, floor_fraction · y_peak)
///            = (max(y_tile, floor_fraction · y_peak) / y_peak)^(2/3)   (CIELAB L* ∝ Y^(1/3)),
/// applied to the tiles of every texture at that position (all components' errors add to the
/// same texels, eq. 4–5). The scale is ≤ 1: a material whose dark texels lie far below its
/// peak (a specular tiles material with dark grout) gets finer steps than the range alone
/// gives (the quality sets the overall budget). Tiles whose texture-0 tile is missing keep 1.
///
/// Display-referred variant (`white` > 0, U given with `components` columns, for
/// ToleranceReference::shared_max only): the rendered image is clamped to [0, 1] before sRGB
/// encoding, so what is visible is an error relative to the display white, not to the
/// material's largest range (a specular peak far above white sets shared_max's tolerance yet
/// clips). With u0 = mean |U[r, 0]| the texel radiance is ≈ u0 · |v_0|, white is W = white / u0
/// in |v_0| units, and the scale becomes
///     scale = (W / R) · (max(y_tile, floor_fraction · W) / W)^(2/3),   R = the largest range,
/// i.e. the tile's absolute tolerance is tolerance_for_quality(q, W) · (Y/W)^(2/3): the same
/// for every material at one quality, allocated by lightness. Preconditions: in built by
/// bsvtf_tiles_from_pyramid (4 channels); u has rows × components entries.
inline void apply_luminance_tolerance(BsvtfTileInputs& in, uint32_t tile_size, uint32_t border, float percentile = 0.1f,
                                      float floor_fraction = 0.05f, std::span<const float> u = {},
                                      uint32_t components = 0, float white = 0.0f) {
  const TileLayout layout{tile_size, border, 4};
  const uint32_t S = layout.stored_size();
  std::unordered_map<uint64_t, float> y_at;  // key of the texture-0 tile → y_tile
  float y_peak = 0.0f;
  std::vector<float> v;
  for (const BsvtfTileInput& t : in.tiles) {
    if (t.id.texture != 0) continue;
    v.clear();
    for (uint32_t y = border; y < border + tile_size; ++y)
      for (uint32_t x = border; x < border + tile_size; ++x) v.push_back(std::fabs(t.samples[(size_t{y} * S + x) * 4]));
    if (v.empty()) continue;
    y_peak = std::max(y_peak, *std::max_element(v.begin(), v.end()));
    const size_t n = std::min(v.size() - 1, static_cast<size_t>(std::clamp(percentile, 0.0f, 1.0f) * (v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n), v.end());
    y_at[t.id.key()] = v[n];
  }
  if (!(y_peak > 0.0f)) return;
  float y_ref = y_peak, factor = 1.0f;
  if (white > 0.0f && components > 0 && u.size() >= components) {
    double u0 = 0;
    const size_t rows = u.size() / components;
    for (size_t r = 0; r < rows; ++r) u0 += std::fabs(u[r * components]);
    u0 /= static_cast<double>(rows);
    float range = 0.0f;
    for (float r : bsvtf_component_ranges(in.tiles, components)) range = std::max(range, r);
    if (u0 > 0 && range > 0.0f) {
      y_ref = static_cast<float>(white / u0);
      factor = y_ref / range;
    }
  }
  for (BsvtfTileInput& t : in.tiles) {
    const auto it = y_at.find(TileId{0, t.id.level, t.id.x, t.id.y}.key());
    t.tolerance_scale =
        it == y_at.end() ? 1.0f : factor * luminance_tolerance_scale(it->second, y_ref, floor_fraction * y_ref);
  }
}

}  // namespace btflod::samples
