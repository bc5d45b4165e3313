// btflod — the tile codec: DCT + quantisation + deflate on residuals to the up-sampled parent
// (paper 000 §6).
//
// A tile is (T + 2B)² texels × C channels of float, texel-interleaved (the 4 eigen-texture
// components of one RGBA texel are adjacent): sample (x, y, c) at (y * S + x) * C + c with
// S = T + 2B. The border is part of the coded tile. A tile at level l > 0 is coded as its
// difference to the bilinearly up-sampled parent tile *as the decoder reconstructs it* (closed
// loop: the encoder decodes its own output and hands that reconstruction back, so the caller
// codes the children against exactly what a client will hold, and errors do not accumulate down
// the hierarchy; paper 000 §6, T'_{i,l}(x,y) = T_{i,l}(x,y) − T_{⌊i/2⌋,l−1}(x/2, y/2)).
//
// Payload layout (little-endian), tile format version 2:
//   u8  format version (2)        u8  block size (8)       u8 channels C (1..4)
//   u8  flags (bit 0: residual to the parent; bits 1–3: 4 − the frequency-weighting exponent in
//       quarters, 0..4 — 0 is JPEG's table, runtime/codec/quantize.hpp quant_step_factors; 5..7 and
//       bits 4–7 are invalid)                              u16 stored width S, u16 stored height S
//   f32 tolerance[C]              (absolute block-RMS error bound per channel, runtime/codec/quantize.hpp)
//   u32 symbol bytes              (size of the inflated symbol stream)
//   raw deflate stream            (RFC 1951, no zlib header) of the symbol stream
// Symbol stream (JPEG-like run-length symbolisation, ITU T.81 F.1.2, but byte-aligned so that
// deflate can model it): for each 8×8 block in raster order, for each channel c, one block code:
//   DC   the quantised DC minus the previous block's DC of channel c (0 before the first block),
//        zig-zag mapped to unsigned (0, −1, 1, −2, … → 0, 1, 2, 3, …), as a LEB128 varint
//        (1..5 bytes, value < 2^31);
//   AC   tokens over zig-zag positions 1..63: byte (r << 4 | m):
//          0x00              end of block: the remaining coefficients are 0;
//          0xF0              16 zero coefficients (r = 15, m = 0);
//          m = 1..14         r zeros (0..15), then a coefficient whose zig-zag mapped value is m;
//          m = 15            r zeros, then a coefficient whose mapped value is 15 + the LEB128
//                            varint that follows;
//        other bytes with m = 0 are invalid. A block whose last coefficient is at position 63
//        has no end-of-block byte.
// Every decoded coefficient lies within ±2^29 quantisation steps (the encoder's limit). Most
// high-frequency coefficients of a residual are 0, so a block is typically a few bytes, inflate
// produces far fewer bytes than one per coefficient, and the decoder skips the zero runs and runs
// the inverse DCT only over the rows and columns that hold non-zero coefficients.
// (Version 1 wrote one byte per coefficient grouped by frequency; it is no longer read.)
//
// Tile format version 3: the same header and symbol stream, with the entropy coder in flags
// bits 4–5 (TileEntropyCoder): 0 = raw deflate as in version 2; 1 = one zstd frame (RFC 8878,
// with its content size, no dictionary) of the symbol stream; 2–3 and bits 6–7 are invalid. The
// encoder writes version 2 for deflate (byte for byte what earlier versions wrote, readable by
// every decoder) and version 3 only for zstd; decoders read both. bench/bench_codec_entropy.cpp
// has the table the coders were chosen from (docs/codec_measurements.md, "Entropy stage").
//
// Entropy backend: RawInflater / RawDeflater below, an opaque handle of fixed size whose state
// lives in the implementation TU (BTFLOD_IMPLEMENTATION, see btflod.hpp): this header includes
// neither zlib nor libdeflate, and no build option changes the layout of any type here. zlib's
// inflate is always compiled in; libdeflate's decompressor (faster on these streams,
// bench/bench_codec.cpp: only with it does decoding beat libjpeg-turbo) is compiled in when the
// implementation TU sees BTFLOD_TILE_CODEC_LIBDEFLATE (the CMake target btflod::btflod defines it
// and links libdeflate when configured with BTFLOD_WITH_LIBDEFLATE, default ON when pkg-config
// finds libdeflate) and is then the decoders' default. The choice is a run-time value
// (InflateBackend, default_inflate_backend(), inflate_backend_available()); a libdeflate request
// without libdeflate compiled in falls back to zlib. The format is the same raw deflate either way.
// zstd (format 3, coder 1) is compiled in when the implementation TU sees BTFLOD_TILE_CODEC_ZSTD
// (CMake BTFLOD_WITH_ZSTD, default ON when pkg-config finds libzstd); without it, decoders reject
// zstd tiles with Status::unsupported and encoders cannot select it
// (tile_entropy_coder_available). Both zstd contexts are static (ZSTD_initStatic*CCtx/DCtx over a
// workspace allocated at set-up), so neither encode() nor decode() allocates.
//
// SIMD: the inverse DCT of each block (for C = 4 the four channels of a block position at once,
// added interleaved) and the parent up-sampling are kernels of core/simd.hpp (tile_idct_add /
// tile_idct_add4, core/dct.hpp; upsample_parent), compiled per ISA and chosen once at run time;
// every build returns the scalar twin's bits, so the encoder's closed loop and any client
// reproduce the same reconstruction on every CPU (TileDecoder::set_simd(false) runs the scalar
// twin).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "btflod/core/allocator.hpp"
#include "btflod/core/dct.hpp"
#include "btflod/core/result.hpp"
#include "btflod/runtime/codec/quantize.hpp"

namespace btflod {

/// Geometry of a coded tile: interior T, border B on each side, C channels per texel.
struct TileLayout {
  uint32_t tile_size = 64;  ///< T, interior texels per side
  uint32_t border = 4;      ///< B, border texels on each side (part of the coded tile)
  uint32_t channels = 4;    ///< C, eigen-texture components per texel (RGBA = 4)

