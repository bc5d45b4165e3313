// Tests of offline/factor/truncated_svd.hpp on matrices with a KNOWN spectrum (A = U·diag(s)·Vᵀ with
// random orthonormal U, V), so the Eckart–Young optimum sqrt(Σ_{i≥C} s_i²) is exact: the
// randomised path (sparse-sign or Gaussian sketch, fused last pass, adaptive power iterations
// with a flat-tailed spectrum that the old fixed q = 2 misses) against it, orthonormality,
// rank-deficient and zero inputs, determinism, cancellation.
//
// CMake also builds this file as test_factor_svd_offline_arch with the offline tools' flags
// (BTFLOD_OFFLINE_ARCH, e.g. -march=x86-64-v3), so both the default and the vectorised build
// of the SVD are tested.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <string>
#include <vector>

#include "btflod/offline/factor/truncated_svd.hpp"

namespace btflod {
namespace {

Eigen::MatrixXd random_orthonormal(Eigen::Index rows, Eigen::Index cols, uint64_t seed) {
  detail::NormalGenerator gen(seed);
  Eigen::MatrixXd g(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) g(i, j) = gen.next();
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(g);
  return qr.householderQ() * Eigen::MatrixXd::Identity(rows, cols);
}

struct Known {
  Eigen::MatrixXf a;
  std::vector<double> s;  // descending
};

// m × n with singular values s_i = s0 · decay^i (i < min(m, n)), the first `rank` nonzero.
Known known_matrix(Eigen::Index m, Eigen::Index n, double decay, Eigen::Index rank, uint64_t seed) {
  const Eigen::Index r = std::min(m, n);
  Known k;
  Eigen::VectorXd s = Eigen::VectorXd::Zero(r);
  for (Eigen::Index i = 0; i < std::min(r, rank); ++i) s[i] = 10.0 * std::pow(decay, static_cast<double>(i));
  k.s.assign(s.data(), s.data() + r);
  k.a =
      (random_orthonormal(m, r, seed) * s.asDiagonal() * random_orthonormal(n, r, seed + 1).transpose()).cast<float>();
  return k;
}

double optimum(const Known& k, int c) {
  double t = 0.0;
  for (size_t i = static_cast<size_t>(c); i < k.s.size(); ++i) t += k.s[i] * k.s[i];
  return std::sqrt(t);
}

double error_of(const Eigen::MatrixXf& a, const TruncatedSvd& f) {
  const Eigen::MatrixXd rec = f.u.cast<double>() * f.s.cast<double>().asDiagonal() * f.v.cast<double>().transpose();
  return (a.cast<double>() - rec).norm();
}

// Fixed q power iterations (max_power_iterations = q: the rule of earlier versions), p = 20.
SvdOptions randomized(int zeta, int q) {
  SvdOptions o;
  o.method = SvdMethod::randomized;
  o.sketch_nonzeros = zeta;
  o.power_iterations = q;
  o.max_power_iterations = q;
  o.block_columns = 37;  // ragged blocks
  o.oversampling = 20;
  return o;
}

// The default options (adaptive power iterations, p = 50), forced onto the randomised path.
SvdOptions adaptive(int zeta = 8) {
  SvdOptions o;
  o.method = SvdMethod::randomized;
  o.sketch_nonzeros = zeta;
  o.block_columns = 37;
  return o;
}

// m × n with a fast head and a flat tail: s_i = 10·0.99^min(i, c)·0.999^max(0, i − c). Like the
// car paint, the tail beyond the rank is nearly flat, so subspace iteration converges slowly.
Known flat_tail_matrix(Eigen::Index m, Eigen::Index n, Eigen::Index c, uint64_t seed) {
  const Eigen::Index r = std::min(m, n);
  Known k;
  Eigen::VectorXd s(r);
  for (Eigen::Index i = 0; i < r; ++i)
    s[i] = 10.0 * std::pow(0.99, static_cast<double>(std::min(i, c))) *
           std::pow(0.999, static_cast<double>(std::max<Eigen::Index>(0, i - c)));
  k.s.assign(s.data(), s.data() + r);
  k.a =
      (random_orthonormal(m, r, seed) * s.asDiagonal() * random_orthonormal(n, r, seed + 1).transpose()).cast<float>();
  return k;
}

#if defined(BTFLOD_TEST_OFFLINE_ARCH)
TEST(FactorSvd, OfflineArchTwinIsCompiledWithAvx2AndFma) {
#if defined(__AVX2__) && defined(__FMA__)
  SUCCEED();
#else
  FAIL() << "test_factor_svd_offline_arch should be compiled with the BTFLOD_OFFLINE_ARCH flags";
#endif
}
#endif

TEST(FactorSvd, RandomizedWithinHalfPercentOfEckartYoungBothSketches) {
  // Tall and wide, slowly decaying spectrum (0.93^i: the tail beyond C is far from negligible).
  for (auto [m, n] : {std::pair<Eigen::Index, Eigen::Index>{300, 500}, {500, 300}}) {
    const Known k = known_matrix(m, n, 0.93, 1000, 11);
    for (int zeta : {0, 8})
      for (int c : {5, 20}) {
        auto f = truncated_svd(k.a, c, adaptive(zeta));
        ASSERT_TRUE(f.ok()) << f.message();
        ASSERT_EQ(f->u.cols(), c);
        ASSERT_EQ(f->v.cols(), c);
        ASSERT_EQ(f->s.size(), c);
        const double err = error_of(k.a, *f), opt = optimum(k, c);
        EXPECT_LE(err, 1.005 * opt) << m << "x" << n << " zeta " << zeta << " rank " << c;
        EXPECT_GE(err, opt * (1.0 - 1e-4)) << "nothing beats the optimum";
        for (int i = 0; i < c; ++i) EXPECT_NEAR(f->s[i], k.s[static_cast<size_t>(i)], 2e-3 * k.s[0]) << i;
        for (int i = 1; i < c; ++i) EXPECT_GE(f->s[i - 1], f->s[i]);
      }
  }
}

TEST(FactorSvd, AdaptiveIterationsMeetTheBoundOnAFlatTailWhereFixedTwoDoNot) {
  const Known k = flat_tail_matrix(300, 500, 20, 23);
  const double opt = optimum(k, 20);
  auto fixed = truncated_svd(k.a, 20, randomized(8, 2));
  SvdOptions fixed50 = adaptive();
  fixed50.max_power_iterations = 2;  // the old default: q = 2, p = 50
  auto old_default = truncated_svd(k.a, 20, fixed50);
  auto f = truncated_svd(k.a, 20, adaptive());
  ASSERT_TRUE(fixed.ok() && old_default.ok() && f.ok());
  EXPECT_EQ(old_default->report.power_iterations, 2);
  EXPECT_GT(error_of(k.a, *old_default), 1.005 * opt) << "the old fixed q = 2 rule must miss the bound here";
  EXPECT_GT(error_of(k.a, *fixed), 1.005 * opt);
  const double err = error_of(k.a, *f);
  EXPECT_LE(err, 1.005 * opt);
  EXPECT_GT(f->report.power_iterations, 2);
  EXPECT_LE(f->report.power_iterations, 6);
  // The estimate is the true error (Pythagoras, U and V orthonormal) and the prediction is sane.
  EXPECT_NEAR(f->report.error_estimate, err, 1e-4 * err);
  EXPECT_NEAR(f->report.frobenius_norm, k.a.cast<double>().norm(), 1e-5 * k.a.cast<double>().norm());
  EXPECT_GE(f->report.predicted_ratio, 1.0);
  EXPECT_LE(f->report.predicted_ratio, 1.0 + SvdOptions{}.power_tolerance);
  EXPECT_FALSE(f->report.exact);
}

TEST(FactorSvd, AdaptiveIterationsCostNothingExtraOnAFastDecay) {
  // 0.8^i: two iterations are already at the optimum, the rule must not add a third.
  const Known k = known_matrix(300, 500, 0.8, 1000, 29);
  auto f = truncated_svd(k.a, 15, adaptive());
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->report.power_iterations, 2);
  EXPECT_LE(error_of(k.a, *f), 1.005 * optimum(k, 15));
}

TEST(FactorSvd, PowerIterationLimitsAreHonouredAndProgressShowsTheEstimate) {
  const Known k = flat_tail_matrix(200, 300, 10, 31);
  SvdOptions o = adaptive();
  o.power_iterations = 1;
  o.max_power_iterations = 1;
  std::vector<std::string> stages;
  auto one = truncated_svd(k.a, 10, o, [&](std::string_view s, double) {
    stages.emplace_back(s);
    return true;
  });
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->report.power_iterations, 1);
  bool saw_estimate = false;
  for (const auto& s : stages) saw_estimate = saw_estimate || s.find("error estimate") != std::string::npos;
  EXPECT_TRUE(saw_estimate);
  o.power_iterations = 4;
  o.max_power_iterations = 3;  // cap below the minimum: the minimum wins
  auto four = truncated_svd(k.a, 10, o);
  ASSERT_TRUE(four.ok());
  EXPECT_EQ(four->report.power_iterations, 4);
  EXPECT_LT(error_of(k.a, *four), error_of(k.a, *one));
  SvdOptions e;
  e.method = SvdMethod::exact;
  auto ex = truncated_svd(k.a, 10, e);
  ASSERT_TRUE(ex.ok());
  EXPECT_TRUE(ex->report.exact);
  EXPECT_NEAR(ex->report.error_estimate, optimum(k, 10), 1e-4 * optimum(k, 10));
}

