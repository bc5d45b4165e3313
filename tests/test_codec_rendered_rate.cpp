// Tests for the encoder-side rate allocation of the tile codec: dead-zone quantisation
// (TileEncoder::set_ac_rounding_threshold, BsvtfBuildOptions::ac_rounding_threshold) — its
// tiles decode with the unchanged decoder to exactly the encoder's reconstruction, small AC
// coefficients fall to zero, the error stays within threshold · step, 0.5 keeps the old bytes —
// and samples/research/progressive/rendered_rate_control.hpp: the rendered ΔE*ab against an independent CIELAB
// conversion, and build_bsvtf_rendered equalising the rendered error quantile over tile
// positions whose sensitivities differ by an order of magnitude (a plain build does not), and the
// per-block quantiles with the report's block spread.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "../samples/research/progressive/rendered_rate_control.hpp"
#include "btflod/core/dct.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "test_codec_two_level_texture.hpp"

namespace {

using namespace btflod;

std::vector<float> noisy_tile(const TileLayout& layout, uint32_t seed, float amplitude) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, amplitude);
  std::vector<float> t(layout.sample_count());
  const uint32_t s = layout.stored_size();
  for (uint32_t y = 0; y < s; ++y)
    for (uint32_t x = 0; x < s; ++x)
      for (uint32_t c = 0; c < layout.channels; ++c)
        t[(size_t{y} * s + x) * layout.channels + c] = amplitude * std::sin(0.3f * x + c) * std::cos(0.2f * y) + n(rng);
  return t;
}

TEST(CodecDeadZone, RoundToNearestKeepsTheBytesAndDeadZoneDecodesWithTheUnchangedDecoder) {
  const TileLayout layout{16, 4, 4};
  const std::vector<float> tile = noisy_tile(layout, 3, 1.0f);
  const float tolerance[4] = {0.05f, 0.05f, 0.1f, 0.2f};
  TileEncoder plain(layout), half(layout), dead(layout);
  half.set_ac_rounding_threshold(0.5f);
  dead.set_ac_rounding_threshold(0.75f);
  std::vector<uint8_t> a(plain.bound()), b(half.bound()), c(dead.bound());
  std::vector<float> ra(layout.sample_count()), rc(layout.sample_count()), decoded(layout.sample_count());
  size_t na = 0, nb = 0, nc = 0;
  ASSERT_EQ(plain.encode(tile, {}, 0, 0, tolerance, a, na, ra), Status::success);
  ASSERT_EQ(half.encode(tile, {}, 0, 0, tolerance, b, nb), Status::success);
  ASSERT_EQ(dead.encode(tile, {}, 0, 0, tolerance, c, nc, rc), Status::success);
  a.resize(na), b.resize(nb), c.resize(nc);
  EXPECT_EQ(a, b) << "threshold 0.5 is round-to-nearest: the bytes of earlier versions";
  EXPECT_LT(nc, na) << "the dead zone must code fewer bytes";
  TileDecoder decoder(layout);
  ASSERT_EQ(decoder.decode(c, {}, 0, 0, decoded), Status::success) << decoder.message();
  EXPECT_EQ(decoded, rc) << "the closed loop must hold: the client decodes the encoder's reconstruction";
  // Error bound: every coefficient within 0.75 step → block RMS ≤ 2 · 0.75 · t; and the dead
  // zone really adds error (it is not plain rounding under another name).
  double se_plain = 0, se_dead = 0;
  const uint32_t s = layout.stored_size();
  for (uint32_t ch = 0; ch < 4; ++ch)
    for (uint32_t by = 0; by < s / 8; ++by)
      for (uint32_t bx = 0; bx < s / 8; ++bx) {
        double block = 0;
        for (uint32_t y = 0; y < 8; ++y)
          for (uint32_t x = 0; x < 8; ++x) {
            const size_t i = ((size_t{by} * 8 + y) * s + bx * 8 + x) * 4 + ch;
            block += (rc[i] - tile[i]) * (rc[i] - tile[i]);
            se_dead += (rc[i] - tile[i]) * (rc[i] - tile[i]);
            se_plain += (ra[i] - tile[i]) * (ra[i] - tile[i]);
          }
        EXPECT_LE(std::sqrt(block / 64), 2 * 0.75 * tolerance[ch] * 1.001) << ch << " " << bx << " " << by;
      }
  EXPECT_GT(se_dead, se_plain);
}

