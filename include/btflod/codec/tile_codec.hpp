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
// Payload layout (little-endian):
//   u8  format version (1)        u8  block size (8)       u8 channels C (1..4)
//   u8  flags (bit 0: residual to the parent)              u16 stored width S, u16 stored height S
//   f32 tolerance[C]              (absolute block-RMS error bound per channel, codec/quantize.hpp)
//   u32 symbol bytes              (size of the inflated symbol stream)
//   raw deflate stream            (RFC 1951, no zlib header) of the symbol stream
// Symbol stream: for each channel, for each zig-zag position k, for each 8×8 block in raster
// order, the quantised coefficient (the DC one as a difference to the previous block's DC),
// zig-zag mapped to unsigned (0, −1, 1, −2, … → 0, 1, 2, 3, …) and written as one byte when
// < 255, else 0xFF followed by the u32 value. Grouping by frequency puts the many zero high-
// frequency coefficients next to each other, which deflate turns into long matches.
//
// Entropy backend: zlib's inflate by default. Defining BTFLOD_TILE_CODEC_LIBDEFLATE before
// including this header (in every translation unit of the program, and linking libdeflate, e.g.
// CMake PkgConfig::BTFLOD_LIBDEFLATE) adds libdeflate's decompressor, about twice as fast on
// these streams (bench/bench_codec.cpp), and makes it the decoders' default. The format is the
// same raw deflate either way.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include <zlib.h>
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
#include <libdeflate.h>
#endif

#include "btflod/codec/dct.hpp"
#include "btflod/codec/quantize.hpp"
#include "btflod/core/result.hpp"

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

inline constexpr uint8_t kTileFormatVersion = 1;
inline constexpr int kTileBlock = 8;
inline constexpr uint32_t kTileMaxChannels = 4;

/// Size of the payload header for `channels` channels.
constexpr size_t tile_header_size(uint32_t channels) noexcept { return 12 + 4 * size_t{channels}; }

/// Worst-case size of the symbol stream of one tile (every symbol escaped: 5 bytes).
constexpr size_t tile_symbol_bound(const TileLayout& layout) noexcept { return layout.sample_count() * 5; }

/// Worst-case size of one encoded tile: the buffer size that tile_encode can always fill.
/// Returns 0 for an invalid layout. Thread-safe.
inline size_t tile_encode_bound(const TileLayout& layout) noexcept {
  if (!layout.valid()) return 0;
  return tile_header_size(layout.channels) + static_cast<size_t>(compressBound(static_cast<uLong>(tile_symbol_bound(layout))));
}

/// Bilinear up-sampling of a decoded parent tile to the prediction of its child in quadrant
/// (qx, qy) ∈ {0,1}² (qx = child.x & 1, qy = child.y & 1). A child texel with stored index i
/// lies at parent stored coordinate p = qx·T/2 + B/2 − 1/4 + i/2 (texel centres, level l → l−1
/// halves coordinates); for B ≥ 1 every tap lies inside the parent's stored texels, so the
/// borders provide the filter support. Preconditions: layout.valid(), parent and out hold
/// layout.sample_count() floats. Thread-safe, no allocation.
inline void upsample_parent(const TileLayout& layout, const float* parent, uint32_t qx, uint32_t qy,
                            float* out) noexcept {
  const uint32_t s = layout.stored_size();
  const uint32_t c = layout.channels;
  const float base_x = static_cast<float>(qx & 1u) * layout.tile_size * 0.5f + layout.border * 0.5f - 0.25f;
  const float base_y = static_cast<float>(qy & 1u) * layout.tile_size * 0.5f + layout.border * 0.5f - 0.25f;
  for (uint32_t j = 0; j < s; ++j) {
    const float py = base_y + j * 0.5f;
    uint32_t y0 = static_cast<uint32_t>(py);
    if (y0 > s - 2) y0 = s - 2;
    const float fy = py - static_cast<float>(y0);
    const float* row0 = parent + size_t{y0} * s * c;
    const float* row1 = row0 + size_t{s} * c;
    float* dst = out + size_t{j} * s * c;
    for (uint32_t i = 0; i < s; ++i) {
      const float px = base_x + i * 0.5f;
      uint32_t x0 = static_cast<uint32_t>(px);
      if (x0 > s - 2) x0 = s - 2;
      const float fx = px - static_cast<float>(x0);
      const float w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
      const float* a = row0 + size_t{x0} * c;
      const float* b = row1 + size_t{x0} * c;
      for (uint32_t k = 0; k < c; ++k) dst[i * c + k] = w00 * a[k] + w10 * a[c + k] + w01 * b[k] + w11 * b[c + k];
    }
  }
}

