// btflod — the SIMD kernels' builds (implementation TU only; see core/simd.hpp).
//
// core/simd_kernels.inl holds the kernels once; this file defines one vector-operations type per
// instruction set and includes the kernels once per type, each build in its own namespace and
// compiled for its ISA by a function target attribute. The resulting SimdKernels tables are what
// core/simd.hpp dispatches to. Everything here is under BTFLOD_IMPLEMENTATION: including this
// header elsewhere declares nothing. core/dct.hpp (and so half.hpp and runtime/lod/feedback.hpp, whose
// implementation sections include it) pulls it into the implementation TU.
#pragma once

#include "btflod/core/dct.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/simd.hpp"

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include <cstring>
#if BTFLOD_HAS_X86_DISPATCH
#include <immintrin.h>
#endif

// Keeps a product out of the compiler's FMA contraction (GCC contracts separate multiply and add
// intrinsics when FMA is enabled, as it is under AVX-512 or -march with FMA): an empty asm makes
// the product an opaque value, at no instruction cost.
#if defined(__GNUC__) || defined(__clang__)
#define BTFLOD_OPAQUE_MEM(x) __asm__("" : "+m"(x))
#define BTFLOD_OPAQUE_XMM(x) __asm__("" : "+x"(x))
#define BTFLOD_OPAQUE_VEC(x) __asm__("" : "+v"(x))
#else
#define BTFLOD_OPAQUE_MEM(x) (void)(x)
#endif

