// The tile codec's zstd entropy coder (tile format 3, coder 1; runtime/codec/tile_codec.hpp): the same
// reconstruction as deflate bit for bit, format-2 tiles unchanged and still decoded, hostile
// frames rejected, no allocation in decode. Skipped when the build has no zstd (BTFLOD_WITH_ZSTD).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "../fuzz/tile_zstd_decode_payload.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "test_counting_new.hpp"
#include "test_fuzz_seeds.hpp"

namespace {
using btflod::Status;
using btflod::TileDecoder;
using btflod::TileEncoder;
using btflod::TileEntropyCoder;
using btflod::TileHeaderInfo;
using btflod::TileLayout;

const TileLayout kLayout{16, 4, 4};  // 24×24×4

std::vector<float> make_tile(uint32_t seed) {
  std::vector<float> t(kLayout.sample_count());
  uint32_t s = seed * 2654435761u + 1;
  for (size_t i = 0; i < t.size(); ++i) {
    s = s * 1664525u + 1013904223u;
    const float noise = static_cast<float>(s >> 8) / 16777216.0f - 0.5f;
    const float x = static_cast<float>((i / 4) % 24), y = static_cast<float>((i / 4) / 24);
    t[i] = std::sin(0.3f * x + static_cast<float>(i % 4)) * std::cos(0.2f * y) + 0.2f * noise;
  }
  return t;
}

struct Coded {
  std::vector<uint8_t> bytes;
  std::vector<float> recon;
};

Coded encode(TileEncoder& enc, const std::vector<float>& tile, const std::vector<float>& parent = {}) {
  Coded c;
  c.bytes.resize(enc.bound());
  c.recon.resize(kLayout.sample_count());
  const float tol[4] = {0.01f, 0.02f, 0.005f, 0.01f};
  size_t written = 0;
  EXPECT_EQ(enc.encode(tile, parent, 1, 0, tol, c.bytes, written, c.recon), Status::success) << enc.message();
  c.bytes.resize(written);
  return c;
}

class TileZstd : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!btflod::tile_entropy_coder_available(TileEntropyCoder::zstd))
      GTEST_SKIP() << "built without zstd (BTFLOD_WITH_ZSTD=OFF)";
    ASSERT_TRUE(zstd_.set_entropy_coder(TileEntropyCoder::zstd));
    tile_ = make_tile(1);
    plain_ = encode(deflate_, tile_);
    packed_ = encode(zstd_, tile_);
  }
  Status decode(const std::vector<uint8_t>& payload, std::vector<float>& out, const std::vector<float>& parent = {}) {
    out.assign(kLayout.sample_count(), 0.0f);
    return dec_.decode(payload, parent, 1, 0, out);
  }
  TileEncoder deflate_{kLayout};
  TileEncoder zstd_{kLayout};
  TileDecoder dec_{kLayout};
  std::vector<float> tile_;
  Coded plain_, packed_;
};

TEST_F(TileZstd, HeaderSaysWhichCoderAndDeflateStaysFormat2) {
  TileHeaderInfo a, b;
  ASSERT_EQ(btflod::tile_peek_header(plain_.bytes, a), Status::success);
  ASSERT_EQ(btflod::tile_peek_header(packed_.bytes, b), Status::success);
  EXPECT_EQ(plain_.bytes[0], 2);  // deflate: the format earlier decoders read, flags bits 4–7 clear
  EXPECT_EQ(plain_.bytes[3] & 0xF0, 0);
  EXPECT_EQ(a.coder, TileEntropyCoder::deflate);
  EXPECT_EQ(packed_.bytes[0], 3);
  EXPECT_EQ(packed_.bytes[3] >> 4, 1);
  EXPECT_EQ(b.coder, TileEntropyCoder::zstd);
  EXPECT_EQ(a.symbol_bytes, b.symbol_bytes);  // the same symbol stream under both coders
  // Everything else in the header is identical.
  EXPECT_EQ(std::memcmp(plain_.bytes.data() + 4, packed_.bytes.data() + 4, btflod::tile_header_size(4) - 4), 0);
  EXPECT_EQ(plain_.bytes[3] & 0x0F, packed_.bytes[3] & 0x0F);
}

TEST_F(TileZstd, BothCodersReconstructTheSameBits) {
  EXPECT_EQ(plain_.recon, packed_.recon);
  std::vector<float> a, b;
  ASSERT_EQ(decode(plain_.bytes, a), Status::success) << dec_.message();
  ASSERT_EQ(decode(packed_.bytes, b), Status::success) << dec_.message();
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0);
  EXPECT_EQ(std::memcmp(a.data(), plain_.recon.data(), a.size() * sizeof(float)), 0);
  // A residual child coded against the reconstruction, both coders.
  const std::vector<float> child = make_tile(2);
  const Coded c1 = encode(deflate_, child, plain_.recon), c2 = encode(zstd_, child, plain_.recon);
  ASSERT_EQ(decode(c1.bytes, a, plain_.recon), Status::success);
  ASSERT_EQ(decode(c2.bytes, b, plain_.recon), Status::success);
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0);
  EXPECT_EQ(c2.recon, c1.recon);
}

