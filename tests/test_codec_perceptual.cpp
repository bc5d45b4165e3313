// Tests for offline/build/perceptual_tolerance.hpp: the ΔE*ab gain against finite differences of an
// independent CIELAB conversion (offline/metrics/image_metrics.hpp), the allocation it implies (dark
// texels finer than bright ones by the CIELAB slope, clipped or never-shown components at the
// maximum scale), direction weights, determinism across thread counts, hostile input leaving
// the tiles untouched, and build_bsvtf applying channel scales and the weighting exponent.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "btflod/offline/build/perceptual_tolerance.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "test_codec_two_level_texture.hpp"

namespace {

using namespace btflod;

TEST(CodecPerceptual, GainMatchesFiniteDifferencesOfCielab) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> level(0.02f, 0.9f), dir(-1.0f, 1.0f);
  for (int i = 0; i < 500; ++i) {
    const float rgb[3] = {level(rng), level(rng), level(rng)};
    const float d[3] = {dir(rng), dir(rng), dir(rng)};
    const double h = 1e-4;
    const auto a = linear_srgb_to_lab(rgb[0] + h * d[0], rgb[1] + h * d[1], rgb[2] + h * d[2]);
    const auto b = linear_srgb_to_lab(rgb[0] - h * d[0], rgb[1] - h * d[1], rgb[2] - h * d[2]);
    const double expect =
        std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2])) /
        (2 * h);
    ASSERT_NEAR(detail::perceptual_gain(rgb, d, 0.0f), expect, 2e-3 * expect + 1e-3) << i;
  }
  // Below CIELAB's toe the slope is constant: halving a dark grey does not change the gain.
  const float grey_a[3] = {0.004f, 0.004f, 0.004f}, grey_b[3] = {0.002f, 0.002f, 0.002f}, up[3] = {1, 1, 1};
  EXPECT_NEAR(detail::perceptual_gain(grey_a, up, 0.0f), detail::perceptual_gain(grey_b, up, 0.0f), 1e-3);
  // A floor caps the sensitivity: at the floor level and below it the gain is the same.
  const float floor_grey[3] = {0.05f, 0.05f, 0.05f};
  EXPECT_NEAR(detail::perceptual_gain(grey_b, up, 0.05f), detail::perceptual_gain(floor_grey, up, 0.05f), 0.05);
  EXPECT_LT(detail::perceptual_gain(grey_b, up, 0.05f), 0.5f * detail::perceptual_gain(grey_b, up, 0.0f));
  // Clipped channels do not move: a step along a channel at or above white is invisible.
  const float clipped[3] = {1.5f, 0.3f, 0.3f}, red[3] = {1, 0, 0}, green[3] = {0, 1, 0};
  EXPECT_EQ(detail::perceptual_gain(clipped, red, 0.0f), 0.0f);
  EXPECT_GT(detail::perceptual_gain(clipped, green, 0.0f), 1.0f);
}

// One texture (4 components), T = 16, B = 4, 2 levels; 2 lights × 2 views × RGB. Component 0
// is a grey "mean" column (constant over the 4 directions), component 1 lives only at angular
// row 3 (light 1, view 1), components 2 and 3 are 0. Level-1 tile (x, y) has v_0 = base[x + 2y].
struct Fixture : btflod_test::TwoLevelTexture {
  explicit Fixture(std::array<float, 4> base = {0.05f, 0.5f, 5.0f, 50.0f}) : TwoLevelTexture(2 * 2 * 3) {
    md.light_directions = {0, 0, 1, 0.8f, 0, 0.6f};
    md.view_directions = {0, 0, 1, 0, 0.6f, 0.8f};
    for (uint32_t a = 0; a < 4; ++a)
      for (uint32_t k = 0; k < 3; ++k) {
        u[(a * 3 + k) * 4 + 0] = 0.01f;
        if (a == 3) u[(a * 3 + k) * 4 + 1] = 0.01f;
      }
    const TileLayout layout = md.layout();
    add_tiles([&](uint32_t index) {
      const float v0 = index == 0 ? 1.0f : base[index - 1];
      std::vector<float> t(layout.sample_count(), 0.0f);
      for (size_t i = 0; i < layout.texel_count(); ++i) t[i * 4] = v0;  // v_1 = 0: every row renders alike
      return t;
    });
  }
};