TEST(CodecDeadZone, ACoefficientBelowTheThresholdFallsToZeroAndDcIsStillRounded) {
  // One 8×8 channel block pattern: DC of 2.6 steps and one AC coefficient (zig-zag 1: u = 1) of
  // 0.65 steps, repeated in every block. Nearest: DC 3, AC 1. Threshold 0.7: DC 3, AC 0.
  const TileLayout layout{16, 4, 1};
  const float t = 0.1f;
  const auto& f = quant_step_factors<8>(kJpegWeightQuarters);
  std::array<float, 64> coef{};
  coef[0] = 2.6f * t * f[0];
  coef[1] = 0.65f * t * f[1];
  std::array<float, 64> block{};
  dct_inverse_scalar<8, float>(coef.data(), block.data(), 8);
  std::vector<float> tile(layout.sample_count());
  const uint32_t s = layout.stored_size();
  for (uint32_t y = 0; y < s; ++y)
    for (uint32_t x = 0; x < s; ++x) tile[size_t{y} * s + x] = block[(y % 8) * 8 + x % 8];
  const auto coded_block = [&](float threshold) {
    TileEncoder e(layout);
    e.set_ac_rounding_threshold(threshold);
    std::vector<uint8_t> out(e.bound());
    std::vector<float> rec(layout.sample_count());
    size_t n = 0;
    EXPECT_EQ(e.encode(tile, {}, 0, 0, std::span<const float>(&t, 1), out, n, rec), Status::success);
    std::array<float, 64> in{}, c{};
    for (int i = 0; i < 64; ++i) in[i] = rec[(i / 8) * s + i % 8];
    dct_forward_scalar<8, float>(in.data(), 8, c.data());
    return c;
  };
  const auto nearest = coded_block(0.5f), dead = coded_block(0.7f);
  EXPECT_NEAR(nearest[0], 3 * t * f[0], 1e-4);
  EXPECT_NEAR(nearest[1], 1 * t * f[1], 1e-4);
  EXPECT_NEAR(dead[0], 3 * t * f[0], 1e-4) << "DC is rounded to nearest whatever the threshold";
  EXPECT_NEAR(dead[1], 0.0f, 1e-4) << "0.65 steps is inside a 0.7 dead zone";
}

TEST(CodecDeadZone, BuildBsvtfRejectsAThresholdOutsideTheRange) {
  BsvtfMetadata md;
  md.tile_size = 16;
  md.border = 4;
  md.level_count = 1;
  md.width = md.height = 16;
  md.component_count = 4;
  md.u_rows = 3;
  std::vector<float> u(12, 0.1f);
  const std::vector<float> samples = noisy_tile(md.layout(), 1, 1.0f);
  const BsvtfTileInput tile{{0, 0, 0, 0}, samples, 1.0f};
  for (float bad : {0.4f, 1.0f, std::nanf("")}) {
    BsvtfBuildOptions bo;
    bo.ac_rounding_threshold = bad;
    auto r = build_bsvtf(md, u, std::span<const BsvtfTileInput>(&tile, 1), bo);
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().status, Status::invalid_argument);
  }
}

