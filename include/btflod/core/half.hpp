// btflod — IEEE 754 binary16 ("half") conversion.
//
// Scalar conversions are exact (half → float) and round to nearest, ties to even
// (float → half), with correct zeros, subnormals, infinities and NaN. The bulk converters are
// SIMD kernels of core/simd.hpp (F16C in the AVX2 build, 16 lanes in the AVX-512 build, chosen
// once at run time); every build returns the scalar twin's bits, NaN included (a NaN keeps its
// sign and top payload bits and is quieted, as F16C does). BTFLOD_FORCE_ISA=scalar forces the
// scalar twin. This header includes no <immintrin.h>.
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

/// Portable scalar bulk conversion (the scalar build's kernel). Preconditions: out.size() >=
/// in.size(). Thread-safe, no allocation.
inline void float_to_half_scalar(std::span<const float> in, std::span<uint16_t> out) noexcept {
  for (size_t i = 0; i < in.size(); ++i) out[i] = float_to_half_bits(in[i]);
}

/// Portable scalar bulk conversion. Preconditions: out.size() >= in.size(). Thread-safe.
inline void half_to_float_scalar(std::span<const uint16_t> in, std::span<float> out) noexcept {
  for (size_t i = 0; i < in.size(); ++i) out[i] = half_bits_to_float(in[i]);
}

#if BTFLOD_HAS_X86_DISPATCH
/// Bulk conversion of the AVX2 (F16C) build, simd_kernels_for(SimdIsa::avx2)->float_to_half.
/// Precondition: simd_isa_available(SimdIsa::avx2), out.size() >= in.size(). Thread-safe.
void float_to_half_f16c(std::span<const float> in, std::span<uint16_t> out) noexcept;

/// Bulk conversion of the AVX2 (F16C) build, simd_kernels_for(SimdIsa::avx2)->half_to_float.
/// Precondition: simd_isa_available(SimdIsa::avx2), out.size() >= in.size(). Thread-safe.
void half_to_float_f16c(std::span<const uint16_t> in, std::span<float> out) noexcept;
#endif

/// Converts floats to half bits with the ISA build in use (simd_kernels()); bit-identical in
/// every build. Precondition: out.size() >= in.size(). Thread-safe, no allocation.
inline void float_to_half(std::span<const float> in, std::span<uint16_t> out) noexcept {
  simd_kernels().float_to_half(in.data(), out.data(), in.size());
}

/// Converts half bits to floats with the ISA build in use (simd_kernels()); bit-identical in
/// every build. Precondition: out.size() >= in.size(). Thread-safe, no allocation.
inline void half_to_float(std::span<const uint16_t> in, std::span<float> out) noexcept {
  simd_kernels().half_to_float(in.data(), out.data(), in.size());
}

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
// The kernels and float_to_half_f16c / half_to_float_f16c are defined in core/simd_kernels.hpp,
// which core/dct.hpp's implementation section includes.
#include "btflod/core/dct.hpp"
#endif  // BTFLOD_IMPLEMENTATION