/// What a payload header says, without decoding (tile_peek_header).
struct TileHeaderInfo {
  uint32_t channels = 0;
  uint32_t stored_size = 0;
  bool residual = false;  ///< true: decoding needs the parent's decoded tile
  float tolerance[kTileMaxChannels] = {};
  uint32_t symbol_bytes = 0;
};

/// Parses and validates a payload header. Returns success, short_output (fewer bytes than a
/// header) or bad_data (wrong version or block size, sizes out of range, tolerance not finite
/// and positive). Safe on untrusted input; thread-safe, no allocation.
inline Status tile_peek_header(std::span<const uint8_t> payload, TileHeaderInfo& info, const char** why = nullptr) noexcept {
  auto fail = [&](Status s, const char* m) {
    if (why) *why = m;
    return s;
  };
  if (payload.size() < 4) return fail(Status::short_output, "tile payload shorter than its header");
  if (payload[0] != kTileFormatVersion) return fail(Status::bad_data, "tile format version is not 1");
  if (payload[1] != kTileBlock) return fail(Status::bad_data, "tile block size is not 8");
  const uint32_t channels = payload[2];
  if (channels < 1 || channels > kTileMaxChannels) return fail(Status::bad_data, "tile channel count not in 1..4");
  if ((payload[3] & ~1u) != 0) return fail(Status::bad_data, "tile flags have unknown bits set");
  if (payload.size() < tile_header_size(channels)) return fail(Status::short_output, "tile payload shorter than its header");
  uint16_t w = 0, h = 0;
  std::memcpy(&w, payload.data() + 4, 2);
  std::memcpy(&h, payload.data() + 6, 2);
  if (w != h || w == 0 || w % kTileBlock != 0 || w > 1024) return fail(Status::bad_data, "tile size not square, a multiple of 8 and <= 1024");
  info.channels = channels;
  info.stored_size = w;
  info.residual = (payload[3] & 1u) != 0;
  for (uint32_t c = 0; c < channels; ++c) {
    float t = 0;
    std::memcpy(&t, payload.data() + 8 + 4 * c, 4);
    if (!(t > 0.0f) || !(t < 1e15f)) return fail(Status::bad_data, "tile tolerance not finite and positive");
    info.tolerance[c] = t;
  }
  std::memcpy(&info.symbol_bytes, payload.data() + 8 + 4 * channels, 4);
  const size_t count = size_t{w} * w * channels;
  if (info.symbol_bytes < count || info.symbol_bytes > count * 5) return fail(Status::bad_data, "tile symbol byte count out of range");
  return Status::success;
}

/// Which inflate implementation a TileDecoder uses (see the file comment).
enum class InflateBackend : uint8_t { zlib, libdeflate };
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
inline constexpr InflateBackend kDefaultInflateBackend = InflateBackend::libdeflate;
#else
inline constexpr InflateBackend kDefaultInflateBackend = InflateBackend::zlib;
#endif

/// Tile decoder: owns its inflate state and scratch buffers, allocated in the constructor, so
/// decode() does not allocate (zlib allocates its 32 KiB window once, on the first decode).
/// One object per thread: decode() is not thread-safe on the same object; different objects are
/// independent. Safe on untrusted input: malformed payloads return an error status and may leave
/// garbage in `out`, but never read or write outside the given spans.
class TileDecoder {
 public:
  /// `backend` libdeflate needs BTFLOD_TILE_CODEC_LIBDEFLATE; without it zlib is used.
  explicit TileDecoder(TileLayout layout = {}, InflateBackend backend = kDefaultInflateBackend) : layout_(layout) {
    if (layout_.valid()) {
      symbols_.resize(tile_symbol_bound(layout_));
      coefficients_.resize(layout_.sample_count());
    }
    std::memset(&stream_, 0, sizeof stream_);
    ready_ = layout_.valid() && inflateInit2(&stream_, -15) == Z_OK;
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
    if (backend == InflateBackend::libdeflate) {
      libdeflate_ = libdeflate_alloc_decompressor();
      ready_ = ready_ && libdeflate_ != nullptr;
    }
#else
    (void)backend;
#endif
  }
  TileDecoder(const TileDecoder&) = delete;
  TileDecoder& operator=(const TileDecoder&) = delete;
  ~TileDecoder() {
    inflateEnd(&stream_);  // safe on a zeroed or failed stream (returns Z_STREAM_ERROR)
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
    if (libdeflate_) libdeflate_free_decompressor(libdeflate_);
#endif
  }

