// btflod codec — perceptual codec tolerances (offline, before build_bsvtf).
//
// The tile codec quantises each eigen-texture component to an absolute tolerance t_c. What a
// viewer sees is the rendered radiance, not the eigen-texture: at texel x lit from l and seen
// from v the BTF is Σ_c v_c(x) U[(l, v), c] (paper 000 eq. 4–5), so an error δv_c changes the
// displayed colour by δv_c · U[(l, v), :, c], and how visible that is depends on the colour it
// lands on: CIELAB (ΔE*ab ≈ one just-noticeable difference at 2.3) is ∝ Y^(1/3) above its toe,
// so the same radiance error is ~10× more visible on a texel at 1 % of white than at white, and
// invisible where the display clips. To first order the ΔE*ab of component c's error is
//     δE = |J(x, l, v) · U[(l, v), :, c]| · |δv_c|,   J = ∂Lab/∂RGB at the rendered colour
// (the gain g_c(x, l, v) = |J · U_c|). With the expected ΔE as the distortion (linear in each
// component's error t_c) and −log t_c bits per component at high rate, the Lagrangian optimum
// of "Σ bits subject to Σ_c G_c t_c = D" is
//     t_c · G_c = const,   G_c = the mean of g_c over the tile's texels and the directions,
// i.e. every component spends the same share of the perceptual error budget (the same holds
// for the squared error with the RMS of g_c; the mean is what the measurements favour, see
// gain_power). For FMF with an orthonormal U and a uniform sensitivity this reduces to
// ToleranceReference::shared_max (one absolute tolerance); the perceptual weights add what it
// misses: dark texels, colour components (a*, b* are 500× / 200× differences of f(X), f(Y),
// f(Z)), clipped highlights and directions a renderer rarely shows (grazing views: a surface
// seen at θ_v covers ∝ cos θ_v of the screen).
//
// perceptual_tolerance_scales() estimates G_c per tile position (level, x, y) from a sample
// of the tile's interior texels and of the (light, view) pairs, and stores
//     channel_scale = tolerance_for_quality(q, reference_delta_e) / G_c / tolerance_for_quality(q, R)
//                   = reference_delta_e / (G_c · R)          (R = the largest component range)
// in BsvtfTileInput::channel_scale, so that build_bsvtf with ToleranceReference::shared_max
// codes component c to t_c = tolerance_for_quality(q, reference_delta_e) / G_c: at quality 50
// each component's block-RMS error is ≈ reference_delta_e / 128 ΔE*ab (the quality keeps its
// meaning; the tile header stores the absolute tolerances, readers need nothing).
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
#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/quantize.hpp"

