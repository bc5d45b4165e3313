// Prototype measured by bench_codec_entropy (not part of the library): a context-modelled
// adaptive binary range coder for the tile codec's quantised 8×8 DCT blocks.
//
// Binary arithmetic coding (a range coder with carry propagation, as in LZMA) of a CABAC-like
// binarisation (ITU-T H.264 §9.3: significance map, "last" flags, greater-than-one /
// greater-than-two flags, Exp-Golomb remainders), with adaptive probabilities per context:
//   DC   the difference to the previous block's DC of the same channel: zero flag (context: was
//        the previous difference zero), sign, then |d| − 1 as Exp-Golomb: the bit length in unary
//        (one context per length) and the bits below the leading one in equiprobable (bypass) bits.
//   AC   for each zig-zag position k = 1..63 up to the last non-zero coefficient:
//          sig   is q[k] non-zero; context (channel, k, n, z) with n = how many of the left and
//                upper neighbour blocks (same channel) have a non-zero coefficient at k (0..2)
//                and z = whether q[k − 1] is non-zero — a per-frequency, per-level model;
//          last  (after a non-zero) is it the block's last non-zero; context (channel, k, n > 0);
//          gt1, gt2  |q| > 1, |q| > 2; context (channel, frequency band of k, n);
//          rem   |q| − 3 as Exp-Golomb (unary length with contexts per band, bypass bits);
//          sign  bypass.
//        A block whose DC difference is coded and whose AC part is empty codes one extra flag
//        before the AC part: "has AC" (context: channel, n of position 1).
// Probabilities: two 16-bit estimates per context adapting at rates 2⁻⁴ and 2⁻⁷, averaged (fast
// learning on the 81 blocks per channel of a tile, precise in the long run); each tile starts
// from p = ½, so tiles decode independently.
//
// Stream: the coder's bytes; the first byte is always 0 (the range coder's carry slot). A valid
// stream is consumed exactly (the decoder reads 4 bytes ahead, the encoder's flush writes them)
// and ends with the decoder's code register at 0; RangeDecoder::finish() checks both, so a
// truncated, extended or corrupted stream is rejected (bytes past the end read as 0 and count as
// an overrun). Values are bounded (Exp-Golomb lengths ≤ 30 bits, |coefficient| ≤ 2^29 steps), so
// decoding garbage ends in a bounded number of steps with bad_data.
//
// Measured result (bench_codec_entropy on the demo materials): 1.6–1.7× deflate's bytes — with
// every context starting at p = ½ in each tile, the ~2000 contexts of a 4-channel tile cannot
// learn from its 324 blocks (context dilution); a usable version needs trained initial
// probabilities shipped with the material, like zstd's dictionary.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

namespace btflod {

namespace detail {
// Frequency band of zig-zag position k (1..63) for the magnitude contexts.
inline constexpr uint8_t kRangeBand[64] = {0, 0, 0, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 3, 4, 4, 4, 4, 4, 4, 5,
                                           5, 5, 5, 5, 5, 5, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6,
                                           6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6};
inline constexpr int kRangeBands = 7;
inline constexpr int kRangeMaxLength = 30;  // Exp-Golomb bit lengths 1..30
}  // namespace detail

/// One adaptive binary context: two estimates of P(bit = 0) in 1/65536, rates 2⁻⁴ and 2⁻⁷.
struct RangeContext {
  uint16_t fast = 32768;
  uint16_t slow = 32768;
  /// P(bit = 0) in 1/32768, always in [35, 32732].
  uint32_t p() const noexcept { return (uint32_t{fast} + slow) >> 2; }
  void update(uint32_t bit) noexcept {
    if (bit) {
      fast = static_cast<uint16_t>(fast - (fast >> 4));
      slow = static_cast<uint16_t>(slow - (slow >> 7));
    } else {
      fast = static_cast<uint16_t>(fast + ((65536u - fast) >> 4));
      slow = static_cast<uint16_t>(slow + ((65536u - slow) >> 7));
    }
  }
};

/// Range encoder (LZMA's carry-propagating scheme) into a caller-owned buffer. Writing past the
/// buffer sets overflow() instead. No allocation; not thread-safe on one object.
class RangeEncoder {
 public:
  explicit RangeEncoder(std::span<uint8_t> out) noexcept : out_(out) {}

