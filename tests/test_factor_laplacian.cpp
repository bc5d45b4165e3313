// Tests of the Laplacian-pyramid PCA (paper 001 §3): exact reconstruction with all mips and
// components, LOD blending of eq. 7, Levenberg–Marquardt Phong fit, §3.3 packing sizes, I/O.
#include <gtest/gtest.h>

#include "btflod/offline/factor/laplacian_pca.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "test_factor_helpers.hpp"

namespace btflod {
namespace {

using namespace btflod_test;

BtfFloat test_btf(int w = 8, int h = 6) {
  return make_low_rank_btf(w, h, small_direction_set(2, 3, "v"), small_direction_set(3, 3, "l"), 6, 0.8f, 0.02f, 11);
}

double max_abs_diff(const BtfFloat& a, const BtfFloat& b) {
  double m = 0.0;
  for (size_t i = 0; i < a.samples().size(); ++i)
    m = std::max(m, std::abs(static_cast<double>(a.samples()[i]) - b.samples()[i]));
  return m;
}

TEST(FactorLaplacian, FullPyramidAllComponentsReconstructsExactly) {
  const auto btf = test_btf();
  for (int mips : {1, 2, 3}) {
    auto p = factorize_laplacian_pca(btf, laplacian_options(mips, {1000, 1000, 1000}));  // clamped to full rank
    ASSERT_TRUE(p.ok()) << p.message();
    EXPECT_EQ(p->lambda_max(), mips);
    EXPECT_LT(max_abs_diff(btf, p->reconstruct(0.0f)), 2e-5) << mips;
  }
}

TEST(FactorLaplacian, IntegerLodIsNearestUpsampledLowPass) {
  // With all components, λ = 1 drops band 0: the result is ↑F_1, i.e. the 3×3 box mean
  // around (2⌊x/2⌋, 2⌊y/2⌋) with clamped borders (YCbCr is linear, so this holds in RGB).
  const auto btf = test_btf();
  auto p = factorize_laplacian_pca(btf, laplacian_options(2, {1000, 1000, 1000}));
  ASSERT_TRUE(p.ok());
  for (auto [x, y] : {std::pair{0, 0}, std::pair{3, 2}, std::pair{7, 5}}) {
    const glm::vec3 got = p->evaluate_measured(x, y, 2, 4, 1.0f);
    for (int c = 0; c < 3; ++c) {
      double s = 0.0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          s += btf.value(std::clamp(2 * (x / 2) + dx, 0, 7), std::clamp(2 * (y / 2) + dy, 0, 5), 2, 4, c);
      EXPECT_NEAR(got[c], s / 9.0, 2e-5);
    }
    // Eq. 7 weights: λ = 0.25 → w_0 = 0.75, so the result is 0.75·F_0 + 0.25·↑F_1.
    const glm::vec3 f0 = p->evaluate_measured(x, y, 2, 4, 0.0f);
    const glm::vec3 mix = p->evaluate_measured(x, y, 2, 4, 0.25f);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(mix[c], 0.75f * f0[c] + 0.25f * got[c], 2e-5);
  }
}

TEST(FactorLaplacian, LevenbergMarquardtRecoversPhongParameters) {
  const auto views = DirectionSet::ubo2003(), lights = DirectionSet::ubo2003();
  for (const PhongParams truth : {PhongParams{0.05f, 0.6f, 0.3f, 20.0f}, PhongParams{0.1f, 0.2f, 1.5f, 3.5f},
                                  PhongParams{0.0f, 0.8f, 0.05f, 60.0f}}) {
    std::vector<float> target(views.size() * lights.size());
    for (size_t v = 0; v < views.size(); ++v)
      for (size_t l = 0; l < lights.size(); ++l)
        target[v * lights.size() + l] = truth.evaluate(lights[l].vector, views[v].vector);
    const PhongParams fit = fit_phong_lm(views, lights, target);
    EXPECT_NEAR(fit.ka, truth.ka, 1e-3);
    EXPECT_NEAR(fit.kd, truth.kd, 1e-3);
    EXPECT_NEAR(fit.ks, truth.ks, 2e-3 * truth.ks + 1e-4);
    EXPECT_NEAR(fit.alpha, truth.alpha, 1e-2 * truth.alpha);
  }
}

TEST(FactorLaplacian, DefaultsAndPackedSizesOfSection33) {
  // 64×64 with 81×81 directions would be the paper's case; the formulas are checked on a
  // smaller shape with the same rules: 8/2/2 components → 3 RGBA texels per image and mip.
  const auto btf = test_btf(16, 16);
  auto p = factorize_laplacian_pca(btf);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p->lambda_max(), 2);  // 16 → 8 → 4 (16 texels ≥ 2·8), 2×2 would be < 16
  const size_t images = btf.view_count() * btf.light_count();
  EXPECT_EQ(p->packed_eigen_map_bytes(), 48 * images * 3);  // 48pq(λmax+1)
  EXPECT_EQ(p->packed_weight_map_bytes(), 48u * (256 + 64 + 16));
  EXPECT_EQ(p->mips[0].components[0], 8);
  EXPECT_EQ(p->mips[0].components[1], 2);
  EXPECT_EQ(laplacian_auto_mip_count(64, 64, 8), 4);  // the paper's λmax = 4 for r = 64
  // Lower LOD → coarser detail → larger error against the original.
  const double e0 = max_abs_diff(btf, p->reconstruct(0.0f)), e2 = max_abs_diff(btf, p->reconstruct(2.0f));
  EXPECT_LT(e0, e2);
}

TEST(FactorLaplacian, RoundTripAndRejectsInconsistentMips) {
  const auto btf = test_btf();
  auto p = factorize_laplacian_pca(btf, laplacian_options(2, {3, 1, 1}));
  ASSERT_TRUE(p.ok());
  const auto back = expect_reads_back(*p);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->evaluate_measured(3, 3, 1, 2, 0.5f), p->evaluate_measured(3, 3, 1, 2, 0.5f));
  expect_prefixes_refused<LaplacianPca>(p->serialize(), 61);
  LaplacianPcaOptions bad;
  bad.mip_count = 5;  // 8×6 has at most 3 halvings
  EXPECT_EQ(factorize_laplacian_pca(btf, bad).status(), Status::invalid_argument);
}

}  // namespace
}  // namespace btflod
