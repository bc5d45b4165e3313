// btflod — building the tile pyramid of an FMF material's eigen-textures (paper 000 §3, §5.2, §7).
//
// Pre-processing code (allocates, not per frame): box-filtered down-sampling of the eigen-
// textures to every level, cutting each level into T×T tiles with B texels of border taken from
// the neighbouring texels of the same level (clamp-to-edge or wrapped outside the texture, see
// TileEdge), so bilinear
// filtering inside the physical cache matches bilinear filtering of the level image exactly;
// stored as RGBA16F, four eigen-texture components per texel. Also computes the tile weights
// w(i, l, l−1) of eq. 8 and the tile energies ‖T‖²_F/T² of §6, stored as half.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"

namespace btflod {

/// Bilinear sample of a 4-channel level image at continuous texel coordinates (s, t) (texel
/// centres at i + 0.5), clamp-to-edge addressing. Writes 4 floats to out. Thread-safe, noexcept.
/// Precondition: image has 4 channels and is non-empty.
inline void sample_bilinear_clamped(const Image<float>& image, float s, float t, float* out) noexcept {
  const float fs = s - 0.5f, ft = t - 0.5f;
  const float x0f = std::floor(fs), y0f = std::floor(ft);
  const float ax = fs - x0f, ay = ft - y0f;
  const int w = image.width(), h = image.height();
  const auto clampi = [](int v, int hi) { return v < 0 ? 0 : (v > hi ? hi : v); };
  const int x0 = clampi(static_cast<int>(x0f), w - 1), x1 = clampi(static_cast<int>(x0f) + 1, w - 1);
  const int y0 = clampi(static_cast<int>(y0f), h - 1), y1 = clampi(static_cast<int>(y0f) + 1, h - 1);
  const float* p00 = &image.at(x0, y0);
  const float* p10 = &image.at(x1, y0);
  const float* p01 = &image.at(x0, y1);
  const float* p11 = &image.at(x1, y1);
  for (int c = 0; c < 4; ++c) {
    const float top = p00[c] + (p10[c] - p00[c]) * ax;
    const float bottom = p01[c] + (p11[c] - p01[c]) * ax;
    out[c] = top + (bottom - top) * ay;
  }
}

/// What the borders of tiles at the texture's outer edge hold. `clamp` repeats the edge texel
/// (a texture shown once); `wrap` takes the texels of the opposite edge, so a material repeated
/// over a surface (uv wrapped with fract / GL_REPEAT) filters across the repeat without a seam.
/// Interior texels, borders between tiles, weights and energies are the same in both modes.
enum class TileEdge : uint8_t { clamp, wrap };

/// The tile pyramid of one material: per virtual texture (four components each) the level
/// images (float, kept for reference sampling and error measurement) and every tile as half
/// texels with borders, plus w and energies. Immutable after build(); thread-safe reads.
class TilePyramid {
 public:
  /// Builds every level and tile, with outer borders as `edge` says. Returns invalid_argument
  /// when the input is inconsistent (empty texture, U' of the wrong size) or the hierarchy
  /// exceeds the tile-id bit budget. Allocates every level image and tile. Defined in the
  /// implementation TU (offline code: its loops and containers are compiled once there).
  static Result<TilePyramid> build(const EigenTextures& input, uint32_t tile_size = kDefaultTileSize,
                                   uint32_t border = kDefaultTileBorder, TileEdge edge = TileEdge::clamp);

  /// Hierarchy shape shared by the material's virtual textures.
  const VtGeometry& geometry() const noexcept { return geometry_; }
  /// Level offsets for flat tile indices.
  const VtLevelTable& levels() const noexcept { return levels_; }
  /// ⌈C/4⌉ virtual textures.
  uint32_t texture_count() const noexcept { return static_cast<uint32_t>(level_images_.size()); }
  /// The 4-channel level-l image of virtual texture k. Precondition: k, level in range.
  const Image<float>& level_image(uint32_t k, uint32_t level) const noexcept { return level_images_[k][level]; }
  /// Half elements per stored tile: (T + 2B)² · 4.
  size_t tile_elements() const noexcept {
    return static_cast<size_t>(geometry_.stored_size()) * geometry_.stored_size() * 4;
  }
  /// Uncompressed bytes of one stored tile (RGBA16F with borders): 41,472 for T = 64, B = 4.
  size_t tile_bytes() const noexcept { return tile_elements() * 2; }
  /// Half bits of the stored tile with flat index `index` of virtual texture k, row-major
  /// (T + 2B) × (T + 2B) × RGBA. Precondition: k, index in range.
  std::span<const uint16_t> tile_texels(uint32_t k, uint32_t index) const noexcept {
    return std::span<const uint16_t>(tiles_[k]).subspan(tile_elements() * index, tile_elements());
  }
  /// w(i, l, l−1) of eq. 8 per tile of virtual texture k (flat index). Precondition: k in range.
  std::span<const Half> weights(uint32_t k) const noexcept { return weights_[k]; }
  /// ‖T‖²_F / T² per tile of virtual texture k (§6). Precondition: k in range.
  std::span<const Half> energies(uint32_t k) const noexcept { return energies_[k]; }

