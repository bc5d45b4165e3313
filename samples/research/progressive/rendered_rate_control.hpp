// btflod-visibility — rate control to a rendered-error target (an experiment around build_bsvtf).
//
// perceptual_tolerance_scales() (offline/build/perceptual_tolerance.hpp) sets how a tile's error budget
// is shared between its components (t_c · G_c = const, G_c the mean ΔE*ab gain of component c):
// the rate–distortion optimum for the EXPECTED rendered error. What a viewer judges, and what
// btflod-visibility measures, is a tail statistic: the 99th percentile of ΔE*ab over the
// pixels. Its ratio to the mean depends on the material (the spread of the gains over texels and
// directions — deep self-shadows, clipped highlights — and on how much of each coefficient the
// quantiser keeps), so one quality meant different visibilities on different materials (the
// stone was invisible from quality 50, the cloth from 32: docs/bsvtf_format.md).
//
// build_bsvtf_rendered() closes that loop in texture space: it encodes the tiles, decodes them
// as a client does (closed loop over the levels), renders every sampled texel of every tile
// position (level, x, y) under a sample of (light, view) pairs from the original and from the
// decoded eigen-textures — ρ(x, l, v) = Σ_c v_c(x) U[(l, v), c] (paper 000 eq. 4–5), times the
// exposure, clipped at white as the display does, in CIELAB — and takes the weighted quantile q
// of the colour difference per tile position. Each position's tolerances are then multiplied by
// (target / measured) and the tiles coded again; after a few passes every tile position meets
// the same rendered-error quantile: the error is equalised over tiles and levels, the share of
// each component stays the perceptual one. The tile headers store the absolute tolerances as
// always, so readers need nothing new.
//
// The target at quality Q is kRenderedTargetAtQuality50 · quality_scale(Q) (runtime/codec/quantize.hpp):
// quality keeps JPEG's scale.
//
// The same measurement per 8×8 block (RenderedErrorOptions::block_quantiles) shows how far the
// blocks of a tile lie below its quantile (RenderedRateReport::block_spread): on the demo
// materials three quarters lie within 10 %, because the error tail comes from directions that every
// texel sees, so a per-block step would gain little (docs/bsvtf_format.md, "Per-block steps").
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/core/thread_pool.hpp"
#include "btflod/offline/build/perceptual_tolerance.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/quantize.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"

