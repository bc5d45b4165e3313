// Tests of offline/metrics/image_metrics.hpp against hand-checked values.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "btflod/offline/metrics/btf_metrics.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"

namespace btflod {
namespace {

struct Img {
  int w, h, c;
  std::vector<float> px;
  Img(int w_, int h_, int c_, float fill = 0.0f) : w(w_), h(h_), c(c_), px(static_cast<size_t>(w_ * h_ * c_), fill) {}
  ImageView<const float> view() const { return ImageView<const float>(px.data(), w, h, c); }
  float& at(int x, int y, int ch = 0) { return px[static_cast<size_t>((y * w + x) * c + ch)]; }
};

Img pattern(int w, int h, int c, int seed) {
  Img im(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int ch = 0; ch < c; ++ch)
        im.at(x, y, ch) = 0.5f + 0.4f * std::sin(0.7f * x + 1.3f * y + 0.9f * ch + static_cast<float>(seed));
  return im;
}

TEST(MetricsImage, RmsePsnrHandValues) {
  Img a(2, 2, 1, 0.0f), b(2, 2, 1, 0.0f);
  b.at(0, 0) = 1.0f;  // one error of 1 among 4 values: MSE 0.25, RMSE 0.5
  EXPECT_DOUBLE_EQ(mse(a.view(), b.view()), 0.25);
  EXPECT_DOUBLE_EQ(rmse(a.view(), b.view()), 0.5);
  EXPECT_NEAR(psnr(a.view(), b.view(), 1.0), 10.0 * std::log10(4.0), 1e-12);
  EXPECT_TRUE(std::isinf(psnr(a.view(), a.view(), 1.0)));
  Img c(3, 2, 1);
  EXPECT_TRUE(std::isnan(rmse(a.view(), c.view())));
  const float s1[] = {1, 2, 3}, s2[] = {1, 2, 6};
  EXPECT_NEAR(rmse(std::span<const float>(s1), std::span<const float>(s2)), std::sqrt(3.0), 1e-12);
}

TEST(MetricsImage, SsimIsOneForIdenticalImages) {
  const Img a = pattern(24, 20, 3, 1);
  EXPECT_NEAR(mean_ssim(a.view(), a.view()), 1.0, 1e-12);
}

TEST(MetricsImage, SsimOfConstantImagesMatchesFormula) {
  // Constant images: σ = 0 everywhere, so SSIM = (2ab + C1) / (a² + b² + C1) (Wang 2004 eq. 13).
  Img a(16, 16, 1, 0.4f), b(16, 16, 1, 0.6f);
  const double c1 = (0.01 * 1.0) * (0.01 * 1.0);
  const double want = (2 * 0.4 * 0.6 + c1) / (0.16 + 0.36 + c1);
  EXPECT_NEAR(mean_ssim(a.view(), b.view()), want, 1e-6);
  SsimOptions o;
  o.data_range = 255.0;  // C1 scales with the range
  const double c1b = (0.01 * 255.0) * (0.01 * 255.0);
  EXPECT_NEAR(mean_ssim(a.view(), b.view(), o), (2 * 0.4 * 0.6 + c1b) / (0.16 + 0.36 + c1b), 1e-6);
}

TEST(MetricsImage, SsimOfScaledZeroMeanPattern) {
  // A checkerboard x ∈ {−d, +d} and y = s·x over an 11×11 window: means ≈ 0 (odd window: not
  // exactly), so compute by hand with the same Gaussian weights at the single valid position.
  Img a(11, 11, 1), b(11, 11, 1);
  for (int y = 0; y < 11; ++y)
    for (int x = 0; x < 11; ++x) {
      a.at(x, y) = ((x + y) % 2 ? 0.2f : -0.2f) + 0.5f;
      b.at(x, y) = ((x + y) % 2 ? 0.1f : -0.1f) + 0.5f;
    }
  int mw = 0;
  const auto map = ssim_map(a.view(), b.view(), 0, {}, &mw);
  ASSERT_EQ(map.size(), 1u);
  EXPECT_EQ(mw, 1);
  double g[11], gs = 0;
  for (int i = 0; i < 11; ++i) gs += (g[i] = std::exp(-(i - 5) * (i - 5) / 4.5));
  double mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
  for (int y = 0; y < 11; ++y)
    for (int x = 0; x < 11; ++x) {
      const double w = g[x] * g[y] / (gs * gs), va = a.at(x, y), vb = b.at(x, y);
      mx += w * va, my += w * vb, xx += w * va * va, yy += w * vb * vb, xy += w * va * vb;
    }
  const double c1 = 1e-4, c2 = 9e-4;
  const double vx = xx - mx * mx, vy = yy - my * my, cxy = xy - mx * my;
  const double want = ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
  EXPECT_NEAR(map[0], want, 1e-9);
  // And the closed form when means are equal (≈ 0.5): contrast/structure term 2·s·d²/(d²+s²d²) → 0.8.
  EXPECT_NEAR(map[0], 0.8, 0.02);
}

TEST(MetricsImage, SsimDropsWithNoise) {
  const Img a = pattern(32, 32, 1, 2);
  Img b = a;
  for (size_t i = 0; i < b.px.size(); ++i) b.px[i] += (i % 3 == 0 ? 0.05f : -0.03f);
  const double s = mean_ssim(a.view(), b.view());
  EXPECT_LT(s, 0.999);
  EXPECT_GT(s, 0.5);
}

TEST(MetricsImage, CielabOfKnownColours) {
  const auto white = linear_srgb_to_lab(1, 1, 1);
  EXPECT_NEAR(white[0], 100.0, 1e-3);
  EXPECT_NEAR(white[1], 0.0, 1e-2);
  EXPECT_NEAR(white[2], 0.0, 1e-2);
  const auto black = linear_srgb_to_lab(0, 0, 0);
  EXPECT_NEAR(black[0], 0.0, 1e-9);
  // sRGB primaries (reference values, e.g. Bruce Lindbloom's calculator, D65).
  const auto red = linear_srgb_to_lab(1, 0, 0);
  EXPECT_NEAR(red[0], 53.24, 0.02);
  EXPECT_NEAR(red[1], 80.09, 0.05);
  EXPECT_NEAR(red[2], 67.20, 0.05);
  const auto green = linear_srgb_to_lab(0, 1, 0);
  EXPECT_NEAR(green[0], 87.73, 0.02);
  EXPECT_NEAR(green[1], -86.18, 0.05);
  EXPECT_NEAR(green[2], 83.18, 0.05);
  const auto blue = linear_srgb_to_lab(0, 0, 1);
  EXPECT_NEAR(blue[0], 32.30, 0.02);
  EXPECT_NEAR(blue[1], 79.19, 0.05);
  EXPECT_NEAR(blue[2], -107.86, 0.05);
  // 18% grey: L* = 116·0.18^(1/3) − 16 ≈ 49.50
  EXPECT_NEAR(linear_srgb_to_lab(0.18, 0.18, 0.18)[0], 49.496, 0.01);
}

TEST(MetricsImage, MaeCielabAveragesChannels) {
  Img a(1, 1, 3, 1.0f), b(1, 1, 3, 0.0f);  // white vs black: |ΔL| = 100, Δa = Δb ≈ 0
  EXPECT_NEAR(mae_cielab(a.view(), b.view()), 100.0 / 3.0, 0.01);
  EXPECT_DOUBLE_EQ(mae_cielab(a.view(), a.view()), 0.0);
}

// ΔE*ab p99 (DeltaEHistogram): 98 texels of a 10 × 10 image are exact and 2 are off by a known
// ΔE, so p99 is that ΔE (the 99th texel in order) to the bin width, p98 is 0; a NaN texel lands
// in the last bin and is counted, never dropped. compare_btfs()'s relative Frobenius error of a
// BTF scaled by 1.1 is 0.1.
TEST(MetricsImage, DeltaEPercentileAndRelativeFrobenius) {
  Img a(10, 10, 3, 0.18f), b(10, 10, 3, 0.18f);
  for (int ch = 0; ch < 3; ++ch) b.at(3, 4, ch) = b.at(7, 1, ch) = 0.2f;
  const auto la = linear_srgb_to_lab(0.18, 0.18, 0.18), lb = linear_srgb_to_lab(0.2, 0.2, 0.2);
  const double d = std::abs(la[0] - lb[0]);  // grey: a* = b* = 0
  ASSERT_GT(d, 1.0);
  DeltaEHistogram h;
  h.add(a.view(), b.view());
  EXPECT_EQ(h.count, 100u);
  EXPECT_NEAR(h.percentile(0.99), d, DeltaEHistogram::kBinWidth);
  EXPECT_GE(h.percentile(0.99), d);  // an upper bound
  EXPECT_LE(h.percentile(0.98), DeltaEHistogram::kBinWidth);
  b.at(0, 0, 0) = std::nanf("");
  h.add(a.view(), b.view());
  EXPECT_EQ(h.count, 200u);
  EXPECT_EQ(h.bins.back(), 1u);

  const std::pair<float, float> two[] = {{0.0f, 0.0f}, {0.5f, 1.0f}};
  const DirectionSet dirs = DirectionSet::from_radians("two", two);
  BtfFloat ref(4, 4, dirs, dirs), scaled(4, 4, dirs, dirs);
  for (size_t i = 0; i < ref.samples().size(); ++i) {
    ref.samples()[i] = 0.05f + 0.01f * static_cast<float>(i % 17);
    scaled.samples()[i] = 1.1f * ref.samples()[i];
  }
  const BtfErrorReport r = compare_btfs(ref, scaled, btf_peak(ref));
  EXPECT_NEAR(r.relative_frobenius, 0.1, 1e-6);
  EXPECT_GT(r.delta_e_p99, 0.0);
  EXPECT_EQ(compare_btfs(ref, ref, 1.0).relative_frobenius, 0.0);
}

TEST(MetricsImage, YcbcrRoundTripAndPerChannelMse) {
  const auto ycc = rgb_to_ycbcr(0.2f, 0.5f, 0.9f);
  const auto rgb = ycbcr_to_rgb(ycc[0], ycc[1], ycc[2]);
  EXPECT_NEAR(rgb[0], 0.2f, 1e-5);
  EXPECT_NEAR(rgb[1], 0.5f, 1e-5);
  EXPECT_NEAR(rgb[2], 0.9f, 1e-5);
  // Grey error only changes Y: Cb and Cr are differences from Y.
  Img a(2, 1, 3, 0.5f), b(2, 1, 3, 0.5f);
  for (int c = 0; c < 3; ++c) b.at(0, 0, c) = 0.7f;
  const auto e = mse_ycbcr(a.view(), b.view());
  EXPECT_NEAR(e[0], 0.04 / 2, 1e-7);
  EXPECT_NEAR(e[1], 0.0, 1e-12);
  EXPECT_NEAR(e[2], 0.0, 1e-12);
}

}  // namespace
}  // namespace btflod