PerceptualToleranceOptions plain_options() {
  PerceptualToleranceOptions o;
  o.view_cosine_power = 0.0f;  // every direction alike: the fixture's directions are few
  o.texel_stride = 2;
  o.dark_floor = 0.0f;  // CIELAB's own toe
  o.reference_delta_e = 100.0f;
  return o;
}

TEST(CodecPerceptual, DarkTilesGetFinerTolerancesByTheCielabSlope) {
  Fixture f({0.5f, 5.0f, 5.0f, 5.0f});
  auto rep = perceptual_tolerance_scales(f.md, f.u, f.tiles, plain_options());
  ASSERT_TRUE(rep) << rep.message();
  // Rendered grey: Y = 0.01 · v0 → 0.005 (below the toe, slope 1/(3·(6/29)²)) and 0.05
  // (slope 0.05^(−2/3)/3). Component 0's gain is 116 × that slope per unit Y × 0.01.
  const double slope_dark = 1.0 / (3 * (6.0 / 29) * (6.0 / 29)), slope_bright = 1.0 / (3 * std::cbrt(0.05 * 0.05));
  const double expect_ratio = slope_dark / slope_bright;  // scale ∝ 1 / gain
  EXPECT_NEAR(f.level1(1, 0).channel_scale[0] / f.level1(0, 0).channel_scale[0], expect_ratio, 0.02 * expect_ratio);
  // Absolute: scale = reference_delta_e (100) / (G · R), R = the largest range (v0: 5 − 0.5 = 4.5).
  const double gain_bright = 116 * slope_bright * 0.01;
  EXPECT_NEAR(rep->largest_range, 4.5, 1e-5);
  EXPECT_NEAR(f.level1(1, 0).channel_scale[0], 100.0 / (gain_bright * 4.5), 0.01 * 100.0 / (gain_bright * 4.5));
  // Components 2 and 3 are 0 in U: never visible, so the largest scale.
  EXPECT_EQ(f.level1(0, 0).channel_scale[2], plain_options().max_scale);
  EXPECT_EQ(f.level1(0, 0).channel_scale[3], plain_options().max_scale);
  // Component 1 is seen in one of 4 directions: gain (mean |g|) = a quarter of component 0's.
  // (The dark tile: the bright one's would pass max_scale.)
  EXPECT_NEAR(f.level1(0, 0).channel_scale[1] / f.level1(0, 0).channel_scale[0], 4.0, 0.05);
  EXPECT_EQ(f.level1(1, 0).channel_scale[1], plain_options().max_scale) << "clamped";
}

