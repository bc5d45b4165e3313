// Tests for offline/btf/heightfield.hpp and offline/btf/synthesizer.hpp: analytic flat cases (Lambert equals
// albedo·cosθ_l/π, reciprocity of the analytic BRDF, energy bound), self-shadowing and masking
// on a hand-made ridge, interreflection, determinism across thread counts and seeds,
// tileability of the procedural materials, the measured-BRDF base, progress/cancellation and
// argument errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "btflod/offline/btf/bonn_btf.hpp"
#include "btflod/offline/btf/synthesizer.hpp"

namespace {

using namespace btflod;

DirectionSet custom(std::vector<std::pair<float, float>> theta_phi_deg) {
  std::vector<std::pair<float, float>> rad;
  for (auto [t, p] : theta_phi_deg) rad.emplace_back(degrees_to_radians(t), degrees_to_radians(p));
  return DirectionSet::from_radians("custom", rad);
}

// Equal-area points on the upper hemisphere (Fibonacci spiral): each covers 2π/n sr.
DirectionSet fibonacci_hemisphere(int n) {
  std::vector<std::pair<float, float>> rad;
  for (int i = 0; i < n; ++i) {
    const float z = 1.0f - (static_cast<float>(i) + 0.5f) / static_cast<float>(n);
    rad.emplace_back(std::acos(z), std::fmod(static_cast<float>(i) * 2.39996323f, kTwoPi));
  }
  return DirectionSet::from_radians("fibonacci", rad);
}

SynthesisOptions options_with(DirectionSet views, DirectionSet lights) {
  SynthesisOptions o;
  o.views = std::move(views);
  o.lights = std::move(lights);
  return o;
}

// A flat floor (green) with a 2-texel-wide wall of height 4 (red) at columns 15 and 16.
Mesostructure ridge_field(int width = 32, int height = 4) {
  Mesostructure m = make_flat_mesostructure(width, height, glm::vec3(0.1f, 0.6f, 0.1f), 0.5f, 0.0f);
  for (int y = 0; y < height; ++y)
    for (int x = 15; x <= 16; ++x) {
      m.height_map.at(x, y) = 4.0f;
      m.albedo_map.at(x, y, 0) = 0.8f;
      m.albedo_map.at(x, y, 1) = 0.05f;
      m.albedo_map.at(x, y, 2) = 0.05f;
    }
  return m;
}

TEST(SynthFlat, LambertEqualsAlbedoCosOverPi) {
  const glm::vec3 albedo(0.5f, 0.3f, 0.2f);
  const Mesostructure flat = make_flat_mesostructure(4, 3, albedo, 0.5f, 0.0f);
  auto opts = options_with(DirectionSet::ubo2003(), DirectionSet::ubo2003());
  auto btf = synthesize_btf(flat, opts);
  ASSERT_TRUE(btf.ok()) << btf.message();
  ASSERT_EQ(btf->width(), 4);
  ASSERT_EQ(btf->height(), 3);
  for (size_t v = 0; v < btf->view_count(); ++v)
    for (size_t l = 0; l < btf->light_count(); ++l) {
      const float cos_l = std::cos(btf->lights()[l].theta);
      for (int c = 0; c < 3; ++c) {
        const float expected = albedo[c] * cos_l / kPi;
        ASSERT_NEAR(btf->value(v % 4, l % 3, v, l, c), expected, 1e-6f) << v << " " << l << " " << c;
      }
    }
  opts.convention = BtfValueConvention::brdf;
  auto plain = synthesize_btf(flat, opts);
  ASSERT_TRUE(plain.ok());
  EXPECT_NEAR(plain->value(1, 1, 40, 77, 0), albedo[0] / kPi, 1e-6f);
}

// The synthesiser stores ρ·cosθ_l by default; written as a Bonn file, the header's cosine flag
// must say so (btflib: flag 1 = "the cosine is already multiplied into the data"), so a reader
// that follows the flag's meaning (reconstruct_bonn_btf divides by cosθ_l, as btflib does) gets
// the synthesiser's ρ back, and one that keeps the stored values gets ρ·cosθ_l.
TEST(SynthBonn, CosineFlagMatchesTheStoredValuesThroughAFileRoundTrip) {
  auto meso = make_mesostructure(SynthMaterial::stone, 4, 4, 5);
  ASSERT_TRUE(meso.ok()) << meso.message();
  SynthesisOptions opts = options_with(DirectionSet::ubo2003(), DirectionSet::ubo2003());
  auto with_cos = synthesize_btf(*meso, opts);
  ASSERT_TRUE(with_cos.ok()) << with_cos.message();
  opts.convention = BtfValueConvention::brdf;
  auto rho = synthesize_btf(*meso, opts);
  ASSERT_TRUE(rho.ok()) << rho.message();

  DfmfFactorizeOptions fo;
  fo.components = 16;  // 4 × 4 texels: full rank, the factorisation is exact up to rounding
  auto file = factorize_bonn_dfmf(*with_cos, fo);
  ASSERT_TRUE(file.ok()) << file.message();
  auto bytes = encode_bonn_btf(*file);
  ASSERT_TRUE(bytes.ok()) << bytes.message();
  auto read = read_bonn_btf(*bytes);
  ASSERT_TRUE(read.ok()) << read.message();
  EXPECT_TRUE(read->cosine_in_data) << "the data is rho*cos(theta_l): the Bonn cosine flag must be 1";

  auto follows_flag = reconstruct_bonn_btf(*read);  // btflib's decoder: divide when the flag is 1
  ASSERT_TRUE(follows_flag.ok()) << follows_flag.message();
  BonnReconstructOptions keep;
  keep.remove_cosine = false;
  auto as_stored = reconstruct_bonn_btf(*read, keep);
  ASSERT_TRUE(as_stored.ok()) << as_stored.message();
  double max_rho = 0, err_rho = 0, err_stored = 0;
  for (size_t i = 0; i < rho->samples().size(); ++i) {
    max_rho = std::max(max_rho, double(rho->samples()[i]));
    err_rho = std::max(err_rho, std::abs(double(follows_flag->samples()[i]) - rho->samples()[i]));
    err_stored = std::max(err_stored, std::abs(double(as_stored->samples()[i]) - with_cos->samples()[i]));
  }
  ASSERT_GT(max_rho, 0.05);
  EXPECT_LT(err_rho, 1e-4 * max_rho);
  EXPECT_LT(err_stored, 1e-4 * max_rho);
}

TEST(SynthFlat, AnalyticBrdfIsReciprocal) {
  const Mesostructure flat = make_flat_mesostructure(2, 2, glm::vec3(0.6f, 0.5f, 0.4f), 0.3f, 0.04f);
  const DirectionSet dirs = DirectionSet::ubo2003();
  auto opts = options_with(dirs, dirs);
  opts.convention = BtfValueConvention::brdf;
  auto btf = synthesize_btf(flat, opts);
  ASSERT_TRUE(btf.ok()) << btf.message();
  float max_rel = 0.0f;
  bool saw_specular = false;
  for (size_t v = 0; v < dirs.size(); ++v)
    for (size_t l = 0; l < dirs.size(); ++l) {
      const float a = btf->value(0, 0, v, l, 1), b = btf->value(0, 0, l, v, 1);
      max_rel = std::max(max_rel, std::abs(a - b) / std::max(1e-6f, std::max(a, b)));
      if (a > 2.0f * 0.5f / kPi) saw_specular = true;  // well above the diffuse level
    }
  EXPECT_LT(max_rel, 1e-4f);
  EXPECT_TRUE(saw_specular) << "the GGX lobe never showed up";
}

TEST(SynthFlat, EnergyBoundHoldsForTheAnalyticModel) {
  const DirectionSet lights = fibonacci_hemisphere(6000);
  for (auto [rough, f0] : {std::pair{0.3f, 0.04f}, std::pair{0.5f, 0.08f}, std::pair{0.9f, 0.04f}}) {
    const Mesostructure flat = make_flat_mesostructure(1, 1, glm::vec3(0.95f), rough, f0);
    auto btf = synthesize_btf(flat, options_with(DirectionSet::ubo2003(), lights));
    ASSERT_TRUE(btf.ok()) << btf.message();
    for (size_t v = 0; v < btf->view_count(); ++v) {
      double albedo = 0.0;  // ∫ ρ cosθ_l dω_l by equal-area quadrature
      for (size_t l = 0; l < lights.size(); ++l) albedo += btf->value(0, 0, v, l, 0);
      albedo *= 2.0 * kPi / static_cast<double>(lights.size());
      EXPECT_LE(albedo, 1.0) << "rough " << rough << " view " << v;
      EXPECT_GT(albedo, 0.5) << "rough " << rough << " view " << v;
    }
  }
}

TEST(SynthShadow, GrazingLightDarkensTexelsBehindARidge) {
  const Mesostructure ridge = ridge_field();
  const Mesostructure flat = make_flat_mesostructure(32, 4, glm::vec3(0.1f, 0.6f, 0.1f), 0.5f, 0.0f);
  // Light 0 comes from +x (φ = 0) at 75°, light 1 from −x, light 2 from above.
  auto opts = options_with(custom({{0, 0}}), custom({{75, 0}, {75, 180}, {0, 0}}));
  auto r = synthesize_btf(ridge, opts);
  auto f = synthesize_btf(flat, opts);
  ASSERT_TRUE(r.ok() && f.ok());
  const float lit = 0.6f * std::cos(degrees_to_radians(75.0f)) / kPi;
  // Column 10 lies 5 texels on the −x side of the wall: the ray towards +x rises 0.27 texels
  // per texel and meets the 4-texel wall, so it is in shadow; the flat field has no shadows.
  EXPECT_EQ(r->value(10, 1, 0, 0, 1), 0.0f);
  EXPECT_NEAR(f->value(10, 1, 0, 0, 1), lit, 1e-6f);
  // The same texel is lit from the other side (its ray wraps around for 26 texels first).
  EXPECT_NEAR(r->value(10, 1, 0, 1, 1), lit, 1e-6f);
  // Column 25 is 22 texels away (through the wrap) and lit from +x; column 20 is shadowed
  // from −x (4 texels from the wall).
  EXPECT_NEAR(r->value(25, 1, 0, 0, 1), lit, 1e-6f);
  EXPECT_EQ(r->value(20, 1, 0, 1, 1), 0.0f);
  // Counting: many texels are shadowed at grazing light, none from above.
  int shadowed_grazing = 0, shadowed_top = 0;
  for (int x = 0; x < 32; ++x) {
    if (r->value(x, 2, 0, 0, 1) == 0.0f) ++shadowed_grazing;
    if (r->value(x, 2, 0, 2, 1) == 0.0f) ++shadowed_top;
  }
  EXPECT_GE(shadowed_grazing, 10);
  EXPECT_EQ(shadowed_top, 0);
}

TEST(SynthMasking, GrazingViewSeesTheWallInsteadOfTheFloorBehindIt) {
  const Mesostructure ridge = ridge_field();
  // View 0 from above, view 1 from +x at 60°; light from above.
  auto opts = options_with(custom({{0, 0}, {60, 0}}), custom({{0, 0}}));
  auto r = synthesize_btf(ridge, opts);
  ASSERT_TRUE(r.ok()) << r.message();
  // Columns 10..13 are floor (green, g ≈ 6 r) from above; from the +x side the camera rays
  // through them pass the wall below its top (at 1.7 texels for column 13): they show the red
  // wall (column 13 lands on the wall's bilinear slope, half red).
  for (int x = 10; x <= 13; ++x) {
    EXPECT_GT(r->value(x, 1, 0, 0, 1), 5.0f * r->value(x, 1, 0, 0, 0)) << x;
    EXPECT_GT(r->value(x, 1, 1, 0, 0), r->value(x, 1, 1, 0, 1)) << x;
  }
  EXPECT_GT(r->value(10, 1, 1, 0, 0), 3.0f * r->value(10, 1, 1, 0, 1));
  // Far from the wall, and on the camera's side of it, the floor is seen from both views.
  EXPECT_GT(r->value(5, 1, 1, 0, 1), 5.0f * r->value(5, 1, 1, 0, 0));
  EXPECT_GT(r->value(20, 1, 1, 0, 1), 5.0f * r->value(20, 1, 1, 0, 0));
}

TEST(SynthInterreflection, AddsLightOnlyWhereSurfacesSeeEachOther) {
  const Mesostructure ridge = ridge_field();
  auto opts = options_with(custom({{0, 0}}), custom({{30, 0}, {0, 0}}));
  auto direct = synthesize_btf(ridge, opts);
  opts.interreflection = true;
  opts.interreflection_rays = 32;
  auto bounced = synthesize_btf(ridge, opts);
  ASSERT_TRUE(direct.ok() && bounced.ok());
  float best_gain = 1.0f;
  for (int x = 0; x < 32; ++x)
    for (size_t l = 0; l < 2; ++l)
      for (int c = 0; c < 3; ++c) {
        const float d = direct->value(x, 0, 0, l, c), b = bounced->value(x, 0, 0, l, c);
        EXPECT_GE(b, d - 1e-7f) << x << " " << l << " " << c;
        if (d > 0.01f) best_gain = std::max(best_gain, b / d);
      }
  // The floor next to the wall receives light bounced off the wall (about +8% here), but
  // never absurdly much.
  EXPECT_GT(best_gain, 1.04f);
  EXPECT_LT(best_gain, 1.5f);
  // A flat field has nothing to bounce off: identical results.
  const Mesostructure flat = make_flat_mesostructure(8, 8, glm::vec3(0.7f), 0.5f, 0.04f);
  auto f0 = synthesize_btf(flat, options_with(DirectionSet::ubo2003(), DirectionSet::ubo2003()));
  auto o = options_with(DirectionSet::ubo2003(), DirectionSet::ubo2003());
  o.interreflection = true;
  auto f1 = synthesize_btf(flat, o);
  ASSERT_TRUE(f0.ok() && f1.ok());
  EXPECT_EQ(0, std::memcmp(f0->samples().data(), f1->samples().data(), f0->size_bytes()));
}

TEST(SynthEnergy, MesostructureWithInterreflectionStaysBounded) {
  auto meso = make_mesostructure(SynthMaterial::stone, 16, 16, 3);
  ASSERT_TRUE(meso.ok());
  // Raise the albedo to the worst case the maps allow.
  for (float& a : meso->albedo_map.elements()) a = 0.95f;
  const DirectionSet lights = fibonacci_hemisphere(600);
  auto opts = options_with(custom({{0, 0}, {45, 30}, {75, 200}}), lights);
  opts.interreflection = true;
  auto btf = synthesize_btf(*meso, opts);
  ASSERT_TRUE(btf.ok()) << btf.message();
  double worst = 0.0;
  for (size_t v = 0; v < btf->view_count(); ++v)
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) {
        double e = 0.0;
        for (size_t l = 0; l < lights.size(); ++l) e += btf->value(x, y, v, l, 0);
        worst = std::max(worst, e * 2.0 * kPi / static_cast<double>(lights.size()));
      }
  EXPECT_LE(worst, 1.05);  // quadrature noise only; an energy-creating bug gives ≫ 1
  EXPECT_GT(worst, 0.3);
}

