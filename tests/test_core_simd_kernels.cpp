// Tests for the SIMD kernels of core/simd.hpp: every ISA build the machine can run returns the
// scalar twin's bits on every kernel (half <-> float, 8x8 DCT, the tile decoder's inverse DCT and
// parent up-sampling, feedback run detection), the up-sampling kernel those of the plain loops, the dispatch can be
// forced to each build (simd_force_isa, the BTFLOD_FORCE_ISA names), and whole tile decodes and vote counts are
// bit-identical under every forced build. A build the CPU lacks is reported as skipped, never as passed.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "btflod/core/dct.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/simd.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/lod/feedback.hpp"

namespace {

using btflod::SimdIsa;
using btflod::SimdKernels;

// The SIMD builds available here (scalar excluded), each with its table.
std::vector<const SimdKernels*> simd_builds() {
  std::vector<const SimdKernels*> out;
  for (int i = 1; i < btflod::kSimdIsaCount; ++i)
    if (const SimdKernels* k = btflod::simd_kernels_for(static_cast<SimdIsa>(i))) out.push_back(k);
  return out;
}

const SimdKernels& scalar_twin() { return *btflod::simd_kernels_for(SimdIsa::scalar); }

// Bit equality, except that any two NaN are equal (the payload of a NaN made from two NaN
// operands is unspecified by IEEE 754; see core/simd.hpp).
bool same_bits(float a, float b) {
  if (std::isnan(a) && std::isnan(b)) return true;
  return std::bit_cast<uint32_t>(a) == std::bit_cast<uint32_t>(b);
}

// Restores the dispatch chosen at start-up when a test that forces a build ends.
class ForcedIsa {
 public:
  ForcedIsa() : saved_(btflod::simd_active_isa()) {}
  ~ForcedIsa() { btflod::simd_force_isa(saved_); }

