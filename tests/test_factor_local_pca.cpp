// Tests of Local PCA (paper 002 §3, ref. [10]) and its 8-bit quantisation (paper 002 §6.3).
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <vector>

#include "btflod/offline/factor/local_pca.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "test_factor_helpers.hpp"

namespace btflod {
namespace {

using namespace btflod_test;

// Texel t belongs to "material" t·3 / n (three vertical bands); each material is its own
// mean plus a 2-dimensional subspace, so K = 3, C = 2 represents the BTF exactly.
BtfFloat three_subspace_btf(int w = 12, int h = 8) {
  BtfFloat btf(w, h, small_direction_set(2, 3, "v"), small_direction_set(3, 3, "l"));
  const size_t n = btf.texel_count(), d = btf.view_count() * btf.light_count() * 3;
  detail::NormalGenerator gen(21);
  std::vector<float> mean(3 * d), basis(3 * 2 * d);
  for (auto& v : mean) v = 0.5f + 0.3f * static_cast<float>(gen.next());
  for (auto& v : basis) v = 0.2f * static_cast<float>(gen.next());
  for (size_t t = 0; t < n; ++t) {
    const size_t j = (t % static_cast<size_t>(w)) * 3 / static_cast<size_t>(w);
    const float a = static_cast<float>(gen.next()), b = static_cast<float>(gen.next());
    for (size_t i = 0; i < d; ++i)
      btf.samples()[((i / 3) * n + t) * 3 + i % 3] =
          mean[j * d + i] + a * basis[(j * 2) * d + i] + b * basis[(j * 2 + 1) * d + i];
  }
  return btf;
}

double rms(const BtfFloat& a, const BtfFloat& b) { return rmse(a.samples(), b.samples()); }

TEST(FactorLocalPca, RecoversClustersAndIsExactOnUnionOfSubspaces) {
  const auto btf = three_subspace_btf();
  auto p = factorize_local_pca(btf, local_pca_options(3, 2, false));
  ASSERT_TRUE(p.ok()) << p.message();
  EXPECT_LT(rms(btf, p->reconstruct()), 1e-4);
  // Each band maps to one cluster and the three bands to different clusters.
  std::set<uint16_t> seen;
  for (int band = 0; band < 3; ++band) {
    const uint16_t c = p->cluster_of[static_cast<size_t>(band * 4)];
    for (int y = 0; y < 8; ++y)
      for (int x = band * 4; x < band * 4 + 4; ++x) EXPECT_EQ(p->cluster_of[static_cast<size_t>(y * 12 + x)], c);
    seen.insert(c);
  }
  EXPECT_EQ(seen.size(), 3u);
}

TEST(FactorLocalPca, ReclusteringLowersTheError) {
  const auto btf = make_low_rank_btf(12, 8, small_direction_set(2, 3), small_direction_set(3, 3), 10, 0.9f, 0.02f, 4);
  LocalPcaOptions o = local_pca_options(4, 2, false);
  o.max_iterations = 0;  // initial (nearest-seed) clusters only
  const double e0 = rms(btf, factorize_local_pca(btf, o)->reconstruct());
  o.max_iterations = 30;
  auto p = factorize_local_pca(btf, o);
  ASSERT_TRUE(p.ok());
  EXPECT_GE(p->iterations, 1);
  EXPECT_LT(rms(btf, p->reconstruct()), e0);
}

TEST(FactorLocalPca, ReclusteringNeverIncreasesTheTotalError) {
  // Noisy low-rank data, K = 3 on 600 texels: one cluster grows past the Gram-matrix limit
  // (256 members), so both per-cluster PCA paths (exact Gram, randomised SVD with the previous
  // basis kept when it is better) take part.
  const auto btf = make_low_rank_btf(30, 20, small_direction_set(2, 3), small_direction_set(3, 3), 12, 0.85f, 0.05f, 8);
  LocalPcaOptions o = local_pca_options(3, 3, false);
  o.max_iterations = 30;
  o.svd.method = SvdMethod::randomized;  // large clusters: randomised even though d is small
  auto p = factorize_local_pca(btf, o);
  ASSERT_TRUE(p.ok()) << p.message();
  ASSERT_GE(p->error_history.size(), 2u);
  EXPECT_EQ(p->error_history.size(), static_cast<size_t>(p->iterations));
  for (size_t i = 1; i < p->error_history.size(); ++i)
    EXPECT_LE(p->error_history[i], p->error_history[i - 1] * (1.0 + 1e-6)) << "pass " << i;
  EXPECT_LT(p->error_history.back(), p->error_history.front());
  size_t largest = 0;
  std::vector<size_t> count(3, 0);
  for (auto c : p->cluster_of) largest = std::max(largest, ++count[c]);
  EXPECT_GT(largest, 256u) << "the randomised per-cluster PCA path is not exercised";
  // The last entry is the error of the returned (unquantised) representation.
  const double sum = squared_error(p->reconstruct(), btf);
  if (p->iterations < o.max_iterations) {
    EXPECT_NEAR(sum, p->error_history.back(), 1e-3 * sum);
  }
}

TEST(FactorLocalPca, EightBitQuantisationFoldsScalesIntoWeights) {
  const auto btf = three_subspace_btf();
  LocalPcaOptions o = local_pca_options(3, 2, false);
  auto f = factorize_local_pca(btf, o);
  o.quantize_8bit = true;
  auto q = factorize_local_pca(btf, o);
  ASSERT_TRUE(f.ok() && q.ok());
  EXPECT_TRUE(q->eigen.empty());
  ASSERT_EQ(q->eigen_q.size(), f->eigen.size());
  // Every component uses the full int8 range (its largest |value| maps to ±127).
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 2; ++k) {
      int mx = 0;
      const size_t d = q->angular_size();
      for (size_t i = 0; i < d; ++i) mx = std::max(mx, std::abs(static_cast<int>(q->eigen_q[(j * d + i) * 2 + k])));
      EXPECT_EQ(mx, 127);
    }
  // The quantised evaluation is close to the float one: error ≤ Σ|w'|·0.5/127 per value.
  const double e = rms(f->reconstruct(), q->reconstruct());
  EXPECT_GT(e, 0.0);
  EXPECT_LT(e, 5e-3);
  EXPECT_LT(q->size_bytes(), f->size_bytes());
}

TEST(FactorLocalPca, RoundTripAndRejectsBadClusterIds) {
  const auto btf = three_subspace_btf();
  auto p = factorize_local_pca(btf, local_pca_options(3, 2));
  ASSERT_TRUE(p.ok());
  const auto back = expect_reads_back(*p);
  ASSERT_TRUE(back);
  AngularSample l{{0, 1, 2}, {0.5f, 0.5f, 0.0f}}, v{{3, 3, 3}, {1.0f, 0.0f, 0.0f}};
  EXPECT_EQ(back->evaluate(5, 5, l, v), p->evaluate(5, 5, l, v));
  LocalPca bad = *p;
  bad.cluster_of[7] = 3;  // K = 3
  auto r = LocalPca::deserialize(bad.serialize());
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.message().find("texel 7"), std::string::npos);
  expect_prefixes_refused<LocalPca>(p->serialize(), 89);
  LocalPcaOptions too_many;
  too_many.clusters = 1000;
  EXPECT_EQ(factorize_local_pca(btf, too_many).status(), Status::invalid_argument);
}

}  // namespace
}  // namespace btflod