TEST(SynthDeterminism, SameBytesForAnyThreadCountAndSeedMatters) {
  auto meso = make_mesostructure(SynthMaterial::cloth, 16, 16, 42);
  ASSERT_TRUE(meso.ok());
  auto opts = options_with(DirectionSet::ubo2003(), DirectionSet::ubo2003());
  opts.interreflection = true;
  ThreadPool one(1), three(3);
  opts.pool = &one;
  auto a = synthesize_btf(*meso, opts);
  opts.pool = &three;
  auto b = synthesize_btf(*meso, opts);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(0, std::memcmp(a->samples().data(), b->samples().data(), a->size_bytes()));
  auto again = make_mesostructure(SynthMaterial::cloth, 16, 16, 42);
  auto other = make_mesostructure(SynthMaterial::cloth, 16, 16, 43);
  ASSERT_TRUE(again.ok() && other.ok());
  EXPECT_EQ(meso->height_map.elements().size(), again->height_map.elements().size());
  EXPECT_EQ(0, std::memcmp(meso->height_map.data(), again->height_map.data(), meso->height_map.size() * 4));
  EXPECT_NE(0, std::memcmp(meso->albedo_map.data(), other->albedo_map.data(), meso->albedo_map.size() * 4));
}

TEST(SynthMaterials, AllFourAreTileableAndHaveRelief) {
  for (auto kind : {SynthMaterial::cloth, SynthMaterial::stone, SynthMaterial::leather, SynthMaterial::tiles}) {
    SCOPED_TRACE(material_name(kind));
    ASSERT_EQ(material_from_name(material_name(kind)), kind);
    auto m = make_mesostructure(kind, 64, 64, 7);
    ASSERT_TRUE(m.ok()) << m.message();
    ASSERT_TRUE(m->validate().ok()) << m->validate().message();
    const auto& h = m->height_map;
    float lo = 1e9f, hi = -1e9f, interior = 0.0f, seam = 0.0f;
    double mean = 0.0;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        lo = std::min(lo, h.at(x, y));
        hi = std::max(hi, h.at(x, y));
        mean += h.at(x, y);
        if (x + 1 < 64) interior = std::max(interior, std::abs(h.at(x + 1, y) - h.at(x, y)));
        if (y + 1 < 64) interior = std::max(interior, std::abs(h.at(x, y + 1) - h.at(x, y)));
      }
    for (int i = 0; i < 64; ++i) {
      seam = std::max(seam, std::abs(h.at(0, i) - h.at(63, i)));
      seam = std::max(seam, std::abs(h.at(i, 0) - h.at(i, 63)));
    }
    EXPECT_GT(hi - lo, 1.0f);               // real relief, in texels
    EXPECT_LE(seam, interior + 1e-4f);      // the wrap is no rougher than the inside
    EXPECT_NEAR(mean / 4096.0, 0.0, 1e-3);  // reference plane through the middle
  }
  EXPECT_FALSE(material_from_name("velvet").has_value());
  EXPECT_FALSE(make_mesostructure(SynthMaterial::cloth, 0, 4, 1).ok());
  EXPECT_FALSE(make_mesostructure(SynthMaterial::cloth, 4, 4, 1, NAN).ok());
}