 private:
  SimdIsa saved_;
};

TEST(SimdKernels, EveryAvailableBuildHasACompleteTable) {
  const SimdKernels* s = btflod::simd_kernels_for(SimdIsa::scalar);
  ASSERT_NE(s, nullptr) << "the scalar twin is always available";
  EXPECT_EQ(s->isa, SimdIsa::scalar);
  for (int i = 0; i < btflod::kSimdIsaCount; ++i) {
    const auto isa = static_cast<SimdIsa>(i);
    const SimdKernels* k = btflod::simd_kernels_for(isa);
    EXPECT_EQ(k != nullptr, btflod::simd_isa_available(isa)) << btflod::simd_isa_name(isa);
    if (k == nullptr) continue;
    EXPECT_EQ(k->isa, isa);
    EXPECT_TRUE(k->half_to_float && k->float_to_half && k->dct8_forward && k->dct8_inverse && k->tile_idct_add &&
                k->tile_idct_add4 && k->run_marks && k->upsample_parent);
  }
#if BTFLOD_HAS_X86_DISPATCH
  __builtin_cpu_init();
  EXPECT_EQ(btflod::simd_isa_available(SimdIsa::avx2), __builtin_cpu_supports("avx2") != 0);
  EXPECT_EQ(btflod::simd_isa_available(SimdIsa::avx512),
            __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"));
#else
  EXPECT_FALSE(btflod::simd_isa_available(SimdIsa::avx2));
  EXPECT_FALSE(btflod::simd_isa_available(SimdIsa::avx512));
#endif
  if (simd_builds().empty()) GTEST_SKIP() << "no SIMD build runs on this CPU: only the scalar twin was checked";
}

TEST(SimdKernels, IsaNamesRoundTripAndForcingSelectsTheBuild) {
  ForcedIsa restore;
  for (int i = 0; i < btflod::kSimdIsaCount; ++i) {
    const auto isa = static_cast<SimdIsa>(i);
    SimdIsa parsed = SimdIsa::scalar;
    ASSERT_TRUE(btflod::simd_isa_from_name(btflod::simd_isa_name(isa), parsed));
    EXPECT_EQ(parsed, isa);
    EXPECT_EQ(btflod::simd_force_isa(isa), btflod::simd_isa_available(isa));
    if (btflod::simd_isa_available(isa)) {
      EXPECT_EQ(btflod::simd_active_isa(), isa);
      EXPECT_EQ(&btflod::simd_kernels(), btflod::simd_kernels_for(isa));
    }
  }
  SimdIsa unchanged = SimdIsa::avx2;
  EXPECT_FALSE(btflod::simd_isa_from_name("sse9", unchanged));
  EXPECT_FALSE(btflod::simd_isa_from_name(nullptr, unchanged));
  EXPECT_FALSE(btflod::simd_isa_from_name("AVX2", unchanged)) << "names are case-sensitive";
  EXPECT_EQ(unchanged, SimdIsa::avx2);
}

TEST(SimdKernels, StartupChoiceFollowsTheEnvironment) {
  // The first query read BTFLOD_FORCE_ISA / BTFLOD_DISABLE_SIMD (ctest runs this file once per
  // forced build, see tests/CMakeLists.txt or run it by hand with the variable set).
  const char* forced = std::getenv("BTFLOD_FORCE_ISA");
  SimdIsa wanted = SimdIsa::avx512;
  if (forced != nullptr && *forced != '\0') {
    ASSERT_TRUE(btflod::simd_isa_from_name(forced, wanted)) << forced;
  }
  if (btflod::simd_disabled_by_environment()) wanted = SimdIsa::scalar;
  int expected = static_cast<int>(wanted);
  while (expected > 0 && !btflod::simd_isa_available(static_cast<SimdIsa>(expected))) --expected;
  EXPECT_EQ(btflod::simd_active_isa(), static_cast<SimdIsa>(expected));
}

TEST(SimdKernels, HalfToFloatIsBitIdenticalOnEveryPattern) {
  const auto builds = simd_builds();
  if (builds.empty()) GTEST_SKIP() << "no SIMD build on this CPU";
  std::vector<uint16_t> patterns(65536 + 13);  // odd length: the tails run too
  for (size_t i = 0; i < patterns.size(); ++i) patterns[i] = static_cast<uint16_t>(i * 40503u);
  std::vector<float> ref(patterns.size()), got(patterns.size());
  scalar_twin().half_to_float(patterns.data(), ref.data(), patterns.size());
  for (const SimdKernels* k : builds) {
    for (size_t offset : {size_t{0}, size_t{1}, size_t{7}}) {
      std::fill(got.begin(), got.end(), -1.0f);
      k->half_to_float(patterns.data() + offset, got.data(), patterns.size() - offset);
      ASSERT_EQ(0, std::memcmp(got.data(), ref.data() + offset, (patterns.size() - offset) * sizeof(float)))
          << btflod::simd_isa_name(k->isa) << " offset " << offset;
    }
  }
}

TEST(SimdKernels, FloatToHalfIsBitIdenticalOnEdgeCasesAndRandomBits) {
  const auto builds = simd_builds();
  if (builds.empty()) GTEST_SKIP() << "no SIMD build on this CPU";
  std::vector<float> in;
  // Every rounding boundary class: half ulps around the normal/subnormal/overflow thresholds,
  // signed zeros, infinities, quiet and signalling NaN with payloads.
  for (uint32_t bits : {0x00000000u, 0x80000000u, 0x7f800000u, 0xff800000u, 0x7fc00000u, 0x7f800001u, 0xffbfffffu,
                        0x477fe000u, 0x477fefffu, 0x477ff000u, 0x38800000u, 0x387fffffu, 0x33000000u, 0x33000001u,
                        0x32ffffffu, 0x337fffffu, 0x3f801000u, 0x3f803000u, 0x3f800fffu})
    for (uint32_t d = 0; d < 3; ++d) in.push_back(std::bit_cast<float>(bits + d));
  std::mt19937 rng(7);
  for (int i = 0; i < 200000; ++i) in.push_back(std::bit_cast<float>(static_cast<uint32_t>(rng())));
  for (int i = 0; i < 100000; ++i)
    in.push_back(std::ldexp(std::uniform_real_distribution<float>(-1, 1)(rng), i % 50 - 30));
  std::vector<uint16_t> ref(in.size()), got(in.size());
  scalar_twin().float_to_half(in.data(), ref.data(), in.size());
  for (const SimdKernels* k : builds) {
    std::fill(got.begin(), got.end(), uint16_t{0x1234});
    k->float_to_half(in.data(), got.data(), in.size());
    for (size_t i = 0; i < in.size(); ++i)
      ASSERT_EQ(got[i], ref[i]) << btflod::simd_isa_name(k->isa) << " input bits 0x" << std::hex
                                << std::bit_cast<uint32_t>(in[i]);
  }
  // The scalar twin is the reference converter itself.
  for (size_t i = 0; i < in.size(); ++i) ASSERT_EQ(ref[i], btflod::float_to_half_bits(in[i]));
}

TEST(SimdKernels, Dct8ForwardAndInverseAreBitIdentical) {
  const auto builds = simd_builds();
  if (builds.empty()) GTEST_SKIP() << "no SIMD build on this CPU";
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-300, 300);
  for (int trial = 0; trial < 2000; ++trial) {
    const size_t stride = 8 + static_cast<size_t>(trial % 5);
    std::vector<float> in(8 * stride);
    for (float& v : in) v = trial % 7 == 0 ? std::round(u(rng)) : u(rng);
    float ref_f[64], ref_i[8 * 12], got_f[64], got_i[8 * 12];
    scalar_twin().dct8_forward(in.data(), stride, ref_f);
    scalar_twin().dct8_inverse(ref_f, ref_i, stride);
    for (const SimdKernels* k : builds) {
      k->dct8_forward(in.data(), stride, got_f);
      k->dct8_inverse(ref_f, got_i, stride);
      ASSERT_EQ(0, std::memcmp(got_f, ref_f, sizeof got_f)) << btflod::simd_isa_name(k->isa) << " trial " << trial;
      for (int y = 0; y < 8; ++y)
        ASSERT_EQ(0, std::memcmp(got_i + y * stride, ref_i + y * stride, 8 * sizeof(float)))
            << btflod::simd_isa_name(k->isa) << " trial " << trial;
    }
    // The kernel is still an orthonormal DCT: the inverse gives the block back.
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) ASSERT_NEAR(ref_i[y * stride + x], in[y * stride + x], 2e-3f);
  }
}

