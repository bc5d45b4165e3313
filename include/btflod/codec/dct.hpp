// btflod — 2-D DCT-II on square blocks (paper 000 §6: "a discrete cosine transformation (DCT)
// on 8×8 pixel blocks of the tile-images").
//
// The transform is the orthonormal DCT-II, separable, computed as two matrix products:
//   forward  Y = C · X · Cᵀ,   inverse  X = Cᵀ · Y · C,
//   C[k][n] = s(k) · cos(π (2n + 1) k / (2N)),  s(0) = √(1/N), s(k>0) = √(2/N).
// Orthonormality matters for the quantiser: a coefficient error e_k maps to a spatial error of
// the same energy (Parseval), which is what lets codec/quantize.hpp bound the block RMS error.
//
// Templated on block size N and scalar type S (scalar path). For N = 8 and float there is an
// AVX2/FMA path selected at run time (cpu_has_avx2_fma, core/simd.hpp), defined in the
// implementation TU (BTFLOD_IMPLEMENTATION) and compiled for AVX2 + FMA there; this header
// includes no <immintrin.h>. The scalar twin is always available; set BTFLOD_DISABLE_SIMD=1 to
// force it. Both produce the same result up
// to float rounding (the tests bound the difference).
//
// Layout: blocks are row-major, element (row y, column x) at y * stride + x; coefficient
// (v, u) — v the vertical and u the horizontal frequency — at v * N + u.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <type_traits>

#include "btflod/core/simd.hpp"  // BTFLOD_HAS_X86_DISPATCH, cpu_has_avx2_fma

namespace btflod {

/// The DCT-II basis matrix C (N×N, row k = frequency k) in scalar type S, built once on first
/// use. Thread-safe (function-local static); never allocates after the first call.
template <int N, class S>
inline const std::array<S, N * N>& dct_basis() noexcept {
  static_assert(N >= 2 && N <= 64, "block size out of range");
  static const std::array<S, N* N> basis = [] {
    std::array<S, N * N> c{};
    for (int k = 0; k < N; ++k) {
      const long double s = k == 0 ? std::sqrt(1.0L / N) : std::sqrt(2.0L / N);
      for (int n = 0; n < N; ++n) {
        c[k * N + n] = static_cast<S>(s * std::cos(std::numbers::pi_v<long double> * (2 * n + 1) * k / (2.0L * N)));
      }
    }
    return c;
  }();
  return basis;
}

/// Forward 2-D DCT-II of one N×N block, scalar path. `in` has row stride `in_stride` elements;
/// `out` receives N*N coefficients, (v, u) at v*N + u. Preconditions: non-null, non-aliasing.
/// Thread-safe, no allocation.
template <int N, class S>
inline void dct_forward_scalar(const S* in, size_t in_stride, S* out) noexcept {
  const auto& c = dct_basis<N, S>();
  S tmp[N * N];  // tmp = C · X
  for (int k = 0; k < N; ++k) {
    for (int x = 0; x < N; ++x) {
      S acc = 0;
      for (int n = 0; n < N; ++n) acc += c[k * N + n] * in[n * in_stride + x];
      tmp[k * N + x] = acc;
    }
  }
  for (int v = 0; v < N; ++v) {  // out = tmp · Cᵀ
    for (int u = 0; u < N; ++u) {
      S acc = 0;
      for (int n = 0; n < N; ++n) acc += tmp[v * N + n] * c[u * N + n];
      out[v * N + u] = acc;
    }
  }
}

/// Inverse 2-D DCT (DCT-III, the exact inverse of dct_forward_scalar), scalar path. `in` holds
/// N*N coefficients; `out` has row stride `out_stride`. Thread-safe, no allocation.
template <int N, class S>
inline void dct_inverse_scalar(const S* in, S* out, size_t out_stride) noexcept {
  const auto& c = dct_basis<N, S>();
  S tmp[N * N];  // tmp = Cᵀ · Y
  for (int y = 0; y < N; ++y) {
    for (int u = 0; u < N; ++u) {
      S acc = 0;
      for (int k = 0; k < N; ++k) acc += c[k * N + y] * in[k * N + u];
      tmp[y * N + u] = acc;
    }
  }
  for (int y = 0; y < N; ++y) {  // out = tmp · C
    for (int x = 0; x < N; ++x) {
      S acc = 0;
      for (int k = 0; k < N; ++k) acc += tmp[y * N + k] * c[k * N + x];
      out[y * out_stride + x] = acc;
    }
  }
}

#if BTFLOD_HAS_X86_DISPATCH
/// Forward 8×8 DCT, AVX2/FMA kernel (implementation TU). Precondition: cpu_has_avx2_fma();
/// same contract as dct_forward_scalar<8, float>.
void dct8_forward_avx2(const float* in, size_t in_stride, float* out) noexcept;

/// Inverse 8×8 DCT, AVX2/FMA kernel (implementation TU). Precondition: cpu_has_avx2_fma();
/// same contract as dct_inverse_scalar<8, float>.
void dct8_inverse_avx2(const float* in, float* out, size_t out_stride) noexcept;
#endif

/// Forward 2-D DCT with run-time dispatch: the AVX2/FMA path for N = 8 floats when available,
/// otherwise the scalar twin. Thread-safe, no allocation.
template <int N, class S>
inline void dct_forward(const S* in, size_t in_stride, S* out) noexcept {
#if BTFLOD_HAS_X86_DISPATCH
  if constexpr (N == 8 && std::is_same_v<S, float>) {
    if (cpu_has_avx2_fma()) return dct8_forward_avx2(in, in_stride, out);
  }
#endif
  dct_forward_scalar<N, S>(in, in_stride, out);
}

/// Inverse 2-D DCT with run-time dispatch (see dct_forward). Thread-safe, no allocation.
template <int N, class S>
inline void dct_inverse(const S* in, S* out, size_t out_stride) noexcept {
#if BTFLOD_HAS_X86_DISPATCH
  if constexpr (N == 8 && std::is_same_v<S, float>) {
    if (cpu_has_avx2_fma()) return dct8_inverse_avx2(in, out, out_stride);
  }
#endif
  dct_inverse_scalar<N, S>(in, out, out_stride);
}

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) && BTFLOD_HAS_X86_DISPATCH
#include <immintrin.h>

