// Tests for core/dct.hpp and runtime/codec/quantize.hpp: the separable DCT (scalar twin and AVX2 path)
// against a direct O(N⁴) evaluation of the DCT-II definition, inverse, Parseval, zig-zag order and
// the quantiser's error guarantee.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <vector>

#include "btflod/core/dct.hpp"
#include "btflod/runtime/codec/quantize.hpp"

namespace {

// The orthonormal DCT basis in long double: s(v) s(u) cos(π(2r+1)v/2N) cos(π(2c+1)u/2N), the
// weight of coefficient (v, u) at sample (r, c), with s(0) = √(1/N) and s(k > 0) = √(2/N).
long double dct_basis(int n, int r, int c, int v, int u) {
  const long double pi = std::numbers::pi_v<long double>;
  const long double sv = v == 0 ? std::sqrt(1.0L / n) : std::sqrt(2.0L / n);
  const long double su = u == 0 ? std::sqrt(1.0L / n) : std::sqrt(2.0L / n);
  return sv * su * std::cos(pi * (2 * r + 1) * v / (2.0L * n)) * std::cos(pi * (2 * c + 1) * u / (2.0L * n));
}

// The direct O(N⁴) sums: out[i][j] = Σ_k Σ_l in[k][l] · basis, with (i, j) the coefficient and
// (k, l) the sample for the forward DCT-II, and the roles swapped for the inverse (DCT-III).
std::vector<long double> reference_transform(const std::vector<double>& in, int n, bool inverse) {
  std::vector<long double> out(static_cast<size_t>(n) * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      long double acc = 0;
      for (int k = 0; k < n; ++k)
        for (int l = 0; l < n; ++l)
          acc += in[k * n + l] * (inverse ? dct_basis(n, i, j, k, l) : dct_basis(n, k, l, i, j));
      out[i * n + j] = acc;
    }
  return out;
}

// Direct definition: Y[v][u] = s(v) s(u) Σ_y Σ_x X[y][x] cos(π(2y+1)v/2N) cos(π(2x+1)u/2N).
std::vector<long double> reference_forward(const std::vector<double>& x, int n) {
  return reference_transform(x, n, false);
}

// Direct DCT-III (inverse) definition.
std::vector<long double> reference_inverse(const std::vector<double>& y, int n) {
  return reference_transform(y, n, true);
}

std::vector<double> random_block(int n, std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> d(-scale, scale);
  std::vector<double> b(static_cast<size_t>(n) * n);
  for (auto& v : b) v = d(rng);
  return b;
}

template <int N, class S>
void check_scalar_against_reference(double tol) {
  std::mt19937 rng(N * 31 + sizeof(S));
  for (int trial = 0; trial < 20; ++trial) {
    const auto x = random_block(N, rng, 100.0);
    // Embed in a wider row stride to check stride handling.
    const size_t stride = N + 3;
    std::vector<S> in(N * stride, S(-999)), out(N * N), back(N * stride, S(-999));
    for (int r = 0; r < N; ++r)
      for (int c = 0; c < N; ++c) in[r * stride + c] = static_cast<S>(x[r * N + c]);
    btflod::dct_forward_scalar<N, S>(in.data(), stride, out.data());
    const auto ref = reference_forward(x, N);
    for (int i = 0; i < N * N; ++i)
      ASSERT_NEAR(static_cast<double>(out[i]), static_cast<double>(ref[i]), tol) << "coef " << i;
    // Inverse against the direct DCT-III of the same coefficients.
    std::vector<double> coef(out.begin(), out.end());
    const auto ref_inv = reference_inverse(coef, N);
    btflod::dct_inverse_scalar<N, S>(out.data(), back.data(), stride);
    for (int r = 0; r < N; ++r) {
      for (int c = 0; c < N; ++c) {
        ASSERT_NEAR(static_cast<double>(back[r * stride + c]), static_cast<double>(ref_inv[r * N + c]), tol);
        ASSERT_NEAR(static_cast<double>(back[r * stride + c]), x[r * N + c], tol);
      }
      for (size_t c = N; c < stride; ++c) ASSERT_EQ(back[r * stride + c], S(-999)) << "wrote outside the block";
    }
  }
}

TEST(CodecDct, ScalarMatchesDirectDefinitionForSeveralSizesAndTypes) {
  check_scalar_against_reference<8, float>(2e-3);
  check_scalar_against_reference<8, double>(1e-9);
  check_scalar_against_reference<4, double>(1e-9);
  check_scalar_against_reference<16, float>(4e-3);
}

TEST(CodecDct, BasisRowsAreOrthonormal) {
  const auto& c = btflod::dct_basis<8, double>();
  for (int a = 0; a < 8; ++a)
    for (int b = 0; b < 8; ++b) {
      double dot = 0;
      for (int n = 0; n < 8; ++n) dot += c[a * 8 + n] * c[b * 8 + n];
      EXPECT_NEAR(dot, a == b ? 1.0 : 0.0, 1e-12);
    }
}

TEST(CodecDct, ParsevalHolds) {
  std::mt19937 rng(5);
  const auto x = random_block(8, rng, 3.0);
  std::vector<float> in(x.begin(), x.end()), out(64);
  btflod::dct_forward<8, float>(in.data(), 8, out.data());
  double ex = 0, ey = 0;
  for (int i = 0; i < 64; ++i) {
    ex += x[i] * x[i];
    ey += static_cast<double>(out[i]) * out[i];
  }
  EXPECT_NEAR(ex, ey, 1e-4 * ex);
}

TEST(CodecDct, SimdPathMatchesScalarTwinAndReference) {
#if BTFLOD_HAS_X86_DISPATCH
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) GTEST_SKIP() << "CPU has no AVX2/FMA";
  std::mt19937 rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const auto x = random_block(8, rng, trial % 2 ? 1e3 : 1e-2);
    const size_t stride = 13;
    std::vector<float> in(8 * stride), a(64), b(64), ia(8 * stride, -7.f), ib(8 * stride, -7.f);
    for (int r = 0; r < 8; ++r)
      for (int c = 0; c < 8; ++c) in[r * stride + c] = static_cast<float>(x[r * 8 + c]);
    btflod::dct_forward_scalar<8, float>(in.data(), stride, a.data());
    btflod::dct8_forward_avx2(in.data(), stride, b.data());
    const auto ref = reference_forward(x, 8);
    double scale = 0;
    for (double v : x) scale = std::max(scale, std::fabs(v));
    for (int i = 0; i < 64; ++i) {
      ASSERT_NEAR(a[i], b[i], 1e-5 * scale * 8);
      ASSERT_NEAR(b[i], static_cast<double>(ref[i]), 1e-5 * scale * 8);
    }
    btflod::dct_inverse_scalar<8, float>(a.data(), ia.data(), stride);
    btflod::dct8_inverse_avx2(a.data(), ib.data(), stride);
    for (int r = 0; r < 8; ++r) {
      for (int c = 0; c < 8; ++c) {
        ASSERT_NEAR(ia[r * stride + c], ib[r * stride + c], 1e-5 * scale * 8);
        ASSERT_NEAR(ib[r * stride + c], x[r * 8 + c], 1e-5 * scale * 8);
      }
      for (size_t c = 8; c < stride; ++c) ASSERT_EQ(ib[r * stride + c], -7.f);
    }
  }