TEST(CodecPerceptual, ClippedTexelsAndUnseenDirectionsGetTheLargestScale) {
  Fixture f({0.5f, 500.0f, 5.0f, 5.0f});  // tile (1, 0): Y = 5, clipped in every channel
  PerceptualToleranceOptions o = plain_options();
  auto rep = perceptual_tolerance_scales(f.md, f.u, f.tiles, o);
  ASSERT_TRUE(rep) << rep.message();
  EXPECT_EQ(f.level1(1, 0).channel_scale[0], o.max_scale);
  EXPECT_LT(f.level1(0, 0).channel_scale[0], o.max_scale);
  // Direction weights that never show row 3 make component 1 invisible everywhere...
  Fixture g;
  std::vector<float> weights = {1, 1, 1, 0};
  o.direction_weights = weights;
  ASSERT_TRUE(perceptual_tolerance_scales(g.md, g.u, g.tiles, o));
  for (uint32_t i = 0; i < 4; ++i) EXPECT_EQ(g.tiles[1 + i].channel_scale[1], o.max_scale) << i;
  // ...and weights that show only row 3 give components 0 and 1 the same gain.
  weights = {0, 0, 0, 2};
  ASSERT_TRUE(perceptual_tolerance_scales(g.md, g.u, g.tiles, o));
  EXPECT_NEAR(g.level1(0, 1).channel_scale[1] / g.level1(0, 1).channel_scale[0], 1.0, 1e-3);
  // The cosine model: row 3 has cos θ_l = 0.6, cos θ_v = 0.8 — a strong view power hides it.
  Fixture c;
  PerceptualToleranceOptions cos = plain_options();
  cos.view_cosine_power = 1.0f;
  ASSERT_TRUE(perceptual_tolerance_scales(c.md, c.u, c.tiles, cos));
  const float r1 = c.level1(0, 1).channel_scale[1] / c.level1(0, 1).channel_scale[0];
  cos.view_cosine_power = 8.0f;
  ASSERT_TRUE(perceptual_tolerance_scales(c.md, c.u, c.tiles, cos));
  EXPECT_GT(c.level1(0, 1).channel_scale[1] / c.level1(0, 1).channel_scale[0], 1.5f * r1);
  // Row order: component 2 only at row 1 — (light 0, view 1: cos θ_v = 0.8) light-major, (view 0,
  // light 1: cos θ_v = 1) view-major; with view power 8 only the former is rarely shown.
  Fixture lm, vm;
  for (Fixture* f : {&lm, &vm})
    for (uint32_t k = 0; k < 3; ++k) f->u[(1 * 3 + k) * 4 + 2] = 0.01f;
  PerceptualToleranceOptions ro = cos;
  ASSERT_TRUE(perceptual_tolerance_scales(lm.md, lm.u, lm.tiles, ro));
  ro.row_order = AngularRowOrder::view_major;
  ASSERT_TRUE(perceptual_tolerance_scales(vm.md, vm.u, vm.tiles, ro));
  EXPECT_NEAR(lm.level1(0, 1).channel_scale[2] / vm.level1(0, 1).channel_scale[2], 1.0 / std::pow(0.8, 8.0),
              0.05 / std::pow(0.8, 8.0));
  EXPECT_EQ(lm.level1(0, 1).channel_scale[0], vm.level1(0, 1).channel_scale[0])
      << "component 0 is the same in every row";
}

TEST(CodecPerceptual, ThreadCountDoesNotChangeTheScales) {
  Fixture a, b;
  ThreadPool one(1), three(3);
  PerceptualToleranceOptions o = plain_options();
  o.pool = &one;
  ASSERT_TRUE(perceptual_tolerance_scales(a.md, a.u, a.tiles, o));
  o.pool = &three;
  ASSERT_TRUE(perceptual_tolerance_scales(b.md, b.u, b.tiles, o));
  for (size_t i = 0; i < a.tiles.size(); ++i)
    for (int k = 0; k < 4; ++k) ASSERT_EQ(a.tiles[i].channel_scale[k], b.tiles[i].channel_scale[k]);
}

