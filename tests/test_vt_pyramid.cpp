// Tests for runtime/vt/vt_layout.hpp and offline/build/tile_pyramid.hpp: hierarchy geometry for any M×N, box-
// filtered levels, seamless borders, tile weights of paper 000 eq. 8 and §6 energies.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"

using namespace btflod;

namespace {
EigenTextures make_input(int w, int h, int c, uint32_t seed) {
  EigenTextures e;
  e.textures.resize(w, h, c);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(-1.0f, 1.0f);
  for (float& v : e.textures.elements()) v = d(rng);
  e.light_count = 2;
  e.view_count = 3;
  e.angular.assign(static_cast<size_t>(2 * 3 * 3 * c), 0.5f);
  return e;
}
}  // namespace

TEST(VtGeometry, SquarePowerOfTwo) {
  const VtGeometry g = VtGeometry::make(512, 512);
  ASSERT_TRUE(g.valid());
  EXPECT_EQ(g.finest_level, 3u);
  EXPECT_EQ(g.stored_size(), 72u);
  for (uint32_t l = 0; l <= 3; ++l) {
    EXPECT_EQ(g.tiles_x(l), 1u << l);
    EXPECT_EQ(g.level_width(l), 64u << l);
  }
  EXPECT_EQ(g.tile_count(), 1u + 4 + 16 + 64);
  EXPECT_EQ(VtGeometry::make(64, 64).finest_level, 0u);
  EXPECT_EQ(VtGeometry::make(65, 10).finest_level, 1u);
}

TEST(VtGeometry, NonSquareTilesAllHaveParents) {
  const VtGeometry g = VtGeometry::make(300, 100);
  ASSERT_TRUE(g.valid());
  EXPECT_EQ(g.finest_level, 3u);  // 64·2^3 = 512 ≥ 300
  EXPECT_EQ(g.tiles_x(3), 5u);
  EXPECT_EQ(g.tiles_y(3), 2u);
  EXPECT_EQ(g.tiles_x(2), 3u);
  EXPECT_EQ(g.tiles_y(2), 1u);
  EXPECT_EQ(g.tiles_x(0), 1u);
  const VtLevelTable lv(g);
  for (uint32_t i = 0; i < lv.tile_count(); ++i) {
    const TileId t = lv.tile(7, i);
    EXPECT_EQ(lv.index(t), i);
    EXPECT_TRUE(g.contains(t));
    if (t.level > 0) {
      EXPECT_TRUE(g.contains(t.parent()));
    }
  }
}

TEST(TilePyramid, RejectsInconsistentInput) {
  EigenTextures e = make_input(64, 64, 4, 1);
  e.angular.pop_back();
  auto r = TilePyramid::build(e);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().status, Status::invalid_argument);
  EXPECT_NE(r.error().message.find("expected"), std::string::npos);
}

TEST(TilePyramid, PacksFourComponentsPerVirtualTexture) {
  const EigenTextures e = make_input(128, 96, 6, 2);
  EXPECT_EQ(e.virtual_texture_count(), 2u);
  auto r = TilePyramid::build(e, 32, 2);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const TilePyramid& p = r.value();
  ASSERT_EQ(p.texture_count(), 2u);
  const uint32_t L = p.geometry().finest_level;
  EXPECT_EQ(L, 2u);
  EXPECT_FLOAT_EQ(p.level_image(1, L).at(5, 7, 1), e.textures.at(5, 7, 5));
  EXPECT_FLOAT_EQ(p.level_image(1, L).at(5, 7, 2), 0.0f);  // component 6 does not exist
  // Box filter: level L−1 texel = mean of its 2×2 children.
  const auto& fine = p.level_image(0, L);
  const float want = 0.25f * (fine.at(6, 8, 3) + fine.at(7, 8, 3) + fine.at(6, 9, 3) + fine.at(7, 9, 3));
  EXPECT_NEAR(p.level_image(0, L - 1).at(3, 4, 3), want, 1e-6f);
  EXPECT_EQ(p.level_image(0, 0).width(), 32);
  EXPECT_EQ(p.level_image(0, 0).height(), 24);
}