TEST_F(TileZstd, Format3WithTheDeflateCoderDecodes) {
  std::vector<uint8_t> v3 = plain_.bytes;
  v3[0] = 3;  // coder bits 0 = deflate
  std::vector<float> a;
  ASSERT_EQ(decode(v3, a), Status::success) << dec_.message();
  EXPECT_EQ(std::memcmp(a.data(), plain_.recon.data(), a.size() * sizeof(float)), 0);
}

TEST_F(TileZstd, RejectsUnknownCodersAndFlags) {
  std::vector<float> out;
  for (uint8_t coder : {2, 3}) {
    std::vector<uint8_t> p = packed_.bytes;
    p[3] = static_cast<uint8_t>((p[3] & 0x0F) | coder << 4);
    EXPECT_EQ(decode(p, out), Status::bad_data);
  }
  std::vector<uint8_t> p = packed_.bytes;
  p[3] |= 0x40;  // bit 6
  EXPECT_EQ(decode(p, out), Status::bad_data);
  p = packed_.bytes;
  p[0] = 2;  // format 2 has no coder bits
  EXPECT_EQ(decode(p, out), Status::bad_data);
  p = packed_.bytes;
  p[0] = 4;
  EXPECT_EQ(decode(p, out), Status::bad_data);
  // A zstd frame declared as deflate and a deflate stream declared as zstd.
  p = packed_.bytes;
  p[3] &= 0x0F;
  EXPECT_EQ(decode(p, out), Status::bad_data);
  p = plain_.bytes;
  p[0] = 3;
  p[3] |= 0x10;
  EXPECT_EQ(decode(p, out), Status::bad_data);
}

TEST_F(TileZstd, RejectsTruncatedExtendedAndMismatchedFrames) {
  std::vector<float> out;
  const size_t header = btflod::tile_header_size(4);
  for (size_t n = 0; n < packed_.bytes.size(); ++n) {
    const std::vector<uint8_t> p(packed_.bytes.begin(), packed_.bytes.begin() + static_cast<ptrdiff_t>(n));
    const Status s = decode(p, out);
    EXPECT_TRUE(s == Status::short_output || s == Status::bad_data) << n;
    if (n >= header + 8) {
      EXPECT_EQ(s, Status::short_output) << n << ": " << dec_.message();
    }
  }
  std::vector<uint8_t> p = packed_.bytes;
  p.push_back(0);  // trailing byte
  EXPECT_EQ(decode(p, out), Status::bad_data);
  p = packed_.bytes;  // a second frame
  p.insert(p.end(), packed_.bytes.begin() + static_cast<ptrdiff_t>(header), packed_.bytes.end());
  EXPECT_EQ(decode(p, out), Status::bad_data);
  // A skippable frame instead of the data frame.
  p.assign(packed_.bytes.begin(), packed_.bytes.begin() + static_cast<ptrdiff_t>(header));
  for (uint8_t b : {0x50, 0x2A, 0x4D, 0x18, 4, 0, 0, 0, 1, 2, 3, 4}) p.push_back(b);
  EXPECT_EQ(decode(p, out), Status::bad_data);
  // The declared symbol byte count differs from the frame's content size.
  for (int delta : {-1, 1}) {
    p = packed_.bytes;
    uint32_t declared = 0;
    std::memcpy(&declared, p.data() + header - 4, 4);
    declared = static_cast<uint32_t>(static_cast<int64_t>(declared) + delta);
    std::memcpy(p.data() + header - 4, &declared, 4);
    EXPECT_EQ(decode(p, out), Status::bad_data) << delta;
  }
}

TEST_F(TileZstd, CorruptedFramesNeverCrash) {
  std::vector<float> out;
  const size_t header = btflod::tile_header_size(4);
  size_t rejected = 0;
  for (size_t i = header; i < packed_.bytes.size(); ++i)
    for (uint8_t x : {0x01, 0x80, 0xFF}) {
      std::vector<uint8_t> p = packed_.bytes;
      p[i] ^= x;
      const Status s = decode(p, out);
      // Without a checksum a flipped literal can still decode to a valid symbol stream; the
      // container's per-payload CRC catches those. Anything else must be an error status.
      EXPECT_TRUE(s == Status::success || s == Status::bad_data || s == Status::short_output);
      if (s == Status::success) {
        for (float v : out) ASSERT_TRUE(std::isfinite(v));
      }
      rejected += s != Status::success;
    }
  EXPECT_GT(rejected, 0u);
}

TEST_F(TileZstd, DecodeDoesNotAllocate) {
  std::vector<float> out(kLayout.sample_count());
  ASSERT_EQ(dec_.decode(packed_.bytes, {}, 1, 0, out), Status::success);  // warm
  std::vector<uint8_t> bad = packed_.bytes;
  bad.resize(bad.size() - 3);
  const uint64_t before = btflod_test::global_news();
  for (int i = 0; i < 4; ++i) ASSERT_EQ(dec_.decode(packed_.bytes, {}, 1, 0, out), Status::success);
  EXPECT_NE(dec_.decode(bad, {}, 1, 0, out), Status::success);
  EXPECT_EQ(btflod_test::global_news(), before);
}

