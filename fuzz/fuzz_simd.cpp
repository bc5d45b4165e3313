// Differential libFuzzer target for the SIMD kernels of core/simd.hpp: every ISA build the CPU
// runs (AVX2, AVX-512) must return the scalar twin's bits on every input. Byte 0 selects the
// kernel (value % 6), the rest is its input:
//   0  half -> float      the bytes as binary16 patterns
//   1  float -> half      the bytes as float bit patterns (NaN payloads, subnormals, overflow)
//   2  8x8 DCT            forward and inverse of 64 floats from the bytes, row stride 8..15
//   3  tile inverse DCT   four coefficient blocks (rows, cols from the bytes, 0..8 each) added
//                         interleaved to 8 rows of a 4-channel tile, and one block added with a
//                         column step 1..4
//   4  run detection      feedback words from the bytes (small alphabet, so runs occur), the
//                         run marks of each build, and VoteCounter::count under each forced build
//   5  parent up-sampling a parent tile of s x s texels (s 2..40, 1..4 channels, origin at any
//                         quarter texel in (-1, s/2)) from the bytes; every build and the scalar
//                         twin against the plain separable loops (detail::upsample_parent_reference)
// A mismatch traps. Floats are compared by bits, except that any two NaN are equal: the payload of
// a NaN made from two NaN operands is unspecified by IEEE 754 (core/simd.hpp). On a CPU without
// SIMD builds the target still runs the scalar twin (no comparison).
//
// Speed: no allocation per input (fixed static buffers; the vote counters are built once).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "btflod/core/dct.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/simd.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/lod/feedback.hpp"