  /// Codes `bit` (0 or 1) with context `c` and adapts it.
  void encode(RangeContext& c, uint32_t bit) noexcept {
    const uint32_t bound = (range_ >> 15) * c.p();
    if (bit == 0) {
      range_ = bound;
    } else {
      low_ += bound;
      range_ -= bound;
    }
    c.update(bit);
    while (range_ < (1u << 24)) {
      range_ <<= 8;
      shift_low();
    }
  }
  /// Codes the `count` low bits of `bits` (most significant first) with probability ½ each.
  void encode_direct(uint32_t bits, int count) noexcept {
    for (int i = count - 1; i >= 0; --i) {
      range_ >>= 1;
      if ((bits >> i) & 1u) low_ += range_;
      while (range_ < (1u << 24)) {
        range_ <<= 8;
        shift_low();
      }
    }
  }
  /// Writes the last bytes; returns the stream size, or 0 when the buffer was too small.
  size_t finish() noexcept {
    for (int i = 0; i < 5; ++i) shift_low();
    return overflow_ ? 0 : pos_;
  }
  bool overflow() const noexcept { return overflow_; }

 private:
  void put(uint8_t b) noexcept {
    if (pos_ < out_.size()) {
      out_[pos_++] = b;
    } else {
      overflow_ = true;
    }
  }
  void shift_low() noexcept {
    if (static_cast<uint32_t>(low_) < 0xFF000000u || (low_ >> 32) != 0) {
      const uint8_t carry = static_cast<uint8_t>(low_ >> 32);
      uint8_t temp = cache_;
      do {
        put(static_cast<uint8_t>(temp + carry));
        temp = 0xFF;
      } while (--cache_size_ != 0);
      cache_ = static_cast<uint8_t>(low_ >> 24);
    }
    ++cache_size_;
    low_ = (low_ & 0x00FFFFFFu) << 8;
  }

  std::span<uint8_t> out_;
  size_t pos_ = 0;
  uint64_t low_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  uint8_t cache_ = 0;
  uint64_t cache_size_ = 1;
  bool overflow_ = false;
};

/// Range decoder over an untrusted byte span: bytes past the end read as 0 and are counted;
/// finish() tells a well-formed, exactly consumed stream from anything else. No allocation.
class RangeDecoder {
 public:
  /// Starts decoding `in` (reads its first 5 bytes; a first byte other than 0 makes finish() fail).
  explicit RangeDecoder(std::span<const uint8_t> in) noexcept : p_(in.data()), end_(in.data() + in.size()) {
    bad_first_ = next() != 0;
    for (int i = 0; i < 4; ++i) code_ = code_ << 8 | next();
  }

  /// Decodes one bit with context `c` and adapts it.
  uint32_t decode(RangeContext& c) noexcept {
    const uint32_t bound = (range_ >> 15) * c.p();
    uint32_t bit;
    if (code_ < bound) {
      range_ = bound;
      bit = 0;
    } else {
      code_ -= bound;
      range_ -= bound;
      bit = 1;
    }
    c.update(bit);
    while (range_ < (1u << 24)) {  // a 15-bit probability can shrink the range by up to 2^10
      range_ <<= 8;
      code_ = code_ << 8 | next();
    }
    return bit;
  }
  /// Decodes `count` (≤ 30) equiprobable bits, most significant first.
  uint32_t decode_direct(int count) noexcept {
    uint32_t v = 0;
    for (int i = 0; i < count; ++i) {
      range_ >>= 1;
      uint32_t bit = 0;
      if (code_ >= range_) {
        code_ -= range_;
        bit = 1;
      }
      v = v << 1 | bit;
      if (range_ < (1u << 24)) {
        range_ <<= 8;
        code_ = code_ << 8 | next();
      }
    }
    return v;
  }
  /// True when the stream was consumed exactly, started with 0 and ended where the encoder's
  /// flush ends (code register 0).
  bool finish() const noexcept { return !bad_first_ && overrun_ == 0 && p_ == end_ && code_ == 0; }