TEST(SynthMeasured, FlatFieldReproducesTheMeasuredBrdfTimesCos) {
  auto constant = MeasuredBrdf::from_table(3, 4, 3, std::vector<float>(3 * 3 * 4 * 3, 0.2f));
  ASSERT_TRUE(constant.ok());
  const Mesostructure flat = make_flat_mesostructure(2, 2, glm::vec3(0.3f), 0.5f, 0.0f);
  auto opts = options_with(DirectionSet::ubo2003(), DirectionSet::ubo2003());
  opts.measured_brdf = &*constant;
  auto btf = synthesize_btf(flat, opts);
  ASSERT_TRUE(btf.ok()) << btf.message();
  for (size_t l = 0; l < 81; l += 4)
    EXPECT_NEAR(btf->value(1, 0, 30, l, 2), 0.2f * std::cos(btf->lights()[l].theta), 1e-5f);

  const std::string path = std::string(BTFLOD_SHARED_DIR) + "/data/measured/carpaint_blue.mbsdf";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is absent";
  auto paint = read_mbsdf(path);
  ASSERT_TRUE(paint.ok()) << paint.message();
  opts.measured_brdf = &*paint;
  auto real = synthesize_btf(flat, opts);
  ASSERT_TRUE(real.ok());
  const DirectionSet& d = opts.views;
  for (size_t v = 0; v < 81; v += 9)
    for (size_t l = 0; l < 81; l += 7) {
      const glm::vec3 ref = paint->evaluate(d[l].vector, d[v].vector) * d[l].vector.z;
      EXPECT_NEAR(real->value(0, 1, v, l, 2), ref.b, 1e-4f * std::max(1.0f, ref.b));
    }
}