// One texture of 4 components, T = 16, B = 4, 2 levels, 3 lights × 3 views, RGB. Component 0 is a
// grey mean column; 1..3 add coloured variation. Level-1 tile (x, y) renders at brightness
// base[x + 2y] (an order of magnitude apart: CIELAB makes the dark ones far more sensitive).
struct Material : btflod_test::TwoLevelTexture {
  Material() : TwoLevelTexture(3 * 3 * 3) {
    md.u_row_order = AngularRowOrder::light_major;
    md.light_directions = {0, 0, 1, 0.6f, 0, 0.8f, 0, 0.6f, 0.8f};
    md.view_directions = {0, 0, 1, 0.8f, 0, 0.6f, 0, -0.6f, 0.8f};
    for (uint32_t a = 0; a < 9; ++a)
      for (uint32_t k = 0; k < 3; ++k) {
        u[(a * 3 + k) * 4 + 0] = 0.3f;
        for (uint32_t c = 1; c < 4; ++c) u[(a * 3 + k) * 4 + c] = 0.05f * std::cos(1.0f + a + 2.0f * k + 3.0f * c);
      }
    const TileLayout layout = md.layout();
    const float base[4] = {0.01f, 0.1f, 0.5f, 2.0f};
    add_tiles([&](uint32_t index) {  // seeds 10 (root) and 11 + x + 2y
      const float v0 = index == 0 ? 0.5f : base[index - 1];
      std::vector<float> t = noisy_tile(layout, 10 + index, 0.2f * v0);
      for (size_t i = 0; i < layout.texel_count(); ++i) t[i * 4] += v0;
      return t;
    });
  }
};

TEST(CodecRenderedRate, RenderedErrorMatchesAnIndependentCielabConversion) {
  Material m;
  std::vector<std::vector<float>> decoded(m.samples);
  EXPECT_EQ(decoded.size(), m.tiles.size());
  RenderedErrorOptions o;
  o.view_cosine_power = 0.0f;
  o.quantile = 1.0f;
  o.direction_samples = 1000;  // every row
  auto zero = rendered_tile_errors(m.md, m.u, m.tiles, decoded, o);
  ASSERT_TRUE(zero) << zero.message();
  ASSERT_EQ(zero->size(), 5u);
  for (const RenderedTileError& e : *zero) EXPECT_EQ(e.quantile, 0.0f);
  // A constant error δ in component 0 of the level-0 tile: every row shifts grey by 0.3 δ.
  const float delta = 0.05f;
  for (size_t i = 0; i < m.md.layout().texel_count(); ++i) decoded[0][i * 4] += delta;
  auto err = rendered_tile_errors(m.md, m.u, m.tiles, decoded, o);
  ASSERT_TRUE(err) << err.message();
  double expect_max = 0, expect_sum = 0, n = 0;
  const uint32_t S = m.md.layout().stored_size();
  for (uint32_t y = 4; y < 20; y += o.texel_stride)
    for (uint32_t x = 4; x < 20; x += o.texel_stride)
      for (uint32_t a = 0; a < 9; ++a) {
        double ra[3], rb[3];
        for (uint32_t k = 0; k < 3; ++k) {
          ra[k] = rb[k] = 0;
          for (uint32_t c = 0; c < 4; ++c) {
            ra[k] += m.samples[0][(size_t{y} * S + x) * 4 + c] * m.u[(a * 3 + k) * 4 + c];
            rb[k] += decoded[0][(size_t{y} * S + x) * 4 + c] * m.u[(a * 3 + k) * 4 + c];
          }
          ra[k] = std::clamp(ra[k], 0.0, 1.0), rb[k] = std::clamp(rb[k], 0.0, 1.0);
        }
        const auto la = linear_srgb_to_lab(ra[0], ra[1], ra[2]), lb = linear_srgb_to_lab(rb[0], rb[1], rb[2]);
        const double d = std::sqrt((la[0] - lb[0]) * (la[0] - lb[0]) + (la[1] - lb[1]) * (la[1] - lb[1]) +
                                   (la[2] - lb[2]) * (la[2] - lb[2]));
        expect_max = std::max(expect_max, d), expect_sum += d, ++n;
      }
  EXPECT_NEAR((*err)[0].quantile, expect_max, 1e-3 * expect_max);
  EXPECT_NEAR((*err)[0].mean, expect_sum / n, 1e-3 * expect_sum / n);
  EXPECT_GT((*err)[0].quantile, 0.5f);
  for (size_t p = 1; p < err->size(); ++p) EXPECT_EQ((*err)[p].quantile, 0.0f) << "other positions are exact";
}