// A random coefficient block with `rows` x `cols` possibly non-zero coefficients.
btflod::TileCoefBlock random_block(std::mt19937& rng, uint32_t rows, uint32_t cols) {
  btflod::TileCoefBlock b{};
  b.rows = rows;
  b.cols = cols;
  std::uniform_real_distribution<float> u(-1000, 1000);
  for (uint32_t v = 0; v < rows; ++v)
    for (uint32_t x = 0; x < cols; ++x) b.coef[v * 8 + x] = (rng() % 3 == 0) ? 0.0f : u(rng);
  return b;
}

TEST(SimdKernels, TileInverseDctAddsAreBitIdentical) {
  const auto builds = simd_builds();
  if (builds.empty()) GTEST_SKIP() << "no SIMD build on this CPU";
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-5, 5);
  const size_t row_stride = 72 * 4;
  std::vector<float> base(8 * row_stride), ref, got;
  for (int trial = 0; trial < 3000; ++trial) {
    for (float& v : base) v = (rng() % 17 == 0) ? -0.0f : u(rng);  // -0 + +0 must come out alike
    btflod::TileCoefBlock b[4];
    for (auto& blk : b) {
      const auto rows = static_cast<uint32_t>(rng() % 9);
      const auto cols = rows == 0 ? 0u : static_cast<uint32_t>(1 + rng() % 8);
      blk = random_block(rng, rows, cols);
    }
    if (trial % 10 == 0) b[0] = b[1] = b[2] = b[3] = btflod::TileCoefBlock{};  // all empty: nothing added
    ref = base;
    scalar_twin().tile_idct_add4(b, ref.data() + 8, row_stride);
    const size_t step = 1 + trial % 4;
    std::vector<float> ref1 = base, got1;
    scalar_twin().tile_idct_add(b[trial % 4], ref1.data() + 3, row_stride, step);
    for (const SimdKernels* k : builds) {
      got = base;
      k->tile_idct_add4(b, got.data() + 8, row_stride);
      for (size_t i = 0; i < got.size(); ++i)
        ASSERT_TRUE(same_bits(got[i], ref[i])) << btflod::simd_isa_name(k->isa) << " trial " << trial << " at " << i;
      got1 = base;
      k->tile_idct_add(b[trial % 4], got1.data() + 3, row_stride, step);
      for (size_t i = 0; i < got1.size(); ++i)
        ASSERT_TRUE(same_bits(got1[i], ref1[i])) << btflod::simd_isa_name(k->isa) << " trial " << trial << " at " << i;
    }
  }
}

