// Tests for runtime/vt/cache_format.hpp: the rgba8_affine encoder (error bound, exact ends, constant
// components, hostile floats, sizes), the slot-map table layout, CpuCacheTexture reading the
// format, and a Streamer configured with it handing out the encoder's bytes and maps of the
// exactly decoded tiles.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/vt/cache_format.hpp"
#include "test_runtime_helpers.hpp"

using namespace btflod;

namespace {

std::vector<float> random_tile(size_t texels, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(-3.0f, 5.0f);
  std::vector<float> v(texels * 4);
  for (size_t i = 0; i < v.size(); ++i) v[i] = d(rng) * static_cast<float>(1 + i % 4);  // ranges differ per component
  return v;
}

}  // namespace

TEST(CacheFormat, ConfigSizesFollowTheFormat) {
  CacheConfig c{16, 8, 1024, 64, 4, 2};
  EXPECT_EQ(c.texel_bytes(), 8u);
  EXPECT_EQ(c.slot_map_bytes(), 0u);
  const uint64_t wide = c.cache_bytes();
  EXPECT_EQ(wide, uint64_t{16 * 72} * (8 * 72) * 2 * 8);
  c.format = CacheFormat::rgba8_affine;
  EXPECT_TRUE(c.valid());
  EXPECT_EQ(c.cache_bytes() * 2, wide);
  EXPECT_EQ(c.slot_map_bytes(), uint64_t{c.slot_count()} * 16);
  c.format = static_cast<CacheFormat>(7);
  EXPECT_FALSE(c.valid());
}

TEST(CacheFormat, EncoderErrorIsHalfAStepOfTheTileRange) {
  const size_t texels = 72 * 72;
  const std::vector<float> v = random_tile(texels, 1);
  std::vector<uint8_t> q(v.size());
  const CacheSlotMap map = encode_cache_tile_unorm8(v, q);
  for (uint32_t c = 0; c < 4; ++c) {
    float lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < texels; ++i) lo = std::min(lo, v[i * 4 + c]), hi = std::max(hi, v[i * 4 + c]);
    // Halves: the offset at or below the minimum, the scale reaching the maximum, both within
    // half rounding (2^-10 relative) of the exact range.
    EXPECT_EQ(half_bits_to_float(float_to_half_bits(map.offset[c])), map.offset[c]);
    EXPECT_EQ(half_bits_to_float(float_to_half_bits(map.scale[c])), map.scale[c]);
    EXPECT_LE(map.offset[c], lo);
    EXPECT_GE(map.offset[c] + map.scale[c], hi * (1.0f - 1e-6f));
    EXPECT_LE(map.offset[c] + map.scale[c], hi + std::fabs(hi) * 2e-3f + std::fabs(lo) * 2e-3f);
  }
  double worst = 0.0;
  bool hit_zero[4] = {}, hit_full[4] = {};
  for (size_t i = 0; i < v.size(); ++i) {
    const uint32_t c = static_cast<uint32_t>(i % 4);
    const float back = decode_cache_unorm8(map, c, q[i]);
    const double err = std::fabs(static_cast<double>(back) - v[i]) / map.scale[c];
    worst = std::max(worst, err);
    hit_zero[c] |= q[i] == 0;
    hit_full[c] |= q[i] == 255;
  }
  // Half a step (1/510 of the range), plus float rounding.
  EXPECT_LE(worst, 1.0 / 510.0 + 1e-6);  // relative to the map's (half-rounded) range
  EXPECT_GT(worst, 0.5 / 510.0);         // the bound is reached, not an accident of easy data
  for (int c = 0; c < 4; ++c) EXPECT_TRUE(hit_zero[c] && hit_full[c]) << "the ends map to 0 and 255";
}