namespace btflod {
namespace detail {
// rows_out[k] = Σ_n a[k*8 + n] · rows[n]: an 8×8 scalar matrix times 8 row vectors.
BTFLOD_TARGET_AVX2_FMA inline void dct8_mul_avx2(const float* a, const __m256* rows, __m256* rows_out) noexcept {
  for (int k = 0; k < 8; ++k) {
    __m256 acc = _mm256_mul_ps(_mm256_broadcast_ss(a + k * 8), rows[0]);
    for (int n = 1; n < 8; ++n) acc = _mm256_fmadd_ps(_mm256_broadcast_ss(a + k * 8 + n), rows[n], acc);
    rows_out[k] = acc;
  }
}

// Basis rows of C and of Cᵀ as 8 vectors each, plus C and Cᵀ as scalar tables.
struct Dct8Tables {
  alignas(32) float c[64];
  alignas(32) float ct[64];
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
}  // namespace detail

BTFLOD_TARGET_AVX2_FMA void dct8_forward_avx2(const float* in, size_t in_stride, float* out) noexcept {
  const auto& t = detail::dct8_tables();
  __m256 rows[8], tmp[8], basis[8];
  for (int n = 0; n < 8; ++n) rows[n] = _mm256_loadu_ps(in + n * in_stride);
  detail::dct8_mul_avx2(t.c, rows, tmp);  // tmp = C · X
  alignas(32) float tmp_s[64];
  for (int k = 0; k < 8; ++k) _mm256_store_ps(tmp_s + k * 8, tmp[k]);
  for (int n = 0; n < 8; ++n) basis[n] = _mm256_load_ps(t.ct + n * 8);
  detail::dct8_mul_avx2(tmp_s, basis, rows);  // out = tmp · Cᵀ
  for (int k = 0; k < 8; ++k) _mm256_storeu_ps(out + k * 8, rows[k]);
}

BTFLOD_TARGET_AVX2_FMA void dct8_inverse_avx2(const float* in, float* out, size_t out_stride) noexcept {
  const auto& t = detail::dct8_tables();
  __m256 rows[8], tmp[8], basis[8];
  for (int n = 0; n < 8; ++n) rows[n] = _mm256_loadu_ps(in + n * 8);
  detail::dct8_mul_avx2(t.ct, rows, tmp);  // tmp = Cᵀ · Y
  alignas(32) float tmp_s[64];
  for (int k = 0; k < 8; ++k) _mm256_store_ps(tmp_s + k * 8, tmp[k]);
  for (int n = 0; n < 8; ++n) basis[n] = _mm256_load_ps(t.c + n * 8);
  detail::dct8_mul_avx2(tmp_s, basis, rows);  // out = tmp · C
  for (int k = 0; k < 8; ++k) _mm256_storeu_ps(out + k * out_stride, rows[k]);
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