namespace btflod {

/// The frequency weighting (BsvtfBuildOptions::weight_quarters) to use with perceptual
/// tolerances: JPEG's table to the power 1/4. Measured on the four demo materials at each one's
/// invisibility threshold (docs/bsvtf_format.md): 11–24 % higher ratios than JPEG's table (4),
/// at least those of 0 and 3 on all four and of 2 on three (stone: 2 is 1.5 % better).
inline constexpr uint32_t kPerceptualWeightQuarters = 1;

// AngularRowOrder (the order of U's angular rows) is defined in runtime/codec/container.hpp, which
// stores it in the container (BsvtfMetadata::u_row_order).

/// The renders a perceptual error measure imagines: their display mapping and how often they
/// show each (light, view) pair. Shared by PerceptualToleranceOptions and RenderedErrorOptions
/// (samples/research/progressive/rendered_rate_control.hpp), which sample directions alike.
struct ViewingConditions {
  /// Display-linear RGB = exposure ⊙ BTF value; the display clips at 1 (white). E.g. the light's
  /// colour times the exposure of the renderer. Each must be finite and > 0.
  std::array<float, 3> exposure{1.0f, 1.0f, 1.0f};
  /// How often a rendered pixel shows the pair (l, v), up to a constant: cos θ_l^light_cosine_power
  /// · cos θ_v^view_cosine_power (z of the metadata's unit direction vectors), each power in
  /// [0, 64]. View power 1 is projected area: a surface seen at θ_v covers ∝ cos θ_v of the
  /// screen. Both 0: every measured pair alike. Needs light_directions / view_directions with
  /// angular rows = lights · views unless both are 0.
  float light_cosine_power = 0.0f;
  float view_cosine_power = 1.0f;
  /// How angular rows map to (light, view) for the cosine weights (and direction_weights).
  AngularRowOrder row_order = AngularRowOrder::light_major;
  /// If not empty: the frequency of each (light, view) pair in rendering instead of the cosine
  /// model, one entry per angular row in row_order, ≥ 0 and finite, not all 0 —
  /// e.g. accumulated from a renderer's feedback pass with accumulate_direction_weights().
  std::span<const float> direction_weights;
  /// With direction_weights: the share in [0, 1) of the cosine model mixed under the histogram,
  /// (1 − prior) · h / Σh + prior · c / Σc, so that pairs a few training views never showed keep
  /// some weight (needs the cosine model's directions when > 0). 0: the histogram alone.
  float direction_prior = 0.0f;
};

/// Options for perceptual_tolerance_scales().
struct PerceptualToleranceOptions : ViewingConditions {
  /// ΔE*ab that plays the role of the component range in tolerance_for_quality (> 0): each
  /// component's block-RMS error bound is ≈ reference_delta_e / 128 ΔE*ab at quality 50. 50
  /// (half the L* scale) makes quality 50 invisible (p99 ΔE*ab < 2.3) on the four demo
  /// materials in btflod-visibility's scene (docs/bsvtf_format.md).
  float reference_delta_e = 50.0f;
  /// Relative luminance below which the sensitivity stops growing (0: CIELAB's own linear toe
  /// at 0.008856). In [0, 1). 0.02 (L* ≈ 15.5): the deepest shadows, where 8-bit output and
  /// display flare mask differences, no longer dictate a component's tolerance (measured against 0
  /// at the demo materials' invisibility thresholds: −0.5 % to +15 % in ratio, docs/bsvtf_format.md).
  float dark_floor = 0.02f;
  /// Interior texels are sampled every `texel_stride` texels in x and y (≥ 1).
  uint32_t texel_stride = 4;
  /// (light, view) pairs sampled, stratified over U's angular rows (≥ 1; capped at the rows).
  /// The display mapping and the direction model are the ViewingConditions fields.
  uint32_t direction_samples = 1024;
  /// G_c is the power mean (mean of g_c^gain_power)^(1/gain_power) over the samples, in
  /// [0.125, 64]: 1 (the default) is the expected ΔE*ab per unit error; 2 (RMS, the squared-
  /// error optimum) lets rare extreme samples (grazing, shadowed: the top 1 % a p99 criterion
  /// ignores) dictate the tolerance: measured 1.35× (leather) and 2.0× (tiles) lower ratios at
  /// equal visibility, cloth and stone within 2 %.
  float gain_power = 1.0f;
  /// channel_scale is clamped to [min_scale, max_scale] (0 < min ≤ max < 1e6): a component
  /// that is never visible (all clipped, or U_c = 0) gets max_scale.
  float min_scale = 1.0f / 4096.0f;
  float max_scale = 16.0f;
  ThreadPool* pool = nullptr;  ///< nullptr: default_thread_pool()
};

/// What perceptual_tolerance_scales() found (for reports).
struct PerceptualToleranceReport {
  float largest_range = 0.0f;  ///< R: the shared_max reference
  float min_channel_scale = 0.0f, max_channel_scale = 0.0f;
  std::vector<float> component_gain;  ///< C values: G_c (ΔE*ab per unit of v_c), RMS over all positions
};

/// Adds one rendered pixel's angular interpolation weights to a (light, view) histogram for
/// PerceptualToleranceOptions::direction_weights (light-major rows): weights[l · view_count +
/// v] += w_l · w_v for
/// the ≤ 3 × 3 taps. Out-of-range indices and non-finite or negative weights are skipped.
/// noexcept, no allocation.
inline void accumulate_direction_weights(const AngularSample& light, const AngularSample& view, uint32_t view_count,
                                         std::span<float> weights) noexcept {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const float w = light.weight[i] * view.weight[j];
      const size_t k = size_t{light.index[i]} * view_count + view.index[j];
      if (view.index[j] < view_count && k < weights.size() && w > 0.0f && std::isfinite(w)) weights[k] += w;
    }
}

