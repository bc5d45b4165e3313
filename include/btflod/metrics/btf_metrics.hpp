// btflod — error report of a reconstructed BTF against its source: the image metrics of
// image_metrics.hpp aggregated over every (view, light) image.
#pragma once

#include <array>
#include <cmath>
#include <limits>

#include "btflod/btf/tabulated_btf.hpp"
#include "btflod/metrics/image_metrics.hpp"

namespace btflod {

/// Errors of a BTF reconstruction. rmse/psnr over all samples; mean_ssim and mae_cielab are
/// averages of the per-image values; mse_ycbcr per channel over all samples.
struct BtfErrorReport {
  double rmse = 0.0;
  double psnr = 0.0;                               ///< dB for the given data range
  double mean_ssim = 1.0;                          ///< mean over images of MSSIM (Wang 2004)
  double mae_cielab = 0.0;                         ///< mean over images of the CIELAB MAE (paper 004 §7.1)
  std::array<double, 3> mse_ycbcr{0.0, 0.0, 0.0};  ///< paper 001 Table 1
};

/// Compares `approx` with `reference` image by image. data_range is the peak value used by
/// PSNR and SSIM (e.g. the maximum of the reference). Returns NaNs when the shapes differ.
/// Allocates temporaries; single-threaded, thread-safe.
inline BtfErrorReport compare_btfs(const BtfFloat& reference, const BtfFloat& approx, double data_range) {
  BtfErrorReport r;
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (reference.width() != approx.width() || reference.height() != approx.height() ||
      reference.view_count() != approx.view_count() || reference.light_count() != approx.light_count() ||
      reference.empty()) {
    return BtfErrorReport{kNaN, kNaN, kNaN, kNaN, {kNaN, kNaN, kNaN}};
  }
  SsimOptions so;
  so.data_range = data_range;
  double sse = 0.0, ssim = 0.0, lab = 0.0;
  std::array<double, 3> ycc{0, 0, 0};
  const size_t images = reference.view_count() * reference.light_count();
  for (size_t v = 0; v < reference.view_count(); ++v)
    for (size_t l = 0; l < reference.light_count(); ++l) {
      const auto a = reference.image(v, l), b = approx.image(v, l);
      const double m = mse(a, b);
      sse += m;
      ssim += btflod::mean_ssim(a, b, so);
      lab += btflod::mae_cielab(a, b);
      const auto e = btflod::mse_ycbcr(a, b);
      for (int c = 0; c < 3; ++c) ycc[static_cast<size_t>(c)] += e[static_cast<size_t>(c)];
    }
  const double n = static_cast<double>(images);
  r.rmse = std::sqrt(sse / n);
  r.psnr =
      sse == 0.0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(data_range * data_range / (sse / n));
  r.mean_ssim = ssim / n;
  r.mae_cielab = lab / n;
  for (int c = 0; c < 3; ++c) r.mse_ycbcr[static_cast<size_t>(c)] = ycc[static_cast<size_t>(c)] / n;
  return r;
}

/// The largest sample of a BTF (a data range for compare_btfs); 1 for an empty or all-zero BTF.
inline double btf_peak(const BtfFloat& btf) noexcept {
  float m = 0.0f;
  for (float v : btf.samples())
    if (v > m) m = v;
  return m > 0.0f ? static_cast<double>(m) : 1.0;
}

}  // namespace btflod
