// Tests for runtime/codec/tile_codec.hpp: parent up-sampling geometry, round trip within the tolerance,
// closed-loop residual coding along a 6-level chain without drift, the AVX2 inverse DCT against
// its scalar twin, and failure classes (truncated, trailing bytes, corrupted, wrong layout,
// missing parent, decompression bomb, hostile symbol streams: runs past the block, invalid
// tokens, over-long varints, coefficients out of range, streams ending inside a block or
// running past the tile). With BTFLOD_WRITE_TILE_SEEDS=<dir> it also writes the fuzz seeds of
// fuzz/corpus/fuzz_tile_decoder into <dir>.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <zlib.h>

#include "btflod/runtime/codec/tile_codec.hpp"
#include "test_deflate_bomb.hpp"
#include "test_fuzz_seeds.hpp"

// The inflate backend of every decoder here; test_codec_tile_zlib.cpp runs this file again with
// zlib (the backend is a run-time choice, runtime/codec/tile_codec.hpp).
#ifndef BTFLOD_TEST_INFLATE_BACKEND
#define BTFLOD_TEST_INFLATE_BACKEND btflod::default_inflate_backend()
#endif

namespace {

using btflod::Status;
using btflod::TileDecoder;
using btflod::TileEncoder;
using btflod::TileLayout;

// A smooth multi-frequency "eigen-texture" over [0,1]², 4 components of different ranges, plus
// a little deterministic texel noise, sampled at texel centres of level `level` (64·2^level
// texels per side) with clamped borders — the same construction a tile pyramid builder uses.
float texture_value(uint32_t c, double u, double v, uint32_t level) {
  const double amp[4] = {1.0, 0.2, 0.05, 3.0};
  double f = amp[c] * (std::sin(6.3 * u + c) * std::cos(4.1 * v - c) + 0.3 * std::sin(40.0 * u * v + c) +
                       0.1 * std::cos(150.0 * (u + 0.3 * v)));
  // Hash noise at the finest scale of this level.
  const uint64_t h = (static_cast<uint64_t>(u * 1e6) * 0x9E3779B97F4A7C15ull) ^
                     (static_cast<uint64_t>(v * 1e6) * 0xC2B2AE3D27D4EB4Full) ^ (c * 0x165667B19E3779F9ull) ^ level;
  f += amp[c] * 0.01 * (static_cast<double>(h % 1000) / 1000.0 - 0.5);
  return static_cast<float>(f);
}

std::vector<float> make_tile(const TileLayout& layout, uint32_t level, uint32_t tx, uint32_t ty) {
  const uint32_t s = layout.stored_size();
  const double w = static_cast<double>(layout.tile_size) * (1u << level);
  std::vector<float> t(layout.sample_count());
  for (uint32_t j = 0; j < s; ++j)
    for (uint32_t i = 0; i < s; ++i) {
      double x = static_cast<double>(tx) * layout.tile_size - layout.border + i;
      double y = static_cast<double>(ty) * layout.tile_size - layout.border + j;
      x = std::clamp(x, 0.0, w - 1);
      y = std::clamp(y, 0.0, w - 1);
      for (uint32_t c = 0; c < layout.channels; ++c)
        t[(j * s + i) * layout.channels + c] = texture_value(c, (x + 0.5) / w, (y + 0.5) / w, level);
    }
  return t;
}

// Largest 8×8-block RMS error of channel c.
double max_block_rms(const TileLayout& layout, const std::vector<float>& a, const std::vector<float>& b, uint32_t c) {
  const uint32_t s = layout.stored_size();
  double worst = 0;
  for (uint32_t by = 0; by < s / 8; ++by)
    for (uint32_t bx = 0; bx < s / 8; ++bx) {
      double e = 0;
      for (uint32_t y = 0; y < 8; ++y)
        for (uint32_t x = 0; x < 8; ++x) {
          const size_t i = ((by * 8 + y) * s + bx * 8 + x) * layout.channels + c;
          e += (static_cast<double>(a[i]) - b[i]) * (static_cast<double>(a[i]) - b[i]);
        }
      worst = std::max(worst, std::sqrt(e / 64));
    }
  return worst;
}

std::vector<float> tolerances(float quality) {
  const float ranges[4] = {2.6f, 0.52f, 0.13f, 7.8f};
  std::vector<float> t(4);
  for (int c = 0; c < 4; ++c) t[c] = btflod::tolerance_for_quality(quality, ranges[c]);
  return t;
}

struct Encoded {
  std::vector<uint8_t> bytes;
  std::vector<float> reconstruction;
};

Encoded encode(TileEncoder& enc, const std::vector<float>& tile, const std::vector<float>* parent, uint32_t qx,
               uint32_t qy, const std::vector<float>& tol) {
  Encoded e;
  e.bytes.resize(enc.bound());
  e.reconstruction.resize(enc.layout().sample_count());
  size_t written = 0;
  const Status s = enc.encode(tile, parent ? std::span<const float>(*parent) : std::span<const float>(), qx, qy, tol,
                              e.bytes, written, e.reconstruction);
  EXPECT_EQ(s, Status::success) << enc.message();
  e.bytes.resize(written);
  return e;
}

TEST(CodecTile, UpsamplingReproducesLinearFunctionsAtTheChildGeometry) {
  const TileLayout layout;  // 64 + 2·4, 4 channels
  const uint32_t s = layout.stored_size();
  // Parent tile (px, py) = (3, 5) at level l−1 holds F(X', Y') = 0.25 X' − 0.5 Y' + 2 (level l−1 texels).
  const uint32_t px = 3, py = 5;
  std::vector<float> parent(layout.sample_count());
  auto f = [](double x, double y, uint32_t c) { return 0.25 * x - 0.5 * y + 2.0 + c; };
  for (uint32_t j = 0; j < s; ++j)
    for (uint32_t i = 0; i < s; ++i)
      for (uint32_t c = 0; c < 4; ++c)
        parent[(j * s + i) * 4 + c] = static_cast<float>(f(px * 64.0 - 4 + i, py * 64.0 - 4 + j, c));
  std::vector<float> pred(layout.sample_count());
  for (uint32_t q = 0; q < 4; ++q) {
    const uint32_t cx = 2 * px + (q & 1), cy = 2 * py + (q >> 1);
    btflod::upsample_parent(layout, parent.data(), q & 1, q >> 1, pred.data());
    for (uint32_t j = 0; j < s; ++j)
      for (uint32_t i = 0; i < s; ++i) {
        // Child texel centre X + 0.5 at level l is (X + 0.5)/2 at level l−1, i.e. texel coordinate (X − 0.5)/2.
        const double x = (cx * 64.0 - 4 + i - 0.5) / 2.0, y = (cy * 64.0 - 4 + j - 0.5) / 2.0;
        for (uint32_t c = 0; c < 4; ++c)
          ASSERT_NEAR(pred[(j * s + i) * 4 + c], f(x, y, c), 1e-4) << i << "," << j << " q" << q;
      }
  }
}

TEST(CodecTile, RoundTripWithoutParentStaysWithinTolerance) {
  const TileLayout layout;
  TileEncoder enc(layout);
  TileDecoder dec(layout, BTFLOD_TEST_INFLATE_BACKEND);
  const auto tile = make_tile(layout, 0, 0, 0);
  for (float quality : {10.0f, 50.0f, 90.0f}) {
    const auto tol = tolerances(quality);
    const auto e = encode(enc, tile, nullptr, 0, 0, tol);
    std::vector<float> out(layout.sample_count());
    ASSERT_EQ(dec.decode(e.bytes, {}, 0, 0, out), Status::success) << dec.message();
    EXPECT_EQ(0, std::memcmp(out.data(), e.reconstruction.data(), out.size() * 4))
        << "encoder's reconstruction differs";
    for (uint32_t c = 0; c < 4; ++c) {
      const double err = max_block_rms(layout, tile, out, c);
      EXPECT_LE(err, tol[c] * 1.001) << "quality " << quality << " channel " << c;
      EXPECT_GT(err, 0.0);
    }
    EXPECT_LT(e.bytes.size(), layout.texel_count() * 8) << "no smaller than raw halves";
  }
}

// Every frequency-weighting exponent keeps the block-RMS bound (the tables are normalised to
// the same RMS), is recorded in the header and decoded with its own table; the default writes
// JPEG's table with the weighting bits 0 (the bytes of earlier versions).
TEST(CodecTile, FrequencyWeightingExponentsRoundTripWithinTolerance) {
  const TileLayout layout;
  TileDecoder dec(layout, BTFLOD_TEST_INFLATE_BACKEND);
  const auto tile = make_tile(layout, 2, 1, 2);
  const auto tol = tolerances(50);
  std::vector<size_t> sizes;
  for (uint32_t quarters = 0; quarters <= 4; ++quarters) {
    const auto& f = btflod::quant_step_factors<8>(quarters);
    double sum_sq = 0;
    for (float x : f) sum_sq += double{x} * x;
    EXPECT_NEAR(std::sqrt(sum_sq / 64), 2.0, 1e-5) << "quarters " << quarters;
    if (quarters == 0) {
      for (float x : f) EXPECT_NEAR(x, 2.0f, 1e-6f);
    }
    TileEncoder enc(layout);
    enc.set_weight_quarters(quarters);
    const auto e = encode(enc, tile, nullptr, 0, 0, tol);
    btflod::TileHeaderInfo info;
    ASSERT_EQ(btflod::tile_peek_header(e.bytes, info), Status::success);
    EXPECT_EQ(info.weight_quarters, quarters);
    EXPECT_EQ(e.bytes[3] >> 1, 4 - quarters) << "flag bits 1-3";
    std::vector<float> out(layout.sample_count());
    ASSERT_EQ(dec.decode(e.bytes, {}, 0, 0, out), Status::success) << dec.message();
    EXPECT_EQ(0, std::memcmp(out.data(), e.reconstruction.data(), out.size() * 4)) << "quarters " << quarters;
    for (uint32_t c = 0; c < 4; ++c) EXPECT_LE(max_block_rms(layout, tile, out, c), tol[c] * 1.001) << quarters;
    sizes.push_back(e.bytes.size());
  }
  TileEncoder plain(layout);
  EXPECT_EQ(encode(plain, tile, nullptr, 0, 0, tol).bytes.size(), sizes[4]) << "default = JPEG's table";
  EXPECT_NE(sizes[0], sizes[4]) << "the flat table codes differently";
  // Decoding with the wrong table must show: rewrite the code of a JPEG-table tile to flat.
  TileEncoder jpeg(layout);
  auto e = encode(jpeg, tile, nullptr, 0, 0, tol);
  e.bytes[3] = static_cast<uint8_t>(e.bytes[3] | 4u << 1);
  std::vector<float> wrong(layout.sample_count());
  ASSERT_EQ(dec.decode(e.bytes, {}, 0, 0, wrong), Status::success);
  double worst = 0;
  for (uint32_t c = 0; c < 4; ++c) worst = std::max(worst, max_block_rms(layout, tile, wrong, c) / tol[c]);
  EXPECT_GT(worst, 1.5) << "the header's table is the one used";
}

TEST(CodecTile, HigherQualityCostsMoreBytesAndLessError) {
  const TileLayout layout;
  TileEncoder enc(layout);
  const auto tile = make_tile(layout, 2, 1, 2);
  size_t previous_size = 0;
  for (float quality : {5.0f, 30.0f, 60.0f, 95.0f}) {
    const auto e = encode(enc, tile, nullptr, 0, 0, tolerances(quality));
    EXPECT_GT(e.bytes.size(), previous_size);
    previous_size = e.bytes.size();
  }
}

// The 6-level decode chain: each level coded against the decoded parent; a client decoding the
// chain from the root gets bit-identical tiles, and the error at level 5 is still within the
// tolerance (no drift).
TEST(CodecTile, SixLevelChainDecodesWithoutDrift) {
  const TileLayout layout;
  TileEncoder enc(layout);
  const auto tol = tolerances(50);
  std::vector<std::vector<float>> originals;
  std::vector<Encoded> coded;
  std::vector<std::array<uint32_t, 2>> quadrant;
  uint32_t x = 0, y = 0;
  for (uint32_t level = 0; level < 6; ++level) {
    if (level > 0) {
      const uint32_t qx = level & 1u, qy = (level >> 1) & 1u;
      x = 2 * x + qx;
      y = 2 * y + qy;
      quadrant.push_back({qx, qy});
    } else {
      quadrant.push_back({0, 0});
    }
    originals.push_back(make_tile(layout, level, x, y));
    coded.push_back(encode(enc, originals.back(), level ? &coded.back().reconstruction : nullptr, quadrant.back()[0],
                           quadrant.back()[1], tol));
  }
  TileDecoder dec(layout, BTFLOD_TEST_INFLATE_BACKEND);
  std::vector<float> parent, out(layout.sample_count());
  for (uint32_t level = 0; level < 6; ++level) {
    ASSERT_EQ(dec.decode(coded[level].bytes, parent, quadrant[level][0], quadrant[level][1], out), Status::success)
        << dec.message();
    ASSERT_EQ(0, std::memcmp(out.data(), coded[level].reconstruction.data(), out.size() * 4)) << "level " << level;
    for (uint32_t c = 0; c < 4; ++c)
      EXPECT_LE(max_block_rms(layout, originals[level], out, c), tol[c] * 1.001) << level;
    if (level > 0) {
      // Residual coding pays: the same tile coded without its parent is larger.
      const auto alone = encode(enc, originals[level], nullptr, 0, 0, tol);
      EXPECT_LT(coded[level].bytes.size(), alone.bytes.size()) << "level " << level;
    }
    parent = out;
  }
}

TEST(CodecTile, DecoderRejectsWrongArguments) {
  const TileLayout layout;
  TileEncoder enc(layout);
  TileDecoder dec(layout, BTFLOD_TEST_INFLATE_BACKEND);
  const auto tile = make_tile(layout, 1, 1, 0);
  const auto parent_tile = make_tile(layout, 0, 0, 0);
  const auto e = encode(enc, tile, &parent_tile, 1, 0, tolerances(50));
  std::vector<float> out(layout.sample_count());
  EXPECT_EQ(dec.decode(e.bytes, {}, 1, 0, out), Status::invalid_argument) << "residual tile needs its parent";
  EXPECT_EQ(dec.decode(e.bytes, parent_tile, 1, 0, std::span<float>(out).first(out.size() - 1)),
            Status::insufficient_space);
  TileDecoder other(TileLayout{32, 4, 4}, BTFLOD_TEST_INFLATE_BACKEND);
  std::vector<float> small(TileLayout{32, 4, 4}.sample_count());
  EXPECT_EQ(other.decode(e.bytes, parent_tile, 1, 0, small), Status::bad_data) << "wrong layout";
  TileDecoder invalid(TileLayout{64, 3, 4});
  EXPECT_EQ(invalid.decode(e.bytes, parent_tile, 1, 0, out), Status::invalid_argument);
}

TEST(CodecTile, EncoderRejectsNonFiniteInputAndSmallOutput) {
  const TileLayout layout;
  TileEncoder enc(layout);
  auto tile = make_tile(layout, 0, 0, 0);
  std::vector<uint8_t> out(enc.bound());
  size_t written = 1;
  const auto tol = tolerances(50);
  tile[777] = std::nanf("");
  EXPECT_EQ(enc.encode(tile, {}, 0, 0, tol, out, written), Status::invalid_argument);
  EXPECT_EQ(written, 0u);
  tile[777] = 0;
  std::vector<float> zero_tol(4, 0.0f);
  EXPECT_EQ(enc.encode(tile, {}, 0, 0, zero_tol, out, written), Status::invalid_argument);
  std::vector<uint8_t> tiny(40);
  EXPECT_EQ(enc.encode(tile, {}, 0, 0, tol, tiny, written), Status::insufficient_space);
  EXPECT_EQ(enc.encode(tile, {}, 0, 0, tol, out, written), Status::success) << "encoder recovers after failures";
}

class CodecTileFailures : public ::testing::Test {
 protected:
  void SetUp() override {
    parent_ = make_tile(layout_, 0, 0, 0);
    encoded_ = encode(enc_, make_tile(layout_, 1, 0, 1), &parent_, 0, 1, tolerances(50));
    // Canaries around the output span catch out-of-bounds writes.
    storage_.assign(layout_.sample_count() + 64, 12345.0f);
  }
  std::span<float> out() { return std::span<float>(storage_).subspan(32, layout_.sample_count()); }
  void expect_canaries() {
    for (int i = 0; i < 32; ++i) {
      ASSERT_EQ(storage_[i], 12345.0f);
      ASSERT_EQ(storage_[storage_.size() - 1 - i], 12345.0f);
    }
  }
  TileLayout layout_;
  TileEncoder enc_{layout_};
  TileDecoder dec_{layout_, BTFLOD_TEST_INFLATE_BACKEND};
  std::vector<float> parent_;
  Encoded encoded_;
  std::vector<float> storage_;
};

TEST_F(CodecTileFailures, TruncatedPayloadIsShortOutputOrBadData) {
  const auto& b = encoded_.bytes;
  for (size_t n = 0; n < b.size(); n += (n < 64 ? 1 : 13)) {
    const Status s = dec_.decode(std::span<const uint8_t>(b).first(n), parent_, 0, 1, out());
    ASSERT_NE(s, Status::success) << "prefix " << n;
    if (n >= btflod::tile_header_size(4) + 8) {
      EXPECT_EQ(s, Status::short_output) << "prefix " << n << ": " << dec_.message();
    }
  }
  expect_canaries();
  EXPECT_EQ(dec_.decode(b, parent_, 0, 1, out()), Status::success) << "decoder recovers after failures";
}

TEST_F(CodecTileFailures, TrailingBytesAreBadData) {
  auto b = encoded_.bytes;
  b.push_back(0);
  EXPECT_EQ(dec_.decode(b, parent_, 0, 1, out()), Status::bad_data);
  EXPECT_STREQ(dec_.message(), "trailing bytes after the deflate stream");
}

TEST_F(CodecTileFailures, HeaderFieldsOutOfRangeAreBadData) {
  auto mutate = [&](size_t offset, uint8_t value) {
    auto b = encoded_.bytes;
    b[offset] = value;
    return dec_.decode(b, parent_, 0, 1, out());
  };
  EXPECT_EQ(mutate(0, 1), Status::bad_data);     // version 1 is no longer read
  EXPECT_EQ(mutate(0, 4), Status::bad_data);     // unknown version (3: test_codec_tile_zstd)
  EXPECT_EQ(mutate(1, 16), Status::bad_data);    // block size
  EXPECT_EQ(mutate(2, 5), Status::bad_data);     // channels
  EXPECT_EQ(mutate(3, 0x81), Status::bad_data);  // unknown flag
  for (uint8_t code = 5; code <= 7; ++code)      // frequency weighting code beyond 0..4
    EXPECT_EQ(mutate(3, static_cast<uint8_t>(code << 1 | 1)), Status::bad_data) << int{code};
  EXPECT_EQ(mutate(4, 80), Status::bad_data);     // width ≠ height
  EXPECT_EQ(mutate(11, 0xFF), Status::bad_data);  // tolerance → NaN
  auto b = encoded_.bytes;
  const uint32_t too_many = static_cast<uint32_t>(btflod::tile_symbol_bound(layout_) + 1);
  std::memcpy(b.data() + 24, &too_many, 4);
  EXPECT_EQ(dec_.decode(b, parent_, 0, 1, out()), Status::bad_data) << "oversized symbol count";
  uint32_t declared = 0;
  std::memcpy(&declared, encoded_.bytes.data() + 24, 4);
  b = encoded_.bytes;
  const uint32_t more = declared + 1;
  std::memcpy(b.data() + 24, &more, 4);
  EXPECT_EQ(dec_.decode(b, parent_, 0, 1, out()), Status::bad_data) << "declared size larger than the stream";
  b = encoded_.bytes;
  const uint32_t fewer = declared - 1;
  std::memcpy(b.data() + 24, &fewer, 4);
  EXPECT_EQ(dec_.decode(b, parent_, 0, 1, out()), Status::bad_data) << "stream larger than declared";
  expect_canaries();
}

TEST_F(CodecTileFailures, DecompressionBombIsRejectedWithoutInflatingIt) {
  // A valid header followed by 64 MiB of zeros deflated (≈ 64 KiB): the decoder must stop at the
  // declared symbol count instead of inflating it all.
  const std::vector<uint8_t> packed = btflod_test::deflated_zeros(64u << 20);
  ASSERT_FALSE(packed.empty());
  std::vector<uint8_t> bomb(encoded_.bytes.begin(), encoded_.bytes.begin() + btflod::tile_header_size(4));
  bomb.insert(bomb.end(), packed.begin(), packed.end());
  EXPECT_EQ(dec_.decode(bomb, parent_, 0, 1, out()), Status::bad_data);
  EXPECT_STREQ(dec_.message(), "deflate stream inflates beyond the declared size");
  expect_canaries();
}

TEST_F(CodecTileFailures, RandomCorruptionNeverCrashesAndSuccessIsFinite) {
  std::mt19937 rng(99);
  int successes = 0;
  for (int trial = 0; trial < 600; ++trial) {
    auto b = encoded_.bytes;
    const int flips = 1 + trial % 4;
    for (int f = 0; f < flips; ++f) b[rng() % b.size()] ^= static_cast<uint8_t>(1u << (rng() % 8));
    if (dec_.decode(b, parent_, 0, 1, out()) == Status::success) {
      ++successes;
      for (float v : out()) ASSERT_TRUE(std::isfinite(v));
    }
  }
  expect_canaries();
  EXPECT_LT(successes, 600);
}

// --- symbol stream (tile format 2) -----------------------------------------------------------

// A payload with a valid header for `layout` and the given (hand-made) symbol stream.
std::vector<uint8_t> payload_with_symbols(const TileLayout& layout, const std::vector<uint8_t>& symbols,
                                          float tol = 0.5f) {
  std::vector<uint8_t> p(btflod::tile_header_size(layout.channels), 0);
  p[0] = btflod::kTileFormatVersion;
  p[1] = 8;
  p[2] = static_cast<uint8_t>(layout.channels);
  const uint16_t s = static_cast<uint16_t>(layout.stored_size());
  std::memcpy(p.data() + 4, &s, 2);
  std::memcpy(p.data() + 6, &s, 2);
  for (uint32_t c = 0; c < layout.channels; ++c) std::memcpy(p.data() + 8 + 4 * c, &tol, 4);
  const uint32_t n = static_cast<uint32_t>(symbols.size());
  std::memcpy(p.data() + 8 + 4 * layout.channels, &n, 4);
  z_stream z{};
  EXPECT_EQ(deflateInit2(&z, 9, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::vector<uint8_t> packed(deflateBound(&z, symbols.size()) + 16);
  z.next_in = const_cast<uint8_t*>(symbols.data());
  z.avail_in = n;
  z.next_out = packed.data();
  z.avail_out = static_cast<uInt>(packed.size());
  EXPECT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
  packed.resize(z.total_out);
  deflateEnd(&z);
  p.insert(p.end(), packed.begin(), packed.end());
  return p;
}

class CodecTileSymbols : public ::testing::Test {
 protected:
  static constexpr size_t kBlocks = 3 * 3 * 4;  // 24×24 texels, 4 channels
  // All blocks "DC 0, end of block", with block `index` replaced by `block`.
  static std::vector<uint8_t> stream_with(size_t index, const std::vector<uint8_t>& block) {
    std::vector<uint8_t> s;
    for (size_t b = 0; b < kBlocks; ++b) {
      if (b == index) {
        s.insert(s.end(), block.begin(), block.end());
      } else {
        s.push_back(0);
        s.push_back(0);
      }
    }
    return s;
  }
  Status decode(const std::vector<uint8_t>& symbols) {
    return dec_.decode(payload_with_symbols(layout_, symbols), {}, 0, 0, out_);
  }
  TileLayout layout_{16, 4, 4};
  TileDecoder dec_{layout_, BTFLOD_TEST_INFLATE_BACKEND};
  std::vector<float> out_ = std::vector<float>(layout_.sample_count());
};

TEST_F(CodecTileSymbols, HandMadeStreamsDecodeToTheirCoefficients) {
  // All-zero tile: the shortest valid stream.
  ASSERT_EQ(decode(stream_with(kBlocks, {})), Status::success) << dec_.message();
  for (float v : out_) ASSERT_EQ(v, 0.0f);
  // Block 0 of channel 0: DC = +1 step (mapped 2), then coefficient 63 = −1 via three 16-zero runs
  // and a run of 14 (positions 1..62 zero), no end-of-block byte after position 63.
  ASSERT_EQ(decode(stream_with(0, {0x02, 0xF0, 0xF0, 0xF0, 0xE1})), Status::success) << dec_.message();
  const auto& factors = btflod::quant_step_factors<8>();
  const auto& basis = btflod::dct_basis<8, float>();
  for (uint32_t y = 0; y < 8; ++y)
    for (uint32_t x = 0; x < 8; ++x) {
      // X = Cᵀ Y C with Y00 = 0.5·f0, Y77 = −0.5·f63 (tolerance 0.5).
      const double expect = 0.5 * factors[0] * basis[0 * 8 + y] * basis[0 * 8 + x] -
                            0.5 * factors[63] * basis[7 * 8 + y] * basis[7 * 8 + x];
      ASSERT_NEAR(out_[(y * 24 + x) * 4], expect, 1e-5) << x << "," << y;
    }
  // The next block of channel 0 (block code 4) inherits DC = 1 step: a DC difference of 0 keeps it.
  const double dc = 0.5 * factors[0] / 8.0;
  EXPECT_NEAR(out_[(0 * 24 + 8) * 4], dc, 1e-6);
  EXPECT_EQ(out_[(0 * 24 + 0) * 4 + 1], 0.0f) << "channel 1 untouched";
  // Escaped value: mapped 15 + 100 = 115 → −58 at position 1; a 2-byte DC varint.
  ASSERT_EQ(decode(stream_with(1, {0x80, 0x00, 0x0F, 100, 0x00})), Status::success) << dec_.message();
  EXPECT_NEAR(out_[1], -58.0 * 0.5 * factors[1] * basis[0] * basis[8 + 0], 1e-4);
  // An escape as the block's last coefficient (position 63, no end-of-block byte) with a 2-byte
  // varint: mapped 15 + 200 = 215 → −108; the blocks after it must still parse from the next byte.
  ASSERT_EQ(decode(stream_with(0, {0x00, 0xF0, 0xF0, 0xF0, 0xEF, 0xC8, 0x01})), Status::success) << dec_.message();
  EXPECT_NEAR(out_[0], -108.0 * 0.5 * factors[63] * basis[7 * 8] * basis[7 * 8], 1e-4);
}

TEST_F(CodecTileSymbols, HostileStreamsAreBadDataWithAMessage) {
  struct Case {
    std::vector<uint8_t> symbols;
    const char* message_part;
  };
  std::vector<uint8_t> too_long_tail = stream_with(kBlocks, {});
  too_long_tail.push_back(0);
  too_long_tail.push_back(0);
  std::vector<uint8_t> ends_inside = stream_with(0, {0x80, 0x00, 0x00});  // 2-byte DC varint: one byte over
  ends_inside.resize(ends_inside.size() - 2);                             // ... and the last block loses its EOB
  ends_inside.push_back(0x00);                                            // last block: DC only
  const Case cases[] = {
      {stream_with(0, {0x00, 0xF0, 0xF0, 0xF0, 0xF0, 0x00}), "zero run past the end"},        // 64 zeros
      {stream_with(0, {0x00, 0xF0, 0xF0, 0xF0, 0xF1, 0x00}), "zero run past the end"},        // value at 64
      {stream_with(0, {0x00, 0xF0, 0xF0, 0xF0, 0xFF, 0x01, 0x00}), "zero run past the end"},  // escape at 64
      {stream_with(0, {0x00, 0xF0, 0xF0, 0xF0, 0xE1, 0x01}), "longer than the tile"},         // a token after 63
      {stream_with(0, {0x00, 0x10, 0x00}), "invalid token"},
      {stream_with(0, {0x80, 0x80, 0x80, 0x80, 0x80, 0x01, 0x00}), "DC varint"},        // 6-byte varint
      {stream_with(0, {0xFF, 0xFF, 0xFF, 0xFF, 0x0F, 0x00}), "DC varint"},              // ≥ 2^31
      {stream_with(0, {0x82, 0x80, 0x80, 0x80, 0x04, 0x00}), "DC coefficient beyond"},  // mapped 2^30+2: 2^29+1
      {stream_with(0, {0x00, 0x0F, 0x80, 0x80, 0x80, 0x80, 0x04, 0x00}), "AC coefficient beyond"},
      {stream_with(kBlocks - 1, {0x00, 0x0F, 0x80, 0x80}), "coefficient varint"},  // stream ends in the varint
      {ends_inside, "ends inside a block"},
      {too_long_tail, "longer than the tile"},
  };
  for (const Case& c : cases) {
    std::fill(out_.begin(), out_.end(), 0.0f);
    EXPECT_EQ(decode(c.symbols), Status::bad_data) << c.message_part;
    EXPECT_NE(std::string(dec_.message()).find(c.message_part), std::string::npos)
        << dec_.message() << " vs " << c.message_part;
  }
  // Two DC differences of 2^29 each: the second block's DC leaves the ±2^29 range.
  std::vector<uint8_t> s = stream_with(kBlocks, {});
  const std::vector<uint8_t> half_range = {0x80, 0x80, 0x80, 0x80, 0x04, 0x00};  // mapped 2^30 = +2^29
  s.erase(s.begin(), s.begin() + 2);
  s.insert(s.begin(), half_range.begin(), half_range.end());
  ASSERT_EQ(decode(s), Status::success) << "+2^29 steps is the largest allowed DC: " << dec_.message();
  s.erase(s.begin() + 12, s.begin() + 14);  // block code 4 (6 + 3·2 bytes in) = channel 0 of block 1
  s.insert(s.begin() + 12, half_range.begin(), half_range.end());
  EXPECT_EQ(decode(s), Status::bad_data);
  // A decoder that failed mid-block decodes the next good tile exactly (no stale coefficients).
  ASSERT_EQ(decode(stream_with(kBlocks, {})), Status::success);
  for (float v : out_) ASSERT_EQ(v, 0.0f);
}

TEST(CodecTile, SimdAndScalarDecodersAgree) {
  const TileLayout layout;
  TileEncoder enc(layout);
  TileDecoder simd(layout, BTFLOD_TEST_INFLATE_BACKEND), scalar(layout, BTFLOD_TEST_INFLATE_BACKEND);
  scalar.set_simd(false);
  EXPECT_FALSE(scalar.uses_simd());
  const auto parent_tile = make_tile(layout, 2, 1, 1);
  const auto tile = make_tile(layout, 3, 2, 3);
  for (float quality : {5.0f, 50.0f, 97.0f}) {
    const auto e = encode(enc, tile, &parent_tile, 0, 1, tolerances(quality));
    std::vector<float> a(layout.sample_count()), b(layout.sample_count());
    ASSERT_EQ(simd.decode(e.bytes, parent_tile, 0, 1, a), Status::success) << simd.message();
    ASSERT_EQ(scalar.decode(e.bytes, parent_tile, 0, 1, b), Status::success) << scalar.message();
    double worst = 0;
    for (size_t i = 0; i < a.size(); ++i)
      worst = std::max(worst, std::fabs(static_cast<double>(a[i]) - b[i]) / (1.0 + std::fabs(b[i])));
    EXPECT_LT(worst, 2e-6) << "quality " << quality;
    for (uint32_t c = 0; c < 4; ++c) EXPECT_LE(max_block_rms(layout, tile, b, c), tolerances(quality)[c] * 1.001);
  }
  if (!simd.uses_simd()) GTEST_SKIP() << "no AVX2/FMA here: both decoders ran the scalar twin";
}

TEST(CodecTile, ChannelCountsOneToThreeRoundTrip) {
  for (uint32_t ch = 1; ch <= 3; ++ch) {
    const TileLayout layout{16, 4, ch};
    TileEncoder enc(layout);
    TileDecoder dec(layout, BTFLOD_TEST_INFLATE_BACKEND);
    std::vector<float> tile(layout.sample_count());
    for (size_t i = 0; i < tile.size(); ++i)
      tile[i] = std::sin(0.05f * static_cast<float>(i)) + 0.1f * static_cast<float>(i % 5);
    std::vector<float> tol(ch, 0.01f), recon(layout.sample_count()), out(layout.sample_count());
    std::vector<uint8_t> bytes(enc.bound());
    size_t written = 0;
    ASSERT_EQ(enc.encode(tile, {}, 0, 0, tol, bytes, written, recon), Status::success) << enc.message();
    ASSERT_EQ(dec.decode(std::span<const uint8_t>(bytes).first(written), {}, 0, 0, out), Status::success)
        << dec.message();
    EXPECT_EQ(0, std::memcmp(out.data(), recon.data(), out.size() * 4));
    for (uint32_t c = 0; c < ch; ++c) EXPECT_LE(max_block_rms(layout, tile, out, c), 0.01 * 1.001);
  }
}

// 36 block codes (24×24×4) using every token kind: runs of 16, escapes, multi-byte varints.
std::vector<uint8_t> symbols_with_escapes_and_runs() {
  std::vector<uint8_t> s = {0x02, 0xF0, 0xF0, 0xF0, 0xE1, 0x80, 0x00, 0x0F, 100, 0x00, 0x05, 0x21, 0x13, 0x0E, 0x00};
  for (int b = 3; b < 36; ++b) {
    s.push_back(b % 5 == 0 ? 0x03 : 0x00);
    s.push_back(0x00);
  }
  return s;
}

// What fuzz/fuzz_tile_decoder.cpp does with an input: byte 0 selects the quadrant (bits 1, 2)
// and the inflate backend (bit 3), the rest is a payload decoded by a 24×24 or 72×72 decoder
// (from the header, channels from the header) against the parent (i % 17) / 8. Returns the
// decoder's status; a success must give finite samples, a failure a message.
Status fuzzer_decode(const std::vector<uint8_t>& input) {
  const std::span<const uint8_t> payload(input.data() + 1, input.size() - 1);
  btflod::TileHeaderInfo info;
  const bool peeked = btflod::tile_peek_header(payload, info) == Status::success;
  const uint32_t channels = peeked && info.channels >= 1 && info.channels <= 4 ? info.channels : 4;
  const TileLayout layout{peeked && info.stored_size == 72 ? 64u : 16u, 4, channels};
  TileDecoder dec(layout, input[0] >> 3 & 1u ? btflod::InflateBackend::libdeflate : btflod::InflateBackend::zlib);
  std::vector<float> parent(layout.sample_count()), out(layout.sample_count());
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<float>(i % 17) * 0.125f;
  const Status st = dec.decode(payload, parent, input[0] >> 1 & 1u, input[0] >> 2 & 1u, out);
  if (st == Status::success) {
    for (float v : out) EXPECT_TRUE(std::isfinite(v));
  } else {
    EXPECT_TRUE(dec.message() != nullptr && dec.message()[0] != '\0');
  }
  return st;
}

// Fuzz seeds for fuzz/fuzz_tile_decoder.cpp (byte 0: even = decode mode with the quadrant in
// bits 1..2; odd = the former round-trip mode, kept as seeds of hostile payloads), written into
// BTFLOD_WRITE_TILE_SEEDS when set (BTFLOD_WRITE_TILE_SEEDS=fuzz/corpus/fuzz_tile_decoder
// test_codec_tile --gtest_filter='*Seeds*' refreshes the corpus), else into the test's temporary
// folder. Read back and fed as the fuzzer does, every decode-mode seed must decode (a seed that
// stops at a header check would fuzz nothing beyond it) and every other one fail with a message.
TEST(CodecTile, WritesFuzzSeedsThatDecodeTheFuzzersWay) {
  const btflod_test::FuzzSeedFolder seeds("BTFLOD_WRITE_TILE_SEEDS", "seeds_tile_decoder");
  std::vector<std::string> decoding, failing;
  // A seed is the mode byte, then the payload.
  auto write = [&](const std::string& name, uint8_t mode, const std::vector<uint8_t>& payload) {
    std::vector<uint8_t> seed{mode};
    seed.insert(seed.end(), payload.begin(), payload.end());
    seeds.write(name, seed);
    (mode & 1u ? failing : decoding).push_back(name);
  };
  for (uint32_t stored : {24u, 72u}) {
    const TileLayout layout{stored - 8, 4, 4};
    TileEncoder enc(layout);
    // The fuzzer's parent: (i % 17) / 8, as fuzz_tile_decoder.cpp builds it.
    std::vector<float> parent(layout.sample_count());
    for (size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<float>(i % 17) * 0.125f;
    const auto root = encode(enc, make_tile(layout, 0, 0, 0), nullptr, 0, 0, tolerances(50));
    const auto child = encode(enc, make_tile(layout, 1, 1, 0), &parent, 1, 0, tolerances(20));
    const std::string tag = std::to_string(stored);
    write("seed_root_" + tag, 0, root.bytes);
    write("seed_residual_" + tag, 2, child.bytes);
    enc.set_weight_quarters(1);  // a flatter frequency weighting (flag bits 1-3)
    write("seed_weight_quarters_1_" + tag, 0,
          encode(enc, make_tile(layout, 0, 0, 0), nullptr, 0, 0, tolerances(50)).bytes);
  }
  for (uint32_t ch = 1; ch <= 3; ++ch) {
    const TileLayout layout{16, 4, ch};
    TileEncoder enc(layout);
    std::vector<float> tile(layout.sample_count());
    for (size_t i = 0; i < tile.size(); ++i)
      tile[i] = std::cos(0.07f * static_cast<float>(i)) * static_cast<float>(1 + i % 3);
    std::vector<float> tol(ch, 0.02f);
    std::vector<uint8_t> bytes(enc.bound());
    size_t written = 0;
    ASSERT_EQ(enc.encode(tile, {}, 0, 0, tol, bytes, written), Status::success);
    bytes.resize(written);
    write("seed_channels_" + std::to_string(ch), 0, bytes);
  }
  const TileLayout small{16, 4, 4};
  write("seed_escapes_and_runs", 0, payload_with_symbols(small, symbols_with_escapes_and_runs()));
  write("seed_roundtrip", 1, std::vector<uint8_t>{7, 200, 13, 0, 255, 90, 33, 1});
  write("seed_roundtrip_jpeg", 1 | 4 << 1, std::vector<uint8_t>{9, 100, 3, 250, 5, 80, 1});  // JPEG table
  EXPECT_EQ(decoding.size(), 10u);
  for (const auto& name : decoding) {
    const std::vector<uint8_t> seed = seeds.read(name);
    ASSERT_GT(seed.size(), 1u) << name;
    EXPECT_EQ(fuzzer_decode(seed), Status::success) << name;
  }
  for (const auto& name : failing) {
    const std::vector<uint8_t> seed = seeds.read(name);
    EXPECT_NE(fuzzer_decode(seed), Status::success) << name;
  }
}

}  // namespace