  constexpr uint32_t stored_size() const noexcept { return tile_size + 2 * border; }
  constexpr size_t texel_count() const noexcept { return size_t{stored_size()} * stored_size(); }
  constexpr size_t sample_count() const noexcept { return texel_count() * channels; }
  /// True when the codec can handle the layout: 8 ≤ T, T even, 1 ≤ B, S a multiple of 8 and at
  /// most 1024, 1 ≤ C ≤ 4.
  constexpr bool valid() const noexcept {
    const uint32_t s = stored_size();
    return tile_size >= 8 && tile_size % 2 == 0 && border >= 1 && border <= 64 && s % 8 == 0 && s <= 1024 &&
           channels >= 1 && channels <= 4;
  }
  friend constexpr bool operator==(const TileLayout&, const TileLayout&) = default;
};

inline constexpr uint8_t kTileFormatVersion = 2;
/// Tile format version whose flags carry the entropy coder (see the file comment).
inline constexpr uint8_t kTileFormatVersionCoder = 3;

/// Entropy coder of a tile's symbol stream (flags bits 4–5 of a version-3 header).
enum class TileEntropyCoder : uint8_t {
  deflate = 0,  ///< raw deflate (RFC 1951); written as tile format 2
  zstd = 1,     ///< one zstd frame (RFC 8878) with its content size; tile format 3
};
/// True when the implementation TU can code `coder` (deflate always; zstd with
/// BTFLOD_TILE_CODEC_ZSTD — decoding only under BTFLOD_TILE_CODEC_ZSTD_DECODER_ONLY). Thread-safe.
bool tile_entropy_coder_available(TileEntropyCoder coder) noexcept;
/// The coder encoders use unless told otherwise (BsvtfBuildOptions::entropy_coder): zstd when the
/// implementation TU can encode it (BTFLOD_TILE_CODEC_ZSTD without _DECODER_ONLY), else deflate.
/// zstd tiles are smaller and decode faster (docs/codec_measurements.md, "Entropy stage"). Thread-safe.
TileEntropyCoder default_tile_entropy_coder() noexcept;
inline constexpr int kTileBlock = 8;
inline constexpr uint32_t kTileMaxChannels = 4;
/// Largest magnitude of a quantised coefficient, in quantisation steps (encoder and decoder).
inline constexpr int64_t kTileMaxCoefficient = int64_t{1} << 29;

/// Size of the payload header for `channels` channels.
constexpr size_t tile_header_size(uint32_t channels) noexcept { return 12 + 4 * size_t{channels}; }

/// Number of 8×8 channel blocks of a tile: (S/8)² · C.
constexpr size_t tile_block_count(uint32_t stored_size, uint32_t channels) noexcept {
  return size_t{stored_size / kTileBlock} * (stored_size / kTileBlock) * channels;
}
/// Longest block code: a 5-byte DC varint and 63 tokens of 1 byte + a 5-byte varint each.
inline constexpr size_t kTileMaxBlockCode = 5 + 63 * 6;
/// Shortest block code: a 1-byte DC varint and the end-of-block byte.
inline constexpr size_t kTileMinBlockCode = 2;

/// Worst-case size of the symbol stream of one tile (every block at its longest code).
constexpr size_t tile_symbol_bound(const TileLayout& layout) noexcept {
  return tile_block_count(layout.stored_size(), layout.channels) * kTileMaxBlockCode;
}

/// Worst-case size of one encoded tile: the buffer size that tile_encode can always fill.
/// Returns 0 for an invalid layout. Thread-safe.
inline size_t tile_encode_bound(const TileLayout& layout) noexcept {
  if (!layout.valid()) return 0;
  // zlib's compressBound(n) (1.2.12+), an upper bound of any deflate level's raw stream of n bytes.
  const size_t n = tile_symbol_bound(layout);
  return tile_header_size(layout.channels) + n + (n >> 12) + (n >> 14) + (n >> 25) + 13;
}

namespace detail {
template <uint32_t C>
inline void upsample_parent_rows(uint32_t s, float base_x, float base_y, const float* parent, float* out) noexcept {
  // Separable: per output row, blend the two parent rows vertically over the columns the row
  // needs, then blend horizontally with per-column taps (computed once per call).
  uint16_t x0s[1024];
  float fxs[1024];
  for (uint32_t i = 0; i < s; ++i) {
    const float px = base_x + static_cast<float>(i) * 0.5f;
    uint32_t x0 = static_cast<uint32_t>(px);
    if (x0 > s - 2) x0 = s - 2;
    x0s[i] = static_cast<uint16_t>(x0);
    fxs[i] = px - static_cast<float>(x0);
  }
  const uint32_t lo = x0s[0], hi = x0s[s - 1] + 1u;  // parent columns used: [lo, hi]
  float column[1024 * C];
  for (uint32_t j = 0; j < s; ++j) {
    const float py = base_y + static_cast<float>(j) * 0.5f;
    uint32_t y0 = static_cast<uint32_t>(py);
    if (y0 > s - 2) y0 = s - 2;
    const float fy = py - static_cast<float>(y0), gy = 1.0f - fy;
    const float* row0 = parent + (size_t{y0} * s + lo) * C;
    const float* row1 = row0 + size_t{s} * C;
    const uint32_t n = (hi - lo + 1) * C;
    for (uint32_t k = 0; k < n; ++k) column[k] = gy * row0[k] + fy * row1[k];
    float* dst = out + size_t{j} * s * C;
    for (uint32_t i = 0; i < s; ++i) {
      const float fx = fxs[i], gx = 1.0f - fx;
      const float* a = column + (x0s[i] - lo) * C;
      for (uint32_t k = 0; k < C; ++k) dst[i * C + k] = gx * a[k] + fx * a[C + k];
    }
  }
}

/// The up-sampling of upsample_parent as plain separable loops (the form the SIMD kernel
/// SimdKernels::upsample_parent reproduces bit for bit; tests and benches compare with it):
/// `s` × `s` texels of `channels` floats, output texel (i, j) at parent stored coordinate
/// (base_x + i/2, base_y + j/2). Products and sums are those of the kernel only when this
/// translation unit does not contract them into FMA (no -mfma / -march with FMA, or
/// -ffp-contract=off). Preconditions: those of SimdKernels::upsample_parent. Thread-safe, no
/// allocation (≤ 22 KiB of stack).
inline void upsample_parent_reference(const float* parent, uint32_t s, uint32_t channels, float base_x, float base_y,
                                      float* out) noexcept {
  switch (channels) {
    case 1:
      return upsample_parent_rows<1>(s, base_x, base_y, parent, out);
    case 2:
      return upsample_parent_rows<2>(s, base_x, base_y, parent, out);
    case 3:
      return upsample_parent_rows<3>(s, base_x, base_y, parent, out);
    default:
      return upsample_parent_rows<4>(s, base_x, base_y, parent, out);
  }
}

/// Parent stored coordinate of child texel 0 along one axis for quadrant bit `q` (see
/// upsample_parent): q·T/2 + B/2 − 1/4.
inline float upsample_parent_base(const TileLayout& layout, uint32_t q) noexcept {
  return static_cast<float>(q & 1u) * layout.tile_size * 0.5f + layout.border * 0.5f - 0.25f;
}
}  // namespace detail

/// Bilinear up-sampling of a decoded parent tile to the prediction of its child in quadrant
/// (qx, qy) ∈ {0,1}² (qx = child.x & 1, qy = child.y & 1). A child texel with stored index i
/// lies at parent stored coordinate p = qx·T/2 + B/2 − 1/4 + i/2 (texel centres, level l → l−1
/// halves coordinates); for B ≥ 1 every tap lies inside the parent's stored texels, so the
/// borders provide the filter support. Computed separably (vertical, then horizontal blend) by
/// the SIMD kernel of `kernels` (SimdKernels::upsample_parent; default: the build in use), whose
/// every build returns the same bits, so encoder and decoder predict alike on every CPU.
/// Preconditions: layout.valid(), parent and out hold layout.sample_count() floats and do not
/// overlap. Thread-safe, no allocation (≤ 23 KiB of stack).
inline void upsample_parent(const TileLayout& layout, const float* parent, uint32_t qx, uint32_t qy, float* out,
                            const SimdKernels& kernels = simd_kernels()) noexcept {
  kernels.upsample_parent(parent, layout.stored_size(), layout.channels, detail::upsample_parent_base(layout, qx),
                          detail::upsample_parent_base(layout, qy), out);
}

/// What a payload header says, without decoding (tile_peek_header).
struct TileHeaderInfo {
  uint32_t channels = 0;
  uint32_t stored_size = 0;
  bool residual = false;                           ///< true: decoding needs the parent's decoded tile
  uint32_t weight_quarters = kJpegWeightQuarters;  ///< frequency-weighting exponent γ · 4 (quant_step_factors)
  float tolerance[kTileMaxChannels] = {};
  uint32_t symbol_bytes = 0;
  uint32_t version = kTileFormatVersion;               ///< 2 or 3
  TileEntropyCoder coder = TileEntropyCoder::deflate;  ///< deflate for version 2
};

/// Parses and validates a payload header (format 2 or 3). Returns success, short_output (fewer
/// bytes than a header) or bad_data (unknown version, block size or entropy coder, flags with
/// unknown bits, sizes out of range, tolerance not finite and positive, symbol byte count outside
/// [2, 383] bytes per channel block). It does not check that the coder is compiled in. Safe on untrusted
/// input; thread-safe, no allocation.
inline Status tile_peek_header(std::span<const uint8_t> payload, TileHeaderInfo& info,
                               const char** why = nullptr) noexcept {
  auto fail = [&](Status s, const char* m) {
    if (why) *why = m;
    return s;
  };
  if (payload.size() < 4) return fail(Status::short_output, "tile payload shorter than its header");
  if (payload[0] != kTileFormatVersion && payload[0] != kTileFormatVersionCoder)
    return fail(Status::bad_data, "tile format version is not 2 or 3");
  const uint32_t version = payload[0];
  if (payload[1] != kTileBlock) return fail(Status::bad_data, "tile block size is not 8");
  const uint32_t channels = payload[2];
  if (channels < 1 || channels > kTileMaxChannels) return fail(Status::bad_data, "tile channel count not in 1..4");
  if ((payload[3] & (version == kTileFormatVersion ? ~0x0Fu : ~0x3Fu)) != 0)
    return fail(Status::bad_data, "tile flags have unknown bits set");
  const uint32_t coder = (payload[3] >> 4) & 3u;
  if (coder > static_cast<uint32_t>(TileEntropyCoder::zstd))
    return fail(Status::bad_data, "tile entropy coder not deflate (0) or zstd (1)");
  const uint32_t softening = (payload[3] >> 1) & 7u;
  if (softening > kJpegWeightQuarters) return fail(Status::bad_data, "tile frequency weighting code not in 0..4");
  if (payload.size() < tile_header_size(channels))
    return fail(Status::short_output, "tile payload shorter than its header");
  uint16_t w = 0, h = 0;
  std::memcpy(&w, payload.data() + 4, 2);
  std::memcpy(&h, payload.data() + 6, 2);
  if (w != h || w == 0 || w % kTileBlock != 0 || w > 1024)
    return fail(Status::bad_data, "tile size not square, a multiple of 8 and <= 1024");
  info.channels = channels;
  info.stored_size = w;
  info.residual = (payload[3] & 1u) != 0;
  info.version = version;
  info.coder = static_cast<TileEntropyCoder>(coder);
  info.weight_quarters = kJpegWeightQuarters - softening;
  for (uint32_t c = 0; c < channels; ++c) {
    float t = 0;
    std::memcpy(&t, payload.data() + 8 + 4 * c, 4);
    if (!(t > 0.0f) || !(t < 1e15f)) return fail(Status::bad_data, "tile tolerance not finite and positive");
    info.tolerance[c] = t;
  }
  std::memcpy(&info.symbol_bytes, payload.data() + 8 + 4 * channels, 4);
  const size_t blocks = tile_block_count(w, channels);
  if (info.symbol_bytes < blocks * kTileMinBlockCode || info.symbol_bytes > blocks * kTileMaxBlockCode)
    return fail(Status::bad_data, "tile symbol byte count out of range (2..383 per channel block)");
  return Status::success;
}

/// Which inflate implementation a TileDecoder uses (see the file comment).
enum class InflateBackend : uint8_t { zlib, libdeflate };

/// True when `backend` is compiled into the implementation TU (zlib always; libdeflate when that
/// TU saw BTFLOD_TILE_CODEC_LIBDEFLATE). Thread-safe.
bool inflate_backend_available(InflateBackend backend) noexcept;

/// The decoders' default backend: libdeflate when available, else zlib. Thread-safe.
InflateBackend default_inflate_backend() noexcept;

namespace detail {
struct RawInflaterState;
struct RawDeflaterState;
struct ZstdDecompressorState;
struct ZstdCompressorState;

/// What the (de)compressor handles below share: one pointer to a state `S` defined in the
/// implementation TU, null until the derived class's create() succeeds; not copyable. The derived
/// class's destructor frees the state.
template <class S>
class OpaqueStateHandle {
 public:
  OpaqueStateHandle() noexcept = default;
  OpaqueStateHandle(const OpaqueStateHandle&) = delete;
  OpaqueStateHandle& operator=(const OpaqueStateHandle&) = delete;
  /// True after a successful create().
  bool ready() const noexcept { return state_ != nullptr; }

