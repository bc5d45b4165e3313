// btflod-link: PkgConfig::BTFLOD_LIBDEFLATE
// Tests for the optional libdeflate entropy backend of runtime/codec/tile_codec.hpp: bit-identical
// tiles from both backends along a residual chain, and the same failure classes (truncated,
// trailing bytes, decompression bomb, random corruption) rejected without crashing.
// libdeflate is compiled into the implementation TU when the btflod target is built with
// BTFLOD_WITH_LIBDEFLATE; without it these tests skip.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <zlib.h>

#include "btflod/runtime/codec/tile_codec.hpp"
#include "test_deflate_bomb.hpp"

namespace {

using namespace btflod;

std::vector<float> make_tile(const TileLayout& layout, uint32_t seed) {
  std::vector<float> t(layout.sample_count());
  for (size_t i = 0; i < t.size(); ++i)
    t[i] = std::sin(0.013f * static_cast<float>(i) + static_cast<float>(seed)) +
           0.2f * std::cos(0.31f * static_cast<float>(i % 72));
  return t;
}

TEST(CodecTileLibdeflate, BothBackendsDecodeAChainBitIdentically) {
  const TileLayout layout;
  TileEncoder enc(layout);
  if (!inflate_backend_available(InflateBackend::libdeflate)) GTEST_SKIP() << "libdeflate not compiled in";
  TileDecoder a(layout, InflateBackend::zlib), b(layout, InflateBackend::libdeflate);
  ASSERT_EQ(a.backend(), InflateBackend::zlib);
  ASSERT_EQ(b.backend(), InflateBackend::libdeflate);
  EXPECT_EQ(TileDecoder(layout).backend(), InflateBackend::libdeflate) << "libdeflate is the default when compiled in";
  const float tol[4] = {0.01f, 0.02f, 0.005f, 0.03f};
  std::vector<float> parent, out_a(layout.sample_count()), out_b(layout.sample_count()), recon(layout.sample_count());
  std::vector<uint8_t> payload(enc.bound());
  for (uint32_t level = 0; level < 6; ++level) {
    size_t written = 0;
    ASSERT_EQ(enc.encode(make_tile(layout, level), parent, level & 1, 0, tol, payload, written, recon),
              Status::success);
    const auto bytes = std::span<const uint8_t>(payload).first(written);
    ASSERT_EQ(a.decode(bytes, parent, level & 1, 0, out_a), Status::success) << a.message();
    ASSERT_EQ(b.decode(bytes, parent, level & 1, 0, out_b), Status::success) << b.message();
    ASSERT_EQ(0, std::memcmp(out_a.data(), out_b.data(), out_a.size() * 4)) << "level " << level;
    ASSERT_EQ(0, std::memcmp(out_a.data(), recon.data(), out_a.size() * 4));
    parent = out_a;
  }
}

TEST(CodecTileLibdeflate, FailureClassesAreRejected) {
  const TileLayout layout;
  TileEncoder enc(layout);
  if (!inflate_backend_available(InflateBackend::libdeflate)) GTEST_SKIP() << "libdeflate not compiled in";
  TileDecoder dec(layout, InflateBackend::libdeflate);
  const float tol[4] = {0.01f, 0.01f, 0.01f, 0.01f};
  std::vector<uint8_t> payload(enc.bound());
  size_t written = 0;
  ASSERT_EQ(enc.encode(make_tile(layout, 3), {}, 0, 0, tol, payload, written), Status::success);
  payload.resize(written);
  std::vector<float> storage(layout.sample_count() + 64, 777.0f);
  std::span<float> out = std::span<float>(storage).subspan(32, layout.sample_count());
  for (size_t n = 0; n < payload.size(); n += 11)
    ASSERT_NE(dec.decode(std::span<const uint8_t>(payload).first(n), {}, 0, 0, out), Status::success) << n;
  auto trailing = payload;
  trailing.push_back(0);
  EXPECT_EQ(dec.decode(trailing, {}, 0, 0, out), Status::bad_data);
  EXPECT_STREQ(dec.message(), "trailing bytes after the deflate stream");
  // Bomb: the header of a valid tile followed by 16 MiB of deflated zeros.
  const std::vector<uint8_t> packed = btflod_test::deflated_zeros(16u << 20);
  ASSERT_FALSE(packed.empty());
  std::vector<uint8_t> bomb(payload.begin(), payload.begin() + tile_header_size(4));
  bomb.insert(bomb.end(), packed.begin(), packed.end());
  EXPECT_EQ(dec.decode(bomb, {}, 0, 0, out), Status::bad_data);
  EXPECT_STREQ(dec.message(), "deflate stream inflates beyond the declared size");
  std::mt19937 rng(5);
  for (int trial = 0; trial < 400; ++trial) {
    auto b = payload;
    b[rng() % b.size()] ^= static_cast<uint8_t>(1u << (rng() % 8));
    if (dec.decode(b, {}, 0, 0, out) == Status::success) {
      for (float v : out) ASSERT_TRUE(std::isfinite(v));
    }
  }
  for (int i = 0; i < 32; ++i) {
    ASSERT_EQ(storage[i], 777.0f);
    ASSERT_EQ(storage[storage.size() - 1 - i], 777.0f);
  }
  EXPECT_EQ(dec.decode(payload, {}, 0, 0, out), Status::success);
}

}  // namespace
