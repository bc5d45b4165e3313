// btflod — SIMD kernels and their run-time dispatch (the libdeflate pattern).
//
// Every SIMD kernel of the library (bulk half <-> float conversion, the 8x8 DCT, the tile
// decoder's inverse DCT and parent up-sampling, the run detection of feedback vote counting) is
// written ONCE, as a kernel source over a small vector-operations type (core/simd_kernels.inl),
// and compiled once per instruction set in the implementation TU (BTFLOD_IMPLEMENTATION, see btflod.hpp): a scalar
// twin (portable C++, every platform), an AVX2 + F16C build and an AVX-512 (F, BW, DQ, VL) build,
// each with a function target attribute (never whole-program -m flags). The builds of one ISA form
// a SimdKernels table of function pointers. The table is chosen once, on first use, from the CPU
// (CPUID + XGETBV) and the environment, and cached; every dispatching call is then one load and
// one indirect call.
//
// Bit-identity: the kernels use no FMA and evaluate every sum in the same order in every build
// (products are kept out of the compiler's FMA contraction), so each SIMD build returns exactly
// the scalar twin's bits for every input. The one exception is the payload of a NaN produced from
// two NaN operands, which IEEE 754 leaves unspecified; tests and fuzz targets treat any two NaN as
// equal there (and only there).
//
// Choosing the build: the environment variable BTFLOD_FORCE_ISA=scalar|avx2|avx512 (read once, at
// the first query) forces that build, or the best available one below it when the CPU lacks it;
// BTFLOD_DISABLE_SIMD=1 is the same as BTFLOD_FORCE_ISA=scalar. simd_force_isa() changes the
// choice at run time; simd_kernels_for() gives any available build's table directly (tests compare
// every build with the scalar twin). This header declares functions only: it includes no
// <immintrin.h>, no <cpuid.h> and no <atomic>, so every per-frame header stays cheap and portable
// (emscripten, ARM, MSVC see the same declarations and get the scalar twin).
#pragma once

#include <cstddef>
#include <cstdint>

#include "btflod/core/enum_names.hpp"

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define BTFLOD_HAS_X86_DISPATCH 1
#else
#define BTFLOD_HAS_X86_DISPATCH 0
#endif