 protected:
  ~OpaqueStateHandle() = default;
  using State = S;
  State* state_ = nullptr;
};
}  // namespace detail

/// Raw deflate (RFC 1951, no zlib header) decompressor behind an opaque handle: one pointer, the
/// same layout whatever backends are compiled in; the state lives in the implementation TU.
/// create() allocates everything inflate() needs (zlib's 32 KiB window included), so inflate()
/// never allocates. One object per thread.
class RawInflater : public detail::OpaqueStateHandle<detail::RawInflaterState> {
 public:
  ~RawInflater();

  /// Allocates the state for `backend` (libdeflate falls back to zlib when not compiled in; zlib
  /// also classifies libdeflate's failures). Returns false when allocation or zlib's set-up
  /// fails; the object is then unusable (inflate() returns invalid_argument). Set-up only.
  /// The state and zlib's window come from `allocator`. libdeflate's decompressor (libdeflate
  /// 1.14 has no per-object allocator) comes from malloc: pass InflateBackend::zlib when every
  /// byte must go through the callbacks.
  bool create(InflateBackend backend, const RuntimeAllocator& allocator = {}) noexcept;
  /// The backend in use (zlib before create()).
  InflateBackend backend() const noexcept;

  /// Inflates the whole stream `in` into exactly `out.size()` bytes. Returns success; bad_data
  /// (corrupt stream, shorter than out, trailing bytes after the stream, inflates beyond
  /// out.size() — the decompression-bomb guard); short_output (truncated stream);
  /// invalid_argument (not created). `*why` (when non-null) then names the failure (static
  /// string). Safe on untrusted input; no allocation; not thread-safe on one object.
  Status inflate(std::span<const uint8_t> in, std::span<uint8_t> out, const char** why) noexcept;
};

/// Raw deflate compressor (zlib's deflate, levels 0..9) behind an opaque handle; the state lives
/// in the implementation TU. Offline code; deflate() does not allocate. One object per thread.
class RawDeflater : public detail::OpaqueStateHandle<detail::RawDeflaterState> {
 public:
  ~RawDeflater();

  /// Allocates zlib's deflate state at `level` (clamped to 0..9). False on failure. Set-up only.
  bool create(int level) noexcept;

  /// Compresses all of `in` into `out` as one raw deflate stream and sets `written`. Returns
  /// success, insufficient_space (out too small) or invalid_argument (not created). No
  /// allocation; not thread-safe on one object.
  Status deflate(std::span<const uint8_t> in, std::span<uint8_t> out, size_t& written) noexcept;
};

/// zstd decompression context behind an opaque handle (a static ZSTD_DCtx in a workspace
/// allocated by create(); the state lives in the implementation TU). One object per thread.
class ZstdDecompressor : public detail::OpaqueStateHandle<detail::ZstdDecompressorState> {
 public:
  ~ZstdDecompressor();

  /// Allocates the context (its workspace from `allocator`). False when zstd is not compiled in
  /// or allocation fails. Set-up only.
  bool create(const RuntimeAllocator& allocator = {}) noexcept;

  /// Decompresses `in`, which must be exactly one zstd frame declaring a content size of
  /// out.size(), into `out`. Returns success; bad_data (not a zstd frame, more than one frame or
  /// trailing bytes, other content size, corrupt); short_output (truncated frame);
  /// invalid_argument (not created). `*why` names the failure (static string). Safe on untrusted
  /// input; no allocation; not thread-safe on one object.
  Status decompress(std::span<const uint8_t> in, std::span<uint8_t> out, const char** why) noexcept;
};

/// zstd compression context behind an opaque handle (a static ZSTD_CCtx sized for `level` at
/// create()). Offline code; compress() does not allocate. One object per thread.
class ZstdCompressor : public detail::OpaqueStateHandle<detail::ZstdCompressorState> {
 public:
  ~ZstdCompressor();

  /// Allocates a context for `level` (clamped to 1..22), replacing any earlier one. False when
  /// zstd is not compiled in or allocation fails (the object is then not ready). Set-up only.
  bool create(int level) noexcept;