TEST(TilePyramid, BordersMakeBilinearInsideATileSeamless) {
  const EigenTextures e = make_input(256, 256, 4, 3);
  auto r = TilePyramid::build(e, 64, 4);
  ASSERT_TRUE(r.ok());
  const TilePyramid& p = r.value();
  const uint32_t L = p.geometry().finest_level, stored = 72;
  const Image<float>& img = p.level_image(0, L);
  // Every texel of tile (1, 2) including its border equals the level image (clamped) there.
  const uint32_t idx = p.levels().index(L, 1, 2);
  const auto texels = p.tile_texels(0, idx);
  for (uint32_t y = 0; y < stored; ++y)
    for (uint32_t x = 0; x < stored; ++x) {
      const int gx = std::clamp(int(64 + x) - 4, 0, 255), gy = std::clamp(int(128 + y) - 4, 0, 255);
      for (int c = 0; c < 4; ++c)
        ASSERT_EQ(texels[(y * stored + x) * 4 + c], float_to_half_bits(img.at(gx, gy, c))) << x << "," << y;
    }
  // Bilinear at a point on the tile edge, computed from the tile alone, matches the level image.
  const float s = 64.0f + 0.1f, t = 128.0f + 63.9f;  // between texels of tiles (0|1, 2|3)
  float from_image[4];
  sample_bilinear_clamped(img, s, t, from_image);
  Image<float> tile(72, 72, 4);
  for (size_t i = 0; i < texels.size(); ++i) tile.elements()[i] = half_bits_to_float(texels[i]);
  float from_tile[4];
  sample_bilinear_clamped(tile, s - 64.0f + 4.0f, t - 128.0f + 4.0f, from_tile);
  for (int c = 0; c < 4; ++c) EXPECT_NEAR(from_tile[c], from_image[c], 2e-3f);
}

// A repeated material: the outer borders of edge tiles hold the texels of the opposite edge,
// everything else (interior, inner borders, weights) equals the clamped pyramid.
TEST(TilePyramid, WrappedEdgesTakeTheOppositeEdgeAndChangeNothingElse) {
  const EigenTextures e = make_input(128, 96, 4, 9);
  auto clamped = TilePyramid::build(e, 32, 4, TileEdge::clamp);
  auto wrapped = TilePyramid::build(e, 32, 4, TileEdge::wrap);
  ASSERT_TRUE(clamped.ok() && wrapped.ok());
  const uint32_t stored = 40;
  size_t differing = 0;
  for (uint32_t l = 0; l <= wrapped->geometry().finest_level; ++l) {
    const Image<float>& img = wrapped->level_image(0, l);
    const int w = img.width(), h = img.height();
    for (uint32_t ty = 0; ty < wrapped->levels().tiles_y[l]; ++ty)
      for (uint32_t tx = 0; tx < wrapped->levels().tiles_x[l]; ++tx) {
        const uint32_t idx = wrapped->levels().index(l, tx, ty);
        const auto a = wrapped->tile_texels(0, idx), b = clamped->tile_texels(0, idx);
        for (uint32_t y = 0; y < stored; ++y)
          for (uint32_t x = 0; x < stored; ++x) {
            const int ux = int(tx * 32 + x) - 4, uy = int(ty * 32 + y) - 4;
            const int gx = (ux % w + w) % w, gy = (uy % h + h) % h;
            for (int c = 0; c < 4; ++c) {
              const size_t i = (size_t(y) * stored + x) * 4 + c;
              ASSERT_EQ(a[i], float_to_half_bits(img.at(gx, gy, c))) << "level " << l << " texel " << x << "," << y;
              if (ux >= 0 && ux < w && uy >= 0 && uy < h) {
                ASSERT_EQ(a[i], b[i]);
              }
              differing += a[i] != b[i];
            }
          }
        EXPECT_EQ(wrapped->weights(0)[idx].bits, clamped->weights(0)[idx].bits);
      }
  }
  EXPECT_GT(differing, 1000u) << "random texels: wrapped outer borders must differ from clamped ones";
}