TEST(FactorSvd, FactorsAreOrthonormal) {
  const Known k = known_matrix(200, 260, 0.9, 1000, 5);
  auto f = truncated_svd(k.a, 12, randomized(8, 2));
  ASSERT_TRUE(f.ok());
  EXPECT_LT((f->u.transpose() * f->u - Eigen::MatrixXf::Identity(12, 12)).cwiseAbs().maxCoeff(), 1e-4f);
  EXPECT_LT((f->v.transpose() * f->v - Eigen::MatrixXf::Identity(12, 12)).cwiseAbs().maxCoeff(), 1e-4f);
}

TEST(FactorSvd, MorePowerIterationsHelpOnFlatSpectrum) {
  const Known k = known_matrix(200, 300, 0.985, 1000, 7);
  SvdOptions o = randomized(8, 0);
  o.oversampling = 4;
  const double e0 = error_of(k.a, *truncated_svd(k.a, 10, o));
  o.power_iterations = 1;
  const double e1 = error_of(k.a, *truncated_svd(k.a, 10, o));
  o.power_iterations = 3;
  const double e3 = error_of(k.a, *truncated_svd(k.a, 10, o));
  const double opt = optimum(k, 10);
  EXPECT_LT(e1, e0);
  EXPECT_LT(e3, e1);
  EXPECT_LT(e3, 1.02 * opt);  // with p = 4 only (p = 50 by default)
  EXPECT_GT(e0, 1.005 * opt) << "test is too easy to show the power iterations";
}