TEST(CacheFormat, ConstantComponentsDecodeExactly) {
  std::vector<float> v(16 * 4);  // constants that are halves
  for (size_t i = 0; i < 16; ++i) {
    v[i * 4 + 0] = 0.375f;
    v[i * 4 + 1] = -2.0f;
    v[i * 4 + 2] = static_cast<float>(i);
    v[i * 4 + 3] = 0.0f;
  }
  std::vector<uint8_t> q(v.size());
  const CacheSlotMap map = encode_cache_tile_unorm8(v, q);
  EXPECT_EQ(map.scale[0], 0.0f);
  EXPECT_EQ(map.scale[1], 0.0f);
  EXPECT_EQ(map.scale[3], 0.0f);
  for (size_t i = 0; i < 16; ++i) {
    EXPECT_EQ(decode_cache_unorm8(map, 0, q[i * 4 + 0]), 0.375f);
    EXPECT_EQ(decode_cache_unorm8(map, 1, q[i * 4 + 1]), -2.0f);
    EXPECT_EQ(decode_cache_unorm8(map, 3, q[i * 4 + 3]), 0.0f);
  }
  EXPECT_EQ(decode_cache_unorm8(map, 2, q[0]), 0.0f);
  EXPECT_EQ(decode_cache_unorm8(map, 2, q[15 * 4 + 2]), 15.0f);
}

TEST(CacheFormat, HostileValuesGiveAFiniteMap) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<float> v = {nan, inf, -inf, 1.0f, nan, 2.0f, 1e30f, -1.0f, nan, -inf, 3.0f, 1.0f};
  std::vector<uint8_t> q(v.size(), 99);
  const CacheSlotMap map = encode_cache_tile_unorm8(v, q);
  for (int c = 0; c < 4; ++c) {
    EXPECT_TRUE(std::isfinite(map.offset[c]) && std::isfinite(map.scale[c])) << c;
    EXPECT_GE(map.scale[c], 0.0f);
  }
  EXPECT_EQ(map.offset[0], 0.0f);  // component 0 is all NaN: no value
  EXPECT_EQ(map.scale[0], 0.0f);
  EXPECT_EQ(q[0], 0);
  EXPECT_EQ(map.offset[1], -32752.0f);  // ±∞ saturate at ±32752: the range is a half
  EXPECT_EQ(map.scale[1], 65504.0f);
  EXPECT_EQ(q[1], 255);
  EXPECT_EQ(q[9], 0);
  EXPECT_EQ(map.offset[2], -32752.0f);
  EXPECT_EQ(q[2], 0);
  EXPECT_EQ(q[6], 255);  // 1e30 saturates too
  EXPECT_EQ(map.offset[3], -1.0f);
  EXPECT_EQ(map.scale[3], 2.0f);
  TileUpload u{0, {}, q, map};
  const std::array<uint32_t, 4> packed = pack_cache_slot_map(map);
  for (int c = 0; c < 4; ++c) {  // the packed texel holds the same values (they are halves)
    EXPECT_EQ(half_bits_to_float(static_cast<uint16_t>(packed[c / 2] >> (16 * (c % 2)))), map.offset[c]);
    EXPECT_EQ(half_bits_to_float(static_cast<uint16_t>(packed[2 + c / 2] >> (16 * (c % 2)))), map.scale[c]);
  }
  const CacheConfig cache{1, 1, 16, 1, 1, 1, CacheFormat::rgba8_affine};  // 3² texels per slot: not 3 texels
  EXPECT_EQ(check_tile_upload(u, cache), Status::invalid_argument);
  u.map.scale[2] = nan;
  std::vector<uint8_t> nine(9 * 4);
  u.unorm8 = nine;
  EXPECT_EQ(check_tile_upload(u, cache), Status::invalid_argument);  // a non-finite map is refused
  u.map = CacheSlotMap{};
  EXPECT_EQ(check_tile_upload(u, cache), Status::success);
  u.slot = 1;
  EXPECT_EQ(check_tile_upload(u, cache), Status::invalid_argument);
}