namespace btflod {

struct TileCoefBlock;  // core/dct.hpp

/// Instruction sets the kernels are compiled for, in increasing order of capability.
enum class SimdIsa : uint8_t {
  scalar = 0,  ///< portable C++ twin (every platform)
  avx2 = 1,    ///< x86 AVX2 + F16C (no FMA: results equal the scalar twin's)
  avx512 = 2,  ///< x86 AVX-512 F + BW + DQ + VL (and everything avx2 needs)
};
inline constexpr int kSimdIsaCount = 3;

namespace detail {
/// simd_isa_name()'s table: one name per SimdIsa, in value order.
inline constexpr const char* kSimdIsaNames[] = {"scalar", "avx2", "avx512"};
}  // namespace detail

/// Lower-case name of an ISA ("scalar", "avx2", "avx512"). Thread-safe.
constexpr const char* simd_isa_name(SimdIsa isa) noexcept {
  return enum_value_name<SimdIsa::avx512>(isa, detail::kSimdIsaNames);
}

/// The kernels of one ISA build. Every entry is non-null and thread-safe, allocates nothing and
/// never throws; each build returns the scalar twin's bits (see the file comment).
struct SimdKernels {
  SimdIsa isa = SimdIsa::scalar;
  /// out[i] = half_bits_to_float(in[i]) for i < n (core/half.hpp). in/out may not overlap.
  void (*half_to_float)(const uint16_t* in, float* out, size_t n) noexcept = nullptr;
  /// out[i] = float_to_half_bits(in[i]) for i < n (round to nearest even). No overlap.
  void (*float_to_half)(const float* in, uint16_t* out, size_t n) noexcept = nullptr;
  /// Forward orthonormal 8x8 DCT-II (core/dct.hpp): `in` row stride `in_stride` floats, 64
  /// coefficients to `out`, (v, u) at v*8 + u. No overlap.
  void (*dct8_forward)(const float* in, size_t in_stride, float* out) noexcept = nullptr;
  /// Inverse of dct8_forward: 64 coefficients to a block of row stride `out_stride`. No overlap.
  void (*dct8_inverse)(const float* in, float* out, size_t out_stride) noexcept = nullptr;
  /// Adds the inverse DCT of one block to 8x8 samples at `dst` (row stride `row_stride`, column
  /// stride `step` floats); reads only rows < b.rows and columns < b.cols (each <= 8) of b.coef.
  /// A block with rows == 0 or cols == 0 adds nothing.
  void (*tile_idct_add)(const TileCoefBlock& b, float* dst, size_t row_stride, size_t step) noexcept = nullptr;
  /// Four channel blocks of one block position of a 4-channel tile: adds channel c's inverse DCT
  /// at dst[y * row_stride + 4 * x + c]. Nothing is added when all four blocks are empty;
  /// otherwise an empty channel adds +0 to each of its samples.
  void (*tile_idct_add4)(const TileCoefBlock* b, float* dst, size_t row_stride) noexcept = nullptr;
  /// Run boundaries of feedback words: bit k % 64 of marks[k / 64] is set when
  /// words[k] != words[k - 1], for k < n (words[-1] must be readable); the bits of the last mark
  /// word at and above n % 64 are 0. marks holds ceil(n / 64) words.
  void (*run_marks)(const uint32_t* words, size_t n, uint64_t* marks) noexcept = nullptr;
  /// Bilinear up-sampling of a parent tile of s × s texels of `channels` floats (interleaved) to
  /// its child's prediction (runtime/codec/tile_codec.hpp, upsample_parent): output texel (i, j) blends
  /// the parent at stored coordinate (base_x + i/2, base_y + j/2), each tap clamped to
  /// [0, s − 2] + 1. Preconditions: 2 ≤ s ≤ 1024, 1 ≤ channels ≤ 4, −1 < base_x, base_y ≤ s;
  /// parent and out hold s·s·channels floats and do not overlap. ≤ 23 KiB of stack.
  void (*upsample_parent)(const float* parent, uint32_t s, uint32_t channels, float base_x, float base_y,
                          float* out) noexcept = nullptr;
};

/// The table in use: chosen on the first call from the CPU and BTFLOD_FORCE_ISA /
/// BTFLOD_DISABLE_SIMD, then cached (or what simd_force_isa() set). Thread-safe, lock-free.
const SimdKernels& simd_kernels() noexcept;

/// ISA of simd_kernels(). Thread-safe.
SimdIsa simd_active_isa() noexcept;

/// True when `isa` is compiled in and the running CPU (and OS) supports it; ignores the
/// environment. Evaluated once; thread-safe.
bool simd_isa_available(SimdIsa isa) noexcept;

/// The table of one ISA build, or nullptr when simd_isa_available(isa) is false. Thread-safe.
const SimdKernels* simd_kernels_for(SimdIsa isa) noexcept;

/// Makes `isa` the build every dispatching call uses from now on. Returns false (and changes
/// nothing) when it is not available. Thread-safe (calls racing with it use either build; both
/// give the same bits), but meant for start-up, tests and benchmarks.
bool simd_force_isa(SimdIsa isa) noexcept;

/// Parses "scalar", "avx2" or "avx512" (case-sensitive). Returns false for anything else
/// (including nullptr), leaving `isa` unchanged. Thread-safe.
bool simd_isa_from_name(const char* name, SimdIsa& isa) noexcept;

/// True when the environment variable BTFLOD_DISABLE_SIMD is set and does not start with "0".
/// Read once (first call); thread-safe.
bool simd_disabled_by_environment() noexcept;

/// True when the running CPU supports F16C and AVX (with the OS saving YMM state) and
/// BTFLOD_DISABLE_SIMD is not set; false on other architectures. Evaluated once; thread-safe.
bool cpu_has_f16c() noexcept;

/// True when the running CPU supports AVX2 and FMA (with the OS saving YMM state) and
/// BTFLOD_DISABLE_SIMD is not set; false on other architectures. Evaluated once; thread-safe.
bool cpu_has_avx2_fma() noexcept;

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include <atomic>
#include <cstdlib>
#include <cstring>
#if BTFLOD_HAS_X86_DISPATCH
#include <cpuid.h>
#endif

namespace btflod {
namespace detail {
#if BTFLOD_HAS_X86_DISPATCH
// CPUID leaves 1 and 7 and the OS's saved register state (XGETBV), asked directly: clang 14
// rejects "f16c" in __builtin_cpu_supports.
struct X86Features {
  bool avx = false, f16c = false, fma = false, avx2 = false, avx512 = false;
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
  const bool zmm_saved = (xcr0_lo & 0xe0u) == 0xe0u;  // opmask, ZMM0-15 upper halves, ZMM16-31
  if (__get_cpuid_count(7, 0, &eax, &ebx, &ecx, &edx)) {
    f.avx2 = f.avx && (ebx & (1u << 5));
    const bool avx512f = ebx & (1u << 16), avx512dq = ebx & (1u << 17), avx512bw = ebx & (1u << 30),
               avx512vl = ebx & (1u << 31);
    f.avx512 = f.avx2 && f.f16c && zmm_saved && avx512f && avx512dq && avx512bw && avx512vl;
  }
  return f;
}
inline const X86Features& x86_features() noexcept {
  static const X86Features f = query_x86_features();
  return f;
}
#endif

// The ISA builds' tables, defined with the kernels (core/simd_kernels.hpp).
const SimdKernels* simd_kernel_table(SimdIsa isa) noexcept;

// BTFLOD_FORCE_ISA / BTFLOD_DISABLE_SIMD, or the best available ISA.
inline SimdIsa simd_initial_isa() noexcept {
  SimdIsa wanted = SimdIsa::avx512;
  if (const char* env = std::getenv("BTFLOD_FORCE_ISA"); env != nullptr && env[0] != '\0')
    simd_isa_from_name(env, wanted);
  if (simd_disabled_by_environment()) wanted = SimdIsa::scalar;
  int i = static_cast<int>(wanted);
  while (i > 0 && !simd_isa_available(static_cast<SimdIsa>(i))) --i;
  return static_cast<SimdIsa>(i);
}

inline std::atomic<const SimdKernels*>& simd_active_table() noexcept {
  static std::atomic<const SimdKernels*> active{nullptr};
  return active;
}
}  // namespace detail

bool simd_isa_from_name(const char* name, SimdIsa& isa) noexcept {
  if (name == nullptr) return false;
  for (int i = 0; i < kSimdIsaCount; ++i) {
    if (std::strcmp(name, simd_isa_name(static_cast<SimdIsa>(i))) == 0) {
      isa = static_cast<SimdIsa>(i);
      return true;
    }
  }
  return false;
}

bool simd_isa_available(SimdIsa isa) noexcept {
  switch (isa) {
    case SimdIsa::scalar:
      return true;
#if BTFLOD_HAS_X86_DISPATCH
    case SimdIsa::avx2: {
      const detail::X86Features& f = detail::x86_features();
      return f.avx2 && f.f16c;
    }
    case SimdIsa::avx512:
      return detail::x86_features().avx512;
#endif
    default:
      return false;
  }
}

const SimdKernels* simd_kernels_for(SimdIsa isa) noexcept {
  return simd_isa_available(isa) ? detail::simd_kernel_table(isa) : nullptr;
}

const SimdKernels& simd_kernels() noexcept {
  const SimdKernels* k = detail::simd_active_table().load(std::memory_order_acquire);
  if (k != nullptr) [[likely]]
    return *k;
  // First use: every racing thread computes the same table; the first store wins.
  const SimdKernels* chosen = detail::simd_kernel_table(detail::simd_initial_isa());
  const SimdKernels* expected = nullptr;
  if (!detail::simd_active_table().compare_exchange_strong(expected, chosen, std::memory_order_acq_rel))
    return *expected;
  return *chosen;
}

SimdIsa simd_active_isa() noexcept { return simd_kernels().isa; }

bool simd_force_isa(SimdIsa isa) noexcept {
  const SimdKernels* k = simd_kernels_for(isa);
  if (k == nullptr) return false;
  detail::simd_active_table().store(k, std::memory_order_release);
  return true;
}

bool simd_disabled_by_environment() noexcept {
  static const bool disabled = [] {
    const char* env = std::getenv("BTFLOD_DISABLE_SIMD");
    return env != nullptr && env[0] != '\0' && env[0] != '0';
  }();
  return disabled;
}

bool cpu_has_f16c() noexcept {
#if BTFLOD_HAS_X86_DISPATCH
  static const bool has = !simd_disabled_by_environment() && detail::x86_features().f16c;
  return has;
#else
  return false;
#endif
}

bool cpu_has_avx2_fma() noexcept {
#if BTFLOD_HAS_X86_DISPATCH
  static const bool has = !simd_disabled_by_environment() && detail::x86_features().avx2 && detail::x86_features().fma;
  return has;
#else
  return false;
#endif
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