TEST(FactorSvd, RankDeficientMatrixIsRecoveredWithOrthonormalPadding) {
  // rank 4 < requested 10 < sketch width: the fused last pass drops the null directions of Z
  // instead of dividing by them, and pads with orthonormal columns of singular value 0.
  const Known k = known_matrix(150, 220, 0.5, 4, 3);
  for (int q : {0, 1, 2}) {
    auto f = truncated_svd(k.a, 10, randomized(8, q));
    ASSERT_TRUE(f.ok());
    ASSERT_EQ(f->s.size(), 10);
    EXPECT_TRUE(f->u.allFinite() && f->v.allFinite() && f->s.allFinite());
    EXPECT_LT(error_of(k.a, *f), 1e-5 * k.a.cast<double>().norm()) << "q " << q;
    for (int i = 4; i < 10; ++i) EXPECT_LT(f->s[i], 1e-5f * f->s[0]) << i;
    EXPECT_LT((f->u.transpose() * f->u - Eigen::MatrixXf::Identity(10, 10)).cwiseAbs().maxCoeff(), 1e-4f) << q;
    EXPECT_LT((f->v.transpose() * f->v - Eigen::MatrixXf::Identity(10, 10)).cwiseAbs().maxCoeff(), 1e-4f) << q;
  }
}

TEST(FactorSvd, ZeroMatrixGivesZeroSingularValues) {
  const Eigen::MatrixXf a = Eigen::MatrixXf::Zero(90, 120);
  for (int q : {0, 2}) {
    auto f = truncated_svd(a, 6, randomized(8, q));
    ASSERT_TRUE(f.ok());
    EXPECT_EQ(f->s.size(), 6);
    EXPECT_TRUE(f->u.allFinite() && f->v.allFinite());
    EXPECT_EQ(f->s.cwiseAbs().maxCoeff(), 0.0f);
  }
}

TEST(FactorSvd, DeterministicAcrossThreadCountsAndSeedDependent) {
  const Known k = flat_tail_matrix(160, 400, 8, 13);  // adaptive rule runs > 2 iterations
  SvdOptions o = adaptive();
  ThreadPool one(1), three(3);
  o.pool = &one;
  const auto a = truncated_svd(k.a, 8, o);
  o.pool = &three;
  const auto b = truncated_svd(k.a, 8, o);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_TRUE(a->u == b->u && a->s == b->s && a->v == b->v) << "bit-identical for any thread count";
  EXPECT_GT(a->report.power_iterations, 2);
  EXPECT_EQ(a->report.power_iterations, b->report.power_iterations);
  EXPECT_EQ(a->report.error_estimate, b->report.error_estimate);
  o.seed ^= 0x5555;
  const auto c = truncated_svd(k.a, 8, o);
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(a->u == c->u) << "the seed drives the sketch";
  EXPECT_LE(error_of(k.a, *c), 1.005 * optimum(k, 8));
}

TEST(FactorSvd, MatchesExactPath) {
  const Known k = known_matrix(120, 180, 0.8, 1000, 17);
  SvdOptions e;
  e.method = SvdMethod::exact;
  const auto ex = truncated_svd(k.a, 6, e);
  const auto rd = truncated_svd(k.a, 6, randomized(8, 2));
  ASSERT_TRUE(ex.ok() && rd.ok());
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(rd->s[i], ex->s[i], 1e-4f * ex->s[0]) << i;
  // Same subspace: |u_iᵀ u'_i| ≈ 1 (signs may differ).
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(std::abs(rd->u.col(i).dot(ex->u.col(i))), 1.0f, 1e-3f) << i;
}

TEST(FactorSvd, CancelledByProgressAndRejectsBadShapes) {
  const Known k = known_matrix(60, 80, 0.9, 1000, 19);
  auto f = truncated_svd(k.a, 4, randomized(8, 2), [](std::string_view, double) { return false; });
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.status(), Status::cancelled);
  EXPECT_FALSE(truncated_svd(k.a, 0).ok());
  EXPECT_FALSE(truncated_svd(Eigen::MatrixXf(0, 5), 2).ok());
}

}  // namespace
}  // namespace btflod
