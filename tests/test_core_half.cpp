// Tests for core/half.hpp: exhaustive over all 65536 half patterns and a large set of floats,
// scalar twin against the F16C path and against independent reference arithmetic.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "btflod/core/half.hpp"

namespace {

using btflod::float_to_half_bits;
using btflod::half_bits_to_float;

// Independent reference: value of a half pattern computed with ldexp, no bit tricks.
double reference_half_value(uint16_t h) {
  const int sign = (h >> 15) ? -1 : 1;
  const int e = (h >> 10) & 0x1f;
  const int m = h & 0x3ff;
  if (e == 0) return sign * std::ldexp(static_cast<double>(m), -24);
  if (e == 31) return m ? std::nan("") : sign * INFINITY;
  return sign * std::ldexp(1024.0 + m, e - 25);
}

// Independent reference for float → half: pick the nearest finite half by exhaustive search
// over the ordered positive patterns, ties to the even pattern, overflow by IEEE rules.
uint16_t reference_float_to_half(float f) {
  if (std::isnan(f)) return 0x7e00;  // only NaN-ness is compared for NaN
  const uint16_t sign = std::signbit(f) ? 0x8000 : 0;
  const double a = std::fabs(static_cast<double>(f));
  if (a >= 65520.0) return sign | 0x7c00;
  // binary search over 0..0x7bff (monotonic in value)
  uint16_t lo = 0, hi = 0x7bff;
  while (hi - lo > 1) {
    const uint16_t mid = static_cast<uint16_t>((lo + hi) / 2);
    if (reference_half_value(mid) <= a)
      lo = mid;
    else
      hi = mid;
  }
  if (reference_half_value(hi) <= a) lo = hi;
  const uint16_t up = static_cast<uint16_t>(lo == 0x7bff ? 0x7c00 : lo + 1);
  const double dl = a - reference_half_value(lo);
  const double du = (up == 0x7c00 ? 65536.0 : reference_half_value(up)) - a;
  uint16_t pick = lo;
  if (du < dl || (du == dl && (lo & 1))) pick = up;
  return sign | pick;
}

TEST(Half, AllPatternsConvertExactlyToFloat) {
  for (uint32_t h = 0; h < 65536; ++h) {
    const float f = half_bits_to_float(static_cast<uint16_t>(h));
    const double ref = reference_half_value(static_cast<uint16_t>(h));
    if (std::isnan(ref)) {
      ASSERT_TRUE(std::isnan(f)) << h;
      continue;
    }
    ASSERT_EQ(static_cast<double>(f), ref) << "pattern " << h;
    ASSERT_EQ(std::signbit(f), (h & 0x8000) != 0) << "sign of pattern " << h;
  }
}

TEST(Half, AllPatternsRoundTripThroughFloat) {
  for (uint32_t h = 0; h < 65536; ++h) {
    const uint16_t back = float_to_half_bits(half_bits_to_float(static_cast<uint16_t>(h)));
    const bool is_nan = ((h >> 10) & 0x1f) == 31 && (h & 0x3ff);
    if (is_nan) {
      // NaN stays NaN with the same sign and payload, quieted.
      ASSERT_EQ(back, static_cast<uint16_t>(h | 0x200)) << h;
    } else {
      ASSERT_EQ(back, h) << h;
    }
  }
}

TEST(Half, TiesRoundToEven) {
  // Midpoints between consecutive halves in every binade, including subnormals.
  for (uint32_t h = 0; h < 0x7bff; ++h) {
    const double mid =
        0.5 * (reference_half_value(static_cast<uint16_t>(h)) + reference_half_value(static_cast<uint16_t>(h + 1)));
    const float f = static_cast<float>(mid);
    ASSERT_EQ(static_cast<double>(f), mid);  // every such midpoint is representable in float
    const uint16_t expected = static_cast<uint16_t>((h & 1) ? h + 1 : h);
    ASSERT_EQ(float_to_half_bits(f), expected) << "tie above pattern " << h;
    ASSERT_EQ(float_to_half_bits(-f), expected | 0x8000) << "negative tie above pattern " << h;
    // one float ulp either side decides the direction
    ASSERT_EQ(float_to_half_bits(std::nextafter(f, 0.0f)), h);
    ASSERT_EQ(float_to_half_bits(std::nextafter(f, INFINITY)), h + 1);
  }
}

TEST(Half, SpecialValues) {
  EXPECT_EQ(float_to_half_bits(0.0f), 0x0000);
  EXPECT_EQ(float_to_half_bits(-0.0f), 0x8000);
  EXPECT_EQ(float_to_half_bits(INFINITY), 0x7c00);
  EXPECT_EQ(float_to_half_bits(-INFINITY), 0xfc00);
  EXPECT_EQ(float_to_half_bits(65504.0f), 0x7bff);
  EXPECT_EQ(float_to_half_bits(65519.99f), 0x7bff);
  EXPECT_EQ(float_to_half_bits(65520.0f), 0x7c00);  // tie with odd max rounds to Inf
  EXPECT_EQ(float_to_half_bits(1e30f), 0x7c00);
  EXPECT_EQ(float_to_half_bits(std::ldexp(1.0f, -24)), 0x0001);  // smallest subnormal
  EXPECT_EQ(float_to_half_bits(std::ldexp(1.0f, -25)), 0x0000);  // tie to even zero
  EXPECT_EQ(float_to_half_bits(std::ldexp(1.5f, -25)), 0x0001);
  EXPECT_EQ(float_to_half_bits(std::ldexp(1.0f, -14)), 0x0400);  // smallest normal
  EXPECT_EQ(float_to_half_bits(1e-30f), 0x0000);
  EXPECT_EQ(float_to_half_bits(std::numeric_limits<float>::denorm_min()), 0x0000);
  EXPECT_TRUE(std::isnan(half_bits_to_float(float_to_half_bits(std::nanf("")))));
  EXPECT_EQ(half_bits_to_float(0x3c00), 1.0f);
  EXPECT_EQ(half_bits_to_float(0xc000), -2.0f);
}

std::vector<float> interesting_floats() {
  std::vector<float> v;
  std::mt19937 rng(12345);
  std::uniform_int_distribution<uint32_t> bits;
  for (int i = 0; i < 400000; ++i) {
    const uint32_t b = bits(rng);
    float f;
    std::memcpy(&f, &b, 4);
    v.push_back(f);
  }
  // dense coverage of the half range, including exact ties and their neighbours
  for (uint32_t h = 0; h < 0x7c00; h += 7) {
    const float a = half_bits_to_float(static_cast<uint16_t>(h));
    const float b = half_bits_to_float(static_cast<uint16_t>(h + 1));
    const float mid = 0.5f * (a + b);
    for (float f : {a, mid, std::nextafter(mid, 0.0f), std::nextafter(mid, INFINITY)}) {
      v.push_back(f);
      v.push_back(-f);
    }
  }
  return v;
}

TEST(Half, ScalarMatchesIndependentReferenceOnManyFloats) {
  for (float f : interesting_floats()) {
    if (std::isnan(f)) {
      const uint16_t h = float_to_half_bits(f);
      ASSERT_EQ(h & 0x7c00, 0x7c00);
      ASSERT_NE(h & 0x3ff, 0);
      continue;
    }
    ASSERT_EQ(float_to_half_bits(f), reference_float_to_half(f)) << f;
  }
}

#if BTFLOD_HAS_X86_DISPATCH
TEST(Half, F16cMatchesScalarTwinOnAllPatternsAndManyFloats) {
  if (!btflod::cpu_has_f16c())
    GTEST_SKIP() << "CPU has no F16C (or BTFLOD_DISABLE_SIMD is set); only the scalar twin runs here";
  std::vector<uint16_t> patterns(65536);
  for (uint32_t i = 0; i < 65536; ++i) patterns[i] = static_cast<uint16_t>(i);
  std::vector<float> simd(65536), scalar(65536);
  btflod::half_to_float_f16c(patterns, simd);
  btflod::half_to_float_scalar(patterns, scalar);
  for (size_t i = 0; i < patterns.size(); ++i) {
    uint32_t a, b;
    std::memcpy(&a, &simd[i], 4);
    std::memcpy(&b, &scalar[i], 4);
    ASSERT_EQ(a, b) << "half pattern " << i;
  }
  const std::vector<float> floats = interesting_floats();
  std::vector<uint16_t> hs(floats.size()), hv(floats.size());
  btflod::float_to_half_scalar(floats, hs);
  btflod::float_to_half_f16c(floats, hv);
  for (size_t i = 0; i < floats.size(); ++i) ASSERT_EQ(hs[i], hv[i]) << "float " << floats[i];
}
#endif

TEST(Half, DispatchedBulkConversionHandlesTails) {
  for (size_t n : {0u, 1u, 7u, 8u, 9u, 31u}) {
    std::vector<float> in(n);
    for (size_t i = 0; i < n; ++i) in[i] = 0.1f * static_cast<float>(i) - 1.0f;
    std::vector<uint16_t> h(n + 1, 0xabcd);
    btflod::float_to_half(in, std::span<uint16_t>(h.data(), n));
    EXPECT_EQ(h[n], 0xabcd) << "wrote past the end";
    std::vector<float> back(n);
    btflod::half_to_float(std::span<const uint16_t>(h.data(), n), back);
    for (size_t i = 0; i < n; ++i) EXPECT_EQ(back[i], half_bits_to_float(float_to_half_bits(in[i])));
  }
}

}  // namespace
