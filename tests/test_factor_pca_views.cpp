// Tests of PCA over k neighbouring views (paper 004 §4.3).
#include <gtest/gtest.h>

#include <Eigen/SVD>

#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/pca_views.hpp"

namespace btflod {
namespace {

BtfFloat test_btf() {
  return make_low_rank_btf(8, 6, small_direction_set(3, 3, "v"), small_direction_set(3, 4, "l"), 10, 0.7f, 0.01f, 5);
}

double sq_error(const BtfFloat& a, const BtfFloat& b) {
  double s = 0.0;
  for (size_t i = 0; i < a.samples().size(); ++i) {
    const double d = static_cast<double>(a.samples()[i]) - b.samples()[i];
    s += d * d;
  }
  return s;
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
    PcaViewsOptions all;
    all.views_per_group = 0;  // all views
    all.components = comps;
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
    EXPECT_NEAR(sq_error(btf, p0->reconstruct()) / tail, 1.0, 2e-3) << comps;
  }
}

TEST(FactorPcaViews, KOneIsPcaRfOneGroupPerView) {
  const auto btf = test_btf();
  PcaViewsOptions o;
  o.views_per_group = 1;
  o.components = 3;
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
  EXPECT_LT(sq_error(btf, p->reconstruct()), sq_error(btf, all->reconstruct()));
}

TEST(FactorPcaViews, RaggedLastGroupAndFullRankIsExact) {
  const auto btf = test_btf();  // 7 views, k = 3 → groups of 3, 3, 1
  PcaViewsOptions o;
  o.views_per_group = 3;
  o.components = 48;  // ≥ texel count: exact
  auto p = factorize_pca_views(btf, o);
  ASSERT_TRUE(p.ok());
  ASSERT_EQ(p->groups.size(), 3u);
  EXPECT_EQ(p->groups[2].view_count, 1u);
  EXPECT_LT(sq_error(btf, p->reconstruct()), 1e-6);
  AngularSample light{{1, 2, 3}, {0.2f, 0.3f, 0.5f}}, view{{6, 2, 4}, {0.5f, 0.25f, 0.25f}};
  const glm::vec3 got = p->evaluate(5, 3, light, view);
  for (int c = 0; c < 3; ++c) {
    double want = 0.0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        want += view.weight[i] * light.weight[j] * btf.value(5, 3, view.index[i], light.index[j], c);
    EXPECT_NEAR(got[c], want, 1e-4);
  }
}

TEST(FactorPcaViews, RoundTripAndRejectsBadGrouping) {
  const auto btf = test_btf();
  PcaViewsOptions o;
  o.views_per_group = 2;
  o.components = 3;
  auto p = factorize_pca_views(btf, o);
  ASSERT_TRUE(p.ok());
  const auto bytes = p->serialize();
  auto back = PcaViews::deserialize(bytes);
  ASSERT_TRUE(back.ok()) << back.message();
  EXPECT_EQ(back->serialize(), bytes);
  EXPECT_EQ(back->evaluate_measured(1, 2, 3, 4), p->evaluate_measured(1, 2, 3, 4));
  for (size_t cut = 0; cut < bytes.size(); cut += 97)
    EXPECT_FALSE(PcaViews::deserialize(std::span(bytes).first(cut)).ok());
  // A file of another kind is refused by kind, not misparsed.
  std::vector<uint8_t> other = bytes;
  other[12] = 1;  // kind field → FMF; CRCs cover payloads only
  EXPECT_NE(PcaViews::deserialize(other).message().find("not PCA-k"), std::string::npos);
}

}  // namespace
}  // namespace btflod