  /// Compresses all of `in` into `out` as one frame with its content size. Returns success,
  /// insufficient_space (out too small) or invalid_argument (not created).
  Status compress(std::span<const uint8_t> in, std::span<uint8_t> out, size_t& written) noexcept;
};

namespace detail {
// LEB128 varint of at most 5 bytes with a value < 2^31. False when it runs past `end`, is longer
// or is larger.
inline bool tile_read_varint(const uint8_t*& p, const uint8_t* end, uint32_t& value) noexcept {
  uint32_t v = 0;
  for (int shift = 0; shift < 35; shift += 7) {
    if (p == end) return false;
    const uint32_t byte = *p++;
    if (shift == 28 && byte >= 8) return false;
    v |= (byte & 0x7Fu) << shift;
    if ((byte & 0x80u) == 0) {
      value = v;
      return true;
    }
  }
  return false;
}
// tile_read_varint with a shortcut for the common one-byte varint. `fast`: the caller checked
// that bytes remain before `end`, so the shortcut skips the end check.
template <bool fast>
inline bool tile_read_varint_short_first(const uint8_t*& p, const uint8_t* end, uint32_t& value) noexcept {
  if ((fast || p != end) && *p < 0x80u) {
    value = *p++;
    return true;
  }
  return tile_read_varint(p, end, value);
}
inline uint8_t* tile_write_varint(uint8_t* p, uint32_t v) noexcept {
  while (v >= 0x80u) {
    *p++ = static_cast<uint8_t>(v | 0x80u);
    v >>= 7;
  }
  *p++ = static_cast<uint8_t>(v);
  return p;
}
constexpr int64_t tile_unzigzag(uint32_t u) noexcept {
  return static_cast<int64_t>(u >> 1) ^ -static_cast<int64_t>(u & 1u);
}
constexpr uint32_t tile_zigzag(int32_t v) noexcept {
  return (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31);
}

enum class TileTokenKind : uint8_t { value, end_of_block, zero_run, escape, invalid };
// Decoding table of the AC token bytes, plus the extent (rows, columns) of the coefficients up
// to each zig-zag position. Built once; thread-safe.
struct TileTokenTable {
  uint8_t run[256];  // positions skipped before the coefficient (16 for 0xF0, 0 for 0x00)
  TileTokenKind kind[256];
  float value[256];        // the coefficient of a `value` token, in steps
  uint8_t rows_up_to[64];  // 1 + the largest row among zig-zag positions 0..k
  uint8_t cols_up_to[64];
  uint8_t zigzag[64];  // zigzag_order<8>() as bytes
  // The value-token fast path: advance[t] is r + 1 for a value token (the position after its
  // coefficient), kTileTokenSlowAdvance for every other byte, so one load, one addition and one
  // comparison tell the common case apart; zigzag_after[j] = zigzag[j − 1] (the coefficient's
  // position).
  uint16_t advance[256];
  uint8_t zigzag_after[65];
};
// Larger than any block position plus a run: sends a token to the general path.
inline constexpr uint16_t kTileTokenSlowAdvance = 256;
inline const TileTokenTable& tile_token_table() noexcept {
  static const TileTokenTable table = [] {
    TileTokenTable t{};
    for (uint32_t b = 0; b < 256; ++b) {
      const uint32_t r = b >> 4, m = b & 15u;
      t.run[b] = static_cast<uint8_t>(r);
      t.value[b] = 0.0f;
      if (b == 0) {
        t.kind[b] = TileTokenKind::end_of_block;
      } else if (b == 0xF0u) {
        t.kind[b] = TileTokenKind::zero_run;
        t.run[b] = 16;
      } else if (m == 0) {
        t.kind[b] = TileTokenKind::invalid;
        t.run[b] = 0;
      } else if (m == 15) {
        t.kind[b] = TileTokenKind::escape;
      } else {
        t.kind[b] = TileTokenKind::value;
        t.value[b] = static_cast<float>(tile_unzigzag(m));
      }
      t.advance[b] = t.kind[b] == TileTokenKind::value ? static_cast<uint16_t>(r + 1) : kTileTokenSlowAdvance;
    }
    const auto& zigzag = zigzag_order<kTileBlock>();
    uint8_t rows = 0, cols = 0;
    for (int k = 0; k < 64; ++k) {
      rows = std::max<uint8_t>(rows, static_cast<uint8_t>(zigzag[k] / 8 + 1));
      cols = std::max<uint8_t>(cols, static_cast<uint8_t>(zigzag[k] % 8 + 1));
      t.rows_up_to[k] = rows;
      t.cols_up_to[k] = cols;
      t.zigzag[k] = static_cast<uint8_t>(zigzag[k]);
      t.zigzag_after[k + 1] = static_cast<uint8_t>(zigzag[k]);
    }
    return t;
  }();
  return table;
}
}  // namespace detail

/// Tile decoder: owns its inflate state and scratch buffers, allocated in the constructor
/// (zlib's 32 KiB window included), so decode() does not allocate.
/// One object per thread: decode() is not thread-safe on the same object; different objects are
/// independent. Safe on untrusted input: malformed payloads return an error status and may leave
/// garbage in `out`, but never read or write outside the given spans.
class TileDecoder {
 public:
  /// `backend` libdeflate needs libdeflate compiled into the implementation TU
  /// (inflate_backend_available); without it zlib is used. Allocates everything decode() needs,
  /// through `allocator` (except libdeflate's own state: see RawInflater::create). When an
  /// allocation fails every decode() returns invalid_argument.
  explicit TileDecoder(TileLayout layout = {}, InflateBackend backend = default_inflate_backend(),
                       const RuntimeAllocator& allocator = {})
      : layout_(layout) {
    ready_ = layout_.valid() && symbols_.allocate(allocator, tile_symbol_bound(layout_)) &&
             inflater_.create(backend, allocator);
    if (ready_ && tile_entropy_coder_available(TileEntropyCoder::zstd))
      zstd_.create(allocator);  // without it zstd tiles fail with a message
  }
  TileDecoder(const TileDecoder&) = delete;
  TileDecoder& operator=(const TileDecoder&) = delete;

  /// What the constructor allocates through its allocator for `layout` and `backend`: the
  /// symbol buffer, the inflate state (zlib's window included) and the zstd context, not
  /// libdeflate's own state (RawInflater::create). zlib's and zstd's state sizes are private to
  /// those libraries, so this builds one decoder with a counting allocator over operator new
  /// (about 130 KB, released before returning). Set-up only; noexcept (0 when that fails).
  static AllocationTally memory_required(TileLayout layout,
                                         InflateBackend backend = default_inflate_backend()) noexcept;

  /// The inflate implementation in use.
  InflateBackend backend() const noexcept { return inflater_.backend(); }

  const TileLayout& layout() const noexcept { return layout_; }

  /// Allows (default) or forbids the SIMD inverse-DCT builds; with false the scalar twin runs
  /// (same bits; benchmarks compare the two). Not thread-safe on this object.
  void set_simd(bool allowed) noexcept { simd_allowed_ = allowed; }
  /// True when decode() uses a SIMD build of the inverse DCT (allowed, simd_active_isa() is not
  /// scalar).
  bool uses_simd() const noexcept { return simd_allowed_ && simd_active_isa() != SimdIsa::scalar; }

  /// Decodes one payload into `out` (layout().sample_count() floats, texel-interleaved).
  /// `parent` is the parent's decoded tile (same layout) when the payload is a residual (see
  /// tile_peek_header), else ignored and may be empty; (qx, qy) is the child's quadrant
  /// (x & 1, y & 1). Returns success; bad_data (malformed, wrong layout, inflates to more or
  /// less than declared, trailing bytes, invalid tokens, zero runs past the block, coefficients
  /// beyond ±2^29 steps); short_output (payload truncated); insufficient_space (out too small);
  /// unsupported (a zstd tile and a build without zstd);
  /// invalid_argument (parent missing or of the wrong size, invalid layout). message() then says
  /// what failed. No allocation, no exceptions.
  Status decode(std::span<const uint8_t> payload, std::span<const float> parent, uint32_t qx, uint32_t qy,
                std::span<float> out) noexcept {
    if (Status s = inflate_symbols(payload, parent, out); s != Status::success) return s;
    return reconstruct(info_, parent, qx, qy, out);
  }

  /// The entropy stage of decode() alone (header checks and inflate into the internal symbol
  /// buffer), for profiling; same arguments and failures as decode() for those stages. After
  /// success, symbol_bytes() is the inflated size.
  Status inflate_symbols(std::span<const uint8_t> payload, std::span<const float> parent,
                         std::span<float> out) noexcept {
    if (!ready_)
      return fail(Status::invalid_argument,
                  "decoder has an invalid layout or its inflate state could not be allocated");
    if (out.size() < layout_.sample_count())
      return fail(Status::insufficient_space, "output span smaller than the tile");
    TileHeaderInfo& info = info_;
    const char* why = nullptr;
    if (Status s = tile_peek_header(payload, info, &why); s != Status::success) return fail(s, why);
    if (info.channels != layout_.channels || info.stored_size != layout_.stored_size())
      return fail(Status::bad_data, "tile payload layout differs from the decoder's layout");
    if (info.residual && parent.size() < layout_.sample_count())
      return fail(Status::invalid_argument, "residual tile decoded without its parent");

    // Entropy stage. The output buffer is exactly the declared size: a stream that would inflate
    // to more is rejected when the buffer fills (this is the decompression-bomb guard).
    const size_t header = tile_header_size(info.channels);
    const char* inflate_why = nullptr;
    const std::span<uint8_t> symbols(symbols_.data(), info.symbol_bytes);
    Status z;
    if (info.coder == TileEntropyCoder::zstd) {
      if (!zstd_.ready())
        return fail(Status::unsupported,
                    "zstd-coded tile, but this build has no zstd (BTFLOD_WITH_ZSTD) or no zstd context");
      z = zstd_.decompress(payload.subspan(header), symbols, &inflate_why);
    } else {
      z = inflater_.inflate(payload.subspan(header), symbols, &inflate_why);
    }
    if (z != Status::success) return fail(z, inflate_why);
    return Status::success;
  }

  /// Size of the last inflated symbol stream (after a successful decode or inflate_symbols).
  uint32_t symbol_bytes() const noexcept { return info_.symbol_bytes; }

  /// A static description of the last failure ("" after success). Never null.
  const char* message() const noexcept { return message_; }