TEST(CacheFormat, SizeMismatchWritesNothing) {
  std::vector<float> v(8, 1.0f);
  std::vector<uint8_t> q(7, 42);
  const CacheSlotMap map = encode_cache_tile_unorm8(v, q);
  for (int c = 0; c < 4; ++c) EXPECT_EQ(map.scale[c], 0.0f);
  for (uint8_t b : q) EXPECT_EQ(b, 42);
  std::vector<float> odd(6, 1.0f);
  std::vector<uint8_t> q6(6, 42);
  encode_cache_tile_unorm8(odd, q6);
  for (uint8_t b : q6) EXPECT_EQ(b, 42);
  std::vector<uint16_t> halves(8);
  std::vector<float> small_scratch(4);
  encode_cache_tile_unorm8(halves, small_scratch, q);
  for (uint8_t b : q) EXPECT_EQ(b, 42);
}

TEST(CacheFormat, HalfInputEqualsFloatInputOfTheSameValues) {
  std::vector<float> v = random_tile(40 * 40, 2);
  std::vector<uint16_t> h(v.size());
  float_to_half(v, h);
  half_to_float(h, v);  // the values the halves hold
  std::vector<uint8_t> a(v.size()), b(v.size());
  std::vector<float> scratch(v.size());
  const CacheSlotMap ma = encode_cache_tile_unorm8(v, a), mb = encode_cache_tile_unorm8(h, scratch, b);
  EXPECT_EQ(a, b);
  for (int c = 0; c < 4; ++c) {
    EXPECT_EQ(ma.offset[c], mb.offset[c]);
    EXPECT_EQ(ma.scale[c], mb.scale[c]);
  }
}

TEST(CacheFormat, SlotMapTexelsAreDistinctAndInsideTheTable) {
  const CacheConfig c{5, 3, 16, 8, 1, 4, CacheFormat::rgba8_affine};
  std::set<std::pair<uint32_t, uint32_t>> seen;
  for (uint32_t s = 0; s < c.slot_count(); ++s) {
    const CacheSlotMapTexel t = cache_slot_map_texel(c, s);
    EXPECT_LT(t.x, cache_slot_map_width(c));
    EXPECT_LT(t.y, cache_slot_map_height(c));
    EXPECT_TRUE(seen.insert({t.x, t.y}).second) << "slot " << s;
    // Same column and row as the slot's tile in its layer (the shaders compute it that way).
    const CacheSlotPlacement p = cache_slot_placement(c, s);
    EXPECT_EQ(t.x, p.x / c.padded_tile_size());
    EXPECT_EQ(t.y, p.layer * c.slots_y + p.y / c.padded_tile_size());
  }
}