TEST(SynthApi, ProgressIsMonotonicAndCancellationStops) {
  const Mesostructure flat = make_flat_mesostructure(4, 4, glm::vec3(0.5f));
  auto opts = options_with(DirectionSet::ubo2003(), DirectionSet::ubo2003());
  double last_render = -1.0;
  bool monotonic = true;
  int calls = 0;
  opts.progress = [&](std::string_view stage, double f) {
    ++calls;
    if (stage == "render") {
      monotonic = monotonic && f >= last_render;
      last_render = f;
    }
    return true;
  };
  ASSERT_TRUE(synthesize_btf(flat, opts).ok());
  EXPECT_TRUE(monotonic);
  EXPECT_DOUBLE_EQ(last_render, 1.0);
  EXPECT_GE(calls, 81);
  opts.progress = [](std::string_view stage, double f) { return !(stage == "render" && f > 0.2); };
  auto cancelled = synthesize_btf(flat, opts);
  ASSERT_FALSE(cancelled.ok());
  EXPECT_EQ(cancelled.status(), Status::cancelled);
  // The view sink sees views in order and can stop the run too.
  opts.progress = nullptr;
  std::vector<size_t> seen;
  auto stopped = synthesize_btf_views(flat, opts, [&](size_t v, std::span<const float> block) {
    seen.push_back(v);
    EXPECT_EQ(block.size(), 81u * 16u * 3u);
    return v < 4;
  });
  EXPECT_EQ(stopped.status(), Status::cancelled);
  EXPECT_EQ(seen, (std::vector<size_t>{0, 1, 2, 3, 4}));
}

