// btflod — the SIMD kernels, written once. NOT a standalone header: core/simd_kernels.hpp includes
// this file once per instruction set (the libdeflate "template" pattern), inside a namespace of
// its own, after defining
//   V                      the vector-operations type of that ISA (F8 = 8 float lanes: zero,
//                          load, store, bcast, mul, add, add_interleaved4, add_strided;
//                          mul1 (one float product, out of FMA contraction), permute (lanes
//                          by an index table), middle (lanes 4..11 of two vectors); kHalfLanes with half_to_float_lanes
//                          / float_to_half_lanes; kMarkLanes with ne_mask);
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

// Forward 8x8 DCT-II: tmp = C · X, then out = tmp · Cᵀ (core/dct.hpp).
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
    for (; k < lim; ++k)
      m |= static_cast<uint64_t>(p[k] != p[static_cast<ptrdiff_t>(k) - 1]) << k;  // words[-1] is readable
    marks[q / 64] = m;
  }
}

// g·a + f·b with both products kept out of FMA contraction (the order of the scalar loops).
BTFLOD_KERNEL_INLINE float blend1(float g, float a, float f, float b) noexcept { return V::mul1(g, a) + V::mul1(f, b); }

// Output texel of an up-sampled row: gx·column[x0] + fx·column[x0 + 1], channel by channel.
BTFLOD_KERNEL_INLINE void upsample_texel(const float* column, uint32_t x0, float fx, uint32_t channels,
                                         float* dst) noexcept {
  const float gx = 1.0f - fx;
  const float* a = column + size_t{x0} * channels;
  for (uint32_t k = 0; k < channels; ++k) dst[k] = blend1(gx, a[k], fx, a[channels + k]);
}

// The same texel with its two column values blended on the spot from the parent rows (the
// vertical blend gy·row0 + fy·row1 of the column array, same bits).
BTFLOD_KERNEL_INLINE void upsample_texel_from_rows(const float* row0, const float* row1, float gy, float fy,
                                                   uint32_t x0, float fx, uint32_t channels, float* dst) noexcept {
  const float gx = 1.0f - fx;
  const size_t at = size_t{x0} * channels;
  for (uint32_t k = 0; k < channels; ++k) {
    const float a = blend1(gy, row0[at + k], fy, row1[at + k]);
    const float b = blend1(gy, row0[at + channels + k], fy, row1[at + channels + k]);
    dst[k] = blend1(gx, a, fx, b);
  }
}

