// btflod — the SIMD kernels, written once. NOT a standalone header: core/simd_kernels.hpp includes
// this file once per instruction set (the libdeflate "template" pattern), inside a namespace of
// its own, after defining
//   V                      the vector-operations type of that ISA (F8 = 8 float lanes: zero,
//                          load, store, bcast, mul, add, add_interleaved4, add_strided;
//                          kHalfLanes with half_to_float_lanes / float_to_half_lanes;
//                          kMarkLanes with ne_mask);
//   BTFLOD_KERNEL_ATTR     the function attribute compiling the code for that ISA (may be empty);
//   BTFLOD_KERNEL_INLINE   BTFLOD_KERNEL_ATTR plus forced inlining, for the helpers.
// Every sum is evaluated in the same order in every build, starting from its first product, with
// V::mul keeping each product out of FMA contraction: each build returns the scalar twin's bits.

// Σ_{j < count} a[j] · rows[j], j ascending. Precondition: count >= 1.
BTFLOD_KERNEL_INLINE typename V::F8 lincomb(const float* a, const typename V::F8* rows, uint32_t count) noexcept {
  typename V::F8 acc = V::mul(V::bcast(a[0]), rows[0]);
  for (uint32_t j = 1; j < count; ++j) acc = V::add(acc, V::mul(V::bcast(a[j]), rows[j]));
  return acc;
}

BTFLOD_KERNEL_ATTR void half_to_float(const uint16_t* in, float* out, size_t n) noexcept {
  size_t i = 0;
  for (; i + V::kHalfLanes <= n; i += V::kHalfLanes) V::half_to_float_lanes(in + i, out + i);
  for (; i < n; ++i) out[i] = half_bits_to_float(in[i]);
}

BTFLOD_KERNEL_ATTR void float_to_half(const float* in, uint16_t* out, size_t n) noexcept {
  size_t i = 0;
  for (; i + V::kHalfLanes <= n; i += V::kHalfLanes) V::float_to_half_lanes(in + i, out + i);
  for (; i < n; ++i) out[i] = float_to_half_bits(in[i]);
}

// Forward 8x8 DCT-II: tmp = C · X, then out = tmp · Cᵀ (codec/dct.hpp).
BTFLOD_KERNEL_ATTR void dct8_forward(const float* in, size_t in_stride, float* out) noexcept {
  const Dct8Tables& t = dct8_tables();
  typename V::F8 rows[8], basis[8];
  alignas(64) float tmp[64];
  for (int n = 0; n < 8; ++n) rows[n] = V::load(in + n * in_stride);
  for (int k = 0; k < 8; ++k) V::store(tmp + k * 8, lincomb(t.c + k * 8, rows, 8));  // tmp[k] = Σ_n C[k][n] X[n]
  for (int n = 0; n < 8; ++n) basis[n] = V::load(t.ct + n * 8);                      // row n of Cᵀ
  for (int v = 0; v < 8; ++v) V::store(out + v * 8, lincomb(tmp + v * 8, basis, 8));
}

// Inverse 8x8 DCT: tmp = Cᵀ · Y, then out = tmp · C.
BTFLOD_KERNEL_ATTR void dct8_inverse(const float* in, float* out, size_t out_stride) noexcept {
  const Dct8Tables& t = dct8_tables();
  typename V::F8 rows[8], basis[8];
  alignas(64) float tmp[64];
  for (int k = 0; k < 8; ++k) rows[k] = V::load(in + k * 8);
  for (int y = 0; y < 8; ++y) V::store(tmp + y * 8, lincomb(t.ct + y * 8, rows, 8));  // Σ_k C[k][y] Y[k]
  for (int k = 0; k < 8; ++k) basis[k] = V::load(t.c + k * 8);
  for (int y = 0; y < 8; ++y) V::store(out + y * out_stride, lincomb(tmp + y * 8, basis, 8));
}

// X = Cᵀ · (Y · C) of one tile block as 8 row vectors, over its non-zero rows and columns only.
// Precondition: 1 <= rows, cols <= 8.
BTFLOD_KERNEL_INLINE void tile_idct_rows(const float* coef, uint32_t rows, uint32_t cols,
                                         typename V::F8* out) noexcept {
  const Dct8Tables& t = dct8_tables();
  typename V::F8 basis[8], z[8];
  for (uint32_t u = 0; u < cols; ++u) basis[u] = V::load(t.c + u * 8);
  for (uint32_t k = 0; k < rows; ++k) z[k] = lincomb(coef + k * 8, basis, cols);  // z[k] = Σ_u Y[k][u] C[u]
  for (int y = 0; y < 8; ++y) out[y] = lincomb(t.ct + y * 8, z, rows);            // Σ_k C[k][y] z[k]
}

BTFLOD_KERNEL_ATTR void tile_idct_add(const TileCoefBlock& b, float* dst, size_t row_stride, size_t step) noexcept {
  const uint32_t rows = b.rows < 8 ? b.rows : 8, cols = b.cols < 8 ? b.cols : 8;
  if (rows == 0 || cols == 0) return;
  typename V::F8 r[8];
  tile_idct_rows(b.coef, rows, cols, r);
  for (int y = 0; y < 8; ++y) V::add_strided(dst + size_t(y) * row_stride, step, r[y]);
}

BTFLOD_KERNEL_ATTR void tile_idct_add4(const TileCoefBlock* b, float* dst, size_t row_stride) noexcept {
  typename V::F8 r[4][8];
  bool any = false;
  for (int c = 0; c < 4; ++c) {
    const uint32_t rows = b[c].rows < 8 ? b[c].rows : 8, cols = b[c].cols < 8 ? b[c].cols : 8;
    if (rows == 0 || cols == 0) {
      for (int y = 0; y < 8; ++y) r[c][y] = V::zero();
    } else {
      tile_idct_rows(b[c].coef, rows, cols, r[c]);
      any = true;
    }
  }
  if (!any) return;
  for (int y = 0; y < 8; ++y) V::add_interleaved4(dst + size_t(y) * row_stride, r[0][y], r[1][y], r[2][y], r[3][y]);
}

BTFLOD_KERNEL_ATTR void run_marks(const uint32_t* words, size_t n, uint64_t* marks) noexcept {
  for (size_t q = 0; q < n; q += 64) {
    const size_t lim = n - q < 64 ? n - q : 64;
    const uint32_t* p = words + q;
    uint64_t m = 0;
    size_t k = 0;
    for (; k + V::kMarkLanes <= lim; k += V::kMarkLanes) m |= V::ne_mask(p + k) << k;
    for (; k < lim; ++k) m |= static_cast<uint64_t>(p[k] != p[k - 1]) << k;
    marks[q / 64] = m;
  }
}

inline constexpr SimdKernels kTable = {V::kIsa,       &half_to_float, &float_to_half,  &dct8_forward,
                                       &dct8_inverse, &tile_idct_add, &tile_idct_add4, &run_marks};
