// Tests for core/simd.hpp (CPU feature dispatch, resolved once in the implementation TU) and the
// fixed layout of the codec's opaque back-end handles: the feature queries agree with the
// compiler's own CPU detection, BTFLOD_DISABLE_SIMD turns them off, the dispatching entry points
// give the scalar twins' results, and no build option changes the size of the inflate handle.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "btflod/core/dct.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/simd.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"

#if BTFLOD_HAS_X86_DISPATCH
#include <cpuid.h>
#endif

namespace {

TEST(Simd, FeatureQueriesMatchTheCompilersCpuDetection) {
  if (btflod::simd_disabled_by_environment()) {
    EXPECT_FALSE(btflod::cpu_has_f16c());
    EXPECT_FALSE(btflod::cpu_has_avx2_fma());
    GTEST_SKIP() << "BTFLOD_DISABLE_SIMD is set: both queries are false, as asserted";
  }
#if BTFLOD_HAS_X86_DISPATCH
  __builtin_cpu_init();
  EXPECT_EQ(btflod::cpu_has_avx2_fma(), __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"));
#if defined(__clang__)  // clang 14 rejects "f16c" in __builtin_cpu_supports: CPUID leaf 1, ECX bit 29
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  const bool f16c = __get_cpuid(1, &eax, &ebx, &ecx, &edx) && (ecx & bit_F16C) != 0;
#else
  const bool f16c = __builtin_cpu_supports("f16c");
#endif
  EXPECT_EQ(btflod::cpu_has_f16c(), __builtin_cpu_supports("avx") && f16c);
#else
  EXPECT_FALSE(btflod::cpu_has_f16c());
  EXPECT_FALSE(btflod::cpu_has_avx2_fma());
#endif
}

TEST(Simd, QueriesAreStable) {
  // Resolved once: repeated calls give the same answer even if the environment changes later.
  const bool f16c = btflod::cpu_has_f16c(), avx2 = btflod::cpu_has_avx2_fma();
  setenv("BTFLOD_DISABLE_SIMD", btflod::simd_disabled_by_environment() ? "0" : "1", 1);
  EXPECT_EQ(btflod::cpu_has_f16c(), f16c);
  EXPECT_EQ(btflod::cpu_has_avx2_fma(), avx2);
}

TEST(Simd, DispatchedHalfConversionEqualsScalarTwin) {
  std::vector<uint16_t> patterns(65536);
  for (uint32_t i = 0; i < 65536; ++i) patterns[i] = static_cast<uint16_t>(i);
  std::vector<float> dispatched(patterns.size()), scalar(patterns.size());
  btflod::half_to_float(patterns, dispatched);
  btflod::half_to_float_scalar(patterns, scalar);
  ASSERT_EQ(0, std::memcmp(dispatched.data(), scalar.data(), scalar.size() * sizeof(float)));
  std::vector<uint16_t> back_dispatched(scalar.size()), back_scalar(scalar.size());
  btflod::float_to_half(scalar, back_dispatched);
  btflod::float_to_half_scalar(scalar, back_scalar);
  EXPECT_EQ(back_dispatched, back_scalar);
}

TEST(Simd, DispatchedDctMatchesScalarTwinWithinRounding) {
  float block[64], a[64], b[64];
  for (int i = 0; i < 64; ++i) block[i] = static_cast<float>((i * 37) % 17) - 8.0f;
  btflod::dct_forward<8, float>(block, 8, a);
  btflod::dct_forward_scalar<8, float>(block, 8, b);
  for (int i = 0; i < 64; ++i) EXPECT_NEAR(a[i], b[i], 1e-4f) << i;
  btflod::dct_inverse<8, float>(a, b, 8);
  for (int i = 0; i < 64; ++i) EXPECT_NEAR(b[i], block[i], 1e-4f) << i;
}

// The inflate and deflate back ends sit behind one pointer: the same layout with or without
// libdeflate compiled in (BTFLOD_TILE_CODEC_LIBDEFLATE is read by the implementation TU only).
static_assert(sizeof(btflod::RawInflater) == sizeof(void*));
static_assert(sizeof(btflod::RawDeflater) == sizeof(void*));

TEST(Simd, InflateBackendIsARunTimeChoice) {
  btflod::RawInflater zlib_only;
  ASSERT_TRUE(zlib_only.create(btflod::InflateBackend::zlib));
  EXPECT_EQ(zlib_only.backend(), btflod::InflateBackend::zlib);
  btflod::RawInflater preferred;
  ASSERT_TRUE(preferred.create(btflod::InflateBackend::libdeflate));
  EXPECT_EQ(preferred.backend(), btflod::inflate_backend_available(btflod::InflateBackend::libdeflate)
                                     ? btflod::InflateBackend::libdeflate
                                     : btflod::InflateBackend::zlib);
  // Both inflate a raw deflate stream written by RawDeflater identically.
  std::vector<uint8_t> data(5000);
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>((i * i) % 251);
  btflod::RawDeflater deflater;
  ASSERT_TRUE(deflater.create(6));
  std::vector<uint8_t> packed(8000);
  size_t written = 0;
  ASSERT_EQ(deflater.deflate(data, packed, written), btflod::Status::success);
  packed.resize(written);
  for (btflod::RawInflater* inflater : {&zlib_only, &preferred}) {
    std::vector<uint8_t> out(data.size());
    ASSERT_EQ(inflater->inflate(packed, out, nullptr), btflod::Status::success);
    EXPECT_EQ(out, data);
    // Truncated stream and a declared size one byte short are classified the same either way.
    const char* why = nullptr;
    EXPECT_EQ(inflater->inflate(std::span<const uint8_t>(packed).first(packed.size() / 2), out, &why),
              btflod::Status::short_output);
    std::vector<uint8_t> short_out(data.size() - 1);
    EXPECT_EQ(inflater->inflate(packed, short_out, &why), btflod::Status::bad_data);
    EXPECT_STREQ(why, "deflate stream inflates beyond the declared size");
  }
  btflod::RawInflater not_created;
  std::vector<uint8_t> out(4);
  EXPECT_EQ(not_created.inflate(packed, out, nullptr), btflod::Status::invalid_argument);
}

}  // namespace
