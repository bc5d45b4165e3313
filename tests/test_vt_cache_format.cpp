// Tests for runtime/vt/cache_format.hpp: the rgba8_affine encoder (error bound, exact ends, constant
// components, hostile floats, sizes), the slot-map table layout, CpuCacheTexture reading the
// format, and a Streamer configured with it handing out the encoder's bytes and maps of the
// exactly decoded tiles.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/shader/shader_config.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"
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

// Samples both Streamers' CPU caches at 64 × 64 points of every virtual texture (their page
// tables must agree: same requests, same order) and returns the largest |compact − wide| and the
// largest |wide| value seen.
void compare_cpu_caches(const Streamer& compact, const CpuCacheTexture& compact_texture, const Streamer& wide,
                        const CpuCacheTexture& wide_texture, double& worst, double& range) {
  for (uint32_t t = 0; t < compact.cache().set().texture_count(); ++t)
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        float a[4], b[4];
        const float u = (x + 0.5f) / 64.0f, v = (y + 0.5f) / 64.0f;
        ASSERT_EQ(compact.cache().page_table(t)[0], wide.cache().page_table(t)[0]);
        compact_texture.sample(compact.cache(), t, u, v, a);
        wide_texture.sample(wide.cache(), t, u, v, b);
        for (int c = 0; c < 4; ++c) {
          worst = std::max(worst, std::fabs(static_cast<double>(a[c]) - b[c]));
          range = std::max(range, std::fabs(static_cast<double>(b[c])));
        }
      }
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
  compare_cpu_caches(compact, tex8, wide, tex16, worst, range);
  if (HasFatalFailure()) return;
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

// bc5_affine: 2 bytes a texel plus rgba8_affine's slot-map table, and only slot sides that are
// whole 4 × 4 blocks.
TEST(CacheFormatBc5, ConfigSizesAndSlotSide) {
  CacheConfig c{16, 8, 1024, 64, 4, 2, CacheFormat::bc5_affine};
  EXPECT_TRUE(c.valid());
  EXPECT_EQ(c.texel_bytes(), 2u);
  EXPECT_EQ(c.cache_bytes(), uint64_t{c.slot_count()} * cache_bc5_tile_bytes(c.padded_tile_size()));
  EXPECT_EQ(c.slot_map_bytes(), uint64_t{c.slot_count()} * 16);
  EXPECT_STREQ(cache_format_name(c.format), "bc5_affine");
  c.border = 3;  // 70 texels a side: not whole blocks
  EXPECT_FALSE(c.slot_side_fits_format());
  EXPECT_FALSE(c.valid());
  c.format = CacheFormat::rgba8_affine;  // any side for the other formats
  EXPECT_TRUE(c.valid());
}

TEST(CacheFormatBc5, SlotSideNotAMultipleOf4IsRefusedWithAMessage) {
  using namespace btflod_test;
  World w;
  w.add(build(make_eigen(64, 4, 4)));
  w.finish();
  StreamerConfig config = small_config();
  config.cache.format = CacheFormat::bc5_affine;
  config.cache.border = 3;  // 32 + 6 = 38
  Result<Streamer> s = Streamer::create(w.materials, config);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.status(), Status::invalid_argument);
  EXPECT_NE(s.message().find("multiple of 4"), std::string::npos) << s.message();
  ShaderConfig shader;
  static_cast<CacheConfig&>(shader.vt) = config.cache;
  const VoidResult v = validate_shader_config(shader);
  ASSERT_FALSE(v);
  EXPECT_NE(v.message().find("multiple of 4"), std::string::npos) << v.message();
  shader.vt.border = 4;
  EXPECT_TRUE(validate_shader_config(shader));
}

// check_tile_upload for bc5_affine, one failure class each: blocks of the wrong size, no blocks
// (the unorm8 of the other affine format instead), a map that is not finite, a slot out of range.
TEST(CacheFormatBc5, TileUploadChecks) {
  const CacheConfig cache{2, 1, 16, 4, 2, 1, CacheFormat::bc5_affine};  // 8² texels a slot: 128 bytes
  std::vector<uint8_t> blocks(cache_bc5_tile_bytes(8)), unorm8(8 * 8 * 4);
  TileUpload u;
  u.slot = 1;
  u.bc5 = blocks;
  EXPECT_EQ(check_tile_upload(u, cache), Status::success);
  u.bc5 = std::span<const uint8_t>(blocks).first(blocks.size() - 16);
  EXPECT_EQ(check_tile_upload(u, cache), Status::invalid_argument);  // wrong size
  u.bc5 = {};
  u.unorm8 = unorm8;
  EXPECT_EQ(check_tile_upload(u, cache), Status::invalid_argument);  // missing blocks
  u.bc5 = blocks;
  u.map.offset[3] = std::numeric_limits<float>::infinity();
  EXPECT_EQ(check_tile_upload(u, cache), Status::invalid_argument);  // non-finite map
  u.map.offset[3] = 0.0f;
  u.map.scale[0] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(check_tile_upload(u, cache), Status::invalid_argument);
  u.map = CacheSlotMap{};
  u.slot = 2;
  EXPECT_EQ(check_tile_upload(u, cache), Status::invalid_argument);  // slot out of range
}