  /// The inflate implementation in use.
  InflateBackend backend() const noexcept {
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
    if (libdeflate_) return InflateBackend::libdeflate;
#endif
    return InflateBackend::zlib;
  }

  const TileLayout& layout() const noexcept { return layout_; }

  /// Decodes one payload into `out` (layout().sample_count() floats, texel-interleaved).
  /// `parent` is the parent's decoded tile (same layout) when the payload is a residual (see
  /// tile_peek_header), else ignored and may be empty; (qx, qy) is the child's quadrant
  /// (x & 1, y & 1). Returns success; bad_data (malformed, wrong layout, inflates to more or
  /// less than declared, trailing bytes); short_output (payload truncated);
  /// insufficient_space (out too small); invalid_argument (parent missing or of the wrong size,
  /// invalid layout). message() then says what failed. No allocation, no exceptions.
  Status decode(std::span<const uint8_t> payload, std::span<const float> parent, uint32_t qx, uint32_t qy,
                std::span<float> out) noexcept {
    if (!ready_) return fail(Status::invalid_argument, "decoder has an invalid layout or inflateInit failed");
    if (out.size() < layout_.sample_count()) return fail(Status::insufficient_space, "output span smaller than the tile");
    TileHeaderInfo info;
    const char* why = nullptr;
    if (Status s = tile_peek_header(payload, info, &why); s != Status::success) return fail(s, why);
    if (info.channels != layout_.channels || info.stored_size != layout_.stored_size())
      return fail(Status::bad_data, "tile payload layout differs from the decoder's layout");
    if (info.residual && parent.size() < layout_.sample_count())
      return fail(Status::invalid_argument, "residual tile decoded without its parent");

    // Entropy stage. The output buffer is exactly the declared size: a stream that would inflate
    // to more is rejected when the buffer fills (this is the decompression-bomb guard).
    const size_t header = tile_header_size(info.channels);
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
    if (libdeflate_) {
      size_t used = 0, produced = 0;
      const libdeflate_result r = libdeflate_deflate_decompress_ex(libdeflate_, payload.data() + header, payload.size() - header,
                                                                   symbols_.data(), info.symbol_bytes, &used, &produced);
      if (r == LIBDEFLATE_INSUFFICIENT_SPACE) return fail(Status::bad_data, "deflate stream inflates beyond the declared size");
      if (r != LIBDEFLATE_SUCCESS) return fail(Status::bad_data, "deflate stream is corrupt or truncated");
      if (produced != info.symbol_bytes) return fail(Status::bad_data, "symbol stream shorter than declared");
      if (used != payload.size() - header) return fail(Status::bad_data, "trailing bytes after the deflate stream");
      return reconstruct(info, parent, qx, qy, out);
    }
#endif
    inflateReset(&stream_);
    stream_.next_in = const_cast<Bytef*>(payload.data() + header);
    stream_.avail_in = static_cast<uInt>(payload.size() - header);
    stream_.next_out = symbols_.data();
    stream_.avail_out = info.symbol_bytes;
    const int z = inflate(&stream_, Z_FINISH);
    if (z == Z_STREAM_END) {
      if (stream_.avail_out != 0) return fail(Status::bad_data, "symbol stream shorter than declared");
      if (stream_.avail_in != 0) return fail(Status::bad_data, "trailing bytes after the deflate stream");
    } else if (z == Z_DATA_ERROR || z == Z_NEED_DICT || z == Z_STREAM_ERROR || z == Z_MEM_ERROR) {
      return fail(Status::bad_data, "deflate stream is corrupt");
    } else {  // Z_BUF_ERROR or Z_OK: ran out of input or of output space
      if (stream_.avail_out == 0) return fail(Status::bad_data, "deflate stream inflates beyond the declared size");
      return fail(Status::short_output, "deflate stream truncated");
    }
    return reconstruct(info, parent, qx, qy, out);
  }