TEST(SimdKernels, TileInverseDctIsTheInverseOfTheForwardDct) {
  // Guards the kernel itself (not only the twins' agreement): a full block's inverse gives the
  // forward transform's input back, interleaved into channel c of a 4-channel tile.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-10, 10);
  float block[64];
  for (float& v : block) v = u(rng);
  btflod::TileCoefBlock b[4]{};
  scalar_twin().dct8_forward(block, 8, b[2].coef);
  b[2].rows = b[2].cols = 8;
  for (int i = 0; i < btflod::kSimdIsaCount; ++i) {
    const SimdKernels* k = btflod::simd_kernels_for(static_cast<SimdIsa>(i));
    if (k == nullptr) continue;
    std::vector<float> dst(8 * 32, 1.0f);
    k->tile_idct_add4(b, dst.data(), 32);
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        EXPECT_NEAR(dst[y * 32 + 4 * x + 2], 1.0f + block[y * 8 + x], 1e-4f);
        EXPECT_EQ(dst[y * 32 + 4 * x + 0], 1.0f) << "empty channels add +0";
      }
  }
}

TEST(SimdKernels, RunMarksAreBitIdenticalAndMarkEveryChange) {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 4000; ++trial) {
    const size_t n = rng() % 300;
    std::vector<uint32_t> words(n + 1);
    uint32_t w = static_cast<uint32_t>(rng());
    for (auto& x : words) {
      if (rng() % 4 == 0) w = (trial % 3 == 0) ? static_cast<uint32_t>(rng() % 3) : static_cast<uint32_t>(rng());
      x = w;
    }
    std::vector<uint64_t> ref((n + 63) / 64 + 1, 0xdeadbeefu), got;
    scalar_twin().run_marks(words.data() + 1, n, ref.data());
    for (size_t k = 0; k < n; ++k)
      ASSERT_EQ((ref[k / 64] >> (k % 64)) & 1u, uint64_t{words[k + 1] != words[k]}) << "trial " << trial << " k " << k;
    if (n % 64 != 0) {
      ASSERT_EQ(ref[n / 64] >> (n % 64), 0u) << "bits past n are 0";
    }
    ASSERT_EQ(ref.back(), 0xdeadbeefu) << "no mark word past ceil(n / 64) is written";
    for (int i = 1; i < btflod::kSimdIsaCount; ++i) {
      const SimdKernels* k = btflod::simd_kernels_for(static_cast<SimdIsa>(i));
      if (k == nullptr) continue;
      got.assign(ref.size(), 0xdeadbeefu);
      k->run_marks(words.data() + 1, n, got.data());
      ASSERT_EQ(got, ref) << btflod::simd_isa_name(k->isa) << " trial " << trial;
    }
  }
}