// A Streamer in rgba8_affine hands out, for every tile, exactly the encoder's bytes and map of
// the tile decoded straight from its container; CpuCacheTexture fed those samples them within
// the bound of the rgba16f cache fed by a Streamer in rgba16f.
TEST(CacheFormat, StreamerUploadsTheEncodedTiles) {
  using namespace btflod_test;
  World w;
  w.add(build(make_eigen(96, 8, 3)));
  w.add(build(make_eigen(64, 4, 4)));
  w.finish();
  StreamerConfig config = small_config();
  Streamer wide = Streamer::create(w.materials, config).value();
  config.cache.format = CacheFormat::rgba8_affine;
  Streamer compact = Streamer::create(w.materials, config).value();
  std::vector<StreamerTileUpload> tiles(compact.tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(compact.packet_uploads_bound());
  std::vector<PageTableWrite> writes(4096);
  std::vector<ResidencyEvent> events(64);
  CpuCacheTexture tex8(compact.cache()), tex16(wide.cache());
  const std::vector<uint32_t> fb = full_feedback(compact);
  uint64_t checked = 0;
  for (int frame = 0; frame < 40; ++frame) {
    for (Streamer* s : {&wide, &compact}) {
      StreamerOutputs o{tiles, packets, writes, events};
      ASSERT_EQ(s->update(fb, o), Status::success);
      for (size_t i = 0; i < o.tile_upload_count; ++i) {
        const StreamerTileUpload& u = o.tile_uploads[i];
        if (s == &wide) {
          EXPECT_TRUE(u.unorm8.empty());
          ASSERT_TRUE(tex16.upload(wide.cache(), u.slot, u.texels));
          continue;
        }
        ASSERT_TRUE(u.texels.empty());
        const uint32_t m = compact.cache().set().material_of(u.tile.texture);
        const TileId local{u.tile.texture - compact.first_texture(m), u.tile.level, u.tile.x, u.tile.y};
        const std::vector<float> ref = decode_direct_floats(w.files[m], w.dirs[m], local);
        std::vector<uint8_t> q(ref.size());
        const CacheSlotMap map = encode_cache_tile_unorm8(ref, q);
        ASSERT_EQ(std::vector<uint8_t>(u.unorm8.begin(), u.unorm8.end()), q) << "tile " << checked;
        for (int c = 0; c < 4; ++c) {
          ASSERT_EQ(u.map.offset[c], map.offset[c]);
          ASSERT_EQ(u.map.scale[c], map.scale[c]);
        }
        ASSERT_TRUE(tex8.upload(compact.cache(), u.slot, u.unorm8, u.map));
        ++checked;
      }
      s->pump();
    }
  }
  EXPECT_GT(checked, 20u);
  // Both caches hold every tile by now (same requests, same order): sample both everywhere.
  ASSERT_EQ(compact.cache().used_count(), wide.cache().used_count());
  double worst = 0.0, range = 0.0;
  for (uint32_t t = 0; t < compact.cache().set().texture_count(); ++t)
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        float a[4], b[4];
        const float u = (x + 0.5f) / 64.0f, v = (y + 0.5f) / 64.0f;
        ASSERT_EQ(compact.cache().page_table(t)[0], wide.cache().page_table(t)[0]);
        tex8.sample(compact.cache(), t, u, v, a);
        tex16.sample(wide.cache(), t, u, v, b);
        for (int c = 0; c < 4; ++c) {
          worst = std::max(worst, std::fabs(static_cast<double>(a[c]) - b[c]));
          range = std::max(range, std::fabs(static_cast<double>(b[c])));
        }
      }
  std::printf("rgba8_affine vs rgba16f CPU cache: max |diff| %.3g over values up to %.3g\n", worst, range);
  EXPECT_GT(range, 0.1);
  EXPECT_LT(worst, range / 255.0);  // within one step of the largest range: the maps are applied
}

TEST(CacheFormat, MapValuesAreZeroOrNormalHalves) {
  // Tiny offsets and ranges (half subnormals) are widened to 0 or ±2^-14: the shaders widen the
  // packed halves with integer operations, exact for normal halves only.
  const std::vector<float> v = {1e-7f, -3e-6f, 0.5f, 2e-5f, 3e-7f, -1e-6f, 0.5f, 2e-5f};
  std::vector<uint8_t> q(v.size());
  const CacheSlotMap map = encode_cache_tile_unorm8(v, q);
  for (int c = 0; c < 4; ++c)
    for (float x : {map.offset[c], map.scale[c]}) {
      EXPECT_TRUE(x == 0.0f || std::fabs(x) >= 6.103515625e-05f) << c << ": " << x;
      EXPECT_EQ(half_bits_to_float(float_to_half_bits(x)), x);
    }
  EXPECT_EQ(map.offset[0], 0.0f);
  EXPECT_EQ(map.scale[0], 6.103515625e-05f);
  EXPECT_EQ(map.offset[1], -6.103515625e-05f);
  EXPECT_EQ(map.scale[2], 0.0f);         // constant 0.5
  for (size_t i = 0; i < v.size(); ++i)  // still within half a step of each value
    EXPECT_NEAR(decode_cache_unorm8(map, static_cast<uint32_t>(i % 4), q[i]), v[i], map.scale[i % 4] / 510.0f + 1e-9f);
}
