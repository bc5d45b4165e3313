// btflod — IEEE 754 binary16 ("half") conversion.
//
// Scalar conversions are exact (half → float) and round to nearest, ties to even
// (float → half), with correct zeros, subnormals, infinities and NaN. The bulk converters
// dispatch at run time to an F16C path on x86 CPUs that have it; the scalar twin produces
// bit-identical results (NaN included: a NaN keeps its sign and top payload bits and is quieted,
// as F16C does). Set BTFLOD_DISABLE_SIMD=1 in the environment to force the scalar twins. The
// F16C kernels and the dispatching bulk converters are defined in the implementation TU
// (BTFLOD_IMPLEMENTATION, core/simd.hpp): this header includes no <immintrin.h>.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "btflod/core/bit_cast.hpp"
#include "btflod/core/simd.hpp"

namespace btflod {

/// Converts a float to binary16 bits, round to nearest even. Thread-safe, no allocation.
constexpr uint16_t float_to_half_bits(float value) noexcept {
  const uint32_t f = btflod::bit_cast<uint32_t>(value);
  const uint32_t sign = (f >> 16) & 0x8000u;
  const uint32_t abs = f & 0x7fffffffu;
  if (abs >= 0x7f800000u) {  // Inf or NaN
    if (abs > 0x7f800000u) return static_cast<uint16_t>(sign | 0x7e00u | ((abs >> 13) & 0x3ffu));
    return static_cast<uint16_t>(sign | 0x7c00u);
  }
  if (abs >= 0x477ff000u) return static_cast<uint16_t>(sign | 0x7c00u);  // ≥ 65520 rounds to Inf
  if (abs < 0x38800000u) {                                               // below 2^-14: half subnormal or zero
    const uint32_t exponent = abs >> 23;
    const uint32_t shift = 126u - exponent;  // half ulp 2^-24 relative to the float's bits
    if (exponent == 0 || shift > 24) return static_cast<uint16_t>(sign);
    const uint32_t mantissa = (abs & 0x7fffffu) | 0x800000u;
    uint32_t h = mantissa >> shift;
    const uint32_t rem = mantissa & ((1u << shift) - 1u);
    const uint32_t halfway = 1u << (shift - 1u);
    if (rem > halfway || (rem == halfway && (h & 1u))) ++h;  // may carry into the smallest normal
    return static_cast<uint16_t>(sign | h);
  }
  const uint32_t odd = (abs >> 13) & 1u;
  // Rebias the exponent (127 → 15) and round: adding 0xfff + odd rounds half to even.
  const uint32_t rounded = abs + 0xc8000fffu + odd;
  return static_cast<uint16_t>(sign | (rounded >> 13));
}

/// Converts binary16 bits to float; exact for every pattern (NaN are quieted). Thread-safe.
constexpr float half_bits_to_float(uint16_t h) noexcept {
  const uint32_t sign = static_cast<uint32_t>(h & 0x8000u) << 16;
  const uint32_t exponent = (h >> 10) & 0x1fu;
  const uint32_t mantissa = h & 0x3ffu;
  if (exponent == 0) {
    if (mantissa == 0) return btflod::bit_cast<float>(sign);
    // Subnormal: normalise into a float exponent.
    uint32_t m = mantissa;
    uint32_t e = 113;  // 127 - 14
    while ((m & 0x400u) == 0) {
      m <<= 1;
      --e;
    }
    return btflod::bit_cast<float>(sign | (e << 23) | ((m & 0x3ffu) << 13));
  }
  if (exponent == 31) {
    if (mantissa == 0) return btflod::bit_cast<float>(sign | 0x7f800000u);
    return btflod::bit_cast<float>(sign | 0x7fc00000u | (mantissa << 13));
  }
  return btflod::bit_cast<float>(sign | ((exponent + 112u) << 23) | (mantissa << 13));
}

/// A binary16 value. Trivially copyable, 2 bytes; arithmetic happens in float.
struct Half {
  uint16_t bits = 0;