// Every build of the up-sampling kernel, the scalar twin included, equals the plain loops of
// detail::upsample_parent_reference bit for bit: C = 1..4, every quadrant, borders 0 (taps
// clamped at the far edge, weights outside [0, 1] at both ends), odd and even, odd and tiny
// stored sizes, parents with signed zeros, subnormals and wide exponents.
TEST(SimdKernels, ParentUpsamplingIsBitIdenticalToThePlainLoops) {
  struct Geometry {
    uint32_t tile_size, border;
  };
  const Geometry geometries[] = {{64, 4}, {8, 1}, {16, 3}, {62, 5}, {10, 0},   {64, 0},   {9, 1},
                                 {7, 0},  {2, 0}, {1, 1},  {3, 2},  {1024, 0}, {1000, 12}};
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-4, 4);
  std::uniform_int_distribution<int> exponent(-140, 60);
  for (const Geometry& g : geometries) {
    const btflod::TileLayout layout{g.tile_size, g.border, 4};
    const uint32_t s = layout.stored_size();
    for (uint32_t channels = 1; channels <= 4; ++channels) {
      const size_t n = size_t{s} * s * channels;
      std::vector<float> parent(n), ref(n), got(n);
      for (float& v : parent) {
        const uint32_t kind = rng() % 16;
        v = kind == 0 ? -0.0f : kind == 1 ? std::ldexp(u(rng), exponent(rng)) : u(rng);
      }
      for (uint32_t q = 0; q < 4; ++q) {
        const float base_x = btflod::detail::upsample_parent_base(layout, q & 1);
        const float base_y = btflod::detail::upsample_parent_base(layout, q >> 1);
        const std::string where = "T " + std::to_string(g.tile_size) + " B " + std::to_string(g.border) + " C " +
                                  std::to_string(channels) + " q " + std::to_string(q);
        std::vector<const SimdKernels*> builds = simd_builds();
#if defined(__FMA__) || defined(__FP_FAST_FMAF)
        // This translation unit may contract the plain loops into FMA: compare with the scalar twin.
        scalar_twin().upsample_parent(parent.data(), s, channels, base_x, base_y, ref.data());
#else
        btflod::detail::upsample_parent_reference(parent.data(), s, channels, base_x, base_y, ref.data());
        builds.push_back(&scalar_twin());
#endif
        for (const SimdKernels* k : builds) {
          std::fill(got.begin(), got.end(), std::numeric_limits<float>::quiet_NaN());
          k->upsample_parent(parent.data(), s, channels, base_x, base_y, got.data());
          for (size_t i = 0; i < n; ++i) {
            ASSERT_EQ(std::bit_cast<uint32_t>(got[i]), std::bit_cast<uint32_t>(ref[i]))
                << btflod::simd_isa_name(k->isa) << " " << where << " texel " << i / channels << " channel "
                << i % channels << ": " << got[i] << " vs " << ref[i];
          }
        }
      }
    }
  }
}

// Every build blends at the child's positions: a parent linear in x, y and the channel up-samples
// to the same linear function at stored coordinate (base + i/2, base' + j/2), exactly (small
// integers and quarter weights round nowhere), taps clamped or extrapolated at the edges included.
TEST(SimdKernels, ParentUpsamplingBlendsAtTheChildPositions) {
  const uint32_t s = 24;
  for (uint32_t channels = 1; channels <= 4; ++channels) {
    std::vector<float> parent(size_t{s} * s * channels), got(parent.size());
    for (uint32_t y = 0; y < s; ++y)
      for (uint32_t x = 0; x < s; ++x)
        for (uint32_t c = 0; c < channels; ++c)
          parent[(size_t{y} * s + x) * channels + c] = static_cast<float>(4 * x + 8 * y + 64 * c);
    for (const float base : {1.75f, 2.25f, -0.25f, 12.25f}) {
      std::vector<const SimdKernels*> builds = simd_builds();
      builds.push_back(&scalar_twin());
      for (const SimdKernels* k : builds) {
        k->upsample_parent(parent.data(), s, channels, base, base + 0.5f, got.data());
        for (uint32_t y = 0; y < s; ++y)
          for (uint32_t x = 0; x < s; ++x) {
            const float px = base + 0.5f * static_cast<float>(x), py = base + 0.5f + 0.5f * static_cast<float>(y);
            for (uint32_t c = 0; c < channels; ++c)
              ASSERT_EQ(got[(size_t{y} * s + x) * channels + c], 4 * px + 8 * py + 64.0f * static_cast<float>(c))
                  << btflod::simd_isa_name(k->isa) << " C " << channels << " base " << base << " at " << x << "," << y;
          }
      }
    }
  }
}