// The per-position error quantiles of a container's tiles, decoded coarse to fine.
std::vector<float> position_quantiles(const Material& m, const std::vector<uint8_t>& file,
                                      const RenderedErrorOptions& o) {
  auto dir = read_bsvtf(file);
  EXPECT_TRUE(dir);
  std::vector<std::vector<float>> decoded(m.tiles.size());
  TileDecoder decoder(m.md.layout());
  for (size_t i = 0; i < m.tiles.size(); ++i) {  // tiles are listed coarse to fine, the root first
    const BsvtfTileEntry* e = dir->find(m.tiles[i].id);
    decoded[i].resize(m.md.layout().sample_count());
    const std::span<const float> parent = i == 0 ? std::span<const float>() : std::span<const float>(decoded[0]);
    EXPECT_EQ(decoder.decode(std::span<const uint8_t>(file.data() + e->offset, e->size), parent, m.tiles[i].id.x & 1u,
                             m.tiles[i].id.y & 1u, decoded[i]),
              Status::success);
  }
  auto err = rendered_tile_errors(m.md, m.u, m.tiles, decoded, o);
  EXPECT_TRUE(err);
  std::vector<float> q;
  for (const RenderedTileError& e : *err) q.push_back(e.quantile);
  return q;
}

TEST(CodecRenderedRate, BuildEqualisesTheRenderedErrorOverPositionsAndDarkTilesGetFinerSteps) {
  Material m;
  BsvtfBuildOptions bo;
  bo.entropy_coder = TileEntropyCoder::deflate;
  bo.quality = 50;
  RenderedRateOptions ro;
  ro.target_at_quality50 = 1.5f;
  ro.passes = 4;
  ro.error.direction_samples = 1000;
  // A plain build gives every position the same absolute tolerance: the dark tiles' rendered
  // errors are far above the bright ones'.
  auto plain = build_bsvtf(m.md, m.u, m.tiles, bo);
  ASSERT_TRUE(plain) << plain.message();
  const std::vector<float> before = position_quantiles(m, *plain, ro.error);
  const auto [lo0, hi0] = std::minmax_element(before.begin(), before.end());
  EXPECT_GT(*hi0 / *lo0, 3.0f) << "the fixture must start unequal, or the test proves nothing";
  RenderedRateReport report;
  auto file = build_bsvtf_rendered(m.md, m.u, m.tiles, bo, ro, &report);
  ASSERT_TRUE(file) << file.message();
  const std::vector<float> after = position_quantiles(m, *file, ro.error);
  EXPECT_FLOAT_EQ(report.target, 1.5f);
  // Equalised: from a spread of > 3× to < 1.8×, every position near the target (the error of a
  // 16² tile jumps as groups of coefficients fall to zero, so "near" is ±35 %).
  for (size_t p = 0; p < after.size(); ++p) EXPECT_NEAR(after[p], 1.5f, 0.35f * 1.5f) << "position " << p;
  const auto [lo1, hi1] = std::minmax_element(after.begin(), after.end());
  EXPECT_LT(*hi1 / *lo1, 1.8f);
  EXPECT_FLOAT_EQ(report.pass_max.back(), *std::max_element(after.begin(), after.end()));
  // The darkest level-1 tile (base 0.01) gets a finer tolerance than the brightest (2.0).
  auto dir = read_bsvtf(*file);
  ASSERT_TRUE(dir);
  TileHeaderInfo dark, bright;
  const auto header = [&](TileId id, TileHeaderInfo& info) {
    const BsvtfTileEntry* e = dir->find(id);
    ASSERT_NE(e, nullptr);
    ASSERT_EQ(tile_peek_header(std::span<const uint8_t>(file->data() + e->offset, e->size), info), Status::success);
  };
  header({0, 1, 0, 0}, dark);
  header({0, 1, 1, 1}, bright);
  EXPECT_LT(dark.tolerance[0] * 4, bright.tolerance[0]);
  // Quality keeps its scale: quality 25 doubles the target.
  bo.quality = 25;
  auto coarse = build_bsvtf_rendered(m.md, m.u, m.tiles, bo, ro, &report);
  ASSERT_TRUE(coarse) << coarse.message();
  EXPECT_FLOAT_EQ(report.target, 3.0f);
  EXPECT_LT(coarse->size(), file->size());
}