TEST(TilePyramid, WeightsFollowEquation8) {
  // Constant texture: every tile equals its up-sampled parent → w = 0; energy = value².
  EigenTextures flat = make_input(256, 256, 4, 4);
  for (float& v : flat.textures.elements()) v = 0.5f;
  auto rf = TilePyramid::build(flat);
  ASSERT_TRUE(rf.ok());
  for (uint32_t i = 1; i < rf.value().levels().tile_count(); ++i) {
    EXPECT_EQ(rf.value().weights(0)[i].to_float(), 0.0f);
    EXPECT_NEAR(rf.value().energies(0)[i].to_float(), 4 * 0.25f, 1e-3f);
  }
  EXPECT_NEAR(rf.value().weights(0)[0].to_float(), 1.0f, 1e-3f);  // root: distance to nothing
  // A ±1 checkerboard in channel 0 at the finest level: the parent level is 0 everywhere,
  // so w(finest) = mean of 1² = 1; coarser levels are constant 0 → w = 0.
  EigenTextures checker = make_input(256, 256, 4, 5);
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x)
      for (int c = 0; c < 4; ++c) checker.textures.at(x, y, c) = c == 0 ? (((x + y) & 1) ? 1.0f : -1.0f) : 0.0f;
  auto rc = TilePyramid::build(checker);
  ASSERT_TRUE(rc.ok());
  const TilePyramid& p = rc.value();
  const uint32_t L = p.geometry().finest_level;
  for (uint32_t i = p.levels().offset[L]; i < p.levels().tile_count(); ++i)
    EXPECT_NEAR(p.weights(0)[i].to_float(), 1.0f, 1e-3f);
  for (uint32_t i = 0; i < p.levels().offset[L]; ++i) EXPECT_EQ(p.weights(0)[i].to_float(), 0.0f);
}

// Eigen-textures of a few hundred (a log-encoded FMF's first component): the root's w and every
// energy exceed the largest half and saturate at 65504 instead of becoming infinite (a container
// refuses non-finite weights); small values are unchanged.
TEST(TilePyramid, LargeWeightsAndEnergiesSaturateInsteadOfOverflowing) {
  EigenTextures big = make_input(128, 128, 4, 6);
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 128; ++x) {
      big.textures.at(x, y, 0) = -350.0f + 0.01f * static_cast<float>(x % 7);
      for (int c = 1; c < 4; ++c) big.textures.at(x, y, c) = 0.0f;
    }
  auto r = TilePyramid::build(big);
  ASSERT_TRUE(r.ok()) << r.message();
  for (uint32_t i = 0; i < r->levels().tile_count(); ++i) {
    EXPECT_EQ(r->energies(0)[i].to_float(), 65504.0f);  // 350² = 122,500
    EXPECT_TRUE(std::isfinite(r->weights(0)[i].to_float()));
  }
  EXPECT_EQ(r->weights(0)[0].to_float(), 65504.0f);                         // the root: distance to nothing
  EXPECT_LT(r->weights(0)[r->levels().tile_count() - 1].to_float(), 1.0f);  // detail only
}

TEST(TilePyramid, WeightsCopyIntoASharedSet) {
  const EigenTextures e = make_input(128, 128, 8, 6);
  auto r = TilePyramid::build(e);
  ASSERT_TRUE(r.ok());
  VtSet set;
  set.add_material(VtGeometry::make(64, 64), 1);
  const uint32_t m = set.add_material(r.value().geometry(), r.value().texture_count());
  r.value().copy_weights_to(set, m);
  EXPECT_EQ(set.texture_count(), 3u);
  EXPECT_EQ(set.material_of(2), 1u);
  EXPECT_EQ(set.weights(2)[3], r.value().weights(1)[3]);
  EXPECT_EQ(set.energies(1)[4], r.value().energies(0)[4]);
  const auto layouts = vote_layouts(set);
  ASSERT_EQ(layouts.size(), 2u);
  EXPECT_EQ(layouts[1].finest_level, 1u);
  EXPECT_EQ(layouts[1].tiles_x, 2u);
}