  constexpr Half() noexcept = default;
  constexpr explicit Half(float f) noexcept : bits(float_to_half_bits(f)) {}
  static constexpr Half from_bits(uint16_t b) noexcept {
    Half h;
    h.bits = b;
    return h;
  }
  constexpr explicit operator float() const noexcept { return half_bits_to_float(bits); }
  constexpr float to_float() const noexcept { return half_bits_to_float(bits); }
  friend constexpr bool operator==(Half a, Half b) noexcept { return a.bits == b.bits; }
};
static_assert(sizeof(Half) == 2);

/// Portable scalar bulk conversion. Preconditions: out.size() >= in.size().
inline void float_to_half_scalar(std::span<const float> in, std::span<uint16_t> out) noexcept {
  for (size_t i = 0; i < in.size(); ++i) out[i] = float_to_half_bits(in[i]);
}

/// Portable scalar bulk conversion. Preconditions: out.size() >= in.size().
inline void half_to_float_scalar(std::span<const uint16_t> in, std::span<float> out) noexcept {
  for (size_t i = 0; i < in.size(); ++i) out[i] = half_bits_to_float(in[i]);
}

#if BTFLOD_HAS_X86_DISPATCH
/// F16C bulk conversion (defined in the implementation TU, compiled for F16C).
/// Precondition: cpu_has_f16c() (core/simd.hpp), out.size() >= in.size(). Thread-safe.
void float_to_half_f16c(std::span<const float> in, std::span<uint16_t> out) noexcept;

/// F16C bulk conversion (defined in the implementation TU, compiled for F16C).
/// Precondition: cpu_has_f16c() (core/simd.hpp), out.size() >= in.size(). Thread-safe.
void half_to_float_f16c(std::span<const uint16_t> in, std::span<float> out) noexcept;
#endif

/// Converts floats to half bits: the F16C kernel when the CPU has it (resolved once), else the
/// scalar twin; bit-identical results. Precondition: out.size() >= in.size(). Thread-safe.
void float_to_half(std::span<const float> in, std::span<uint16_t> out) noexcept;

/// Converts half bits to floats: the F16C kernel when the CPU has it (resolved once), else the
/// scalar twin; bit-identical results. Precondition: out.size() >= in.size(). Thread-safe.
void half_to_float(std::span<const uint16_t> in, std::span<float> out) noexcept;

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION)
#if BTFLOD_HAS_X86_DISPATCH
#include <immintrin.h>
#endif

namespace btflod {

#if BTFLOD_HAS_X86_DISPATCH
BTFLOD_TARGET_F16C void float_to_half_f16c(std::span<const float> in, std::span<uint16_t> out) noexcept {
  size_t i = 0;
  for (; i + 8 <= in.size(); i += 8) {
    const __m256 v = _mm256_loadu_ps(in.data() + i);
    const __m128i h = _mm256_cvtps_ph(v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out.data() + i), h);
  }
  for (; i < in.size(); ++i) out[i] = float_to_half_bits(in[i]);
}

BTFLOD_TARGET_F16C void half_to_float_f16c(std::span<const uint16_t> in, std::span<float> out) noexcept {
  size_t i = 0;
  for (; i + 8 <= in.size(); i += 8) {
    const __m128i h = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in.data() + i));
    _mm256_storeu_ps(out.data() + i, _mm256_cvtph_ps(h));
  }
  for (; i < in.size(); ++i) out[i] = half_bits_to_float(in[i]);
}
#endif

void float_to_half(std::span<const float> in, std::span<uint16_t> out) noexcept {
#if BTFLOD_HAS_X86_DISPATCH
  if (cpu_has_f16c()) return float_to_half_f16c(in, out);
#endif
  float_to_half_scalar(in, out);
}

void half_to_float(std::span<const uint16_t> in, std::span<float> out) noexcept {
#if BTFLOD_HAS_X86_DISPATCH
  if (cpu_has_f16c()) return half_to_float_f16c(in, out);
#endif
  half_to_float_scalar(in, out);
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