TEST(CodecRenderedRate, BlockQuantilesLocateAnErrorAndTheReportCountsTheSpread) {
  Material m;
  const TileLayout layout = m.md.layout();
  const uint32_t S = layout.stored_size(), per_side = S / kTileBlock;
  std::vector<std::vector<float>> decoded(m.samples);
  // Position 0 (the level-0 tile): an error δ in component 0 of block (1, 1) only.
  const float delta = 0.05f;
  for (uint32_t y = 8; y < 16; ++y)
    for (uint32_t x = 8; x < 16; ++x) decoded[0][(size_t{y} * S + x) * 4] += delta;
  RenderedErrorOptions o;
  o.quantile = 1.0f;
  o.direction_samples = 1000;
  o.view_cosine_power = 0.0f;
  auto plain = rendered_tile_errors(m.md, m.u, m.tiles, decoded, o);
  ASSERT_TRUE(plain) << plain.message();
  EXPECT_TRUE((*plain)[0].block_quantile.empty()) << "block quantiles only when asked for";
  o.block_quantiles = true;
  auto err = rendered_tile_errors(m.md, m.u, m.tiles, decoded, o);
  ASSERT_TRUE(err) << err.message();
  const std::vector<float>& blocks = (*err)[0].block_quantile;
  ASSERT_EQ(blocks.size(), size_t{per_side} * per_side);
  for (uint32_t b = 0; b < blocks.size(); ++b)
    if (b == per_side + 1) {
      EXPECT_FLOAT_EQ(blocks[b], (*err)[0].quantile) << "the erroneous block holds the tile's maximum";
      EXPECT_GT(blocks[b], 0.5f);
    } else {
      EXPECT_EQ(blocks[b], 0.0f) << "block " << b << " is exact";
    }
  EXPECT_FLOAT_EQ((*err)[0].quantile, (*plain)[0].quantile) << "asking for blocks changes no tile quantile";
  // build_bsvtf_rendered reports every block of every position once in block_spread; bright and
  // dark halves of one tile put blocks well below their tile's quantile.
  for (size_t i = 1; i < m.samples.size(); ++i)
    for (uint32_t y = 0; y < S; ++y)
      for (uint32_t x = S / 2; x < S; ++x) m.samples[i][(size_t{y} * S + x) * 4] += 1.5f;
  BsvtfBuildOptions bo;
  bo.entropy_coder = TileEntropyCoder::deflate;
  RenderedRateOptions ro;
  ro.target_at_quality50 = 1.5f;
  ro.error.direction_samples = 1000;
  RenderedRateReport report;
  auto file = build_bsvtf_rendered(m.md, m.u, m.tiles, bo, ro, &report);
  ASSERT_TRUE(file) << file.message();
  size_t counted = 0, far_below = 0;
  for (size_t k = 0; k < report.block_spread.size(); ++k) {
    counted += report.block_spread[k];
    if (k >= 4) far_below += report.block_spread[k];  // Q / q_b ≥ 2
  }
  EXPECT_EQ(counted, size_t{per_side} * per_side * 5) << "every block of the 5 positions has interior samples";
  // 12 of the 45 blocks here (4 without the bright halves: the 16² tiles' border blocks have only
  // 4 interior samples each, so their quantiles scatter).
  EXPECT_GE(far_below, 8u) << "the bright blocks must lie well below their tiles' quantile";
}