// Bilinear up-sampling of a parent tile (runtime/codec/tile_codec.hpp, upsample_parent; the scalar loops
// it reproduces are detail::upsample_parent_reference). Per output row j: column = gy·(parent row
// y0) + fy·(row y0 + 1) over the parent columns the row uses, then texel i = gx·column[x0] +
// fx·column[x0 + 1]. Child texels fall half a parent texel apart, so inside the tile they come in
// pairs (i, i + 1) with adjacent taps x0, x0 + 1 and the same two weights in every pair (0.75 and
// 0.25, in the order of the child's quarter-texel offset). For C = 4 a pair is one vector: the
// vertical blend W of parent texels (x0, x0 + 1) and the next one W' give two pairs as
// g·W + f·M and g·M + f·W' with M = (x0 + 1, x0 + 2) the middle of W and W', all in registers.
// For C = 1, 2, 4 / C pairs are one vector of lanes spread from two loads of the column array.
// Texels before or after the run of pairs (a tap clamped at the edge, weights outside [0, 1] when
// B = 0) and C = 3 take the per-texel path. Every lane computes the reference's products and sums.
BTFLOD_KERNEL_ATTR void upsample_parent(const float* parent, uint32_t s, uint32_t channels, float base_x, float base_y,
                                        float* out) noexcept {
  const uint32_t ch = channels;
  uint16_t x0s[1024];
  float fxs[1024];
  uint32_t lo = 0, hi = 0;  // parent columns used: [lo, hi]
  for (uint32_t i = 0; i < s; ++i) {
    const float px = base_x + static_cast<float>(i) * 0.5f;
    uint32_t x0 = static_cast<uint32_t>(px);
    if (x0 > s - 2) x0 = s - 2;
    x0s[i] = static_cast<uint16_t>(x0);
    fxs[i] = px - static_cast<float>(x0);
    if (i == 0) lo = x0;
    hi = x0 + 1;
  }
  for (uint32_t i = 0; i < s; ++i) x0s[i] = static_cast<uint16_t>(x0s[i] - lo);

  // The run of pairs: pair p covers texels first + 2p and first + 2p + 1, taps x0s[first] + p and
  // x0s[first] + p + 1, weights those of the first pair (compared bit for bit).
  uint32_t first = 0, pairs = 0;
  while (first + 1 < s && x0s[first + 1] != x0s[first] + 1u) ++first;
  for (uint32_t i = first; i + 1 < s; i += 2, ++pairs) {
    if (x0s[i] != x0s[first] + pairs || x0s[i + 1] != x0s[i] + 1u) break;
    if (std::memcmp(&fxs[i], &fxs[first], sizeof(float)) != 0 ||
        std::memcmp(&fxs[i + 1], &fxs[first + 1], sizeof(float)) != 0)
      break;
  }
  const bool fused = ch == 4 && pairs >= 2;
  const uint32_t pairs_per_vector = fused ? 2u : ch == 3 ? 0u : 4u / ch;
  const uint32_t vector_pairs = pairs_per_vector == 0 ? 0u : pairs - pairs % pairs_per_vector;
  const uint32_t vector_end = first + 2 * vector_pairs;  // texels [first, vector_end) go by vectors
  // Lane l holds channel l % C of texel t = l / C of the vector: pair t / 2, member t % 2.
  alignas(32) float gx_lanes[8] = {}, fx_lanes[8] = {};
  alignas(32) int32_t lane_src[8] = {};
  if (vector_pairs > 0) {
    for (uint32_t l = 0; l < 8; ++l) {
      const uint32_t t = l / ch, member = t % 2;
      fx_lanes[l] = fxs[first + member];
      gx_lanes[l] = 1.0f - fx_lanes[l];
      lane_src[l] = static_cast<int32_t>((t / 2 + member) * ch + l % ch);
    }
  }
  const typename V::F8 gx_vec = V::load(gx_lanes), fx_vec = V::load(fx_lanes);

  float column[1024 * 4 + 8];  // + 8: the last vectors' unused lanes read zeros
  const uint32_t n = (hi - lo + 1) * ch;
  if (!fused)
    for (uint32_t k = n; k < n + 8; ++k) column[k] = 0.0f;
  for (uint32_t j = 0; j < s; ++j) {
    const float py = base_y + static_cast<float>(j) * 0.5f;
    uint32_t y0 = static_cast<uint32_t>(py);
    if (y0 > s - 2) y0 = s - 2;
    const float fy = py - static_cast<float>(y0), gy = 1.0f - fy;
    const float* row0 = parent + (size_t{y0} * s + lo) * ch;
    const float* row1 = row0 + size_t{s} * ch;
    const typename V::F8 gy_vec = V::bcast(gy), fy_vec = V::bcast(fy);
    float* dst = out + size_t{j} * s * ch;

    if (fused) {
      for (uint32_t i = 0; i < first; ++i)
        upsample_texel_from_rows(row0, row1, gy, fy, x0s[i], fxs[i], 4, dst + size_t{i} * 4);
      const float* r0 = row0 + size_t{x0s[first]} * 4;
      const float* r1 = row1 + size_t{x0s[first]} * 4;
      float* d = dst + size_t{first} * 4;
      typename V::F8 w = V::add(V::mul(gy_vec, V::load(r0)), V::mul(fy_vec, V::load(r1)));
      for (uint32_t p = 0; p < vector_pairs; p += 2) {
        const size_t next = size_t{p + 2} * 4;
        const typename V::F8 w_next = V::add(V::mul(gy_vec, V::load(r0 + next)), V::mul(fy_vec, V::load(r1 + next)));
        const typename V::F8 mid = V::middle(w, w_next);
        V::store(d + size_t{p} * 8, V::add(V::mul(gx_vec, w), V::mul(fx_vec, mid)));
        V::store(d + size_t{p} * 8 + 8, V::add(V::mul(gx_vec, mid), V::mul(fx_vec, w_next)));
        w = w_next;
      }
      for (uint32_t i = vector_end; i < s; ++i)
        upsample_texel_from_rows(row0, row1, gy, fy, x0s[i], fxs[i], 4, dst + size_t{i} * 4);
      continue;
    }

    uint32_t k = 0;
    for (; k + 8 <= n; k += 8)
      V::store(column + k, V::add(V::mul(gy_vec, V::load(row0 + k)), V::mul(fy_vec, V::load(row1 + k))));
    for (; k < n; ++k) column[k] = blend1(gy, row0[k], fy, row1[k]);
    for (uint32_t i = 0; i < first; ++i) upsample_texel(column, x0s[i], fxs[i], ch, dst + size_t{i} * ch);
    if (ch == 4) {  // at most one pair
      for (uint32_t i = first; i < vector_end; i += 2) {
        const float* a = column + size_t{x0s[i]} * 4;
        V::store(dst + size_t{i} * 4, V::add(V::mul(gx_vec, V::load(a)), V::mul(fx_vec, V::load(a + 4))));
      }
    } else {
      for (uint32_t i = first; i < vector_end; i += 2 * pairs_per_vector) {
        const float* a = column + size_t{x0s[i]} * ch;
        const typename V::F8 ta = V::permute(V::load(a), lane_src), tb = V::permute(V::load(a + ch), lane_src);
        V::store(dst + size_t{i} * ch, V::add(V::mul(gx_vec, ta), V::mul(fx_vec, tb)));
      }
    }
    for (uint32_t i = vector_end; i < s; ++i) upsample_texel(column, x0s[i], fxs[i], ch, dst + size_t{i} * ch);
  }
}

inline constexpr SimdKernels kTable = {V::kIsa,        &half_to_float,  &float_to_half, &dct8_forward,   &dct8_inverse,
                                       &tile_idct_add, &tile_idct_add4, &run_marks,     &upsample_parent};