 private:
  Status fail(Status s, const char* m) noexcept {
    message_ = m;
    return s;
  }

  // Parses one block code into `b` (which must be all zero on entry), dequantising with `steps`.
  // Returns nullptr and sets message_ on malformed input. `fast`: the caller checked that a
  // longest block code fits before `end`, so the per-byte end checks are skipped (they cannot
  // fire).
  template <bool fast>
  const uint8_t* parse_block(const uint8_t* p, const uint8_t* end, int64_t& dc, const float* steps, TileCoefBlock& b,
                             const detail::TileTokenTable& tokens) noexcept {
    const uint8_t* const zigzag = tokens.zigzag;
    uint32_t u = 0;
    if (!detail::tile_read_varint_short_first<fast>(p, end, u)) {
      message_ = "tile symbol stream: DC varint truncated or longer than 5 bytes";
      return nullptr;
    }
    dc += detail::tile_unzigzag(u);
    if (dc > kTileMaxCoefficient || dc < -kTileMaxCoefficient) {
      message_ = "tile symbol stream: DC coefficient beyond 2^29 steps";
      return nullptr;
    }
    uint32_t filled = 0;  // 1 + the zig-zag position of the last non-zero coefficient (0: none)
    if (dc != 0) {
      b.coef[0] = static_cast<float>(dc) * steps[0];
      filled = 1;
    }
    uint32_t k = 1;  // zig-zag position of the next coefficient
    for (;;) {
      if (!fast && p == end) {
        message_ = "tile symbol stream ends inside a block";
        return nullptr;
      }
      const uint32_t t = *p++;
      const uint32_t next = k + tokens.advance[t];
      // [[likely]]: g++ 12 otherwise places this path out of line, two taken jumps per token
      // (3–4 % of a tile's decode, bench_codec).
      if (next < 64) [[likely]] {  // the common case: r zeros and a coefficient, more positions follow
        const uint32_t natural = tokens.zigzag_after[next];
        b.coef[natural] = tokens.value[t] * steps[natural];
        k = filled = next;
        continue;
      }
      // Every other token (escape, end of block, zero run, invalid), or a value token that fills
      // or overruns the block.
      k += tokens.run[t];
      const detail::TileTokenKind kind = tokens.kind[t];
      // Escapes first: they are the next most frequent tokens (about a quarter of all at the
      // bench's quality, against one end of block per block), and their varint is mostly 1 byte.
      if (kind == detail::TileTokenKind::escape && k < 64) [[likely]] {
        uint32_t extra = 0;
        if (!detail::tile_read_varint_short_first<fast>(p, end, extra)) {
          message_ = "tile symbol stream: coefficient varint truncated or longer than 5 bytes";
          return nullptr;
        }
        if (extra > 2u * static_cast<uint32_t>(kTileMaxCoefficient) - 15u) {
          message_ = "tile symbol stream: AC coefficient beyond 2^29 steps";
          return nullptr;
        }
        const uint32_t natural = zigzag[k];
        b.coef[natural] = static_cast<float>(detail::tile_unzigzag(15u + extra)) * steps[natural];
        k = filled = k + 1;
        if (k == 64) break;
        continue;
      }
      if (kind == detail::TileTokenKind::end_of_block) break;
      if (kind == detail::TileTokenKind::invalid) {
        message_ = "tile symbol stream: invalid token (zero value with a run < 16)";
        return nullptr;
      }
      if (k >= 64) {
        message_ = "tile symbol stream: zero run past the end of the block";
        return nullptr;
      }
      if (kind == detail::TileTokenKind::zero_run) continue;
      // A value token whose coefficient is the block's last (zig-zag position 63).
      b.coef[zigzag[k]] = tokens.value[t] * steps[zigzag[k]];
      k = filled = k + 1;
      if (k == 64) break;
    }
    if (filled > 0) {
      b.rows = tokens.rows_up_to[filled - 1];
      b.cols = tokens.cols_up_to[filled - 1];
    }
    return p;
  }

  Status reconstruct(const TileHeaderInfo& info, std::span<const float> parent, uint32_t qx, uint32_t qy,
                     std::span<float> out) noexcept {
    const uint32_t s = layout_.stored_size();
    const uint32_t ch = layout_.channels;
    const uint32_t blocks_per_side = s / kTileBlock;
    const auto& factors = quant_step_factors<kTileBlock>(info.weight_quarters);
    alignas(32) float steps[kTileMaxChannels][64];
    for (uint32_t c = 0; c < ch; ++c)
      for (int k = 0; k < 64; ++k) steps[c][k] = info.tolerance[c] * factors[k];

    float* dst = out.data();
    const SimdKernels& kernels = simd_allowed_ ? simd_kernels() : *simd_kernels_for(SimdIsa::scalar);
    if (info.residual) {
      upsample_parent(layout_, parent.data(), qx, qy, dst, kernels);
    } else {
      std::fill(dst, dst + layout_.sample_count(), 0.0f);
    }
    const detail::TileTokenTable& tokens = detail::tile_token_table();
    const uint8_t* p = symbols_.data();
    const uint8_t* const end = p + info.symbol_bytes;
    int64_t dc[kTileMaxChannels] = {};
    const size_t row_stride = size_t{s} * ch;
    for (uint32_t by = 0; by < blocks_per_side; ++by)
      for (uint32_t bx = 0; bx < blocks_per_side; ++bx) {
        for (uint32_t c = 0; c < ch; ++c) {
          TileCoefBlock& b = blocks_[c];
          // Clear what the previous block position left: only rows < b.rows can be non-zero
          // (fixed 32-byte clears compile to vector stores; a 256-byte memset was 8 % of decode).
          for (uint32_t r = 0; r < b.rows; ++r) std::memset(b.coef + r * 8, 0, 8 * sizeof(float));
          b.rows = b.cols = 0;
          p = static_cast<size_t>(end - p) >= kTileMaxBlockCode
                  ? parse_block<true>(p, end, dc[c], steps[c], b, tokens)
                  : parse_block<false>(p, end, dc[c], steps[c], b, tokens);
          if (p == nullptr) {  // parse_block may have written coefficients: leave blocks_ all zero
            for (TileCoefBlock& z : blocks_) z = TileCoefBlock{};
            return Status::bad_data;
          }
        }
        float* first = dst + (size_t{by} * kTileBlock * s + size_t{bx} * kTileBlock) * ch;
        if (ch == 4) {
          if (blocks_[0].rows | blocks_[1].rows | blocks_[2].rows | blocks_[3].rows)
            kernels.tile_idct_add4(blocks_, first, row_stride);
          continue;
        }
        for (uint32_t c = 0; c < ch; ++c) kernels.tile_idct_add(blocks_[c], first + c, row_stride, ch);
      }
    if (p != end) return fail(Status::bad_data, "symbol stream longer than the tile");
    message_ = "";
    return Status::success;
  }

  TileLayout layout_;
  RuntimeArray<uint8_t> symbols_;
  TileCoefBlock blocks_[kTileMaxChannels] = {};
  TileHeaderInfo info_;
  RawInflater inflater_;
  ZstdDecompressor zstd_;
  bool ready_ = false;
  bool simd_allowed_ = true;
  const char* message_ = "";
};

inline AllocationTally TileDecoder::memory_required(TileLayout layout, InflateBackend backend) noexcept {
  struct Counter {
    AllocationTally live;
    static void* allocate(void* user, size_t bytes, size_t alignment) {
      void* p = RuntimeAllocator{}.allocate_bytes(bytes, alignment);
      if (p != nullptr) static_cast<Counter*>(user)->live.block(bytes);
      return p;
    }
    static void deallocate(void* user, void* p, size_t bytes, size_t alignment) {
      RuntimeAllocator{}.deallocate_bytes(p, bytes, alignment);
      Counter& c = *static_cast<Counter*>(user);
      c.live.bytes -= bytes;
      --c.live.allocations;
    }
  } counter;
  AllocationTally held;
  {
    const TileDecoder probe(layout, backend, RuntimeAllocator{&Counter::allocate, &Counter::deallocate, &counter});
    held = counter.live;
  }
  return held;
}

/// Tile encoder: owns its deflate state, scratch buffers and a TileDecoder (for the closed-loop
/// reconstruction). Offline code, but encode() itself does not allocate. One object per thread.
class TileEncoder {
 public:
  /// `deflate_level` is zlib's 0..9 (default 9: encoding is offline, and the streams are small).
  explicit TileEncoder(TileLayout layout = {}, int deflate_level = 9) : layout_(layout), decoder_(layout) {
    if (layout_.valid()) {
      prediction_.resize(layout_.sample_count());
      quantised_.resize(layout_.sample_count());
      symbols_.resize(tile_symbol_bound(layout_));
    }
    ready_ = layout_.valid() && deflater_.create(deflate_level);
  }
  TileEncoder(const TileEncoder&) = delete;
  TileEncoder& operator=(const TileEncoder&) = delete;

