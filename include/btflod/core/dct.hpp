// btflod — 2-D DCT-II on square blocks (paper 000 §6: "a discrete cosine transformation (DCT)
// on 8×8 pixel blocks of the tile-images").
//
// The transform is the orthonormal DCT-II, separable, computed as two matrix products:
//   forward  Y = C · X · Cᵀ,   inverse  X = Cᵀ · Y · C,
//   C[k][n] = s(k) · cos(π (2n + 1) k / (2N)),  s(0) = √(1/N), s(k>0) = √(2/N).
// Orthonormality matters for the quantiser: a coefficient error e_k maps to a spatial error of
// the same energy (Parseval), which is what lets runtime/codec/quantize.hpp bound the block RMS error.
//
// Templated on block size N and scalar type S (scalar path). For N = 8 and float the transform is
// one of the SIMD kernels of core/simd.hpp (written once, compiled per ISA in the implementation
// TU, chosen once at run time); every ISA build returns the scalar twin's bits. This header
// includes no <immintrin.h>. The tile decoder's inverse DCT (TileCoefBlock, tile_idct_add,
// tile_idct_add4) is a kernel of the same table.
//
// Layout: blocks are row-major, element (row y, column x) at y * stride + x; coefficient
// (v, u) — v the vertical and u the horizontal frequency — at v * N + u.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <type_traits>

#include "btflod/core/simd.hpp"

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

/// One 8×8 block of dequantised coefficients (natural order, (v, u) at v*8 + u) and the extent
/// of its non-zero coefficients: rows v < rows and columns u < cols may be non-zero, the rest are
/// 0 (rows = 0: the block is all zero). The tile decoder's inverse-DCT input.
struct TileCoefBlock {
  alignas(32) float coef[64];
  uint32_t rows = 0;
  uint32_t cols = 0;
};

#if BTFLOD_HAS_X86_DISPATCH
/// Forward 8×8 DCT of the AVX2 build (simd_kernels_for(SimdIsa::avx2)->dct8_forward).
/// Precondition: simd_isa_available(SimdIsa::avx2); same contract as dct_forward<8, float>.
void dct8_forward_avx2(const float* in, size_t in_stride, float* out) noexcept;

/// Inverse 8×8 DCT of the AVX2 build. Precondition: simd_isa_available(SimdIsa::avx2); same
/// contract as dct_inverse<8, float>.
void dct8_inverse_avx2(const float* in, float* out, size_t out_stride) noexcept;
#endif

/// Forward 2-D DCT with run-time dispatch: for N = 8 floats the kernel of the ISA build in use
/// (simd_kernels(), bit-identical in every build), otherwise dct_forward_scalar. Thread-safe, no
/// allocation.
template <int N, class S>
inline void dct_forward(const S* in, size_t in_stride, S* out) noexcept {
  if constexpr (N == 8 && std::is_same_v<S, float>) {
    simd_kernels().dct8_forward(in, in_stride, out);
  } else {
    dct_forward_scalar<N, S>(in, in_stride, out);
  }
}

/// Inverse 2-D DCT with run-time dispatch (see dct_forward). Thread-safe, no allocation.
template <int N, class S>
inline void dct_inverse(const S* in, S* out, size_t out_stride) noexcept {
  if constexpr (N == 8 && std::is_same_v<S, float>) {
    simd_kernels().dct8_inverse(in, out, out_stride);
  } else {
    dct_inverse_scalar<N, S>(in, out, out_stride);
  }
}

/// Adds the inverse DCT of `b` to an 8×8 block of channel samples at `dst` (row stride
/// `row_stride`, column stride `step` floats) with the ISA build in use (SimdKernels::
/// tile_idct_add). Thread-safe, no allocation.
inline void tile_idct_add(const TileCoefBlock& b, float* dst, size_t row_stride, size_t step) noexcept {
  simd_kernels().tile_idct_add(b, dst, row_stride, step);
}

/// The four channel blocks of one block position of a 4-channel tile, added interleaved at
/// `dst` (SimdKernels::tile_idct_add4). Thread-safe, no allocation.
inline void tile_idct_add4(const TileCoefBlock* b, float* dst, size_t row_stride) noexcept {
  simd_kernels().tile_idct_add4(b, dst, row_stride);
}

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
// The kernels, their tables and dct8_forward_avx2 / dct8_inverse_avx2.
#include "btflod/core/simd_kernels.hpp"
#endif  // BTFLOD_IMPLEMENTATION