 private:
  uint32_t next() noexcept {
    if (p_ != end_) return *p_++;
    ++overrun_;
    return 0;
  }
  const uint8_t* p_;
  const uint8_t* end_;
  uint32_t code_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  uint32_t overrun_ = 0;
  bool bad_first_ = false;
};

/// Adaptive context model of one channel's blocks (see the file comment). Plain data: reset()
/// before each tile. 3.2 KiB.
struct RangeChannelModel {
  RangeContext dc_zero[2];
  RangeContext dc_sign;
  RangeContext dc_length[detail::kRangeMaxLength];
  RangeContext has_ac[3];
  RangeContext sig[64][3][2];
  RangeContext last[64][2];
  RangeContext gt1[detail::kRangeBands][3];
  RangeContext gt2[detail::kRangeBands][3];
  RangeContext rem_length[detail::kRangeBands][detail::kRangeMaxLength];
  void reset() noexcept { *this = RangeChannelModel{}; }
};

namespace detail {
inline uint32_t range_bit_length(uint32_t v) noexcept {
  return v == 0 ? 0u : 32u - static_cast<uint32_t>(__builtin_clz(v));
}

// Exp-Golomb-like code of v ≥ 1: bit length L (1..30) in unary with contexts, then L − 1 bypass bits.
inline void range_put_length_coded(RangeEncoder& e, RangeContext* length_ctx, uint32_t v) noexcept {
  const uint32_t len = range_bit_length(v);
  for (uint32_t i = 1; i < len; ++i) e.encode(length_ctx[i - 1], 1);
  if (len < kRangeMaxLength) e.encode(length_ctx[len - 1], 0);
  if (len > 1) e.encode_direct(v, static_cast<int>(len - 1));  // the bits below the leading one
}
// Inverse; false when the length exceeds 30 bits (never produced by the encoder for v < 2^30).
inline bool range_get_length_coded(RangeDecoder& d, RangeContext* length_ctx, uint32_t& v) noexcept {
  uint32_t len = 1;
  while (len < kRangeMaxLength && d.decode(length_ctx[len - 1])) ++len;
  v = (1u << (len - 1)) | (len > 1 ? d.decode_direct(static_cast<int>(len - 1)) : 0u);
  return true;
}
}  // namespace detail

/// Neighbour state of one channel across a row of blocks: the significance masks (bit k = the
/// zig-zag coefficient k is non-zero) of the row above and of the current row so far.
struct RangeNeighbours {
  uint64_t mask[128] = {};  // S/8 ≤ 128 blocks per row
};

/// Encodes one block of `channel_model`: `zz` holds the 64 quantised coefficients in zig-zag order
/// (|q| ≤ 2^29, DC difference |dc_diff| < 2^30); `left`/`above` are the neighbours' masks
/// (0 at the tile edge); `prev_dc_zero` the previous DC difference of the channel was 0.
/// Returns this block's significance mask. No allocation.
inline uint64_t range_encode_block(RangeEncoder& e, RangeChannelModel& m, const int32_t* zz, int64_t dc_diff,
                                   bool prev_dc_zero, uint64_t left, uint64_t above) noexcept {
  e.encode(m.dc_zero[prev_dc_zero], dc_diff != 0);
  if (dc_diff != 0) {
    e.encode(m.dc_sign, dc_diff < 0);
    const uint64_t mag = static_cast<uint64_t>(dc_diff < 0 ? -dc_diff : dc_diff);
    detail::range_put_length_coded(e, m.dc_length, static_cast<uint32_t>(mag));
  }
  int last = 0;
  for (int k = 63; k > 0; --k)
    if (zz[k] != 0) {
      last = k;
      break;
    }
  uint64_t mask = 0;  // AC positions only (bit 0 unused)
  const uint32_t n1 = static_cast<uint32_t>((left >> 1 & 1u) + (above >> 1 & 1u));
  e.encode(m.has_ac[n1], last != 0);
  if (last == 0) return mask;
  uint32_t prev_nz = 0;
  for (int k = 1; k <= last; ++k) {
    const uint32_t n = static_cast<uint32_t>((left >> k & 1u) + (above >> k & 1u));
    const int32_t v = zz[k];
    e.encode(m.sig[k][n][prev_nz], v != 0);
    if (v == 0) {
      prev_nz = 0;
      continue;
    }
    mask |= uint64_t{1} << k;
    prev_nz = 1;
    const uint32_t a = static_cast<uint32_t>(v < 0 ? -static_cast<int64_t>(v) : v);
    const int band = detail::kRangeBand[k];
    e.encode(m.gt1[band][n], a > 1);
    if (a > 1) {
      e.encode(m.gt2[band][n], a > 2);
      if (a > 2) detail::range_put_length_coded(e, m.rem_length[band], a - 2);
    }
    e.encode_direct(v < 0 ? 1u : 0u, 1);
    if (k < 63) e.encode(m.last[k][n != 0], k == last);
  }
  return mask;
}

/// Decoded block: `count` non-zero AC coefficients at zig-zag positions `pos` with values `value`
/// (in steps), the DC difference, and the significance mask.
struct RangeBlock {
  int64_t dc_diff = 0;
  uint32_t count = 0;
  uint8_t pos[63];
  int32_t value[63];
  uint64_t mask = 0;
};

/// Decodes one block (inverse of range_encode_block, same neighbour arguments). The
/// caller adds out.dc_diff to its running DC and checks the range. Returns false on a value out of
/// range (|AC| > 2^29 steps) or an AC part without a non-zero coefficient (never encoded). Never
/// reads outside the decoder's span; bounded work (≤ 63 positions, ≤ 30 bits per length code).
inline bool range_decode_block(RangeDecoder& d, RangeChannelModel& m, bool prev_dc_zero, uint64_t left, uint64_t above,
                               RangeBlock& out) noexcept {
  out.count = 0;
  out.dc_diff = 0;
  uint64_t mask = 0;
  if (d.decode(m.dc_zero[prev_dc_zero])) {
    const uint32_t negative = d.decode(m.dc_sign);
    uint32_t mag = 0;
    detail::range_get_length_coded(d, m.dc_length, mag);
    out.dc_diff = negative ? -static_cast<int64_t>(mag) : static_cast<int64_t>(mag);
  }
  const uint32_t n1 = static_cast<uint32_t>((left >> 1 & 1u) + (above >> 1 & 1u));
  if (d.decode(m.has_ac[n1])) {
    uint32_t prev_nz = 0;
    for (int k = 1; k < 64; ++k) {
      const uint32_t n = static_cast<uint32_t>((left >> k & 1u) + (above >> k & 1u));
      if (!d.decode(m.sig[k][n][prev_nz])) {
        prev_nz = 0;
        continue;
      }
      prev_nz = 1;
      mask |= uint64_t{1} << k;
      const int band = detail::kRangeBand[k];
      uint32_t a = 1;
      if (d.decode(m.gt1[band][n])) {
        a = 2;
        if (d.decode(m.gt2[band][n])) {
          uint32_t r = 0;
          detail::range_get_length_coded(d, m.rem_length[band], r);
          if (r > (uint32_t{1} << 29) - 2u) return false;
          a = r + 2;
        }
      }
      const uint32_t negative = d.decode_direct(1);
      out.pos[out.count] = static_cast<uint8_t>(k);
      out.value[out.count] = negative ? -static_cast<int32_t>(a) : static_cast<int32_t>(a);
      ++out.count;
      if (k == 63 || d.decode(m.last[k][n != 0])) break;
    }
    if (out.count == 0) return false;  // "has AC" without a non-zero AC coefficient: never encoded
  }
  out.mask = mask;
  return true;
}

}  // namespace btflod
