// btflod — error report of a reconstructed BTF against its source: the image metrics of
// image_metrics.hpp aggregated over every (view, light) image.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"

namespace btflod {

/// Errors of a BTF reconstruction. rmse/psnr over all samples; mean_ssim and mae_cielab are
/// averages of the per-image values; mse_ycbcr per channel over all samples.
struct BtfErrorReport {
  double rmse = 0.0;
  double psnr = 0.0;                               ///< dB for the given data range
  double mean_ssim = 1.0;                          ///< mean over images of MSSIM (Wang 2004)
  double mae_cielab = 0.0;                         ///< mean over images of the CIELAB MAE (paper 004 §7.1)
  std::array<double, 3> mse_ycbcr{0.0, 0.0, 0.0};  ///< paper 001 Table 1
  /// 99th percentile over every texel of every image of the CIELAB ΔE*ab (CIE 1976, linear sRGB,
  /// D65), to 0.01 (DeltaEHistogram): the worst visible colour errors, which means hide.
  double delta_e_p99 = 0.0;
  /// ‖reference − approx‖_F / ‖reference‖_F over all samples (paper 000 eq. 4's figure); beside
  /// the perceptual ones because it does not say what a viewer sees (docs/fidelity.md).
  double relative_frobenius = 0.0;
};

/// Mean of the squared samples of an image (its energy per sample; mse() against zero).
inline double mean_square(ImageView<const float> a) noexcept {
  double s = 0.0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      for (int c = 0; c < a.channels(); ++c) s += static_cast<double>(a.at(x, y, c)) * a.at(x, y, c);
  const double n = static_cast<double>(a.width()) * a.height() * a.channels();
  return n > 0.0 ? s / n : 0.0;
}

/// Per-texel CIELAB ΔE*ab (CIE 1976) of compared RGB images in bins of 0.01 up to 200 (the last
/// bin holds larger and non-finite values), so a percentile needs no copy of the values.
struct DeltaEHistogram {
  static constexpr double kBinWidth = 0.01;
  static constexpr size_t kBins = 20001;
  std::vector<uint64_t> bins = std::vector<uint64_t>(kBins, 0);  // allocates 160 KB
  uint64_t count = 0;

  /// Adds every texel of two 3-channel linear sRGB images of one shape (others are ignored).
  void add(ImageView<const float> a, ImageView<const float> b) noexcept {
    if (a.width() != b.width() || a.height() != b.height() || a.channels() != 3 || b.channels() != 3) return;
    for (int y = 0; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x) {
        const auto la = linear_srgb_to_lab(a.at(x, y, 0), a.at(x, y, 1), a.at(x, y, 2));
        const auto lb = linear_srgb_to_lab(b.at(x, y, 0), b.at(x, y, 1), b.at(x, y, 2));
        const double d = std::sqrt((la[0] - lb[0]) * (la[0] - lb[0]) + (la[1] - lb[1]) * (la[1] - lb[1]) +
                                   (la[2] - lb[2]) * (la[2] - lb[2]));
        const double bin = d / kBinWidth;
        ++bins[d >= 0.0 && bin < static_cast<double>(kBins - 1) ? static_cast<size_t>(bin) : kBins - 1];
        ++count;
      }
  }
  /// The q-quantile (0 < q ≤ 1) as the upper edge of its bin (an upper bound within 0.01); 0
  /// when nothing was added.
  double percentile(double q) const noexcept {
    if (count == 0) return 0.0;
    const uint64_t rank = static_cast<uint64_t>(std::ceil(q * static_cast<double>(count)));
    uint64_t seen = 0;
    for (size_t i = 0; i < kBins; ++i)
      if ((seen += bins[i]) >= rank) return static_cast<double>(i + 1) * kBinWidth;
    return static_cast<double>(kBins) * kBinWidth;
  }
};

/// The sums behind a BtfErrorReport, image by image: compare_btfs() and compare_btf_store()
/// (btf_store_metrics.hpp) both feed one, so they form the same figures in the same order.
/// Allocates its ΔE histogram; single-threaded.
class BtfErrorAccumulator {
 public:
  /// data_range: the peak value of PSNR and SSIM.
  explicit BtfErrorAccumulator(double data_range) noexcept : range_(data_range) {
    ssim_options_.data_range = data_range;
  }
  /// Adds one (view, light) image pair (3-channel linear RGB, one shape).
  void add(ImageView<const float> reference, ImageView<const float> approx) {
    sse_ += mse(reference, approx);
    ref_energy_ += mean_square(reference);
    ssim_ += btflod::mean_ssim(reference, approx, ssim_options_);
    lab_ += btflod::mae_cielab(reference, approx);
    delta_e_.add(reference, approx);
    const auto e = btflod::mse_ycbcr(reference, approx);
    for (size_t c = 0; c < 3; ++c) ycc_[c] += e[c];
    ++images_;
  }
  /// The report over every image added (call after at least one).
  BtfErrorReport report() const noexcept {
    BtfErrorReport r;
    const double n = static_cast<double>(images_);
    r.rmse = std::sqrt(sse_ / n);
    r.psnr = sse_ == 0.0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(range_ * range_ / (sse_ / n));
    r.mean_ssim = ssim_ / n;
    r.mae_cielab = lab_ / n;
    for (size_t c = 0; c < 3; ++c) r.mse_ycbcr[c] = ycc_[c] / n;
    r.delta_e_p99 = delta_e_.percentile(0.99);
    r.relative_frobenius = ref_energy_ > 0.0 ? std::sqrt(sse_ / ref_energy_)
                                             : (sse_ > 0.0 ? std::numeric_limits<double>::quiet_NaN() : 0.0);
    return r;
  }

 private:
  double range_;
  SsimOptions ssim_options_;
  double sse_ = 0.0, ssim_ = 0.0, lab_ = 0.0, ref_energy_ = 0.0;
  std::array<double, 3> ycc_{0.0, 0.0, 0.0};
  DeltaEHistogram delta_e_;
  size_t images_ = 0;
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
    r.rmse = r.psnr = r.mean_ssim = r.mae_cielab = r.delta_e_p99 = r.relative_frobenius = kNaN;
    r.mse_ycbcr = {kNaN, kNaN, kNaN};
    return r;
  }
  BtfErrorAccumulator sums(data_range);
  for (size_t v = 0; v < reference.view_count(); ++v)
    for (size_t l = 0; l < reference.light_count(); ++l) sums.add(reference.image(v, l), approx.image(v, l));
  return sums.report();
}

/// The largest sample of a BTF (a data range for compare_btfs); 1 for an empty or all-zero BTF.
inline double btf_peak(const BtfFloat& btf) noexcept {
  float m = 0.0f;
  for (float v : btf.samples())
    if (v > m) m = v;
  return m > 0.0f ? static_cast<double>(m) : 1.0;
}

}  // namespace btflod
