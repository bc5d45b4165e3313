// btflod — colour transfer functions used at load and save time, and the BT.601 YCbCr of
// paper 001 (also the log_ycbcr value encoding, core/value_transform.hpp).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

namespace btflod {

/// sRGB electro-optical transfer (IEC 61966-2-1): encoded [0,1] → linear [0,1].
inline float srgb_to_linear(float encoded) noexcept {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

/// Inverse of srgb_to_linear; input is clamped to [0,1], NaN maps to 0.
inline float linear_to_srgb(float linear) noexcept {
  if (!(linear > 0.0f)) return 0.0f;
  if (linear >= 1.0f) return 1.0f;
  return linear <= 0.0031308f ? linear * 12.92f : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}

/// Linear value → 8-bit sRGB code, rounded to nearest; NaN maps to 0.
inline uint8_t linear_to_srgb8(float linear) noexcept {
  return static_cast<uint8_t>(linear_to_srgb(linear) * 255.0f + 0.5f);
}

/// RGB → YCbCr (ITU-R BT.601, full range, no offsets: Cb, Cr centred on 0) as used by paper 001.
inline std::array<float, 3> rgb_to_ycbcr(float r, float g, float b) noexcept {
  const float y = 0.299f * r + 0.587f * g + 0.114f * b;
  return {y, (b - y) / 1.772f, (r - y) / 1.402f};
}

/// Inverse of rgb_to_ycbcr.
inline std::array<float, 3> ycbcr_to_rgb(float y, float cb, float cr) noexcept {
  const float r = y + 1.402f * cr;
  const float b = y + 1.772f * cb;
  const float g = (y - 0.299f * r - 0.114f * b) / 0.587f;
  return {r, g, b};
}

/// 256-entry table of srgb_to_linear(i / 255), built once. Thread-safe.
inline const float* srgb8_to_linear_table() noexcept {
  static const struct Table {
    float v[256];
    Table() {
      for (int i = 0; i < 256; ++i) v[i] = srgb_to_linear(static_cast<float>(i) / 255.0f);
    }
  } table;
  return table.v;
}

}  // namespace btflod