TEST(CodecRenderedRate, ADirectionPriorMixesTheCosineModelUnderTheHistogram) {
  // With every row evaluated (9 rows ≤ direction_samples) the mean ΔE*ab is linear in the
  // normalised row weights: prior p gives (1 − p) · mean(histogram) + p · mean(cosine model).
  Material m;
  std::vector<std::vector<float>> decoded(m.samples);
  for (size_t i = 0; i < m.md.layout().texel_count(); ++i) decoded[0][i * 4 + 1] += 0.3f;
  RenderedErrorOptions o;
  o.direction_samples = 1000;
  o.view_cosine_power = 1.0f;
  const auto mean_of = [&](const RenderedErrorOptions& options) {
    auto r = rendered_tile_errors(m.md, m.u, m.tiles, decoded, options);
    EXPECT_TRUE(r) << r.message();
    return r ? (*r)[0].mean : 0.0f;
  };
  const float cosine = mean_of(o);
  const std::vector<float> histogram{0, 0, 0, 0, 0, 0, 0, 4, 0};  // light 2, view 1 only
  o.direction_weights = histogram;
  const float seen = mean_of(o);
  EXPECT_GT(std::fabs(seen - cosine), 0.05f * cosine) << "the fixture must tell the two models apart";
  o.direction_prior = 0.25f;
  EXPECT_NEAR(mean_of(o), 0.75f * seen + 0.25f * cosine, 1e-4f * cosine);
  // Out of range: an error naming the call, for the rendered error and the perceptual scales alike.
  for (float bad : {-0.1f, 1.0f, std::nanf("")}) {
    o.direction_prior = bad;
    auto r = rendered_tile_errors(m.md, m.u, m.tiles, decoded, o);
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().status, Status::invalid_argument);
    EXPECT_NE(r.error().message.find("direction prior"), std::string::npos) << r.error().message;
    PerceptualToleranceOptions po;
    po.direction_weights = histogram;
    po.direction_prior = bad;
    std::vector<BsvtfTileInput> tiles(m.tiles);
    EXPECT_EQ(perceptual_tolerance_scales(m.md, m.u, tiles, po).error().status, Status::invalid_argument);
  }
}