namespace detail {

// ∂(L*, a*, b*)/∂(linear sRGB) · d, the ΔE*ab per unit step along d at `rgb` (display-linear);
// clipped channels (≥ 1) do not move. CIELAB after CIE 15 with the D65 white of image_metrics.
inline float perceptual_gain(const float rgb[3], const float d[3], float dark_floor) noexcept {
  constexpr float kM[3][3] = {
      {0.4124564f, 0.3575761f, 0.1804375f}, {0.2126729f, 0.7151522f, 0.0721750f}, {0.0193339f, 0.1191920f, 0.9503041f}};
  constexpr float kWhite[3] = {0.95047f, 1.0f, 1.08883f};
  constexpr float kDelta3 = (6.0f / 29.0f) * (6.0f / 29.0f) * (6.0f / 29.0f);
  constexpr float kToeSlope = 1.0f / (3.0f * (6.0f / 29.0f) * (6.0f / 29.0f));
  float xyz[3] = {0, 0, 0}, dxyz[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) {
      xyz[i] += kM[i][k] * rgb[k];
      if (rgb[k] < 1.0f) dxyz[i] += kM[i][k] * d[k];
    }
  float df[3];
  for (int i = 0; i < 3; ++i) {
    const float t = std::max(xyz[i] / kWhite[i], dark_floor);
    // f(t) = t^(1/3) above δ³, linear below: f'(t) = t^(−2/3) / 3 or the toe slope.
    df[i] = (t > kDelta3 ? 1.0f / (3.0f * std::cbrt(t * t)) : kToeSlope) * dxyz[i] / kWhite[i];
  }
  const float dl = 116.0f * df[1], da = 500.0f * (df[0] - df[1]), db = 200.0f * (df[1] - df[2]);
  return std::sqrt(dl * dl + da * da + db * db);
}

// The angular rows a perceptual measure evaluates, with their weights: each row's weight from
// `v` (direction_weights when given, else the cosine model over the metadata's directions, else
// 1), then every row of weight > 0 when `samples` covers the rows, else a stratified
// inverse-CDF sample of `samples` rows of weight 1 (deterministic). `who` prefixes the errors:
// invalid_argument when the weights do not match the rows or are all 0. Allocates.
inline Result<std::pair<std::vector<uint32_t>, std::vector<double>>> sample_viewing_directions(
    const BsvtfMetadata& md, uint32_t angular, const ViewingConditions& v, uint32_t samples, const char* who) {
  std::vector<double> weight(angular, 1.0);
  const size_t L = md.light_directions.size() / 3, V = md.view_directions.size() / 3;
  const bool histogram = !v.direction_weights.empty();
  if (!(v.direction_prior >= 0.0f && v.direction_prior < 1.0f))
    return make_error(Status::invalid_argument, "%s: direction prior %g not in [0, 1)", who,
                      static_cast<double>(v.direction_prior));
  const bool prior = histogram && v.direction_prior > 0.0f;
  const bool cosine = (!histogram || prior) && (v.light_cosine_power != 0.0f || v.view_cosine_power != 0.0f);
  if (histogram && v.direction_weights.size() != angular)
    return make_error(Status::invalid_argument, "%s: %zu direction weights for %u angular rows", who,
                      v.direction_weights.size(), angular);
  if (cosine && (L * V != angular || md.light_directions.size() != L * 3 || md.view_directions.size() != V * 3))
    return make_error(Status::invalid_argument,
                      "%s: direction weights need %u angular rows = lights × views (have %zu × %zu)", who, angular, L,
                      V);
  std::vector<double> model(angular, 1.0);  // the cosine model (or 1), the prior under a histogram
  double total = 0, model_total = 0;
  for (size_t a = 0; a < angular; ++a) {
    if (cosine) {
      const bool lm = v.row_order == AngularRowOrder::light_major;
      const size_t li = lm ? a / V : a % L, vi = lm ? a % V : a / L;
      const double cl = std::max(0.0f, md.light_directions[li * 3 + 2]);
      const double cv = std::max(0.0f, md.view_directions[vi * 3 + 2]);
      model[a] = std::pow(cl, v.light_cosine_power) * std::pow(cv, v.view_cosine_power);
      if (!std::isfinite(model[a])) model[a] = 0;
    }
    model_total += model[a];
    if (histogram) {
      const float x = v.direction_weights[a];
      if (!(x >= 0.0f) || !(x < 1e30f))
        return make_error(Status::invalid_argument, "%s: direction weight %zu not finite and >= 0", who, a);
      weight[a] = x;
    } else {
      weight[a] = model[a];
    }
    total += weight[a];
  }
  if (!(total > 0)) return make_error(Status::invalid_argument, "%s: every direction has weight 0", who);
  if (prior) {
    if (!(model_total > 0)) return make_error(Status::invalid_argument, "%s: the direction prior has weight 0", who);
    const double p = v.direction_prior;
    for (size_t a = 0; a < angular; ++a) weight[a] = (1.0 - p) * weight[a] / total + p * model[a] / model_total;
    total = 1.0;
  }
  std::vector<uint32_t> rows;
  std::vector<double> row_weight;
  if (samples >= angular) {
    for (uint32_t a = 0; a < angular; ++a)
      if (weight[a] > 0) rows.push_back(a), row_weight.push_back(weight[a]);
  } else {
    std::vector<double> cdf(angular);
    double acc = 0;
    for (uint32_t a = 0; a < angular; ++a) cdf[a] = acc += weight[a];
    for (uint32_t j = 0; j < samples; ++j) {
      const double target = (j + 0.5) / samples * acc;
      rows.push_back(static_cast<uint32_t>(
          std::min<size_t>(angular - 1, std::lower_bound(cdf.begin(), cdf.end(), target) - cdf.begin())));
      row_weight.push_back(1.0);
    }
  }
  return std::make_pair(std::move(rows), std::move(row_weight));
}

}  // namespace detail