TEST(SynthApi, BadArgumentsAreReported) {
  Mesostructure flat = make_flat_mesostructure(4, 4, glm::vec3(0.5f));
  auto opts = options_with(DirectionSet(), DirectionSet::ubo2003());
  auto r = synthesize_btf(flat, opts);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status(), Status::invalid_argument);
  opts.views = DirectionSet::ubo2003();
  opts.march_step = 0.0f;
  EXPECT_EQ(synthesize_btf(flat, opts).status(), Status::invalid_argument);
  opts.march_step = 0.25f;
  flat.albedo_map.at(1, 2, 1) = 1.5f;
  auto bad = synthesize_btf(flat, opts);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("albedo map texel (1, 2)"), std::string::npos) << bad.message();
  Mesostructure small = make_flat_mesostructure(4, 4, glm::vec3(0.5f));
  small.roughness_map = Image<float>(3, 4, 1, 0.5f);
  EXPECT_EQ(synthesize_btf(small, opts).status(), Status::invalid_argument);
  MeasuredBrdf empty;
  Mesostructure ok = make_flat_mesostructure(4, 4, glm::vec3(0.5f));
  opts.measured_brdf = &empty;
  EXPECT_EQ(synthesize_btf(ok, opts).status(), Status::invalid_argument);
}

TEST(SynthApi, HalfStorageMatchesFloatWithinRounding) {
  auto meso = make_mesostructure(SynthMaterial::tiles, 8, 8, 5);
  ASSERT_TRUE(meso.ok());
  auto opts = options_with(DirectionSet::ubo2003(), DirectionSet::ubo2003());
  auto f = synthesize_btf<float>(*meso, opts);
  auto h = synthesize_btf<Half>(*meso, opts);
  ASSERT_TRUE(f.ok() && h.ok());
  for (size_t i = 0; i < f->samples().size(); i += 97) {
    const float a = f->samples()[i], b = h->samples()[i].to_float();
    ASSERT_NEAR(a, b, 1e-3f * std::max(1.0f, a)) << i;
  }
}

}  // namespace