// A Streamer in bc5_affine hands out, for every tile, exactly encode_cache_tile_bc5's blocks and
// map of the tile decoded straight from its container; the rgba16f Streamer's upload of the
// same tile decodes from those blocks within the BC4 bound; CpuCacheTexture fed the blocks
// samples within that bound of the rgba16f cache.
TEST(CacheFormatBc5, StreamerUploadsTheEncodedTiles) {
  using namespace btflod_test;
  World w;
  w.add(build(make_eigen(96, 8, 3)));
  w.add(build(make_eigen(64, 4, 4)));
  w.finish();
  StreamerConfig config = small_config();
  Streamer wide = Streamer::create(w.materials, config).value();
  config.cache.format = CacheFormat::bc5_affine;
  Streamer compact = Streamer::create(w.materials, config).value();
  const uint32_t side = config.cache.padded_tile_size();
  StreamerOutputBuffers buffers(compact, 4096, 64);  // the same bounds as wide's
  CpuCacheTexture tex5(compact.cache()), tex16(wide.cache());
  ASSERT_EQ(tex5.format(), CacheFormat::bc5_affine);
  const std::vector<uint32_t> fb = full_feedback(compact);
  std::map<std::pair<uint32_t, uint64_t>, std::vector<uint16_t>> wide_tiles;  // (texture, tile key) → halves
  std::vector<uint8_t> scratch(size_t{side} * side * 4), blocks(cache_bc5_tile_bytes(side));
  std::vector<float> back(size_t{side} * side * 4);
  uint64_t checked = 0, compared = 0;
  double worst_tile = 0.0;
  for (int frame = 0; frame < 40; ++frame) {
    for (Streamer* s : {&wide, &compact}) {
      StreamerOutputs o = buffers.outputs();
      ASSERT_EQ(s->update(fb, o), Status::success);
      for (size_t i = 0; i < o.tile_upload_count; ++i) {
        const StreamerTileUpload& u = o.tile_uploads[i];
        if (s == &wide) {
          EXPECT_TRUE(u.bc5.empty());
          ASSERT_TRUE(tex16.upload(wide.cache(), u.slot, u.texels));
          wide_tiles[{u.tile.texture, u.tile.key()}].assign(u.texels.begin(), u.texels.end());
          continue;
        }
        ASSERT_TRUE(u.texels.empty() && u.unorm8.empty());
        const TileUpload t{u.slot, u.texels, u.unorm8, u.map, u.bc5};
        ASSERT_EQ(check_tile_upload(t, config.cache), Status::success);
        const uint32_t m = compact.cache().set().material_of(u.tile.texture);
        const TileId local{u.tile.texture - compact.first_texture(m), u.tile.level, u.tile.x, u.tile.y};
        const std::vector<float> ref = decode_direct_floats(w.files[m], w.dirs[m], local);
        const CacheSlotMap map = encode_cache_tile_bc5(ref, side, scratch, blocks);
        ASSERT_EQ(std::vector<uint8_t>(u.bc5.begin(), u.bc5.end()), blocks) << "tile " << checked;
        for (int c = 0; c < 4; ++c) {
          ASSERT_EQ(u.map.offset[c], map.offset[c]);
          ASSERT_EQ(u.map.scale[c], map.scale[c]);
        }
        // The rgba16f upload of the same tile (the wide Streamer ran this frame first).
        const auto it = wide_tiles.find({u.tile.texture, u.tile.key()});
        if (it != wide_tiles.end()) {
          decode_cache_tile_bc5(u.bc5, side, u.map, back);
          for (size_t k = 0; k < back.size(); ++k) {
            const double bound = u.map.scale[k % 4] * (2.0 / 7.0 / 2.0 + 1.0 / 255.0) + 1e-3;
            const double d = std::fabs(static_cast<double>(back[k]) - half_bits_to_float(it->second[k]));
            worst_tile = std::max(worst_tile, d / std::max(static_cast<double>(u.map.scale[k % 4]), 1e-9));
            ASSERT_LE(d, bound) << "tile " << checked << " value " << k;
          }
          ++compared;
        }
        ASSERT_TRUE(tex5.upload(compact.cache(), u.slot, u.texels, u.unorm8, u.map, u.bc5));
        ++checked;
      }
      s->pump();
    }
  }
  EXPECT_GT(checked, 20u);
  EXPECT_GT(compared, 20u);
  ASSERT_EQ(compact.cache().used_count(), wide.cache().used_count());
  double worst = 0.0, range = 0.0;
  compare_cpu_caches(compact, tex5, wide, tex16, worst, range);
  if (HasFatalFailure()) return;
  std::printf(
      "bc5_affine vs rgba16f: worst value error %.3g of the slot's scale; CPU cache max |diff| %.3g over "
      "values up to %.3g\n",
      worst_tile, worst, range);
  EXPECT_GT(range, 0.1);
  EXPECT_LT(worst, range / 7.0);  // within half a BC4 step (1/7 of a block's range) of the largest range
}