  const TileLayout& layout() const noexcept { return layout_; }

  /// Entropy coder of the following encodes (default deflate, tile format 2). zstd (format 3)
  /// allocates its compression context here, for `zstd_level` (1..22; default 19). Returns false,
  /// leaving the coder unchanged, when the coder is not compiled in
  /// (tile_entropy_coder_available) or the context cannot be allocated. A zstd frame larger than
  /// the output buffer falls back to deflate for that tile (bound() stays deflate's bound). Set-up
  /// only (allocates); not thread-safe on this object.
  bool set_entropy_coder(TileEntropyCoder coder, int zstd_level = 19) noexcept {
    if (coder == TileEntropyCoder::zstd) {
      if (!tile_entropy_coder_available(coder)) return false;
      if (!zstd_.ready() || zstd_level != zstd_level_) {
        if (!zstd_.create(zstd_level)) return false;
        zstd_level_ = zstd_level;
      }
    }
    coder_ = coder;
    return true;
  }
  TileEntropyCoder entropy_coder() const noexcept { return coder_; }

  /// Frequency weighting of the following encodes: JPEG's table to the power quarters / 4
  /// (runtime/codec/quantize.hpp quant_step_factors; stored in the tile header, so decoders need
  /// nothing). Values above 4 are treated as 4 (JPEG's table, the default and the bytes of
  /// earlier versions).
  void set_weight_quarters(uint32_t quarters) noexcept { weight_quarters_ = std::min(quarters, kJpegWeightQuarters); }
  uint32_t weight_quarters() const noexcept { return weight_quarters_; }
  /// Dead-zone quantisation of the AC coefficients of the following encodes: a coefficient of
  /// v steps (|v| = n + f, 0 ≤ f < 1) is coded as n + 1 when f ≥ `threshold`, else n (sign kept);
  /// DC stays rounded to nearest. 0.5 (the default) is round-to-nearest, the bytes of earlier
  /// versions. Above 0.5 small coefficients fall to zero and every magnitude leans to the smaller
  /// integer: fewer and shorter symbols for a little more error (at most threshold · step per
  /// coefficient, so the block-RMS bound of runtime/codec/quantize.hpp becomes 2 · threshold · t). The
  /// decoder is unchanged (it multiplies integers by steps either way). Clamped to [0.5, 1).
  void set_ac_rounding_threshold(float threshold) noexcept {
    ac_rounding_ = std::isfinite(threshold) ? std::clamp(threshold, 0.5f, 0.99f) : 0.5f;
  }
  float ac_rounding_threshold() const noexcept { return ac_rounding_; }
  /// tile_encode_bound(layout()).
  size_t bound() const noexcept { return tile_encode_bound(layout_); }

  /// Encodes `tile` (layout().sample_count() floats, texel-interleaved). With a non-empty
  /// `parent` (the parent's *decoded* tile, e.g. the `reconstruction` its own encode returned)
  /// the residual to its up-sampling in quadrant (qx, qy) is coded. `tolerance[c]` is the
  /// absolute block-RMS error bound of channel c (tolerance_for_quality). Writes the payload to
  /// `out` (bound() bytes always suffice) and its size to `written`; when `reconstruction` is not
  /// empty it receives the tile exactly as TileDecoder will decode it.
  /// Returns success, insufficient_space (out or reconstruction too small), invalid_argument
  /// (non-finite samples, tolerance not positive, coefficients beyond ±2^29 steps, wrong parent
  /// size, invalid layout). message() says what failed.
  Status encode(std::span<const float> tile, std::span<const float> parent, uint32_t qx, uint32_t qy,
                std::span<const float> tolerance, std::span<uint8_t> out, size_t& written,
                std::span<float> reconstruction = {}) noexcept {
    written = 0;
    if (!ready_)
      return fail(Status::invalid_argument,
                  "encoder has an invalid layout or its deflate state could not be allocated");
    const uint32_t s = layout_.stored_size();
    const uint32_t ch = layout_.channels;
    const size_t n = layout_.sample_count();
    if (tile.size() < n) return fail(Status::invalid_argument, "tile span smaller than the layout");
    if (!parent.empty() && parent.size() < n)
      return fail(Status::invalid_argument, "parent span smaller than the layout");
    if (tolerance.size() < ch) return fail(Status::invalid_argument, "fewer tolerances than channels");
    for (uint32_t c = 0; c < ch; ++c)
      if (!(tolerance[c] > 0.0f) || !(tolerance[c] < 1e15f))
        return fail(Status::invalid_argument, "tolerance not finite and positive");
    if (!reconstruction.empty() && reconstruction.size() < n)
      return fail(Status::insufficient_space, "reconstruction span too small");
    const size_t header = tile_header_size(ch);
    if (out.size() < header) return fail(Status::insufficient_space, "output smaller than the header");

    if (parent.empty()) {
      std::fill(prediction_.begin(), prediction_.end(), 0.0f);
    } else {
      upsample_parent(layout_, parent.data(), qx, qy, prediction_.data());
    }

    // Forward DCT and quantisation, block-major per channel.
    const uint32_t blocks_per_side = s / kTileBlock;
    const size_t blocks = size_t{blocks_per_side} * blocks_per_side;
    constexpr int kBlockArea = kTileBlock * kTileBlock;
    const auto& factors = quant_step_factors<kTileBlock>(weight_quarters_);
    alignas(32) float residual[kBlockArea];
    alignas(32) float coef[kBlockArea];
    for (uint32_t c = 0; c < ch; ++c) {
      float inv_step[kBlockArea];
      for (int k = 0; k < kBlockArea; ++k) inv_step[k] = 1.0f / (tolerance[c] * factors[k]);
      for (uint32_t by = 0; by < blocks_per_side; ++by)
        for (uint32_t bx = 0; bx < blocks_per_side; ++bx) {
          for (int y = 0; y < kTileBlock; ++y)
            for (int x = 0; x < kTileBlock; ++x) {
              const size_t i = ((size_t{by} * kTileBlock + y) * s + size_t{bx} * kTileBlock + x) * ch + c;
              residual[y * kTileBlock + x] = tile[i] - prediction_[i];
            }
          dct_forward<kTileBlock, float>(residual, kTileBlock, coef);
          int32_t* q = quantised_.data() + (size_t{c} * blocks + size_t{by} * blocks_per_side + bx) * kBlockArea;
          for (int k = 0; k < kBlockArea; ++k) {
            const float v = coef[k] * inv_step[k];
            if (!(std::fabs(v) < static_cast<float>(kTileMaxCoefficient)))
              return fail(Status::invalid_argument, "sample not finite or too large for the tolerance");
            if (ac_rounding_ == 0.5f || k == 0) {
              q[k] = static_cast<int32_t>(std::nearbyint(v));
            } else {  // dead zone: |v| = n + f codes as n + 1 only when f ≥ ac_rounding_
              const int32_t m = static_cast<int32_t>(std::fabs(v) + (1.0f - ac_rounding_));
              q[k] = v < 0.0f ? -m : m;
            }
          }
        }
    }

    // Symbol stream (see the file comment): block-major, channels interleaved, run-length tokens.
    const auto& zigzag = zigzag_order<kTileBlock>();
    uint8_t* sym = symbols_.data();
    int32_t previous_dc[kTileMaxChannels] = {};
    for (size_t b = 0; b < blocks; ++b)
      for (uint32_t c = 0; c < ch; ++c) {
        const int32_t* q = quantised_.data() + (size_t{c} * blocks + b) * kBlockArea;
        sym = detail::tile_write_varint(sym, detail::tile_zigzag(q[0] - previous_dc[c]));
        previous_dc[c] = q[0];
        int last = 0;
        for (int k = kBlockArea - 1; k > 0; --k)
          if (q[zigzag[k]] != 0) {
            last = k;
            break;
          }
        uint32_t run = 0;
        for (int k = 1; k <= last; ++k) {
          const int32_t v = q[zigzag[k]];
          if (v == 0) {
            ++run;
            continue;
          }
          for (; run >= 16; run -= 16) *sym++ = 0xF0;
          const uint32_t u = detail::tile_zigzag(v);
          if (u < 15) {
            *sym++ = static_cast<uint8_t>(run << 4 | u);
          } else {
            *sym++ = static_cast<uint8_t>(run << 4 | 15u);
            sym = detail::tile_write_varint(sym, u - 15);
          }
          run = 0;
        }
        if (last < kBlockArea - 1) *sym++ = 0;  // end of block
      }
    const uint32_t symbol_bytes = static_cast<uint32_t>(sym - symbols_.data());

    // Header (version and coder byte patched below when zstd is used).
    uint8_t* o = out.data();
    o[0] = kTileFormatVersion;
    o[1] = kTileBlock;
    o[2] = static_cast<uint8_t>(ch);
    o[3] = static_cast<uint8_t>((parent.empty() ? 0u : 1u) | (kJpegWeightQuarters - weight_quarters_) << 1);
    const uint16_t size16 = static_cast<uint16_t>(s);
    std::memcpy(o + 4, &size16, 2);
    std::memcpy(o + 6, &size16, 2);
    for (uint32_t c = 0; c < ch; ++c) std::memcpy(o + 8 + 4 * c, &tolerance[c], 4);
    std::memcpy(o + 8 + 4 * ch, &symbol_bytes, 4);

    // Entropy stage.
    const std::span<const uint8_t> symbols(symbols_.data(), symbol_bytes);
    size_t coded = 0;
    if (coder_ == TileEntropyCoder::zstd && zstd_.compress(symbols, out.subspan(header), coded) == Status::success) {
      o[0] = kTileFormatVersionCoder;
      o[3] = static_cast<uint8_t>(o[3] | static_cast<uint32_t>(TileEntropyCoder::zstd) << 4);
    } else if (deflater_.deflate(symbols, out.subspan(header), coded) != Status::success) {
      return fail(Status::insufficient_space, "output buffer smaller than the compressed tile");
    }
    written = header + coded;

    if (!reconstruction.empty()) {  // closed loop: exactly what a client decodes
      const Status d = decoder_.decode(out.first(written), parent, qx, qy, reconstruction);
      if (d != Status::success) return fail(d, decoder_.message());
    }
    message_ = "";
    return Status::success;
  }