#else
  GTEST_SKIP() << "no x86 dispatch in this build";
#endif
}

TEST(CodecQuantize, ZigZagIsAPermutationInJpegOrder) {
  const auto& z = btflod::zigzag_order<8>();
  std::set<int> seen(z.begin(), z.end());
  EXPECT_EQ(seen.size(), 64u);
  // First entries of the JPEG zig-zag (ITU T.81 Figure 5), row-major indices.
  const int expected[] = {0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5};
  for (int i = 0; i < 16; ++i) EXPECT_EQ(z[i], expected[i]) << i;
  EXPECT_EQ(z[63], 63);
  const auto& z4 = btflod::zigzag_order<4>();
  EXPECT_EQ(std::set<int>(z4.begin(), z4.end()).size(), 16u);
}

TEST(CodecQuantize, StepFactorsFollowJpegTableWithUnitRms) {
  const auto& f = btflod::quant_step_factors<8>();
  double sum_sq = 0;
  for (float v : f) sum_sq += static_cast<double>(v) * v / 4.0;
  EXPECT_NEAR(sum_sq / 64.0, 1.0, 1e-5);  // rms(f/2) = 1 is what bounds the block error by t
  EXPECT_NEAR(f[63] / f[0], 99.0 / 16.0, 1e-5);
  EXPECT_NEAR(f[1] / f[0], 11.0 / 16.0, 1e-5);
}

TEST(CodecQuantize, QualityScaleIsMonotoneAndJpegLike) {
  EXPECT_FLOAT_EQ(btflod::quality_scale(50), 1.0f);
  EXPECT_FLOAT_EQ(btflod::quality_scale(25), 2.0f);
  EXPECT_FLOAT_EQ(btflod::quality_scale(75), 0.5f);
  for (int q = 2; q <= 100; ++q) EXPECT_LE(btflod::quality_scale(q), btflod::quality_scale(q - 1));
  EXPECT_GT(btflod::tolerance_for_quality(100, 0.0f), 0.0f);  // degenerate range still positive
  EXPECT_GT(btflod::tolerance_for_quality(90, std::nanf("")), 0.0f);
}

// Quantising DCT coefficients with the tolerance's steps keeps every block's RMS error ≤ t,
// for worst-case (uniform noise) blocks at many tolerances.
TEST(CodecQuantize, BlockRmsErrorWithinTolerance) {
  std::mt19937 rng(3);
  const auto& f = btflod::quant_step_factors<8>();
  for (float t : {1e-4f, 1e-2f, 0.3f, 5.0f}) {
    double worst = 0;
    for (int trial = 0; trial < 300; ++trial) {
      const auto x = random_block(8, rng, 10.0 * t);
      std::vector<float> in(x.begin(), x.end()), c(64), back(64);
      btflod::dct_forward<8, float>(in.data(), 8, c.data());
      for (int k = 0; k < 64; ++k) c[k] = std::nearbyint(c[k] / (t * f[k])) * (t * f[k]);
      btflod::dct_inverse<8, float>(c.data(), back.data(), 8);
      double e = 0;
      for (int i = 0; i < 64; ++i) e += (back[i] - in[i]) * (back[i] - in[i]);
      worst = std::max(worst, std::sqrt(e / 64));
    }
    EXPECT_LE(worst, t * 1.0001) << "t=" << t;
    EXPECT_GT(worst, t * 0.2) << "quantiser is much finer than it needs to be at t=" << t;
  }
}

}  // namespace