namespace btflod {

/// Texture-space rendered-error quantile (ΔE*ab) at quality 50 that build_bsvtf_rendered aims
/// every tile position at. Chosen on btflod-visibility's scene so that quality 50 is invisible
/// (screen p99 ΔE*ab < 2.3) on the four demo materials (docs/bsvtf_format.md: targets 4.8 and
/// 5.2 give screen p99 2.03 and 2.23 on the stone, the material closest to the criterion); the
/// screen's bilinear filtering averages neighbouring texels' errors and the 8-bit output hides
/// the smallest ones, so the screen quantile is 0.3–0.45 of this texture-space one.
inline constexpr float kRenderedTargetAtQuality50 = 5.0f;

/// Options of rendered_tile_errors() and build_bsvtf_rendered().
/// The display mapping and the direction model (exposure, cosine powers, row order, direction
/// weights) are the ViewingConditions fields, as for perceptual_tolerance_scales.
struct RenderedErrorOptions : ViewingConditions {
  /// The quantile of ΔE*ab measured per tile position, in (0, 1]: 0.99 matches the visibility
  /// criterion (99 % of the pixels below one just-noticeable difference).
  float quantile = 0.99f;
  /// Interior texels are sampled every `texel_stride` texels in x and y (≥ 1).
  uint32_t texel_stride = 2;
  /// (light, view) pairs sampled (stratified, ≥ 1; every row when it covers them all).
  uint32_t direction_samples = 256;
  /// Texels averaged per sample, in x and y (1..B + 1): 1 renders each sampled texel; F renders
  /// the mean of the F × F texels from it (reference and decoded alike), as a minified view
  /// averages neighbouring texels' errors.
  uint32_t texel_footprint = 1;
  /// Also measure the quantile of every 8×8 block position of the stored tile
  /// (RenderedTileError::block_quantile).
  bool block_quantiles = false;
  ThreadPool* pool = nullptr;  ///< nullptr: default_thread_pool()
};

/// Options of build_bsvtf_rendered().
struct RenderedRateOptions {
  /// Target quantile of ΔE*ab per tile position at quality 50 (> 0); the target at the build's
  /// quality Q is this · quality_scale(Q).
  float target_at_quality50 = kRenderedTargetAtQuality50;
  /// Encode–measure–rescale passes before the final build (0..16). Each pass moves a position's
  /// scale by (target / measured), limited to [1 / max_step, max_step].
  uint32_t passes = 4;
  float max_step = 4.0f;  ///< > 1
  RenderedErrorOptions error;
};

/// One tile position's rendered error (rendered_tile_errors).
struct RenderedTileError {
  uint32_t level = 0, x = 0, y = 0;
  float quantile = 0.0f;  ///< the options' quantile of ΔE*ab over the position's samples
  float mean = 0.0f;      ///< mean ΔE*ab
  /// With RenderedErrorOptions::block_quantiles: the quantile over the samples of each 8×8 block
  /// position of the stored tile (row-major); 0 for border blocks without samples.
  std::vector<float> block_quantile{};
};

/// What build_bsvtf_rendered() did (for reports).
struct RenderedRateReport {
  std::vector<float> pass_max;               ///< per pass (and the final build): the largest position quantile
  std::vector<float> pass_min;               ///< … and the smallest
  float target = 0.0f;                       ///< the target at the build's quality
  float min_scale = 0.0f, max_scale = 0.0f;  ///< range of the per-position tolerance multipliers
  /// How far each 8×8 block's error quantile q_b lies below its tile position's Q in the final
  /// build: the block positions with Q / q_b below 1.1 (a block may lie above its tile's
  /// quantile), in [1.1, 1.25), [1.25, 1.5), [1.5, 2), [2, 3), and from 3; blocks without samples
  /// are not counted. It bounds what a per-block step could save: a block at Q / q_b = r could
  /// take an r× coarser step before it reached its tile's quantile.
  std::array<size_t, 6> block_spread{};
};

/// The upper edges of RenderedRateReport::block_spread's bins but the last.
inline constexpr std::array<float, 5> kRenderedBlockSpreadEdges{1.1f, 1.25f, 1.5f, 2.0f, 3.0f};

namespace detail {

// Linear sRGB (display-linear, clipped to [0, 1]) → CIELAB, D65 (as offline/metrics/image_metrics.hpp).
inline std::array<float, 3> rendered_lab(const float rgb_in[3]) noexcept {
  float rgb[3];
  for (int k = 0; k < 3; ++k) rgb[k] = std::clamp(rgb_in[k], 0.0f, 1.0f);
  constexpr float kM[3][3] = {
      {0.4124564f, 0.3575761f, 0.1804375f}, {0.2126729f, 0.7151522f, 0.0721750f}, {0.0193339f, 0.1191920f, 0.9503041f}};
  constexpr float kWhite[3] = {0.95047f, 1.0f, 1.08883f};
  constexpr float kDelta = 6.0f / 29.0f;
  float f[3];
  for (int i = 0; i < 3; ++i) {
    const float t = (kM[i][0] * rgb[0] + kM[i][1] * rgb[1] + kM[i][2] * rgb[2]) / kWhite[i];
    f[i] = t > kDelta * kDelta * kDelta ? std::cbrt(t) : t / (3.0f * kDelta * kDelta) + 4.0f / 29.0f;
  }
  return {116.0f * f[1] - 16.0f, 500.0f * (f[0] - f[1]), 200.0f * (f[1] - f[2])};
}

}  // namespace detail

/// The rendered colour difference between `reference` tiles and `decoded` tiles (decoded[i]
/// belongs to reference[i], layout.sample_count() floats each), per tile position (level, x, y):
/// over the position's interior texels (every texel_stride-th) and a weighted sample of the
/// (light, view) pairs, ΔE*ab (CIE76) between exposure ⊙ Σ_c v_c U[(l, v), c] · component
/// scale, clipped to [0, 1], of the two. U as in build_bsvtf (u_rows × C, row = angular ·
/// colours + colour; 1 colour = grey). Returns one entry per position in the order of first
/// appearance in `reference`, or invalid_argument (options out of range, sizes, non-finite
/// values) / unsupported (ycbcr). Deterministic for any thread count. Allocates (offline code).
inline Result<std::vector<RenderedTileError>> rendered_tile_errors(const BsvtfMetadata& metadata,
                                                                   std::span<const float> u,
                                                                   std::span<const BsvtfTileInput> reference,
                                                                   std::span<const std::vector<float>> decoded,
                                                                   const RenderedErrorOptions& options = {}) {
  const RenderedErrorOptions& o = options;
  if (!(o.quantile > 0.0f && o.quantile <= 1.0f) || o.texel_stride < 1 || o.direction_samples < 1 ||
      !std::all_of(o.exposure.begin(), o.exposure.end(), [](float e) { return e > 0.0f && e < 1e30f; }) ||
      !(o.light_cosine_power >= 0.0f && o.light_cosine_power <= 64.0f) ||
      !(o.view_cosine_power >= 0.0f && o.view_cosine_power <= 64.0f))
    return make_error(Status::invalid_argument, "rendered_tile_errors: options out of range");
  if (metadata.color_mode == ColorMode::ycbcr)
    return make_error(Status::unsupported, "rendered_tile_errors: colour mode ycbcr");
  const uint32_t channels = metadata.color_channels, C = metadata.component_count;
  if ((channels != 1 && channels != 3) || C == 0 || metadata.u_rows == 0 || metadata.u_rows % channels != 0 ||
      u.size() != size_t{metadata.u_rows} * C)
    return make_error(Status::invalid_argument,
                      "rendered_tile_errors: U has %zu values, expected %u rows × %u components", u.size(),
                      metadata.u_rows, C);
  const TileLayout layout = metadata.layout();
  if (!layout.valid() || decoded.size() != reference.size())
    return make_error(Status::invalid_argument, "rendered_tile_errors: %zu decoded tiles for %zu reference tiles",
                      decoded.size(), reference.size());
  for (size_t i = 0; i < reference.size(); ++i)
    if (reference[i].samples.size() != layout.sample_count() || decoded[i].size() != layout.sample_count() ||
        !reference[i].id.valid() || reference[i].id.texture >= metadata.texture_count())
      return make_error(Status::invalid_argument, "rendered_tile_errors: tile %zu has a bad id or size", i);
  if (o.texel_footprint < 1 || o.texel_footprint > layout.border + 1)
    return make_error(Status::invalid_argument, "rendered_tile_errors: texel footprint %u not in 1..%u (border + 1)",
                      o.texel_footprint, layout.border + 1);
  if (!std::all_of(u.begin(), u.end(), [](float v) { return std::isfinite(v); }))
    return make_error(Status::invalid_argument, "rendered_tile_errors: U is not finite");
  const uint32_t angular = metadata.u_rows / channels;
  auto sample = detail::sample_viewing_directions(metadata, angular, o, o.direction_samples, "rendered_tile_errors");
  if (!sample) return sample.error();
  const std::vector<uint32_t>& rows = sample->first;
  const std::vector<double>& row_weight = sample->second;
  const uint32_t nd = static_cast<uint32_t>(rows.size());
  std::vector<float> ud(size_t{nd} * 3 * C);
  for (uint32_t j = 0; j < nd; ++j)
    for (uint32_t k = 0; k < 3; ++k)
      for (uint32_t c = 0; c < C; ++c) {
        const float scale = metadata.component_scales.size() == C && std::isfinite(metadata.component_scales[c])
                                ? metadata.component_scales[c]
                                : 1.0f;
        ud[(size_t{j} * 3 + k) * C + c] =
            o.exposure[k] * scale * u[(size_t{rows[j]} * channels + (channels == 3 ? k : 0)) * C + c];
      }

  std::unordered_map<uint64_t, size_t> position_of;
  std::vector<std::vector<size_t>> at;  // [position][texture] → tile index or SIZE_MAX
  std::vector<RenderedTileError> out;
  for (size_t i = 0; i < reference.size(); ++i) {
    const TileId& id = reference[i].id;
    auto [it, inserted] = position_of.try_emplace(TileId{0, id.level, id.x, id.y}.key(), out.size());
    if (inserted) {
      out.push_back(RenderedTileError{id.level, id.x, id.y, 0.0f, 0.0f});
      at.emplace_back(metadata.texture_count(), SIZE_MAX);
    }
    at[it->second][id.texture] = i;
  }
  const uint32_t S = layout.stored_size(), B = layout.border, T = layout.tile_size;
  const uint32_t blocks_per_side = S / kTileBlock;
  // The weighted quantile of (ΔE, weight) pairs (sorts them), and their weighted mean when `mean`
  // is not null; 0 when empty.
  const auto weighted_quantile = [&](std::vector<std::pair<float, double>>& de, float* mean) {
    double total = 0, sum = 0;
    for (const auto& [d, wt] : de) total += wt, sum += wt * d;
    if (mean) *mean = total > 0 ? static_cast<float>(sum / total) : 0.0f;
    std::sort(de.begin(), de.end());
    double acc = 0;
    float q = de.empty() ? 0.0f : de.back().first;
    for (const auto& [d, wt] : de)
      if ((acc += wt) >= o.quantile * total) {
        q = d;
        break;
      }
    return q;
  };
  ThreadPool& pool = o.pool ? *o.pool : default_thread_pool();
  pool.parallel_for(0, out.size(), 1, [&](size_t begin, size_t end) {
    std::vector<float> v(C), w(C);
    std::vector<std::pair<float, double>> de;
    std::vector<std::vector<std::pair<float, double>>> block_de(o.block_quantiles ? blocks_per_side * blocks_per_side
                                                                                  : 0);
    for (size_t p = begin; p < end; ++p) {
      de.clear();
      for (auto& b : block_de) b.clear();
      for (uint32_t y = B; y < B + T; y += o.texel_stride)
        for (uint32_t x = B; x < B + T; x += o.texel_stride) {
          for (uint32_t c = 0; c < C; ++c) {
            const size_t t = at[p][c / 4];
            if (t == SIZE_MAX) {
              v[c] = w[c] = 0.0f;
            } else {                     // the mean over footprint² texels from (x, y): what a minified view averages
              float a = 0.0f, b = 0.0f;  // (footprint 1: exactly the texel's values)
              for (uint32_t dy = 0; dy < o.texel_footprint; ++dy)
                for (uint32_t dx = 0; dx < o.texel_footprint; ++dx) {
                  const size_t f = ((size_t{y} + dy) * S + x + dx) * 4 + c % 4;
                  a += reference[t].samples[f], b += decoded[t][f];
                }
              const float inv = 1.0f / static_cast<float>(o.texel_footprint * o.texel_footprint);
              v[c] = a * inv, w[c] = b * inv;
            }
          }
          for (uint32_t j = 0; j < nd; ++j) {
            const float* row = &ud[size_t{j} * 3 * C];
            float a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
            for (uint32_t k = 0; k < 3; ++k)
              for (uint32_t c = 0; c < C; ++c) a[k] += v[c] * row[k * C + c], b[k] += w[c] * row[k * C + c];
            const auto la = detail::rendered_lab(a), lb = detail::rendered_lab(b);
            const float d = std::sqrt((la[0] - lb[0]) * (la[0] - lb[0]) + (la[1] - lb[1]) * (la[1] - lb[1]) +
                                      (la[2] - lb[2]) * (la[2] - lb[2]));
            de.emplace_back(d, row_weight[j]);
            if (!block_de.empty())
              block_de[(y / kTileBlock) * blocks_per_side + x / kTileBlock].emplace_back(d, row_weight[j]);
          }
        }
      out[p].quantile = weighted_quantile(de, &out[p].mean);
      out[p].block_quantile.resize(block_de.size());
      for (size_t b = 0; b < block_de.size(); ++b) out[p].block_quantile[b] = weighted_quantile(block_de[b], nullptr);
    }
  });
  return out;
}

/// build_bsvtf() with the tolerances of each tile position rescaled until the rendered error
/// quantile (rendered_tile_errors) of every position is the target at options.quality (see the
/// file comment). `tiles` are taken as given — their tolerance_scale and channel_scale (e.g.
/// perceptual_tolerance_scales) set the starting point and the share of each component; every
/// tile of a position gets the same extra multiplier. The passes encode with deflate (the
/// quantised coefficients, hence the error, do not depend on the entropy coder); the final build
/// uses `build`'s coder. Returns the container bytes (as build_bsvtf) and fills `report` when
/// non-null; errors as build_bsvtf and rendered_tile_errors, invalid_argument for rate options
/// out of range. Deterministic; allocates and runs threads (offline code).
inline Result<std::vector<uint8_t>> build_bsvtf_rendered(const BsvtfMetadata& metadata, std::span<const float> u,
                                                         std::span<const BsvtfTileInput> tiles,
                                                         const BsvtfBuildOptions& build,
                                                         const RenderedRateOptions& rate,
                                                         RenderedRateReport* report = nullptr) {
  if (!(rate.target_at_quality50 > 0.0f && rate.target_at_quality50 < 1e6f) || rate.passes > 16 ||
      !(rate.max_step > 1.0f && rate.max_step < 1e6f))
    return make_error(Status::invalid_argument, "build_bsvtf_rendered: rate options out of range");
  const float target = rate.target_at_quality50 * quality_scale(build.quality);
  std::vector<BsvtfTileInput> work(tiles.begin(), tiles.end());
  std::unordered_map<uint64_t, size_t> position_of;
  std::vector<size_t> position(work.size());
  for (size_t i = 0; i < work.size(); ++i) {
    const TileId& id = work[i].id;
    position[i] = position_of.try_emplace(TileId{0, id.level, id.x, id.y}.key(), position_of.size()).first->second;
  }
  std::vector<float> scale(position_of.size(), 1.0f);
  std::vector<std::vector<std::pair<float, float>>> history(position_of.size());  // (scale, error) per pass
  RenderedRateReport rep;
  rep.target = target;
  const TileLayout layout = metadata.layout();
  std::vector<size_t> order(work.size());  // coarse to fine, for closed-loop decoding
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return work[a].id.level < work[b].id.level; });
  std::unordered_map<uint64_t, size_t> index_of;
  for (size_t i = 0; i < work.size(); ++i) index_of[work[i].id.key()] = i;

  for (uint32_t pass = 0; pass <= rate.passes; ++pass) {
    const bool final_build = pass == rate.passes;
    BsvtfBuildOptions bo = build;
    if (!final_build) bo.entropy_coder = TileEntropyCoder::deflate, bo.deflate_level = 1;
    auto file = build_bsvtf(metadata, u, work, bo);
    if (!file) return file.error();
    if (final_build && report == nullptr) return file;
    auto dir = read_bsvtf(*file);
    if (!dir) return dir.error();
    std::vector<std::vector<float>> decoded(work.size());
    TileDecoder decoder(layout);
    for (size_t i : order) {
      const TileId& id = work[i].id;
      const BsvtfTileEntry* e = dir->find(id);
      if (e == nullptr) return make_error(Status::bad_data, "build_bsvtf_rendered: a built tile is missing");
      std::span<const float> parent;
      if (id.level > 0) {
        auto it = index_of.find(id.parent().key());
        if (it == index_of.end())
          return make_error(Status::invalid_argument, "build_bsvtf_rendered: a tile has no parent");
        parent = decoded[it->second];
      }
      decoded[i].resize(layout.sample_count());
      const std::span<const uint8_t> payload(file->data() + e->offset, e->size);
      if (decoder.decode(payload, parent, id.x & 1u, id.y & 1u, decoded[i]) != Status::success)
        return make_error(Status::bad_data, "build_bsvtf_rendered: %s", decoder.message());
    }
    RenderedErrorOptions error_options = rate.error;
    error_options.block_quantiles = final_build;  // for RenderedRateReport::block_spread
    auto errors = rendered_tile_errors(metadata, u, work, decoded, error_options);
    if (!errors) return errors.error();
    float lo = 1e30f, hi = 0.0f;
    for (const RenderedTileError& e : *errors) lo = std::min(lo, e.quantile), hi = std::max(hi, e.quantile);
    rep.pass_max.push_back(hi);
    rep.pass_min.push_back(lo);
    if (final_build) {
      rep.min_scale = *std::min_element(scale.begin(), scale.end());
      rep.max_scale = *std::max_element(scale.begin(), scale.end());
      for (const RenderedTileError& e : *errors)
        for (float qb : e.block_quantile) {
          if (!(qb > 0.0f)) continue;
          const float r = e.quantile / qb;
          ++rep.block_spread[std::upper_bound(kRenderedBlockSpreadEdges.begin(), kRenderedBlockSpreadEdges.end(), r) -
                             kRenderedBlockSpreadEdges.begin()];
        }
      *report = std::move(rep);
      return file;
    }
    // rendered_tile_errors lists positions in order of first appearance, as position_of numbered
    // them. The error is not a smooth function of the step (coefficients fall to zero in groups),
    // so each position keeps its history: while all its passes lie on one side of the target the
    // scale moves by target / error; once two passes bracket it, the next is their geometric mean.
    // The final build takes, per position, the coarsest scale measured at or below the target.
    const bool last_pass = pass + 1 == rate.passes;
    for (size_t p = 0; p < errors->size(); ++p) {
      const float e = (*errors)[p].quantile;
      history[p].emplace_back(scale[p], e);
      float below = 0.0f, above = 1e30f, best_error = 1e30f, best_error_scale = scale[p];
      for (const auto& [sc, er] : history[p]) {
        if (er <= target) below = std::max(below, sc);
        if (er > target) above = std::min(above, sc);
        if (er < best_error) best_error = er, best_error_scale = sc;
      }
      if (last_pass) {
        scale[p] = below > 0.0f
                       ? below
                       : best_error_scale * std::max(1.0f / rate.max_step, std::min(1.0f, target / best_error));
      } else if (below > 0.0f && above < 1e30f && above > below) {
        scale[p] = std::sqrt(below * above);
      } else {
        const float step = e > 0.0f ? std::clamp(target / e, 1.0f / rate.max_step, rate.max_step) : rate.max_step;
        scale[p] = std::clamp(scale[p] * step, 1e-4f, 1e4f);
      }
    }
    for (size_t i = 0; i < work.size(); ++i) work[i].tolerance_scale = tiles[i].tolerance_scale * scale[position[i]];
  }
  return make_error(Status::invalid_argument, "build_bsvtf_rendered: unreachable");
}

}  // namespace btflod