  /// A static description of the last failure ("" after success). Never null.
  const char* message() const noexcept { return message_; }

 private:
  Status fail(Status s, const char* m) noexcept {
    message_ = m;
    return s;
  }

  TileLayout layout_;
  TileDecoder decoder_;
  std::vector<float> prediction_;
  std::vector<int32_t> quantised_;
  std::vector<uint8_t> symbols_;
  RawDeflater deflater_;
  ZstdCompressor zstd_;
  int zstd_level_ = 0;
  TileEntropyCoder coder_ = TileEntropyCoder::deflate;
  bool ready_ = false;
  uint32_t weight_quarters_ = kJpegWeightQuarters;
  float ac_rounding_ = 0.5f;
  const char* message_ = "";
};

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include <new>

#include <zlib.h>
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
#include <libdeflate.h>
#endif
#if defined(BTFLOD_TILE_CODEC_ZSTD)
#define ZSTD_STATIC_LINKING_ONLY  // ZSTD_initStaticCCtx / DCtx, ZSTD_estimate*Size (exported by libzstd.so)
#include <zstd.h>
#include <zstd_errors.h>
// A client that only reads tiles may link zstd's decompressor alone (lib/common + lib/decompress,
// e.g. the WebAssembly client): BTFLOD_TILE_CODEC_ZSTD_DECODER_ONLY then compiles ZstdCompressor
// without zstd (create() returns false, so encoders cannot select zstd).
#if !defined(BTFLOD_TILE_CODEC_ZSTD_DECODER_ONLY)
#define BTFLOD_TILE_CODEC_ZSTD_ENCODER 1
#endif
#endif

namespace btflod {

bool inflate_backend_available(InflateBackend backend) noexcept {
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
  return backend == InflateBackend::zlib || backend == InflateBackend::libdeflate;
#else
  return backend == InflateBackend::zlib;
#endif
}

InflateBackend default_inflate_backend() noexcept {
  return inflate_backend_available(InflateBackend::libdeflate) ? InflateBackend::libdeflate : InflateBackend::zlib;
}

struct detail::RawInflaterState {
  RuntimeAllocator allocator;  // zlib's zalloc/zfree reach it through stream.opaque
  z_stream stream{};
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
  libdeflate_decompressor* libdeflate = nullptr;
#endif
};

namespace detail {
// zlib's allocation hooks over a RuntimeAllocator. zfree is not told the size, so each block
// carries it in a 16-byte prefix (which also keeps the block 16-byte aligned).
inline constexpr size_t kZlibBlockPrefix = 16;

inline voidpf zlib_allocate(voidpf opaque, uInt items, uInt size) {
  const auto* allocator = static_cast<const RuntimeAllocator*>(opaque);
  const size_t bytes = size_t{items} * size_t{size};
  if (size != 0 && bytes / size != items) return Z_NULL;
  auto* block = static_cast<unsigned char*>(allocator->allocate_bytes(bytes + kZlibBlockPrefix, 16));
  if (block == nullptr) return Z_NULL;
  std::memcpy(block, &bytes, sizeof bytes);
  return block + kZlibBlockPrefix;
}

inline void zlib_free(voidpf opaque, voidpf pointer) {
  if (pointer == Z_NULL) return;
  const auto* allocator = static_cast<const RuntimeAllocator*>(opaque);
  unsigned char* block = static_cast<unsigned char*>(pointer) - kZlibBlockPrefix;
  size_t bytes = 0;
  std::memcpy(&bytes, block, sizeof bytes);
  allocator->deallocate_bytes(block, bytes + kZlibBlockPrefix, 16);
}
}  // namespace detail

RawInflater::~RawInflater() {
  if (state_ == nullptr) return;
  inflateEnd(&state_->stream);
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
  if (state_->libdeflate) libdeflate_free_decompressor(state_->libdeflate);
#endif
  const RuntimeAllocator allocator = state_->allocator;
  state_->~State();
  allocator.deallocate_bytes(state_, sizeof(State), alignof(State));
}

bool RawInflater::create(InflateBackend backend, const RuntimeAllocator& allocator) noexcept {
  if (state_ != nullptr) return true;
  void* memory = allocator.allocate_bytes(sizeof(State), alignof(State));
  if (memory == nullptr) return false;
  State* st = ::new (memory) State;
  st->allocator = allocator;
  auto release = [&] {
    st->~State();
    allocator.deallocate_bytes(memory, sizeof(State), alignof(State));
  };
  st->stream.zalloc = detail::zlib_allocate;
  st->stream.zfree = detail::zlib_free;
  st->stream.opaque = &st->allocator;
  if (inflateInit2(&st->stream, -15) != Z_OK) {
    release();
    return false;
  }
  // zlib allocates its 32 KiB window lazily, inside the first inflate() that ends before the
  // stream does (a truncated payload): prime it here so inflate() never allocates. The input is
  // a non-final stored block of one byte.
  static constexpr uint8_t kPrime[] = {0x00, 0x01, 0x00, 0xFE, 0xFF, 0x2A};
  uint8_t sink = 0;
  st->stream.next_in = const_cast<Bytef*>(kPrime);
  st->stream.avail_in = sizeof kPrime;
  st->stream.next_out = &sink;
  st->stream.avail_out = 1;
  bool ok = ::inflate(&st->stream, Z_NO_FLUSH) == Z_OK;
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
  if (ok && backend == InflateBackend::libdeflate) {
    st->libdeflate = libdeflate_alloc_decompressor();
    ok = st->libdeflate != nullptr;
  }
#else
  (void)backend;
#endif
  if (!ok) {
    inflateEnd(&st->stream);
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
    if (st->libdeflate) libdeflate_free_decompressor(st->libdeflate);
#endif
    release();
    return false;
  }
  state_ = st;
  return true;
}

InflateBackend RawInflater::backend() const noexcept {
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
  if (state_ != nullptr && state_->libdeflate != nullptr) return InflateBackend::libdeflate;
#endif
  return InflateBackend::zlib;
}

Status RawInflater::inflate(std::span<const uint8_t> in, std::span<uint8_t> out, const char** why) noexcept {
  auto fail = [&](Status s, const char* m) {
    if (why) *why = m;
    return s;
  };
  if (state_ == nullptr) return fail(Status::invalid_argument, "inflate state not created");
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
  if (state_->libdeflate) {
    size_t used = 0, produced = 0;
    const libdeflate_result r = libdeflate_deflate_decompress_ex(state_->libdeflate, in.data(), in.size(), out.data(),
                                                                 out.size(), &used, &produced);
    if (r == LIBDEFLATE_SUCCESS && produced == out.size() && used == in.size()) return Status::success;
    // Failures only: libdeflate does not tell a truncated stream from a corrupt one, so zlib
    // below classifies it (same status and message with either backend).
  }
#endif
  // The output buffer is exactly the declared size: a stream that would inflate to more is
  // rejected when the buffer fills (the decompression-bomb guard).
  z_stream& zs = state_->stream;
  inflateReset(&zs);
  zs.next_in = const_cast<Bytef*>(in.data());
  zs.avail_in = static_cast<uInt>(std::min<size_t>(in.size(), UINT32_MAX));
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(std::min<size_t>(out.size(), UINT32_MAX));
  const int z = ::inflate(&zs, Z_FINISH);
  if (z == Z_STREAM_END) {
    if (zs.avail_out != 0) return fail(Status::bad_data, "symbol stream shorter than declared");
    if (zs.avail_in != 0) return fail(Status::bad_data, "trailing bytes after the deflate stream");
  } else if (z == Z_DATA_ERROR || z == Z_NEED_DICT || z == Z_STREAM_ERROR || z == Z_MEM_ERROR) {
    return fail(Status::bad_data, "deflate stream is corrupt");
  } else {  // Z_BUF_ERROR or Z_OK: ran out of input or of output space
    if (zs.avail_out == 0) return fail(Status::bad_data, "deflate stream inflates beyond the declared size");
    return fail(Status::short_output, "deflate stream truncated");
  }
  return Status::success;
}

bool tile_entropy_coder_available(TileEntropyCoder coder) noexcept {
#if defined(BTFLOD_TILE_CODEC_ZSTD)
  return coder == TileEntropyCoder::deflate || coder == TileEntropyCoder::zstd;
#else
  return coder == TileEntropyCoder::deflate;
#endif
}

TileEntropyCoder default_tile_entropy_coder() noexcept {
#if defined(BTFLOD_TILE_CODEC_ZSTD_ENCODER)
  return TileEntropyCoder::zstd;
#else
  return TileEntropyCoder::deflate;
#endif
}

// Both zstd contexts live in a workspace owned here (ZSTD_initStatic*: the context never
// allocates, so decompress() and compress() do not either).
struct detail::ZstdDecompressorState {
  RuntimeAllocator allocator;
  size_t workspace_bytes = 0;
  unsigned char* workspace = nullptr;
#if defined(BTFLOD_TILE_CODEC_ZSTD)
  ZSTD_DCtx* dctx = nullptr;
#endif
};

ZstdDecompressor::~ZstdDecompressor() {
  if (state_ == nullptr) return;
  const RuntimeAllocator allocator = state_->allocator;
  allocator.deallocate_bytes(state_->workspace, state_->workspace_bytes, 16);
  state_->~State();
  allocator.deallocate_bytes(state_, sizeof(State), alignof(State));
}

bool ZstdDecompressor::create(const RuntimeAllocator& allocator) noexcept {
#if defined(BTFLOD_TILE_CODEC_ZSTD)
  if (state_ != nullptr) return true;
  void* memory = allocator.allocate_bytes(sizeof(State), alignof(State));
  if (memory == nullptr) return false;
  State* st = ::new (memory) State;
  st->allocator = allocator;
  st->workspace_bytes = ZSTD_estimateDCtxSize();
  st->workspace = static_cast<unsigned char*>(allocator.allocate_bytes(st->workspace_bytes, 16));  // zstd needs 8
  if (st->workspace != nullptr) st->dctx = ZSTD_initStaticDCtx(st->workspace, st->workspace_bytes);
  if (st->dctx == nullptr) {
    allocator.deallocate_bytes(st->workspace, st->workspace_bytes, 16);
    st->~State();
    allocator.deallocate_bytes(memory, sizeof(State), alignof(State));
    return false;
  }
  state_ = st;
  return true;
#else
  (void)allocator;
  return false;
#endif
}

Status ZstdDecompressor::decompress(std::span<const uint8_t> in, std::span<uint8_t> out, const char** why) noexcept {
  auto fail = [&](Status s, const char* m) {
    if (why) *why = m;
    return s;
  };
#if defined(BTFLOD_TILE_CODEC_ZSTD)
  if (state_ == nullptr) return fail(Status::invalid_argument, "zstd state not created");
  // Exactly one frame: no trailing bytes, no second (or skippable) frame.
  const size_t frame = ZSTD_findFrameCompressedSize(in.data(), in.size());
  if (ZSTD_isError(frame))
    return ZSTD_getErrorCode(frame) == ZSTD_error_srcSize_wrong && in.size() >= 4
               ? fail(Status::short_output, "zstd frame truncated")
               : fail(Status::bad_data, "not a zstd frame");
  if (frame != in.size()) return fail(Status::bad_data, "trailing bytes after the zstd frame");
  const unsigned long long content = ZSTD_getFrameContentSize(in.data(), in.size());
  if (content != out.size()) return fail(Status::bad_data, "zstd frame content size differs from the declared size");
  const size_t got = ZSTD_decompressDCtx(state_->dctx, out.data(), out.size(), in.data(), in.size());
  if (ZSTD_isError(got) || got != out.size()) return fail(Status::bad_data, "zstd frame is corrupt");
  return Status::success;
#else
  (void)in;
  (void)out;
  return fail(Status::invalid_argument, "zstd not compiled in");
#endif
}

struct detail::ZstdCompressorState {
  unsigned char* workspace = nullptr;
#if defined(BTFLOD_TILE_CODEC_ZSTD_ENCODER)
  ZSTD_CCtx* cctx = nullptr;
  int level = 19;
#endif
};

ZstdCompressor::~ZstdCompressor() {
  if (state_ == nullptr) return;
  delete[] state_->workspace;
  delete state_;
}

bool ZstdCompressor::create(int level) noexcept {
  if (state_ != nullptr) {
    delete[] state_->workspace;
    delete state_;
    state_ = nullptr;
  }
#if defined(BTFLOD_TILE_CODEC_ZSTD_ENCODER)
  State* st = new (std::nothrow) State;
  if (st == nullptr) return false;
  st->level = std::clamp(level, 1, 22);
  const size_t size = ZSTD_estimateCCtxSize(st->level);  // the largest over every source size
  st->workspace = new (std::nothrow) unsigned char[size];
  if (st->workspace != nullptr) st->cctx = ZSTD_initStaticCCtx(st->workspace, size);
  if (st->cctx == nullptr) {
    delete[] st->workspace;
    delete st;
    return false;
  }
  state_ = st;
  return true;
#else
  (void)level;
  return false;
#endif
}

Status ZstdCompressor::compress(std::span<const uint8_t> in, std::span<uint8_t> out, size_t& written) noexcept {
  written = 0;
#if defined(BTFLOD_TILE_CODEC_ZSTD_ENCODER)
  if (state_ == nullptr) return Status::invalid_argument;
  const size_t n = ZSTD_compressCCtx(state_->cctx, out.data(), out.size(), in.data(), in.size(), state_->level);
  if (ZSTD_isError(n)) return Status::insufficient_space;
  written = n;
  return Status::success;
#else
  (void)in;
  (void)out;
  return Status::invalid_argument;
#endif
}

struct detail::RawDeflaterState {
  z_stream stream{};
};

RawDeflater::~RawDeflater() {
  if (state_ == nullptr) return;
  deflateEnd(&state_->stream);
  delete state_;
}

bool RawDeflater::create(int level) noexcept {
  if (state_ != nullptr) return true;
  State* st = new (std::nothrow) State;
  if (st == nullptr) return false;
  if (deflateInit2(&st->stream, std::clamp(level, 0, 9), Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    delete st;
    return false;
  }
  state_ = st;
  return true;
}

Status RawDeflater::deflate(std::span<const uint8_t> in, std::span<uint8_t> out, size_t& written) noexcept {
  written = 0;
  if (state_ == nullptr) return Status::invalid_argument;
  z_stream& zs = state_->stream;
  deflateReset(&zs);
  zs.next_in = const_cast<Bytef*>(in.data());
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(std::min<size_t>(out.size(), UINT32_MAX));
  if (::deflate(&zs, Z_FINISH) != Z_STREAM_END) return Status::insufficient_space;
  written = zs.total_out;
  return Status::success;
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
