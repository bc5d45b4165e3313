// btflod — quantisation of DCT coefficients (paper 000 §6: "a quantization with respect to a
// quality threshold similar to JPEG").
//
// Eigen-textures have no fixed range, so quality is not a fixed 8-bit table: the encoder turns a
// user quality into an absolute error tolerance t per component (tolerance_for_quality), and
// the step of coefficient k is
//   step_k = t · 2 w_k / rms(w),
// where w is JPEG's luminance table (ITU T.81 Annex K.1), resampled for other block sizes, or
// that table raised to a power γ ∈ {0, 1/4, 1/2, 3/4, 1} (quant_step_factors). With
// round-to-nearest, |e_k| ≤ step_k / 2 = t w_k / rms(w), so Σ e_k² ≤ t² N²; the DCT being
// orthonormal (core/dct.hpp), the RMS error of every N×N block is at most t. This is the
// guarantee the tests check.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace btflod {

/// JPEG's luminance quantisation table (ITU T.81, Table K.1), row-major (v, u).
inline constexpr std::array<uint8_t, 64> kJpegLumaTable = {
    16, 11, 10, 16, 24,  40,  51,  61,  12, 12, 14, 19, 26,  58,  60,  55,  //
    14, 13, 16, 24, 40,  57,  69,  56,  14, 17, 22, 29, 51,  87,  80,  62,  //
    18, 22, 37, 56, 68,  109, 103, 77,  24, 35, 55, 64, 81,  104, 113, 92,  //
    49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99};

/// Frequency weighting: the step of coefficient k follows w_k^γ with γ = quarters / 4 of JPEG's
/// table w. 4 (the default) is JPEG's table itself; smaller exponents flatten it towards one
/// step for every frequency (0). JPEG's table encodes the eye's lower contrast sensitivity at
/// high spatial frequencies for 8×8 pixel blocks viewed directly; eigen-textures are seen
/// through a BTF reconstruction, a mip chain and the display, and a per-pixel colour-difference
/// criterion (p99 ΔE*ab, docs/bsvtf_format.md) is met with fewer bytes by a flatter table
/// (measured: γ = 1/4). Every exponent keeps the block-RMS bound below.
inline constexpr uint32_t kJpegWeightQuarters = 4;

/// Normalised step factors 2 w_k^γ / rms(w^γ) for an N×N block, row-major (v, u), γ =
/// quarters / 4 (quarters ≤ 4; larger values are treated as 4). For N ≠ 8 the JPEG table is
/// sampled bilinearly at the same relative frequency. Built once per (N, quarters); thread-safe.
template <int N>
inline const std::array<float, N * N>& quant_step_factors(uint32_t quarters = kJpegWeightQuarters) noexcept {
  static const std::array<std::array<float, N * N>, kJpegWeightQuarters + 1> tables = [] {
    std::array<double, N * N> w{};
    for (int v = 0; v < N; ++v)
      for (int u = 0; u < N; ++u) {
        const double fv = N == 1 ? 0.0 : v * 7.0 / (N - 1), fu = N == 1 ? 0.0 : u * 7.0 / (N - 1);
        const int v0 = std::min(6, static_cast<int>(fv)), u0 = std::min(6, static_cast<int>(fu));
        const double tv = fv - v0, tu = fu - u0;
        auto at = [](int r, int c) { return static_cast<double>(kJpegLumaTable[r * 8 + c]); };
        w[v * N + u] = (1 - tv) * ((1 - tu) * at(v0, u0) + tu * at(v0, u0 + 1)) +
                       tv * ((1 - tu) * at(v0 + 1, u0) + tu * at(v0 + 1, u0 + 1));
      }
    std::array<std::array<float, N * N>, kJpegWeightQuarters + 1> out{};
    for (uint32_t q = 0; q <= kJpegWeightQuarters; ++q) {
      std::array<double, N * N> wq{};
      for (int i = 0; i < N * N; ++i) wq[i] = q == kJpegWeightQuarters ? w[i] : std::pow(w[i], q / 4.0);
      double sum_sq = 0;
      for (double x : wq) sum_sq += x * x;
      const double rms = std::sqrt(sum_sq / (N * N));
      for (int i = 0; i < N * N; ++i) out[q][i] = static_cast<float>(2.0 * wq[i] / rms);
    }
    return out;
  }();
  return tables[std::min(quarters, kJpegWeightQuarters)];
}