TEST(SimdKernels, TileDecodesAreBitIdenticalUnderEveryForcedBuild) {
  ForcedIsa restore;
  for (uint32_t channels : {4u, 3u, 1u}) {
    const btflod::TileLayout layout{32, 4, channels};
    btflod::TileEncoder enc(layout);
    btflod::TileDecoder dec(layout);
    std::vector<float> parent(layout.sample_count()), tile(layout.sample_count());
    for (size_t i = 0; i < tile.size(); ++i) {
      parent[i] = std::sin(0.013f * static_cast<float>(i)) * 3.0f;
      tile[i] = parent[i] + 0.5f * std::cos(0.21f * static_cast<float>(i)) + 0.01f * static_cast<float>(i % 7);
    }
    const std::vector<float> tol(channels, 0.02f);
    std::vector<uint8_t> bytes(enc.bound());
    std::vector<float> recon(layout.sample_count());
    size_t written = 0;
    ASSERT_TRUE(btflod::simd_force_isa(SimdIsa::scalar));
    ASSERT_EQ(enc.encode(tile, parent, 1, 0, tol, bytes, written, recon), btflod::Status::success) << enc.message();
    bytes.resize(written);
    std::vector<float> ref(layout.sample_count()), got(layout.sample_count());
    ASSERT_EQ(dec.decode(bytes, parent, 1, 0, ref), btflod::Status::success) << dec.message();
    ASSERT_EQ(0, std::memcmp(ref.data(), recon.data(), ref.size() * sizeof(float))) << "closed loop";
    for (const SimdKernels* k : simd_builds()) {
      ASSERT_TRUE(btflod::simd_force_isa(k->isa));
      EXPECT_EQ(dec.uses_simd(), true);
      std::fill(got.begin(), got.end(), 0.0f);
      ASSERT_EQ(dec.decode(bytes, parent, 1, 0, got), btflod::Status::success) << dec.message();
      ASSERT_EQ(0, std::memcmp(got.data(), ref.data(), ref.size() * sizeof(float)))
          << btflod::simd_isa_name(k->isa) << " C=" << channels;
      // The encoder (forward DCT + closed-loop decode) gives the same payload in every build.
      std::vector<uint8_t> again(enc.bound());
      size_t written_again = 0;
      ASSERT_EQ(enc.encode(tile, parent, 1, 0, tol, again, written_again), btflod::Status::success);
      again.resize(written_again);
      EXPECT_EQ(again, bytes) << btflod::simd_isa_name(k->isa) << " C=" << channels;
    }
  }
  if (simd_builds().empty()) GTEST_SKIP() << "no SIMD build on this CPU: only the scalar twin ran";
}

TEST(SimdKernels, VoteCountsAreIdenticalUnderEveryForcedBuild) {
  ForcedIsa restore;
  const btflod::VoteLayout layouts[2] = {{5, 32, 20}, {3, 8, 8}};
  btflod::VoteCounter ref_counter(layouts), counter(layouts);
  std::mt19937 rng(21);
  std::vector<uint32_t> words(1280 * 9 + 77);
  uint32_t w = btflod::kFeedbackNone;
  for (auto& x : words) {
    if (rng() % 9 == 0) {
      const auto m = static_cast<uint32_t>(rng() % 3);  // material 2 does not exist: rejected
      const auto l = static_cast<uint32_t>(rng() % 6);
      w = rng() % 11 == 0
              ? btflod::kFeedbackNone
              : btflod::pack_feedback({m, l, static_cast<uint32_t>(rng() % 40), static_cast<uint32_t>(rng() % 40)});
    }
    x = w;
  }
  ASSERT_TRUE(btflod::simd_force_isa(SimdIsa::scalar));
  const size_t valid = ref_counter.count(words, 3, 1);
  const std::vector<uint32_t> ref_touched(ref_counter.touched().begin(), ref_counter.touched().end());
  ASSERT_GT(valid, 0u);
  ASSERT_GT(ref_counter.rejected(), 0u);
  for (const SimdKernels* k : simd_builds()) {
    ASSERT_TRUE(btflod::simd_force_isa(k->isa));
    EXPECT_EQ(counter.count(words, 3, 1), valid);
    EXPECT_EQ(std::vector<uint32_t>(counter.touched().begin(), counter.touched().end()), ref_touched);
    for (uint32_t word : ref_touched) {
      const btflod::FeedbackTile t = btflod::unpack_feedback(word);
      EXPECT_EQ(counter.votes(t.material, t.level, t.x, t.y), ref_counter.votes(t.material, t.level, t.x, t.y));
    }
  }
  if (simd_builds().empty()) GTEST_SKIP() << "no SIMD build on this CPU: only the scalar twin ran";
}

}  // namespace
