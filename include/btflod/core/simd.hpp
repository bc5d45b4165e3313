// btflod — SIMD dispatch: which instruction sets the running CPU offers.
//
// The header declares functions only: it includes no <immintrin.h> and no <cpuid.h>, so every
// per-frame header stays cheap and portable (emscripten, ARM, MSVC see the same declarations).
// The SIMD kernels themselves (core/half.hpp F16C conversions, codec/dct.hpp and
// codec/tile_codec.hpp AVX2/FMA inverse DCTs) are defined in the implementation translation unit
// (BTFLOD_IMPLEMENTATION, see btflod.hpp), each compiled for its ISA with a target attribute
// (never with whole-program -m flags), next to its scalar twin. The CPU is asked once; every
// dispatching function then branches on a cached bool, as libdeflate does.
//
// BTFLOD_HAS_X86_DISPATCH is 1 when this compiler can build the x86 kernels (GCC or clang on
// x86): the kernel declarations exist only then. Set the environment variable
// BTFLOD_DISABLE_SIMD=1 (read once, at the first query) to force the scalar twins everywhere;
// tests also call both paths explicitly.
#pragma once

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define BTFLOD_HAS_X86_DISPATCH 1
/// Function attribute of the AVX2 + FMA kernels (implementation TU only).
#define BTFLOD_TARGET_AVX2_FMA __attribute__((target("avx2,fma")))
/// Function attribute of the F16C kernels (implementation TU only).
#define BTFLOD_TARGET_F16C __attribute__((target("avx,f16c")))
#else
#define BTFLOD_HAS_X86_DISPATCH 0
#endif

namespace btflod {

/// True when the environment variable BTFLOD_DISABLE_SIMD is set and does not start with "0". Read once (first call);
/// thread-safe.
bool simd_disabled_by_environment() noexcept;

/// True when the running CPU supports F16C and AVX (with the OS saving YMM state) and
/// BTFLOD_DISABLE_SIMD is not set; false on other architectures. Evaluated once; thread-safe.
bool cpu_has_f16c() noexcept;

/// True when the running CPU supports AVX2 and FMA (with the OS saving YMM state) and
/// BTFLOD_DISABLE_SIMD is not set; false on other architectures. Evaluated once; thread-safe.
bool cpu_has_avx2_fma() noexcept;

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION)
#include <cstdlib>
#if BTFLOD_HAS_X86_DISPATCH
#include <cpuid.h>
#endif

namespace btflod {
namespace detail {
#if BTFLOD_HAS_X86_DISPATCH
// CPUID leaf 1 ECX and leaf 7 EBX, and whether the OS saves XMM + YMM state (XGETBV), asked
// directly: clang 14 rejects "f16c" in __builtin_cpu_supports.
struct X86Features {
  bool avx = false, f16c = false, fma = false, avx2 = false;
};
inline X86Features query_x86_features() noexcept {
  X86Features f;
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  if (!__get_cpuid(1, &eax, &ebx, &ecx, &edx)) return f;
  const bool osxsave = ecx & (1u << 27);
  if (!osxsave) return f;
  unsigned xcr0_lo = 0, xcr0_hi = 0;
  __asm__ volatile("xgetbv" : "=a"(xcr0_lo), "=d"(xcr0_hi) : "c"(0));
  if ((xcr0_lo & 6u) != 6u) return f;  // the OS does not save YMM state: no AVX at all
  f.avx = ecx & (1u << 28);
  f.f16c = f.avx && (ecx & (1u << 29));
  f.fma = f.avx && (ecx & (1u << 12));
  if (__get_cpuid_count(7, 0, &eax, &ebx, &ecx, &edx)) f.avx2 = f.avx && (ebx & (1u << 5));
  return f;
}
#endif
}  // namespace detail

bool simd_disabled_by_environment() noexcept {
  static const bool disabled = [] {
    const char* env = std::getenv("BTFLOD_DISABLE_SIMD");
    return env != nullptr && env[0] != '\0' && env[0] != '0';
  }();
  return disabled;
}

bool cpu_has_f16c() noexcept {
#if BTFLOD_HAS_X86_DISPATCH
  static const bool has = !simd_disabled_by_environment() && detail::query_x86_features().f16c;
  return has;
#else
  return false;
#endif
}

bool cpu_has_avx2_fma() noexcept {
#if BTFLOD_HAS_X86_DISPATCH
  static const bool has = [] {
    if (simd_disabled_by_environment()) return false;
    const detail::X86Features f = detail::query_x86_features();
    return f.avx2 && f.fma;
  }();
  return has;
#else
  return false;
#endif
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
