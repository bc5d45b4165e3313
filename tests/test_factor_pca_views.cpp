// Tests of PCA over k neighbouring views (paper 004 §4.3).
#include <gtest/gtest.h>

#include <Eigen/SVD>

#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/pca_views.hpp"
#include "test_factor_helpers.hpp"

namespace btflod {
namespace {

using namespace btflod_test;

BtfFloat test_btf() {
  return make_low_rank_btf(8, 6, small_direction_set(3, 3, "v"), small_direction_set(3, 4, "l"), 10, 0.7f, 0.01f, 5);
}

TEST(FactorPcaViews, KEqualsAllIsPcaBtf) {
  // PCA-BTF computed independently: texels × (all images·3) matrix, row-centred, best rank-C
  // error = Σ_{i>C} σ_i² of the centred matrix (double-precision Jacobi SVD).
  const auto btf = test_btf();
  const size_t n = btf.texel_count(), nv = btf.view_count(), nl = btf.light_count();
  Eigen::MatrixXd a(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(nv * nl * 3));
  for (size_t v = 0; v < nv; ++v)
    for (size_t l = 0; l < nl; ++l)
      for (size_t t = 0; t < n; ++t)
        for (int c = 0; c < 3; ++c)
          a(static_cast<Eigen::Index>(t), static_cast<Eigen::Index>((v * nl + l) * 3 + static_cast<size_t>(c))) =
              btf.value(static_cast<int>(t % 8), static_cast<int>(t / 8), v, l, c);
  const Eigen::VectorXd mean = a.rowwise().mean();
  a.colwise() -= mean;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a);
  for (int comps : {2, 5}) {
    PcaViewsOptions all = pca_views_options(0, comps);  // all views
    auto p0 = factorize_pca_views(btf, all);
    all.views_per_group = static_cast<int>(nv);
    auto p1 = factorize_pca_views(btf, all);
    ASSERT_TRUE(p0.ok() && p1.ok());
    ASSERT_EQ(p0->groups.size(), 1u);
    EXPECT_EQ(p0->serialize(), p1->serialize());
    // L's first column is the per-texel mean, R's first row all ones (L = [m | UΣ], R = [1; Vᵀ]).
    for (size_t t = 0; t < n; ++t)
      EXPECT_NEAR(p0->groups[0].l[t * (comps + 1)], mean[static_cast<Eigen::Index>(t)], 1e-5);
    for (size_t j = 0; j < nv * nl * 3; ++j) EXPECT_EQ(p0->groups[0].r[j], 1.0f);
    double tail = 0.0;
    for (Eigen::Index i = comps; i < svd.singularValues().size(); ++i)
      tail += svd.singularValues()[i] * svd.singularValues()[i];
    EXPECT_NEAR(squared_error(btf, p0->reconstruct()) / tail, 1.0, 2e-3) << comps;
  }
}

TEST(FactorPcaViews, KOneIsPcaRfOneGroupPerView) {
  const auto btf = test_btf();
  PcaViewsOptions o = pca_views_options(1, 3);
  auto p = factorize_pca_views(btf, o);
  ASSERT_TRUE(p.ok());
  ASSERT_EQ(p->groups.size(), btf.view_count());
  for (size_t g = 0; g < p->groups.size(); ++g) {
    EXPECT_EQ(p->groups[g].first_view, g);
    EXPECT_EQ(p->groups[g].view_count, 1u);
  }
  // More groups with the same C: more parameters and lower error than k = all.
  o.views_per_group = 0;
  auto all = factorize_pca_views(btf, o);
  EXPECT_GT(p->size_bytes(), all->size_bytes());
  EXPECT_LT(squared_error(btf, p->reconstruct()), squared_error(btf, all->reconstruct()));
}

TEST(FactorPcaViews, RaggedLastGroupAndFullRankIsExact) {
  const auto btf = test_btf();                                  // 7 views, k = 3 → groups of 3, 3, 1
  auto p = factorize_pca_views(btf, pca_views_options(3, 48));  // C ≥ texel count: exact
  ASSERT_TRUE(p.ok());
  ASSERT_EQ(p->groups.size(), 3u);
  EXPECT_EQ(p->groups[2].view_count, 1u);
  EXPECT_LT(squared_error(btf, p->reconstruct()), 1e-6);
  AngularSample light{{1, 2, 3}, {0.2f, 0.3f, 0.5f}}, view{{6, 2, 4}, {0.5f, 0.25f, 0.25f}};
  expect_nine_tap_blend(btf, 5, 3, light, view, p->evaluate(5, 3, light, view));
}

TEST(FactorPcaViews, RoundTripAndRejectsBadGrouping) {
  const auto btf = test_btf();
  auto p = factorize_pca_views(btf, pca_views_options(2, 3));
  ASSERT_TRUE(p.ok());
  const auto back = expect_reads_back(*p);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->evaluate_measured(1, 2, 3, 4), p->evaluate_measured(1, 2, 3, 4));
  const auto bytes = p->serialize();
  expect_prefixes_refused<PcaViews>(bytes, 97);
  // A file of another kind is refused by kind, not misparsed.
  std::vector<uint8_t> other = bytes;
  other[12] = 1;  // kind field → FMF; CRCs cover payloads only
  EXPECT_NE(PcaViews::deserialize(other).message().find("not PCA-k"), std::string::npos);
}

}  // namespace
}  // namespace btflod