  /// A static description of the last failure ("" after success). Never null.
  const char* message() const noexcept { return message_; }

 private:
  Status fail(Status s, const char* m) noexcept {
    message_ = m;
    return s;
  }

  Status reconstruct(const TileHeaderInfo& info, std::span<const float> parent, uint32_t qx, uint32_t qy,
                     std::span<float> out) noexcept {
    const uint32_t s = layout_.stored_size();
    const uint32_t ch = layout_.channels;
    const uint32_t blocks_per_side = s / kTileBlock;
    const size_t blocks = size_t{blocks_per_side} * blocks_per_side;
    constexpr int kBlockArea = kTileBlock * kTileBlock;
    const auto& zigzag = zigzag_order<kTileBlock>();
    const auto& factors = quant_step_factors<kTileBlock>();

    // Symbols → dequantised coefficients, block-major so the inverse DCT reads them contiguously.
    const uint8_t* p = symbols_.data();
    const uint8_t* const end = p + info.symbol_bytes;
    for (uint32_t c = 0; c < ch; ++c) {
      float* coef = coefficients_.data() + size_t{c} * blocks * kBlockArea;
      for (int k = 0; k < kBlockArea; ++k) {
        const int natural = zigzag[k];
        const float step = info.tolerance[c] * factors[natural];
        int64_t dc = 0;  // DC (k = 0) symbols are differences to the previous block's DC
        float* dst = coef + natural;
        if (static_cast<size_t>(end - p) < blocks) return fail(Status::bad_data, "symbol stream ends before the last coefficient");
        for (size_t b = 0; b < blocks; ++b, dst += kBlockArea) {
          uint32_t u = *p++;
          if (u == 0xFFu) {
            if (end - p < 4) return fail(Status::bad_data, "escaped symbol truncated");
            std::memcpy(&u, p, 4);
            p += 4;
            // Each escape consumed 4 extra bytes: re-check that the remaining blocks still fit.
            if (static_cast<size_t>(end - p) < blocks - b - 1)
              return fail(Status::bad_data, "symbol stream ends before the last coefficient");
          }
          int64_t v = static_cast<int64_t>(u >> 1) ^ -static_cast<int64_t>(u & 1u);
          if (k == 0) {
            dc += v;
            v = dc;
          }
          *dst = static_cast<float>(v) * step;
        }
      }
    }
    if (p != end) return fail(Status::bad_data, "symbol stream longer than the tile");

    float* dst = out.data();
    if (info.residual) {
      upsample_parent(layout_, parent.data(), qx, qy, dst);
    } else {
      std::fill(dst, dst + layout_.sample_count(), 0.0f);
    }
    alignas(32) float block[kBlockArea];
    for (uint32_t c = 0; c < ch; ++c) {
      const float* coef = coefficients_.data() + size_t{c} * blocks * kBlockArea;
      for (uint32_t by = 0; by < blocks_per_side; ++by)
        for (uint32_t bx = 0; bx < blocks_per_side; ++bx) {
          dct_inverse<kTileBlock, float>(coef + (size_t{by} * blocks_per_side + bx) * kBlockArea, block, kTileBlock);
          for (int y = 0; y < kTileBlock; ++y) {
            float* row = dst + ((size_t{by} * kTileBlock + y) * s + size_t{bx} * kTileBlock) * ch + c;
            for (size_t x = 0; x < size_t{kTileBlock}; ++x) row[x * ch] += block[y * kTileBlock + x];
          }
        }
    }
    message_ = "";
    return Status::success;
  }

  TileLayout layout_;
  std::vector<uint8_t> symbols_;
  std::vector<float> coefficients_;
  z_stream stream_;
  bool ready_ = false;
  const char* message_ = "";
#if defined(BTFLOD_TILE_CODEC_LIBDEFLATE)
  libdeflate_decompressor* libdeflate_ = nullptr;
#endif
};