/// Sets BsvtfTileInput::channel_scale of every tile so that build_bsvtf with
/// ToleranceReference::shared_max (the default) codes each component of each tile to an equal
/// share of a perceptual (ΔE*ab) error budget (see the file comment; this is the rate-
/// distortion allocation t_c·G_c = const). `u` is U as passed to build_bsvtf: u_rows ×
/// component_count floats, row = angular sample · color_channels + colour (color_channels 3 =
/// linear RGB, or 1 = luminance: grey), angular samples in options.row_order. Tiles of one position (level, x, y) are
/// evaluated together (every component adds to the same texels); a component whose texture has no tile at a position
/// counts as 0 there. metadata.component_ranges (or, when empty, the ranges of the tiles) give R;
/// metadata.component_scales (when present) multiply v_c. Returns the report, or invalid_argument (options out of
/// range, U size ≠ u_rows × C, tile sizes ≠ the layout, non-finite samples) / unsupported (ColorMode::ycbcr). The tiles
/// are only modified on success. Deterministic for any thread count. Allocates (set-up code).
inline Result<PerceptualToleranceReport> perceptual_tolerance_scales(const BsvtfMetadata& metadata,
                                                                     std::span<const float> u,
                                                                     std::span<BsvtfTileInput> tiles,
                                                                     const PerceptualToleranceOptions& options = {}) {
  const PerceptualToleranceOptions& o = options;
  const bool options_ok =
      std::isfinite(o.light_cosine_power) && std::isfinite(o.view_cosine_power) && o.light_cosine_power >= 0.0f &&
      o.view_cosine_power >= 0.0f && o.light_cosine_power <= 64.0f && o.view_cosine_power <= 64.0f &&
      std::all_of(o.exposure.begin(), o.exposure.end(), [](float e) { return e > 0.0f && e < 1e30f; }) &&
      o.reference_delta_e > 0.0f && o.reference_delta_e < 1e30f && o.dark_floor >= 0.0f && o.dark_floor < 1.0f &&
      o.texel_stride >= 1 && o.direction_samples >= 1 && o.gain_power >= 0.125f && o.gain_power <= 64.0f &&
      o.min_scale > 0.0f && o.max_scale >= o.min_scale && o.max_scale < 1e6f;
  if (!options_ok) return make_error(Status::invalid_argument, "perceptual_tolerance_scales: options out of range");
  if (metadata.color_mode == ColorMode::ycbcr)
    return make_error(Status::unsupported, "perceptual_tolerance_scales: colour mode ycbcr");
  const uint32_t channels = metadata.color_channels;
  const uint32_t C = metadata.component_count;
  if ((channels != 1 && channels != 3) || C == 0 || metadata.u_rows % channels != 0 ||
      u.size() != size_t{metadata.u_rows} * C || metadata.u_rows == 0)
    return make_error(
        Status::invalid_argument,
        "perceptual_tolerance_scales: U has %zu values, expected u_rows %u × %u components with 1 or 3 colours",
        u.size(), metadata.u_rows, C);
  const TileLayout layout = metadata.layout();
  if (!layout.valid()) return make_error(Status::invalid_argument, "perceptual_tolerance_scales: invalid tile layout");
  for (const BsvtfTileInput& t : tiles) {
    if (t.samples.size() != layout.sample_count() || !t.id.valid() || t.id.texture >= metadata.texture_count())
      return make_error(Status::invalid_argument,
                        "perceptual_tolerance_scales: tile (%u, level %u, %u, %u) has a bad id or size", t.id.texture,
                        t.id.level, t.id.x, t.id.y);
    if (!std::all_of(t.samples.begin(), t.samples.end(), [](float v) { return std::isfinite(v); }))
      return make_error(Status::invalid_argument,
                        "perceptual_tolerance_scales: tile (%u, level %u, %u, %u) is not finite", t.id.texture,
                        t.id.level, t.id.x, t.id.y);
  }
  if (!std::all_of(u.begin(), u.end(), [](float v) { return std::isfinite(v); }))
    return make_error(Status::invalid_argument, "perceptual_tolerance_scales: U is not finite");

  PerceptualToleranceReport report;
  {
    const std::vector<float> ranges =
        metadata.component_ranges.size() == C ? metadata.component_ranges : bsvtf_component_ranges(tiles, C);
    for (float r : ranges) report.largest_range = std::max(report.largest_range, std::isfinite(r) ? r : 0.0f);
  }
  // tolerance_for_quality treats ranges ≤ 1e-6 as 1e-6: use the same reference.
  const float R = std::max(report.largest_range, 1e-6f);

  // The sampled angular rows, exposure applied, as RGB × C (grey for luminance U).
  const uint32_t angular = metadata.u_rows / channels;
  auto sample =
      detail::sample_viewing_directions(metadata, angular, o, o.direction_samples, "perceptual_tolerance_scales");
  if (!sample) return sample.error();
  const std::vector<uint32_t>& rows = sample->first;
  const std::vector<double>& row_weight = sample->second;
  const uint32_t nd = static_cast<uint32_t>(rows.size());
  std::vector<float> ud(size_t{nd} * 3 * C);
  for (uint32_t j = 0; j < nd; ++j) {
    const size_t a = rows[j];
    for (uint32_t k = 0; k < 3; ++k)
      for (uint32_t c = 0; c < C; ++c)
        ud[(size_t{j} * 3 + k) * C + c] = o.exposure[k] * u[(a * channels + (channels == 3 ? k : 0)) * C + c];
  }
  std::vector<float> shade_scale(C, 1.0f);
  if (metadata.component_scales.size() == C)
    for (uint32_t c = 0; c < C; ++c)
      shade_scale[c] = std::isfinite(metadata.component_scales[c]) ? metadata.component_scales[c] : 1.0f;

  // Tile positions and the tiles (per texture) at each.
  std::unordered_map<uint64_t, size_t> position_of;
  std::vector<std::vector<const BsvtfTileInput*>> positions;
  std::vector<std::vector<size_t>> position_tiles;
  for (size_t i = 0; i < tiles.size(); ++i) {
    const TileId& id = tiles[i].id;
    const uint64_t key = TileId{0, id.level, id.x, id.y}.key();
    auto [it, inserted] = position_of.try_emplace(key, positions.size());
    if (inserted) {
      positions.emplace_back(metadata.texture_count(), nullptr);
      position_tiles.emplace_back();
    }
    positions[it->second][id.texture] = &tiles[i];
    position_tiles[it->second].push_back(i);
  }

  // Per position: the direction-weighted Σ over samples of g_c^gain_power, and the total weight.
  std::vector<double> gain_sum(positions.size() * C, 0.0);
  std::vector<double> samples_at(positions.size(), 0.0);
  const uint32_t S = layout.stored_size(), B = layout.border, T = layout.tile_size;
  ThreadPool& pool = o.pool ? *o.pool : default_thread_pool();
  const double power = o.gain_power;
  pool.parallel_for(0, positions.size(), 1, [&](size_t begin, size_t end) {
    std::vector<float> v(C);
    std::vector<double> sum(C);
    for (size_t p = begin; p < end; ++p) {
      std::fill(sum.begin(), sum.end(), 0.0);
      double n = 0;
      for (uint32_t y = B; y < B + T; y += o.texel_stride)
        for (uint32_t x = B; x < B + T; x += o.texel_stride) {
          for (uint32_t c = 0; c < C; ++c) {
            const BsvtfTileInput* t = positions[p][c / 4];
            v[c] = t ? t->samples[(size_t{y} * S + x) * 4 + c % 4] * shade_scale[c] : 0.0f;
          }
          for (uint32_t j = 0; j < nd; ++j) {
            const float* row = &ud[size_t{j} * 3 * C];
            float rgb[3] = {0, 0, 0};
            for (uint32_t k = 0; k < 3; ++k)
              for (uint32_t c = 0; c < C; ++c) rgb[k] += v[c] * row[k * C + c];
            for (uint32_t c = 0; c < C; ++c) {
              const float d[3] = {row[c] * shade_scale[c], row[C + c] * shade_scale[c],
                                  row[2 * C + c] * shade_scale[c]};
              const float gc = detail::perceptual_gain(rgb, d, o.dark_floor);
              sum[c] += row_weight[j] * (power == 1.0 ? double{gc} : std::pow(double{gc}, power));
            }
            n += row_weight[j];
          }
        }
      for (uint32_t c = 0; c < C; ++c) gain_sum[p * C + c] = sum[c];
      samples_at[p] = n;
    }
  });

  report.component_gain.assign(C, 0.0f);
  double total_samples = 0;
  std::vector<double> total(C, 0.0);
  for (size_t p = 0; p < positions.size(); ++p) {
    total_samples += samples_at[p];
    for (uint32_t c = 0; c < C; ++c) total[c] += gain_sum[p * C + c];
  }
  for (uint32_t c = 0; c < C; ++c)
    report.component_gain[c] =
        total_samples > 0 ? static_cast<float>(std::pow(total[c] / total_samples, 1.0 / power)) : 0.0f;

  report.min_channel_scale = o.max_scale;
  report.max_channel_scale = o.min_scale;
  for (size_t p = 0; p < positions.size(); ++p)
    for (size_t i : position_tiles[p]) {
      BsvtfTileInput& t = tiles[i];
      for (uint32_t k = 0; k < 4; ++k) {
        const uint64_t c = uint64_t{t.id.texture} * 4 + k;
        float scale = o.max_scale;
        if (c < C && samples_at[p] > 0) {
          const double G = std::pow(gain_sum[p * C + c] / samples_at[p], 1.0 / power);
          if (G > 0)
            scale =
                static_cast<float>(std::clamp(o.reference_delta_e / (G * R), double{o.min_scale}, double{o.max_scale}));
        }
        t.channel_scale[k] = scale;
        report.min_channel_scale = std::min(report.min_channel_scale, scale);
        report.max_channel_scale = std::max(report.max_channel_scale, scale);
      }
    }
  return report;
}

}  // namespace btflod