TEST_F(TileZstd, EncodeDoesNotAllocateAndSwitchesBack) {
  std::vector<uint8_t> buf(zstd_.bound());
  std::vector<float> recon(kLayout.sample_count());
  const float tol[4] = {0.01f, 0.02f, 0.005f, 0.01f};
  size_t written = 0;
  const uint64_t before = btflod_test::global_news();
  ASSERT_EQ(zstd_.encode(tile_, {}, 1, 0, tol, buf, written), Status::success);
  EXPECT_EQ(btflod_test::global_news(), before);
  EXPECT_EQ(buf[0], 3);
  ASSERT_TRUE(zstd_.set_entropy_coder(TileEntropyCoder::deflate));
  ASSERT_EQ(zstd_.encode(tile_, {}, 1, 0, tol, buf, written), Status::success);
  EXPECT_EQ(buf[0], 2);
  EXPECT_EQ(std::vector<uint8_t>(buf.begin(), buf.begin() + static_cast<ptrdiff_t>(written)), plain_.bytes);
}

}  // namespace

namespace {
// What fuzz/fuzz_tile_zstd.cpp does with an input in decode mode (even byte 0): bytes 1–2 fold
// into the declared symbol byte count, the rest is the zstd frame behind the fuzzer's own
// format-3 header. Returns the decoder's status; `out` gets the samples.
Status fuzzer_decode_mode(const std::vector<uint8_t>& input, std::vector<float>& out) {
  std::vector<uint8_t> payload;
  btflod_fuzz::tile_zstd_decode_payload(kLayout, input.data(), input.size(), payload);
  TileDecoder dec(kLayout);
  out.assign(kLayout.sample_count(), 0.0f);
  return dec.decode(payload, {}, input[0] >> 2 & 1u, input[0] >> 3 & 1u, out);
}

// Seeds of fuzz/fuzz_tile_zstd.cpp (mode 0: declared size + frame; mode 1: round trip input),
// written into BTFLOD_WRITE_ZSTD_SEEDS when set (BTFLOD_WRITE_ZSTD_SEEDS=fuzz/corpus/fuzz_tile_zstd
// test_codec_tile_zstd --gtest_filter='*Seeds*' refreshes the corpus), else into the test's
// temporary folder. Each seed is read back and must reach the decoder's success path the way
// the fuzzer feeds it: a seed that stops at a header check would fuzz nothing beyond it.
TEST(TileZstdSeeds, WritesFuzzSeedsThatDecodeTheFuzzersWay) {
  if (!btflod::tile_entropy_coder_available(TileEntropyCoder::zstd)) GTEST_SKIP() << "built without zstd";
  const btflod_test::FuzzSeedFolder seeds("BTFLOD_WRITE_ZSTD_SEEDS", "seeds_tile_zstd");
  TileEncoder enc(kLayout);
  ASSERT_TRUE(enc.set_entropy_coder(TileEntropyCoder::zstd));
  const size_t header = btflod::tile_header_size(4);
  const size_t blocks = btflod::tile_block_count(kLayout.stored_size(), 4);
  const uint32_t lo = static_cast<uint32_t>(blocks * btflod::kTileMinBlockCode);
  for (uint32_t seed : {1u, 2u, 3u}) {
    const Coded c = encode(enc, make_tile(seed));
    uint32_t declared = 0;
    std::memcpy(&declared, c.bytes.data() + header - 4, 4);
    const uint32_t folded = declared - lo;  // the fuzzer maps bytes 1-2 to lo + value % range
    std::vector<uint8_t> s{0, static_cast<uint8_t>(folded), static_cast<uint8_t>(folded >> 8)};
    s.insert(s.end(), c.bytes.begin() + static_cast<ptrdiff_t>(header), c.bytes.end());
    const std::string name = "seed_frame_" + std::to_string(seed);
    seeds.write(name, s);
    // Read back and fed as the fuzzer does: the frame decodes (under the fuzzer's header, whose
    // tolerances differ from the encoder's, so the samples are finite but not the tile's).
    const std::vector<uint8_t> back = seeds.read(name);
    ASSERT_EQ(back, s) << name;
    std::vector<float> out;
    ASSERT_EQ(fuzzer_decode_mode(back, out), Status::success) << name;
    for (float v : out) ASSERT_TRUE(std::isfinite(v)) << name;
  }
  const std::vector<uint8_t> round_trip{1, 7, 200, 13, 99, 0, 255, 128, 64, 32, 16, 8};
  seeds.write("seed_round_trip", round_trip);
  EXPECT_EQ(seeds.read("seed_round_trip"), round_trip);
  EXPECT_EQ(round_trip[0] & 1u, 1u);  // odd: the fuzzer's round-trip mode
}
}  // namespace