namespace btflod::detail {

// The 8x8 DCT basis C (row k = frequency k) and its transpose, aligned for vector loads.
struct Dct8Tables {
  alignas(64) float c[64];
  alignas(64) float ct[64];
};
inline const Dct8Tables& dct8_tables() noexcept {
  static const Dct8Tables tables = [] {
    Dct8Tables t{};
    const auto& c = dct_basis<8, float>();
    for (int i = 0; i < 8; ++i)
      for (int j = 0; j < 8; ++j) {
        t.c[i * 8 + j] = c[i * 8 + j];
        t.ct[i * 8 + j] = c[j * 8 + i];
      }
    return t;
  }();
  return tables;
}

// Portable C++ operations: the scalar twin.
struct ScalarOps {
  static constexpr SimdIsa kIsa = SimdIsa::scalar;
  static constexpr size_t kHalfLanes = 8;
  static constexpr size_t kMarkLanes = 8;
  struct F8 {
    float v[8];
  };
  static F8 zero() noexcept { return F8{}; }
  static F8 load(const float* p) noexcept {
    F8 r;
    std::memcpy(r.v, p, sizeof r.v);
    return r;
  }
  static void store(float* p, const F8& a) noexcept { std::memcpy(p, a.v, sizeof a.v); }
  static F8 bcast(float s) noexcept {
    F8 r;
    for (float& x : r.v) x = s;
    return r;
  }
  static F8 mul(F8 a, const F8& b) noexcept {
    for (int i = 0; i < 8; ++i) a.v[i] *= b.v[i];
#if defined(__FP_FAST_FMAF) || defined(__FMA__) || defined(__aarch64__)
    BTFLOD_OPAQUE_MEM(a);  // only when the target has FMA the compiler could contract
#endif
    return a;
  }
  static F8 add(F8 a, const F8& b) noexcept {
    for (int i = 0; i < 8; ++i) a.v[i] += b.v[i];
    return a;
  }
  // One product, kept out of FMA contraction like mul.
  static float mul1(float a, float b) noexcept {
    float p = a * b;
#if defined(__FP_FAST_FMAF) || defined(__FMA__) || defined(__aarch64__)
    BTFLOD_OPAQUE_MEM(p);
#endif
    return p;
  }
  // r[l] = a[idx[l]], idx[l] < 8.
  static F8 permute(const F8& a, const int32_t* idx) noexcept {
    F8 r;
    for (int l = 0; l < 8; ++l) r.v[l] = a.v[idx[l]];
    return r;
  }
  // The upper half of a, then the lower half of b.
  static F8 middle(const F8& a, const F8& b) noexcept {
    F8 r;
    for (int l = 0; l < 4; ++l) {
      r.v[l] = a.v[4 + l];
      r.v[4 + l] = b.v[l];
    }
    return r;
  }
  static void add_interleaved4(float* dst, const F8& r0, const F8& r1, const F8& r2, const F8& r3) noexcept {
    for (int x = 0; x < 8; ++x) {
      dst[4 * x + 0] += r0.v[x];
      dst[4 * x + 1] += r1.v[x];
      dst[4 * x + 2] += r2.v[x];
      dst[4 * x + 3] += r3.v[x];
    }
  }
  static void add_strided(float* dst, size_t step, const F8& r) noexcept {
    for (int x = 0; x < 8; ++x) dst[size_t(x) * step] += r.v[x];
  }
  static void half_to_float_lanes(const uint16_t* in, float* out) noexcept {
    for (size_t i = 0; i < kHalfLanes; ++i) out[i] = half_bits_to_float(in[i]);
  }
  static void float_to_half_lanes(const float* in, uint16_t* out) noexcept {
    for (size_t i = 0; i < kHalfLanes; ++i) out[i] = float_to_half_bits(in[i]);
  }
  static uint64_t ne_mask(const uint32_t* p) noexcept {
    uint64_t m = 0;
    for (size_t k = 0; k < kMarkLanes; ++k) m |= static_cast<uint64_t>(p[k] != p[static_cast<ptrdiff_t>(k) - 1]) << k;
    return m;
  }
};

namespace simd_scalar {
using V = ScalarOps;
#define BTFLOD_KERNEL_ATTR
#define BTFLOD_KERNEL_INLINE inline
#include "btflod/core/simd_kernels.inl"
#undef BTFLOD_KERNEL_ATTR
#undef BTFLOD_KERNEL_INLINE
}  // namespace simd_scalar

#if BTFLOD_HAS_X86_DISPATCH
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push  // GCC 12's avx512fintrin.h trips -Wmaybe-uninitialized (_mm512_undefined)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#define BTFLOD_TARGET_AVX2 __attribute__((target("avx2,f16c")))
#define BTFLOD_TARGET_AVX512 __attribute__((target("avx2,f16c,avx512f,avx512bw,avx512dq,avx512vl")))

// AVX2 + F16C: 8 float lanes in a __m256 (no FMA, see the file comment of core/simd.hpp).
struct Avx2Ops {
  static constexpr SimdIsa kIsa = SimdIsa::avx2;
  static constexpr size_t kHalfLanes = 8;
  static constexpr size_t kMarkLanes = 8;
  using F8 = __m256;
  BTFLOD_TARGET_AVX2 static F8 zero() noexcept { return _mm256_setzero_ps(); }
  BTFLOD_TARGET_AVX2 static F8 load(const float* p) noexcept { return _mm256_loadu_ps(p); }
  BTFLOD_TARGET_AVX2 static void store(float* p, F8 a) noexcept { _mm256_storeu_ps(p, a); }
  BTFLOD_TARGET_AVX2 static F8 bcast(float s) noexcept { return _mm256_set1_ps(s); }
  BTFLOD_TARGET_AVX2 static F8 mul(F8 a, F8 b) noexcept {
    F8 p = _mm256_mul_ps(a, b);
    BTFLOD_OPAQUE_XMM(p);
    return p;
  }
  BTFLOD_TARGET_AVX2 static F8 add(F8 a, F8 b) noexcept { return _mm256_add_ps(a, b); }
  BTFLOD_TARGET_AVX2 static float mul1(float a, float b) noexcept {
    float p = a * b;
    BTFLOD_OPAQUE_XMM(p);
    return p;
  }
  BTFLOD_TARGET_AVX2 static F8 permute(F8 a, const int32_t* idx) noexcept {
    return _mm256_permutevar8x32_ps(a, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(idx)));
  }
  BTFLOD_TARGET_AVX2 static F8 middle(F8 a, F8 b) noexcept { return _mm256_permute2f128_ps(a, b, 0x21); }
  // dst[4x + c] += r_c[x]: transposes 4 channel rows of 8 texels into 8 texels of 4 channels.
  BTFLOD_TARGET_AVX2 static void add_interleaved4(float* dst, F8 r0, F8 r1, F8 r2, F8 r3) noexcept {
    const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1);
    const __m256 t2 = _mm256_unpacklo_ps(r2, r3), t3 = _mm256_unpackhi_ps(r2, r3);
    const __m256 u0 = _mm256_shuffle_ps(t0, t2, 0x44), u1 = _mm256_shuffle_ps(t0, t2, 0xEE);
    const __m256 u2 = _mm256_shuffle_ps(t1, t3, 0x44), u3 = _mm256_shuffle_ps(t1, t3, 0xEE);
    const __m256 x01 = _mm256_permute2f128_ps(u0, u1, 0x20), x23 = _mm256_permute2f128_ps(u2, u3, 0x20);
    const __m256 x45 = _mm256_permute2f128_ps(u0, u1, 0x31), x67 = _mm256_permute2f128_ps(u2, u3, 0x31);
    _mm256_storeu_ps(dst, _mm256_add_ps(_mm256_loadu_ps(dst), x01));
    _mm256_storeu_ps(dst + 8, _mm256_add_ps(_mm256_loadu_ps(dst + 8), x23));
    _mm256_storeu_ps(dst + 16, _mm256_add_ps(_mm256_loadu_ps(dst + 16), x45));
    _mm256_storeu_ps(dst + 24, _mm256_add_ps(_mm256_loadu_ps(dst + 24), x67));
  }
  BTFLOD_TARGET_AVX2 static void add_strided(float* dst, size_t step, F8 r) noexcept {
    alignas(32) float v[8];
    _mm256_store_ps(v, r);
    for (int x = 0; x < 8; ++x) dst[size_t(x) * step] += v[x];
  }
  BTFLOD_TARGET_AVX2 static void half_to_float_lanes(const uint16_t* in, float* out) noexcept {
    _mm256_storeu_ps(out, _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(in))));
  }
  BTFLOD_TARGET_AVX2 static void float_to_half_lanes(const float* in, uint16_t* out) noexcept {
    const __m128i h = _mm256_cvtps_ph(_mm256_loadu_ps(in), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out), h);
  }
  BTFLOD_TARGET_AVX2 static uint64_t ne_mask(const uint32_t* p) noexcept {
    const __m256i a = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
    const __m256i b = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p - 1));
    const int eq = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(a, b)));
    return static_cast<uint64_t>(~eq & 0xff);
  }
};