TEST(CodecPerceptual, HostileInputIsAnErrorAndLeavesTheTilesUntouched) {
  const auto untouched = [](const Fixture& f) {
    for (const auto& t : f.tiles)
      for (float s : t.channel_scale)
        if (s != 1.0f) return false;
    return true;
  };
  {
    Fixture f;
    f.u[5] = NAN;
    EXPECT_EQ(perceptual_tolerance_scales(f.md, f.u, f.tiles).status(), Status::invalid_argument);
    EXPECT_TRUE(untouched(f));
  }
  {
    Fixture f;
    f.u.pop_back();
    EXPECT_EQ(perceptual_tolerance_scales(f.md, f.u, f.tiles).status(), Status::invalid_argument);
  }
  {
    Fixture f;
    f.samples[2][7] = INFINITY;
    EXPECT_EQ(perceptual_tolerance_scales(f.md, f.u, f.tiles).status(), Status::invalid_argument);
    EXPECT_TRUE(untouched(f));
  }
  {
    Fixture f;
    f.md.color_mode = ColorMode::ycbcr;
    EXPECT_EQ(perceptual_tolerance_scales(f.md, f.u, f.tiles).status(), Status::unsupported);
  }
  {
    Fixture f;
    f.tiles[1].id.texture = 3;  // no such texture
    EXPECT_EQ(perceptual_tolerance_scales(f.md, f.u, f.tiles).status(), Status::invalid_argument);
  }
  for (int which = 0; which < 6; ++which) {
    Fixture f;
    PerceptualToleranceOptions o;
    std::vector<float> weights = {1, 1, 1};  // wrong count
    switch (which) {
      case 0:
        o.exposure[1] = NAN;
        break;
      case 1:
        o.reference_delta_e = -1;
        break;
      case 2:
        o.texel_stride = 0;
        break;
      case 3:
        o.max_scale = 1e7f;
        break;
      case 4:
        o.direction_weights = weights;
        break;
      case 5:
        o.gain_power = NAN;
        break;
    }
    EXPECT_EQ(perceptual_tolerance_scales(f.md, f.u, f.tiles, o).status(), Status::invalid_argument) << which;
    EXPECT_TRUE(untouched(f)) << which;
  }
  {
    Fixture f;  // weights all 0
    PerceptualToleranceOptions o;
    std::vector<float> zero(4, 0.0f);
    o.direction_weights = zero;
    EXPECT_EQ(perceptual_tolerance_scales(f.md, f.u, f.tiles, o).status(), Status::invalid_argument);
  }
  {
    Fixture f;  // cosine weights need lights × views = angular rows
    f.md.view_directions.resize(3);
    EXPECT_EQ(perceptual_tolerance_scales(f.md, f.u, f.tiles).status(), Status::invalid_argument);
  }
}

TEST(CodecPerceptual, BuildBsvtfAppliesChannelScalesAndTheWeightingExponent) {
  Fixture f;
  BsvtfBuildOptions bo;
  auto plain = build_bsvtf(f.md, f.u, f.tiles, bo);
  ASSERT_TRUE(plain) << plain.message();
  f.tiles[2].channel_scale = {1.0f, 2.0f, 0.5f, 1.0f};
  bo.weight_quarters = 1;
  auto scaled = build_bsvtf(f.md, f.u, f.tiles, bo);
  ASSERT_TRUE(scaled) << scaled.message();
  auto a = read_bsvtf(*plain), b = read_bsvtf(*scaled);
  ASSERT_TRUE(a && b);
  const TileId id = f.tiles[2].id;
  const BsvtfTileEntry *ea = a->find(id), *eb = b->find(id);
  ASSERT_TRUE(ea && eb);
  TileHeaderInfo ha, hb;
  ASSERT_EQ(tile_peek_header(std::span<const uint8_t>(*plain).subspan(ea->offset, ea->size), ha), Status::success);
  ASSERT_EQ(tile_peek_header(std::span<const uint8_t>(*scaled).subspan(eb->offset, eb->size), hb), Status::success);
  EXPECT_EQ(ha.weight_quarters, 4u);
  EXPECT_EQ(hb.weight_quarters, 1u);
  EXPECT_EQ(hb.tolerance[0], ha.tolerance[0]);
  EXPECT_EQ(hb.tolerance[1], 2.0f * ha.tolerance[1]);
  EXPECT_EQ(hb.tolerance[2], 0.5f * ha.tolerance[2]);
  for (float bad : {0.0f, -1.0f, NAN, 1e7f}) {
    Fixture g;
    g.tiles[1].channel_scale[3] = bad;
    EXPECT_EQ(build_bsvtf(g.md, g.u, g.tiles).status(), Status::invalid_argument) << bad;
  }
  BsvtfBuildOptions too_many;
  too_many.weight_quarters = 5;
  EXPECT_EQ(build_bsvtf(f.md, f.u, f.tiles, too_many).status(), Status::invalid_argument);
}

}  // namespace
