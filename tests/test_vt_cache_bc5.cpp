// The block-compressed cache layout (runtime/vt/cache_bc5.hpp): the BC4 reference decoder
// against the format's definition, the encoder against an exhaustive endpoint search, and a
// tile's round trip through the two BC5 planes and the slot map.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "btflod/runtime/vt/cache_bc5.hpp"

namespace {

using namespace btflod;

// The block's squared error for the best indices of endpoints (e0, e1): the quantity the
// encoder minimises, computed independently from the palette definition.
double block_error(const uint8_t v[16], int e0, int e1) {
  double palette[8];
  palette[0] = e0, palette[1] = e1;
  if (e0 > e1) {
    for (int k = 2; k < 8; ++k) palette[k] = ((8 - k) * e0 + (k - 1) * e1) / 7.0;
  } else {
    for (int k = 2; k < 6; ++k) palette[k] = ((6 - k) * e0 + (k - 1) * e1) / 5.0;
    palette[6] = 0, palette[7] = 255;
  }
  double total = 0;
  for (int t = 0; t < 16; ++t) {
    double best = 1e30;
    for (double p : palette) best = std::min(best, (v[t] - p) * (v[t] - p));
    total += best;
  }
  return total;
}

TEST(VtCacheBc5, ReferenceDecoderFollowsTheFormat) {
  // Eight-value mode: e0 = 200 > e1 = 60; indices 0..7 then 7..0 over the block.
  uint8_t block[8] = {200, 60, 0, 0, 0, 0, 0, 0};
  uint64_t bits = 0;
  for (int t = 0; t < 16; ++t) bits |= static_cast<uint64_t>(t < 8 ? t : 15 - t) << (3 * t);
  for (int i = 0; i < 6; ++i) block[2 + i] = static_cast<uint8_t>(bits >> (8 * i));
  float out[16];
  decode_bc4_block(block, out);
  EXPECT_FLOAT_EQ(out[0], 200.0f / 255.0f);
  EXPECT_FLOAT_EQ(out[1], 60.0f / 255.0f);
  EXPECT_FLOAT_EQ(out[2], (6 * 200.0f + 60.0f) / 7.0f / 255.0f);  // (6 e0 + e1) / 7
  EXPECT_FLOAT_EQ(out[7], (200.0f + 6 * 60.0f) / 7.0f / 255.0f);  // (e0 + 6 e1) / 7
  EXPECT_FLOAT_EQ(out[8], out[7]);
  // Six-value mode: e0 = 10 <= e1 = 110; indices 6 and 7 are 0 and 1.
  uint8_t six[8] = {10, 110, 0, 0, 0, 0, 0, 0};
  bits = 0;
  for (int t = 0; t < 16; ++t) bits |= static_cast<uint64_t>(t % 8) << (3 * t);
  for (int i = 0; i < 6; ++i) six[2 + i] = static_cast<uint8_t>(bits >> (8 * i));
  decode_bc4_block(six, out);
  EXPECT_FLOAT_EQ(out[2], (4 * 10.0f + 110.0f) / 5.0f / 255.0f);
  EXPECT_FLOAT_EQ(out[5], (10.0f + 4 * 110.0f) / 5.0f / 255.0f);
  EXPECT_FLOAT_EQ(out[6], 0.0f);
  EXPECT_FLOAT_EQ(out[7], 1.0f);
}

TEST(VtCacheBc5, EncoderIsNearTheBestEndpointsAndExactWhereItCanBe) {
  std::mt19937 rng(7);
  double ours_total = 0, best_total = 0;
  for (int trial = 0; trial < 30; ++trial) {
    uint8_t v[16];
    // Smooth ramps with noise (what eigen-texture blocks look like), a few with extremes.
    const int base = static_cast<int>(rng() % 200), slope = static_cast<int>(rng() % 9);
    for (int t = 0; t < 16; ++t)
      v[t] = static_cast<uint8_t>(
          std::clamp(base + slope * (t % 4 + t / 4) + static_cast<int>(rng() % 7) - 3, 0, trial % 10 == 0 ? 255 : 254));
    if (trial % 10 == 0) v[3] = 0, v[12] = 255;
    uint8_t block[8];
    const float err = encode_bc4_block(v, block);
    // The returned error is the decoded block's.
    float decoded[16];
    decode_bc4_block(block, decoded);
    double check = 0;
    for (int t = 0; t < 16; ++t) check += std::pow(v[t] - decoded[t] * 255.0, 2);
    EXPECT_NEAR(err, check, 1e-2 * (1 + check));
    // Exhaustive over endpoints within 12 of the block's range (the best ones lie there).
    int lo = 255, hi = 0;
    for (int t = 0; t < 16; ++t) lo = std::min(lo, int{v[t]}), hi = std::max(hi, int{v[t]});
    double best = 1e30;
    for (int e0 = std::max(0, lo - 12); e0 <= std::min(255, hi + 12); ++e0)
      for (int e1 = std::max(0, lo - 12); e1 <= std::min(255, hi + 12); ++e1)
        best = std::min(best, block_error(v, e0, e1));
    EXPECT_LE(err, 2.0 * best + 16.0) << "trial " << trial;  // at most 1 unit of extra RMS error
    ours_total += err, best_total += best;
  }
  EXPECT_LE(ours_total, 1.25 * best_total + 30.0);
  // Two distinct values, a flat block: exact.
  uint8_t two[16], flat[16], block[8];
  for (int t = 0; t < 16; ++t) two[t] = t % 2 ? 17 : 230, flat[t] = 99;
  EXPECT_EQ(encode_bc4_block(two, block), 0.0f);
  EXPECT_EQ(encode_bc4_block(flat, block), 0.0f);
  float out[16];
  decode_bc4_block(block, out);
  for (float x : out) EXPECT_FLOAT_EQ(x, 99.0f / 255.0f);
}

TEST(VtCacheBc5, TileRoundTripStaysWithinTheBlockError) {
  const uint32_t side = 40;  // T = 32 with a 4-texel border: the demo's slot
  std::vector<float> values(size_t{side} * side * 4);
  for (uint32_t y = 0; y < side; ++y)
    for (uint32_t x = 0; x < side; ++x)
      for (uint32_t c = 0; c < 4; ++c)
        values[(size_t{y} * side + x) * 4 + c] =
            static_cast<float>(std::sin(0.21 * x + c) * std::cos(0.13 * y - c) * (c + 1) + 0.01 * c);
  std::vector<uint8_t> scratch(values.size()), blocks(cache_bc5_tile_bytes(side));
  EXPECT_EQ(blocks.size(), size_t{side} * side * 2);  // a quarter of rgba16f's 8 bytes a texel
  const CacheSlotMap map = encode_cache_tile_bc5(values, side, scratch, blocks);
  std::vector<float> back(values.size());
  decode_cache_tile_bc5(blocks, side, map, back);
  for (uint32_t c = 0; c < 4; ++c) {
    ASSERT_GT(map.scale[c], 0.0f);
    double max_err = 0;
    for (size_t i = c; i < values.size(); i += 4) max_err = std::max(max_err, std::fabs(double(values[i]) - back[i]));
    // A smooth tile: every block spans a small part of the slot's range, so the BC4 error stays
    // well under an eighth of it (plus the unorm8 step).
    EXPECT_LT(max_err, map.scale[c] * (1.0 / 16 + 1.0 / 255)) << "component " << c;
    EXPECT_GT(max_err, 0.0) << "component " << c;  // the format is lossy: the test compares something
  }
  // A size that does not fit writes nothing and returns a zero map.
  std::vector<uint8_t> small(blocks.size() - 1);
  const CacheSlotMap none = encode_cache_tile_bc5(values, side, scratch, small);
  EXPECT_EQ(none.scale[0], 0.0f);
}

}  // namespace
