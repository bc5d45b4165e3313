// btflod — image and BTF quality metrics: RMSE, PSNR, SSIM / mean SSIM (Wang et al. 2004),
// MAE in CIELAB (paper 004 §7.1) and per-channel MSE in YCbCr (paper 001, Table 1).
//
// All functions take float images in linear RGB (or any channel count where noted) as
// ImageView<const float>; the two images must have the same width, height and channel count
// (a mismatch returns NaN rather than reading out of range). Functions are pure, thread-safe
// and allocate only where noted (SSIM keeps one row buffer per call).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <vector>

#include "btflod/core/color.hpp"
#include "btflod/core/image.hpp"

namespace btflod {

namespace detail {
inline bool same_shape(ImageView<const float> a, ImageView<const float> b) noexcept {
  return !a.empty() && !b.empty() && a.width() == b.width() && a.height() == b.height() && a.channels() == b.channels();
}
}  // namespace detail

/// Mean squared error over all pixels and channels, accumulated in double.
/// Returns NaN when the shapes differ or an image is empty.
inline double mse(ImageView<const float> a, ImageView<const float> b) noexcept {
  if (!detail::same_shape(a, b)) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      for (int c = 0; c < a.channels(); ++c) {
        const double d = static_cast<double>(a.at(x, y, c)) - b.at(x, y, c);
        sum += d * d;
      }
  return sum / (static_cast<double>(a.width()) * a.height() * a.channels());
}

/// Root mean squared error; NaN on shape mismatch.
inline double rmse(ImageView<const float> a, ImageView<const float> b) noexcept { return std::sqrt(mse(a, b)); }

/// RMSE of two flat sample arrays of the same length (e.g. a whole BTF against its
/// reconstruction). Returns NaN when the lengths differ or are 0.
inline double rmse(std::span<const float> a, std::span<const float> b) noexcept {
  if (a.size() != b.size() || a.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = static_cast<double>(a[i]) - b[i];
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(a.size()));
}

/// Peak signal-to-noise ratio in dB for the given data range (peak value, e.g. 1 or 255):
/// 10·log10(range² / MSE). Returns +inf for identical images, NaN on shape mismatch.
inline double psnr(ImageView<const float> a, ImageView<const float> b, double data_range) noexcept {
  const double m = mse(a, b);
  if (std::isnan(m)) return m;
  if (m == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(data_range * data_range / m);
}

/// SSIM parameters of Wang et al. 2004: Gaussian window σ = 1.5 truncated to 11×11,
/// K1 = 0.01, K2 = 0.03; data_range is L (the dynamic range of the pixel values).
struct SsimOptions {
  double data_range = 1.0;
  double sigma = 1.5;
  int radius = 5;  ///< window half-size (11×11); shrunk for images smaller than the window
  double k1 = 0.01;
  double k2 = 0.03;
};

/// The SSIM map of channel `channel` (Wang 2004, eq. 13), evaluated at every position where
/// the whole window fits ("valid" mode, as the authors' reference code), so the map is
/// (W − 2r) × (H − 2r). When an image is smaller than the window the radius is reduced to fit.
/// Returns an empty vector on shape mismatch or an out-of-range channel. Allocates the map.
inline std::vector<double> ssim_map(ImageView<const float> a, ImageView<const float> b, int channel,
                                    const SsimOptions& options = {}, int* map_width = nullptr) {
  std::vector<double> out;
  if (!detail::same_shape(a, b) || channel < 0 || channel >= a.channels()) return out;
  const int r = std::max(0, std::min({options.radius, (a.width() - 1) / 2, (a.height() - 1) / 2}));
  const int n = 2 * r + 1;
  std::vector<double> g(static_cast<size_t>(n));
  double gsum = 0.0;
  for (int i = 0; i < n; ++i) {
    const double d = i - r;
    g[static_cast<size_t>(i)] = std::exp(-d * d / (2.0 * options.sigma * options.sigma));
    gsum += g[static_cast<size_t>(i)];
  }
  for (auto& v : g) v /= gsum;
  const double c1 = (options.k1 * options.data_range) * (options.k1 * options.data_range);
  const double c2 = (options.k2 * options.data_range) * (options.k2 * options.data_range);
  const int mw = a.width() - 2 * r, mh = a.height() - 2 * r;
  if (map_width) *map_width = mw;
  out.resize(static_cast<size_t>(mw) * static_cast<size_t>(mh));
  // Separable filtering: horizontal pass into 5 row buffers (x, y, x², y², xy), then vertical.
  const size_t row = static_cast<size_t>(mw);
  std::vector<double> h(5 * row * static_cast<size_t>(a.height()));
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < mw; ++x) {
      double s[5] = {0, 0, 0, 0, 0};
      for (int i = 0; i < n; ++i) {
        const double wa = a.at(x + i, y, channel), wb = b.at(x + i, y, channel), w = g[static_cast<size_t>(i)];
        s[0] += w * wa;
        s[1] += w * wb;
        s[2] += w * wa * wa;
        s[3] += w * wb * wb;
        s[4] += w * wa * wb;
      }
      for (int k = 0; k < 5; ++k) h[(static_cast<size_t>(k) * a.height() + y) * row + x] = s[k];
    }
  for (int y = 0; y < mh; ++y)
    for (int x = 0; x < mw; ++x) {
      double s[5] = {0, 0, 0, 0, 0};
      for (int i = 0; i < n; ++i)
        for (int k = 0; k < 5; ++k)
          s[k] += g[static_cast<size_t>(i)] * h[(static_cast<size_t>(k) * a.height() + y + i) * row + x];
      const double mx = s[0], my = s[1];
      const double vx = s[2] - mx * mx, vy = s[3] - my * my, cxy = s[4] - mx * my;
      out[static_cast<size_t>(y) * row + static_cast<size_t>(x)] =
          ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
    }
  return out;
}

/// Mean SSIM (MSSIM, Wang 2004 eq. 17) averaged over all channels. 1 for identical images;
/// NaN on shape mismatch. Allocates temporaries.
inline double mean_ssim(ImageView<const float> a, ImageView<const float> b, const SsimOptions& options = {}) {
  if (!detail::same_shape(a, b)) return std::numeric_limits<double>::quiet_NaN();
  double total = 0.0;
  for (int c = 0; c < a.channels(); ++c) {
    const auto map = ssim_map(a, b, c, options);
    double s = 0.0;
    for (double v : map) s += v;
    total += s / static_cast<double>(map.size());
  }
  return total / a.channels();
}

/// Linear sRGB (D65) → CIE XYZ with Y of white = 1 (IEC 61966-2-1 matrix).
inline std::array<double, 3> linear_srgb_to_xyz(double r, double g, double b) noexcept {
  return {0.4124564 * r + 0.3575761 * g + 0.1804375 * b, 0.2126729 * r + 0.7151522 * g + 0.0721750 * b,
          0.0193339 * r + 0.1191920 * g + 0.9503041 * b};
}

/// CIE XYZ → CIELAB relative to the D65 white (0.95047, 1, 1.08883).
inline std::array<double, 3> xyz_to_lab(double x, double y, double z) noexcept {
  auto f = [](double t) {
    constexpr double kDelta = 6.0 / 29.0;
    return t > kDelta * kDelta * kDelta ? std::cbrt(t) : t / (3 * kDelta * kDelta) + 4.0 / 29.0;
  };
  const double fx = f(x / 0.95047), fy = f(y / 1.0), fz = f(z / 1.08883);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

/// Linear sRGB → CIELAB (D65). White (1,1,1) → (100, 0, 0).
inline std::array<double, 3> linear_srgb_to_lab(double r, double g, double b) noexcept {
  const auto xyz = linear_srgb_to_xyz(r, g, b);
  return xyz_to_lab(xyz[0], xyz[1], xyz[2]);
}

/// Mean absolute error in CIELAB (paper 004 §7.1): both RGB images (3 channels, linear sRGB)
/// are converted to L*a*b*, the MAE is computed per channel and averaged over L, a, b.
/// Returns NaN on shape mismatch or when the images do not have 3 channels.
inline double mae_cielab(ImageView<const float> a, ImageView<const float> b) noexcept {
  if (!detail::same_shape(a, b) || a.channels() != 3) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const auto la = linear_srgb_to_lab(a.at(x, y, 0), a.at(x, y, 1), a.at(x, y, 2));
      const auto lb = linear_srgb_to_lab(b.at(x, y, 0), b.at(x, y, 1), b.at(x, y, 2));
      sum += std::abs(la[0] - lb[0]) + std::abs(la[1] - lb[1]) + std::abs(la[2] - lb[2]);
    }
  return sum / (3.0 * a.width() * a.height());
}

/// Per-channel MSE in YCbCr (paper 001, Table 1): {MSE_Y, MSE_Cb, MSE_Cr} of two RGB images.
/// Returns NaNs on shape mismatch or when the images do not have 3 channels.
inline std::array<double, 3> mse_ycbcr(ImageView<const float> a, ImageView<const float> b) noexcept {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (!detail::same_shape(a, b) || a.channels() != 3) return {kNaN, kNaN, kNaN};
  std::array<double, 3> sum{0, 0, 0};
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const auto ya = rgb_to_ycbcr(a.at(x, y, 0), a.at(x, y, 1), a.at(x, y, 2));
      const auto yb = rgb_to_ycbcr(b.at(x, y, 0), b.at(x, y, 1), b.at(x, y, 2));
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(ya[static_cast<size_t>(c)]) - yb[static_cast<size_t>(c)];
        sum[static_cast<size_t>(c)] += d * d;
      }
    }
  const double n = static_cast<double>(a.width()) * a.height();
  return {sum[0] / n, sum[1] / n, sum[2] / n};
}

}  // namespace btflod