// AVX-512: the 8-lane float operations of Avx2Ops (EVEX-encoded, products kept opaque in any of
// the 32 vector registers), 16 lanes for half conversion and run detection.
struct Avx512Ops : Avx2Ops {
  static constexpr SimdIsa kIsa = SimdIsa::avx512;
  static constexpr size_t kHalfLanes = 16;
  static constexpr size_t kMarkLanes = 16;
  BTFLOD_TARGET_AVX512 static F8 mul(F8 a, F8 b) noexcept {
    F8 p = _mm256_mul_ps(a, b);
    BTFLOD_OPAQUE_VEC(p);
    return p;
  }
  BTFLOD_TARGET_AVX512 static float mul1(float a, float b) noexcept {
    float p = a * b;
    BTFLOD_OPAQUE_VEC(p);
    return p;
  }
  BTFLOD_TARGET_AVX512 static void half_to_float_lanes(const uint16_t* in, float* out) noexcept {
    _mm512_storeu_ps(out, _mm512_cvtph_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(in))));
  }
  BTFLOD_TARGET_AVX512 static void float_to_half_lanes(const float* in, uint16_t* out) noexcept {
    const __m256i h = _mm512_cvtps_ph(_mm512_loadu_ps(in), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), h);
  }
  BTFLOD_TARGET_AVX512 static uint64_t ne_mask(const uint32_t* p) noexcept {
    return _mm512_cmpneq_epi32_mask(_mm512_loadu_si512(p), _mm512_loadu_si512(p - 1));
  }
};

namespace simd_avx2 {
using V = Avx2Ops;
#define BTFLOD_KERNEL_ATTR BTFLOD_TARGET_AVX2
#define BTFLOD_KERNEL_INLINE BTFLOD_TARGET_AVX2 __attribute__((always_inline)) inline
#include "btflod/core/simd_kernels.inl"
#undef BTFLOD_KERNEL_ATTR
#undef BTFLOD_KERNEL_INLINE
}  // namespace simd_avx2

namespace simd_avx512 {
using V = Avx512Ops;
#define BTFLOD_KERNEL_ATTR BTFLOD_TARGET_AVX512
#define BTFLOD_KERNEL_INLINE BTFLOD_TARGET_AVX512 __attribute__((always_inline)) inline
#include "btflod/core/simd_kernels.inl"
#undef BTFLOD_KERNEL_ATTR
#undef BTFLOD_KERNEL_INLINE
}  // namespace simd_avx512
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
#endif  // BTFLOD_HAS_X86_DISPATCH

const SimdKernels* simd_kernel_table(SimdIsa isa) noexcept {
  switch (isa) {
#if BTFLOD_HAS_X86_DISPATCH
    case SimdIsa::avx2:
      return &simd_avx2::kTable;
    case SimdIsa::avx512:
      return &simd_avx512::kTable;
#endif
    default:
      return &simd_scalar::kTable;
  }
}

}  // namespace btflod::detail

namespace btflod {
#if BTFLOD_HAS_X86_DISPATCH
// The AVX2 build's entry points under their historical names (core/half.hpp, core/dct.hpp).
void float_to_half_f16c(std::span<const float> in, std::span<uint16_t> out) noexcept {
  detail::simd_avx2::float_to_half(in.data(), out.data(), in.size());
}
void half_to_float_f16c(std::span<const uint16_t> in, std::span<float> out) noexcept {
  detail::simd_avx2::half_to_float(in.data(), out.data(), in.size());
}
void dct8_forward_avx2(const float* in, size_t in_stride, float* out) noexcept {
  detail::simd_avx2::dct8_forward(in, in_stride, out);
}
void dct8_inverse_avx2(const float* in, float* out, size_t out_stride) noexcept {
  detail::simd_avx2::dct8_inverse(in, out, out_stride);
}
#endif
}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