namespace {
using namespace btflod;

constexpr size_t kMaxBytes = 65536;

bool same_float(float a, float b) {
  if (std::isnan(a) && std::isnan(b)) return true;
  uint32_t x, y;
  std::memcpy(&x, &a, 4);
  std::memcpy(&y, &b, 4);
  return x == y;
}

void check_floats(const float* a, const float* b, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (!same_float(a[i], b[i])) __builtin_trap();
}

int simd_build_count(const SimdKernels* builds[kSimdIsaCount]) {
  int n = 0;
  for (int i = 1; i < kSimdIsaCount; ++i)
    if (const SimdKernels* k = simd_kernels_for(static_cast<SimdIsa>(i))) builds[n++] = k;
  return n;
}

float float_at(const uint8_t* p, size_t size, size_t i) {  // 0 past the end
  float f = 0;
  if (4 * i + 4 <= size) std::memcpy(&f, p + 4 * i, 4);
  return f;
}

void fuzz_half_to_float(const SimdKernels& s, const SimdKernels* const* builds, int nb, const uint8_t* p, size_t size) {
  static uint16_t in[kMaxBytes / 2];
  static float ref[kMaxBytes / 2], got[kMaxBytes / 2];
  const size_t n = size / 2;
  std::memcpy(in, p, n * 2);
  s.half_to_float(in, ref, n);
  for (int b = 0; b < nb; ++b) {
    builds[b]->half_to_float(in, got, n);
    if (std::memcmp(got, ref, n * sizeof(float)) != 0) __builtin_trap();  // no arithmetic: exact bits
  }
}

void fuzz_float_to_half(const SimdKernels& s, const SimdKernels* const* builds, int nb, const uint8_t* p, size_t size) {
  static float in[kMaxBytes / 4];
  static uint16_t ref[kMaxBytes / 4], got[kMaxBytes / 4];
  const size_t n = size / 4;
  std::memcpy(in, p, n * 4);
  s.float_to_half(in, ref, n);
  for (size_t i = 0; i < n; ++i)
    if (ref[i] != float_to_half_bits(in[i])) __builtin_trap();
  for (int b = 0; b < nb; ++b) {
    builds[b]->float_to_half(in, got, n);
    if (std::memcmp(got, ref, n * sizeof(uint16_t)) != 0) __builtin_trap();
  }
}

void fuzz_dct(const SimdKernels& s, const SimdKernels* const* builds, int nb, const uint8_t* p, size_t size) {
  const size_t stride = 8 + (size > 0 ? p[0] % 8 : 0);
  if (size > 0) {
    ++p;
    --size;
  }
  float in[8 * 15] = {}, ref_f[64], ref_i[8 * 15], got_f[64], got_i[8 * 15];
  for (size_t y = 0; y < 8; ++y)
    for (size_t x = 0; x < 8; ++x) in[y * stride + x] = float_at(p, size, y * 8 + x);
  s.dct8_forward(in, stride, ref_f);
  s.dct8_inverse(ref_f, ref_i, stride);
  for (int b = 0; b < nb; ++b) {
    builds[b]->dct8_forward(in, stride, got_f);
    check_floats(got_f, ref_f, 64);
    builds[b]->dct8_inverse(ref_f, got_i, stride);
    for (size_t y = 0; y < 8; ++y) check_floats(got_i + y * stride, ref_i + y * stride, 8);
  }
}

void fuzz_tile_idct(const SimdKernels& s, const SimdKernels* const* builds, int nb, const uint8_t* p, size_t size) {
  constexpr size_t kRowStride = 40;  // 8 texels x 4 channels + slack
  static TileCoefBlock blocks[4];
  uint8_t shape[5] = {};
  std::memcpy(shape, p, size < 5 ? size : 5);
  p += size < 5 ? size : 5;
  size -= size < 5 ? size : 5;
  size_t f = 0;
  for (int c = 0; c < 4; ++c) {
    blocks[c].rows = shape[c] % 9;
    blocks[c].cols = (shape[c] >> 4) % 9;
    for (float& v : blocks[c].coef) v = float_at(p, size, f++);
  }
  const size_t step = 1 + shape[4] % 4;
  float base[8 * kRowStride], ref[8 * kRowStride], got[8 * kRowStride];
  for (float& v : base) v = float_at(p, size, f++);
  std::memcpy(ref, base, sizeof ref);
  s.tile_idct_add4(blocks, ref, kRowStride);
  for (int b = 0; b < nb; ++b) {
    std::memcpy(got, base, sizeof got);
    builds[b]->tile_idct_add4(blocks, got, kRowStride);
    check_floats(got, ref, 8 * kRowStride);
  }
  const TileCoefBlock& one = blocks[(shape[4] >> 2) % 4];
  std::memcpy(ref, base, sizeof ref);
  s.tile_idct_add(one, ref + 1, kRowStride, step);
  for (int b = 0; b < nb; ++b) {
    std::memcpy(got, base, sizeof got);
    builds[b]->tile_idct_add(one, got + 1, kRowStride, step);
    check_floats(got, ref, 8 * kRowStride);
  }
}

void fuzz_runs(const SimdKernels& s, const SimdKernels* const* builds, int nb, const uint8_t* p, size_t size) {
  static uint32_t words[kMaxBytes + 1];
  static uint64_t ref[kMaxBytes / 64 + 1], got[kMaxBytes / 64 + 1];
  // A small alphabet of words (valid tiles of two materials, a rejected word, no-tile), so that
  // runs of every length occur.
  static const uint32_t alphabet[8] = {pack_feedback({0, 3, 1, 2}),   pack_feedback({0, 3, 2, 2}),
                                       pack_feedback({1, 2, 0, 3}),   pack_feedback({0, 0, 0, 0}),
                                       pack_feedback({5, 1, 0, 0}),   kFeedbackNone,
                                       pack_feedback({1, 9, 500, 7}), pack_feedback({0, 3, 1, 3})};
  const size_t n = size;
  words[0] = alphabet[0];
  for (size_t i = 0; i < n; ++i) words[i + 1] = (p[i] & 0x80) ? (words[i] ^ (uint32_t{p[i]} << 9)) : alphabet[p[i] & 7];
  s.run_marks(words + 1, n, ref);
  for (int b = 0; b < nb; ++b) {
    builds[b]->run_marks(words + 1, n, got);
    if (std::memcmp(got, ref, ((n + 63) / 64) * sizeof(uint64_t)) != 0) __builtin_trap();
  }
  // The whole vote count under each forced build.
  static const VoteLayout layouts[2] = {{4, 16, 16}, {3, 8, 8}};
  static VoteCounter ref_counter(layouts), counter(layouts);
  const SimdIsa saved = simd_active_isa();
  simd_force_isa(SimdIsa::scalar);
  const size_t valid = ref_counter.count({words + 1, n}, 2, p[0] % 3);
  const auto touched = ref_counter.touched();
  for (int b = 0; b < nb; ++b) {
    simd_force_isa(builds[b]->isa);
    if (counter.count({words + 1, n}, 2, p[0] % 3) != valid) __builtin_trap();
    if (counter.touched().size() != touched.size()) __builtin_trap();
    for (size_t i = 0; i < touched.size(); ++i) {
      if (counter.touched()[i] != touched[i]) __builtin_trap();
      const FeedbackTile t = unpack_feedback(touched[i]);
      if (counter.votes(t.material, t.level, t.x, t.y) != ref_counter.votes(t.material, t.level, t.x, t.y))
        __builtin_trap();
    }
  }
  simd_force_isa(saved);
}

void fuzz_upsample(const SimdKernels& s, const SimdKernels* const* builds, int nb, const uint8_t* p, size_t size) {
  constexpr uint32_t kMaxSize = 40;
  static float parent[kMaxSize * kMaxSize * 4], ref[kMaxSize * kMaxSize * 4], got[kMaxSize * kMaxSize * 4];
  uint8_t shape[4] = {};
  std::memcpy(shape, p, size < 4 ? size : 4);
  p += size < 4 ? size : 4;
  size -= size < 4 ? size : 4;
  const uint32_t n = 2 + shape[0] % (kMaxSize - 1), channels = 1 + shape[1] % 4;
  // The decoder's origins are q·T/2 + B/2 − 1/4; any quarter texel in [−1/4, n/2 − 1/2] here.
  const float base_x = -0.25f + 0.25f * static_cast<float>(shape[2] % (2 * n));
  const float base_y = -0.25f + 0.25f * static_cast<float>(shape[3] % (2 * n));
  const size_t count = size_t{n} * n * channels;
  for (size_t i = 0; i < count; ++i) parent[i] = float_at(p, size, i);
  detail::upsample_parent_reference(parent, n, channels, base_x, base_y, ref);
  s.upsample_parent(parent, n, channels, base_x, base_y, got);
  check_floats(got, ref, count);
  for (int b = 0; b < nb; ++b) {
    builds[b]->upsample_parent(parent, n, channels, base_x, base_y, got);
    check_floats(got, ref, count);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1 || size > kMaxBytes) return 0;
  const SimdKernels* builds[kSimdIsaCount];
  const int nb = simd_build_count(builds);
  const SimdKernels& s = *simd_kernels_for(SimdIsa::scalar);
  const uint8_t* p = data + 1;
  const size_t n = size - 1;
  switch (data[0] % 6) {
    case 0:
      fuzz_half_to_float(s, builds, nb, p, n);
      break;
    case 1:
      fuzz_float_to_half(s, builds, nb, p, n);
      break;
    case 2:
      fuzz_dct(s, builds, nb, p, n);
      break;
    case 3:
      fuzz_tile_idct(s, builds, nb, p, n);
      break;
    case 4:
      if (n > 0) fuzz_runs(s, builds, nb, p, n);
      break;
    default:
      fuzz_upsample(s, builds, nb, p, n);
      break;
  }
  return 0;
}