/// Zig-zag scan order of an N×N block (JPEG order generalised): entry i is the row-major index
/// of the i-th coefficient, low frequencies first. Built once; thread-safe.
template <int N>
inline const std::array<uint16_t, N * N>& zigzag_order() noexcept {
  static const std::array<uint16_t, N* N> order = [] {
    std::array<uint16_t, N * N> z{};
    int i = 0;
    for (int s = 0; s <= 2 * (N - 1); ++s) {
      // Odd anti-diagonals run top-right → bottom-left, even ones bottom-left → top-right.
      for (int t = 0; t <= s; ++t) {
        const int v = (s % 2 == 0) ? s - t : t;
        const int u = s - v;
        if (v < N && u < N) z[i++] = static_cast<uint16_t>(v * N + u);
      }
    }
    return z;
  }();
  return order;
}

/// JPEG's quality scaling (IJG): 50 → 1, lower qualities coarser (50/q), higher ones finer
/// (2 − q/50), clamped to [1, 100] and to a floor of 0.01 so quality 100 stays lossy-but-tiny.
constexpr float quality_scale(float quality) noexcept {
  const float q = quality < 1.0f ? 1.0f : (quality > 100.0f ? 100.0f : quality);
  const float s = q < 50.0f ? 50.0f / q : 2.0f - q / 50.0f;
  return s < 0.01f ? 0.01f : s;
}

/// Block-RMS tolerance at quality 50, as a fraction of the component's value range.
inline constexpr float kToleranceAtQuality50 = 1.0f / 128.0f;

/// Absolute error tolerance t of a component whose values span `component_range` (max − min
/// over the whole eigen-texture), at a user quality in [1, 100]. Returns a positive finite value
/// (a range ≤ 0 or non-finite is treated as 1e-6 so that a constant component still codes).
inline float tolerance_for_quality(float quality, float component_range) noexcept {
  const float range = (std::isfinite(component_range) && component_range > 1e-6f) ? component_range : 1e-6f;
  return range * kToleranceAtQuality50 * quality_scale(quality);
}

/// Perceptual (lightness-uniform) scale of a tile's tolerance from the radiance it shows.
/// CIELAB lightness is L* = 116 (Y/Yn)^(1/3) − 16 (above the linear toe), so dL*/dY ∝ Y^(−2/3):
/// an error δY changes L* by the same amount — is equally visible — when δY ∝ Y^(2/3). A
/// tolerance that is absolute over the material (shared_max) therefore puts the most visible
/// errors into its darkest texels (the sRGB curve, ≈ Y^(1/2.4), agrees). Scaling each tile's
/// tolerance by
///     s = (max(y_tile, y_floor) / y_ref)^(2/3)
/// equalises the expected ΔL* over tiles: tiles brighter than y_ref get coarser steps, darker
/// ones finer. y_floor (a small fraction of the material's peak) keeps black tiles from getting
/// vanishing steps (below it the eye's toe, the 8-bit output and the tone map hide errors
/// anyway). y_tile, y_ref and y_floor share one unit (any: only ratios count). Returns a
/// positive finite scale, clamped to [1/64, 64]; non-finite or non-positive inputs give 1.
inline float luminance_tolerance_scale(float y_tile, float y_ref, float y_floor) noexcept {
  if (!(y_ref > 0.0f) || !std::isfinite(y_ref) || !std::isfinite(y_tile) || !std::isfinite(y_floor)) return 1.0f;
  const float y = std::max(y_tile, std::max(y_floor, 1e-30f));
  const float s = std::cbrt((y / y_ref) * (y / y_ref));  // (y / y_ref)^(2/3)
  return std::clamp(s, 1.0f / 64.0f, 64.0f);
}

}  // namespace btflod