  /// Bilinear sample of virtual texture k at level `level` and texture coordinates (u, v) in
  /// [0, 1) (u → M, v → N; clamp-to-edge). Writes 4 floats. Thread-safe, noexcept.
  void sample(uint32_t k, uint32_t level, float u, float v, float* out) const noexcept {
    const float scale = 1.0f / static_cast<float>(1u << (geometry_.finest_level - level));
    sample_bilinear_clamped(level_images_[k][level], u * static_cast<float>(geometry_.width) * scale,
                            v * static_cast<float>(geometry_.height) * scale, out);
  }

  /// Copies w and energies of every virtual texture into material `material` of a VtSet.
  /// Precondition: the material was added with this geometry and texture_count().
  void copy_weights_to(VtSet& set, uint32_t material) const noexcept {
    const VtMaterial& m = set.material(material);
    for (uint32_t k = 0; k < texture_count() && k < m.texture_count; ++k) {
      std::copy(weights_[k].begin(), weights_[k].end(), set.weights(m.first_texture + k).begin());
      std::copy(energies_[k].begin(), energies_[k].end(), set.energies(m.first_texture + k).begin());
    }
  }

 private:
  VtGeometry geometry_;
  VtLevelTable levels_;
  std::vector<std::vector<Image<float>>> level_images_;
  std::vector<std::vector<uint16_t>> tiles_;
  std::vector<std::vector<Half>> weights_;
  std::vector<std::vector<Half>> energies_;
};

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
namespace btflod {

Result<TilePyramid> TilePyramid::build(const EigenTextures& input, uint32_t tile_size, uint32_t border, TileEdge edge) {
  if (!input.valid())
    return make_error(Status::invalid_argument,
                      "tile pyramid: eigen-textures invalid (texture %dx%dx%d, U' has %zu entries, expected %u)",
                      input.textures.width(), input.textures.height(), input.textures.channels(), input.angular.size(),
                      input.light_count * input.view_count * 3 * input.components());
  const VtGeometry g = VtGeometry::make(static_cast<uint32_t>(input.textures.width()),
                                        static_cast<uint32_t>(input.textures.height()), tile_size, border);
  if (!g.valid() || border == 0)
    return make_error(Status::invalid_argument,
                      "tile pyramid: %ux%u texels with T=%u B=%u exceeds the hierarchy limits (L <= %u, 0 < B < T)",
                      g.width, g.height, tile_size, border, kMaxTileLevel);
  TilePyramid p;
  p.geometry_ = g;
  p.levels_ = VtLevelTable(g);
  const uint32_t vts = input.virtual_texture_count();
  const uint32_t comps = input.components();
  p.level_images_.resize(vts);
  p.tiles_.resize(vts);
  p.weights_.resize(vts);
  p.energies_.resize(vts);
  const uint32_t L = g.finest_level;
  for (uint32_t k = 0; k < vts; ++k) {
    auto& levels = p.level_images_[k];
    levels.resize(L + 1);
    // Finest level: components 4k … 4k+3, zero-padded past C.
    Image<float>& finest = levels[L];
    finest.resize(static_cast<int>(g.width), static_cast<int>(g.height), 4);
    for (uint32_t y = 0; y < g.height; ++y)
      for (uint32_t x = 0; x < g.width; ++x)
        for (uint32_t c = 0; c < 4; ++c) {
          const uint32_t comp = 4 * k + c;
          finest.at(static_cast<int>(x), static_cast<int>(y), static_cast<int>(c)) =
              comp < comps ? input.textures.at(static_cast<int>(x), static_cast<int>(y), static_cast<int>(comp)) : 0.0f;
        }
    // Box filter 2×2 (clamp at odd edges) down to level 0.
    for (uint32_t l = L; l > 0; --l) {
      const Image<float>& src = levels[l];
      Image<float>& dst = levels[l - 1];
      dst.resize(static_cast<int>(g.level_width(l - 1)), static_cast<int>(g.level_height(l - 1)), 4);
      for (int y = 0; y < dst.height(); ++y)
        for (int x = 0; x < dst.width(); ++x) {
          const int xa = std::min(2 * x, src.width() - 1), xb = std::min(2 * x + 1, src.width() - 1);
          const int ya = std::min(2 * y, src.height() - 1), yb = std::min(2 * y + 1, src.height() - 1);
          for (int c = 0; c < 4; ++c)
            dst.at(x, y, c) = 0.25f * (src.at(xa, ya, c) + src.at(xb, ya, c) + src.at(xa, yb, c) + src.at(xb, yb, c));
        }
    }
    // Tiles with borders, weights, energies.
    const uint32_t stored = g.stored_size();
    const size_t tile_elems = static_cast<size_t>(stored) * stored * 4;
    p.tiles_[k].assign(tile_elems * p.levels_.tile_count(), 0);
    p.weights_[k].assign(p.levels_.tile_count(), Half(0.0f));
    p.energies_[k].assign(p.levels_.tile_count(), Half(0.0f));
    for (uint32_t l = 0; l <= L; ++l) {
      const Image<float>& img = levels[l];
      for (uint32_t ty = 0; ty < p.levels_.tiles_y[l]; ++ty)
        for (uint32_t tx = 0; tx < p.levels_.tiles_x[l]; ++tx) {
          const uint32_t index = p.levels_.index(l, tx, ty);
          uint16_t* dst = p.tiles_[k].data() + tile_elems * index;
          for (uint32_t y = 0; y < stored; ++y)
            for (uint32_t x = 0; x < stored; ++x) {
              // Borders come from the neighbouring texels of the same level (seamless bilinear).
              const int ux = static_cast<int>(tx * tile_size + x) - static_cast<int>(border);
              const int uy = static_cast<int>(ty * tile_size + y) - static_cast<int>(border);
              const int gx = edge == TileEdge::wrap ? ((ux % img.width()) + img.width()) % img.width()
                                                    : std::clamp(ux, 0, img.width() - 1);
              const int gy = edge == TileEdge::wrap ? ((uy % img.height()) + img.height()) % img.height()
                                                    : std::clamp(uy, 0, img.height() - 1);
              for (int c = 0; c < 4; ++c)
                dst[(static_cast<size_t>(y) * stored + x) * 4 + static_cast<size_t>(c)] =
                    float_to_half_bits(img.at(gx, gy, c));
            }
          // Paper 000 eq. 8 with l' = l − 1: mean over the T² texels of the squared distance
          // (summed over the 4 packed components) to the bilinearly up-sampled parent, i.e. to
          // what the renderer shows when the parent is used instead. §6: mean squared norm.
          double w = 0.0, energy = 0.0;
          for (uint32_t y = 0; y < tile_size; ++y)
            for (uint32_t x = 0; x < tile_size; ++x) {
              const int gx = std::min(static_cast<int>(tx * tile_size + x), img.width() - 1);
              const int gy = std::min(static_cast<int>(ty * tile_size + y), img.height() - 1);
              float parent[4] = {0, 0, 0, 0};
              if (l > 0)
                sample_bilinear_clamped(levels[l - 1], (static_cast<float>(gx) + 0.5f) * 0.5f,
                                        (static_cast<float>(gy) + 0.5f) * 0.5f, parent);
              for (int c = 0; c < 4; ++c) {
                const double v = img.at(gx, gy, c);
                w += (v - parent[c]) * (v - parent[c]);
                energy += v * v;
              }
            }
          // Saturated at the largest finite half: a log-encoded factorisation (core/value_transform.hpp)
          // has eigen-textures of a few hundred (its first component carries the log's offset),
          // whose root w and energies exceed 65504. They rank tiles and packets; a saturated
          // value still ranks above every other.
          const double inv = 1.0 / (static_cast<double>(tile_size) * tile_size), max_half = 65504.0;
          p.weights_[k][index] = Half(static_cast<float>(std::min(w * inv, max_half)));
          p.energies_[k][index] = Half(static_cast<float>(std::min(energy * inv, max_half)));
        }
    }
  }
  return p;
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