TEST(CodecRenderedRate, ATexelFootprintAveragesTheErrorAsAMinifiedViewDoes) {
  Material m;
  const uint32_t S = m.md.layout().stored_size();
  RenderedErrorOptions o;
  o.quantile = 1.0f;
  o.direction_samples = 1000;
  o.texel_stride = 2;  // samples start at even texels: a 2 × 2 footprint covers one of each parity
  const auto quantile_of = [&](const std::vector<std::vector<float>>& decoded, uint32_t footprint) {
    o.texel_footprint = footprint;
    auto r = rendered_tile_errors(m.md, m.u, m.tiles, decoded, o);
    EXPECT_TRUE(r) << r.message();
    return r ? (*r)[0].quantile : -1.0f;
  };
  // A checkerboard error ±δ in component 0 of the level-0 tile: every texel is wrong, every
  // 2 × 2 mean is exact.
  std::vector<std::vector<float>> checker(m.samples), constant(m.samples);
  for (uint32_t y = 0; y < S; ++y)
    for (uint32_t x = 0; x < S; ++x) {
      checker[0][(size_t{y} * S + x) * 4] += (x + y) % 2 ? 0.05f : -0.05f;
      constant[0][(size_t{y} * S + x) * 4] += 0.05f;
    }
  EXPECT_GT(quantile_of(checker, 1), 0.5f);
  EXPECT_NEAR(quantile_of(checker, 2), 0.0f, 1e-3f) << "a 2 × 2 mean cancels a checkerboard";
  // On a flat tile a constant error survives any footprint (CIELAB is not linear, so the
  // reference must not change under the mean either).
  for (uint32_t i = 1; i < S * S; ++i)
    for (uint32_t c = 0; c < 4; ++c) m.samples[0][i * 4 + c] = m.samples[0][c];
  constant[0] = m.samples[0];
  for (uint32_t i = 0; i < S * S; ++i) constant[0][i * 4] += 0.05f;
  EXPECT_GT(quantile_of(constant, 1), 0.5f);
  EXPECT_NEAR(quantile_of(constant, 3), quantile_of(constant, 1), 1e-3f * quantile_of(constant, 1));
  // The footprint must stay inside the stored tile: 1..border + 1.
  for (uint32_t bad : {0u, m.md.border + 2}) {
    o.texel_footprint = bad;
    auto r = rendered_tile_errors(m.md, m.u, m.tiles, constant, o);
    ASSERT_FALSE(r) << bad;
    EXPECT_EQ(r.error().status, Status::invalid_argument);
    EXPECT_NE(r.error().message.find("texel footprint"), std::string::npos) << r.error().message;
  }
  o.texel_footprint = m.md.border + 1;
  EXPECT_TRUE(rendered_tile_errors(m.md, m.u, m.tiles, constant, o));
}

TEST(CodecRenderedRate, HostileOptionsAndSizesAreErrors) {
  Material m;
  std::vector<std::vector<float>> decoded(m.samples);
  RenderedErrorOptions o;
  o.quantile = 0.0f;
  EXPECT_EQ(rendered_tile_errors(m.md, m.u, m.tiles, decoded, o).error().status, Status::invalid_argument);
  o.quantile = 0.99f;
  decoded.pop_back();
  EXPECT_EQ(rendered_tile_errors(m.md, m.u, m.tiles, decoded, o).error().status, Status::invalid_argument);
  decoded = m.samples;
  decoded[2].resize(3);
  EXPECT_EQ(rendered_tile_errors(m.md, m.u, m.tiles, decoded, o).error().status, Status::invalid_argument);
  decoded = m.samples;
  std::vector<float> bad_u = m.u;
  bad_u[5] = std::nanf("");
  EXPECT_EQ(rendered_tile_errors(m.md, bad_u, m.tiles, decoded, o).error().status, Status::invalid_argument);
  // Direction weights (ViewingConditions, sampled as for perceptual tolerances): a count that is
  // not the angular rows, a negative or NaN weight, all weights 0 — each an error naming the call.
  const std::vector<float> eight(8, 1.0f), negative{1, 1, 1, 1, -1, 1, 1, 1, 1},
      not_a_number{1, 1, std::nanf(""), 1, 1, 1, 1, 1, 1}, zeros(9, 0.0f);
  for (const std::vector<float>* w : {&eight, &negative, &not_a_number, &zeros}) {
    o.direction_weights = *w;
    auto r = rendered_tile_errors(m.md, m.u, m.tiles, decoded, o);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().status, Status::invalid_argument);
    EXPECT_NE(r.error().message.find("rendered_tile_errors"), std::string::npos) << r.error().message;
  }
  o.direction_weights = {};
  RenderedRateOptions ro;
  ro.target_at_quality50 = -1.0f;
  EXPECT_EQ(build_bsvtf_rendered(m.md, m.u, m.tiles, {}, ro).error().status, Status::invalid_argument);
  ro.target_at_quality50 = 1.0f;
  ro.max_step = 1.0f;
  EXPECT_EQ(build_bsvtf_rendered(m.md, m.u, m.tiles, {}, ro).error().status, Status::invalid_argument);
}

}  // namespace