/// Tile encoder: owns its deflate state, scratch buffers and a TileDecoder (for the closed-loop
/// reconstruction). Offline code, but encode() itself does not allocate. One object per thread.
class TileEncoder {
 public:
  /// `deflate_level` is zlib's 0..9 (6 = zlib's default balance).
  explicit TileEncoder(TileLayout layout = {}, int deflate_level = 6) : layout_(layout), decoder_(layout) {
    if (layout_.valid()) {
      prediction_.resize(layout_.sample_count());
      quantised_.resize(layout_.sample_count());
      symbols_.resize(tile_symbol_bound(layout_));
    }
    std::memset(&stream_, 0, sizeof stream_);
    ready_ = layout_.valid() &&
             deflateInit2(&stream_, std::clamp(deflate_level, 0, 9), Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) == Z_OK;
  }
  TileEncoder(const TileEncoder&) = delete;
  TileEncoder& operator=(const TileEncoder&) = delete;
  ~TileEncoder() {
    if (ready_) deflateEnd(&stream_);
  }

  const TileLayout& layout() const noexcept { return layout_; }
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
    if (!ready_) return fail(Status::invalid_argument, "encoder has an invalid layout or deflateInit failed");
    const uint32_t s = layout_.stored_size();
    const uint32_t ch = layout_.channels;
    const size_t n = layout_.sample_count();
    if (tile.size() < n) return fail(Status::invalid_argument, "tile span smaller than the layout");
    if (!parent.empty() && parent.size() < n) return fail(Status::invalid_argument, "parent span smaller than the layout");
    if (tolerance.size() < ch) return fail(Status::invalid_argument, "fewer tolerances than channels");
    for (uint32_t c = 0; c < ch; ++c)
      if (!(tolerance[c] > 0.0f) || !(tolerance[c] < 1e15f)) return fail(Status::invalid_argument, "tolerance not finite and positive");
    if (!reconstruction.empty() && reconstruction.size() < n) return fail(Status::insufficient_space, "reconstruction span too small");
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
    const auto& factors = quant_step_factors<kTileBlock>();
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
            if (!(std::fabs(v) < 536870912.0f)) return fail(Status::invalid_argument, "sample not finite or too large for the tolerance");
            q[k] = static_cast<int32_t>(std::nearbyint(v));
          }
        }
    }

    // Symbol stream (see the file comment).
    const auto& zigzag = zigzag_order<kTileBlock>();
    uint8_t* sym = symbols_.data();
    for (uint32_t c = 0; c < ch; ++c) {
      const int32_t* q = quantised_.data() + size_t{c} * blocks * kBlockArea;
      for (int k = 0; k < kBlockArea; ++k) {
        const int natural = zigzag[k];
        int32_t previous_dc = 0;
        for (size_t b = 0; b < blocks; ++b) {
          int32_t v = q[b * kBlockArea + natural];
          if (k == 0) {
            const int32_t d = v - previous_dc;
            previous_dc = v;
            v = d;
          }
          const uint32_t u = (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31);
          if (u < 0xFFu) {
            *sym++ = static_cast<uint8_t>(u);
          } else {
            *sym++ = 0xFF;
            std::memcpy(sym, &u, 4);
            sym += 4;
          }
        }
      }
    }
    const uint32_t symbol_bytes = static_cast<uint32_t>(sym - symbols_.data());

    // Header.
    uint8_t* o = out.data();
    o[0] = kTileFormatVersion;
    o[1] = kTileBlock;
    o[2] = static_cast<uint8_t>(ch);
    o[3] = parent.empty() ? 0 : 1;
    const uint16_t size16 = static_cast<uint16_t>(s);
    std::memcpy(o + 4, &size16, 2);
    std::memcpy(o + 6, &size16, 2);
    for (uint32_t c = 0; c < ch; ++c) std::memcpy(o + 8 + 4 * c, &tolerance[c], 4);
    std::memcpy(o + 8 + 4 * ch, &symbol_bytes, 4);

    // Entropy stage.
    deflateReset(&stream_);
    stream_.next_in = symbols_.data();
    stream_.avail_in = symbol_bytes;
    stream_.next_out = o + header;
    stream_.avail_out = static_cast<uInt>(std::min<size_t>(out.size() - header, UINT32_MAX));
    const int z = deflate(&stream_, Z_FINISH);
    if (z != Z_STREAM_END) return fail(Status::insufficient_space, "output buffer smaller than the compressed tile");
    written = header + stream_.total_out;

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
  z_stream stream_;
  bool ready_ = false;
  const char* message_ = "";
};

}  // namespace btflod
