// The SPMM GPU layout (offline/packing/spmm_packing.hpp, SpmmMaterialData, paper 003 eq. 1–3): a CPU
// evaluation that reads ONLY the packed arrays, exactly as the spmm program does (slot loop to
// the first empty slot, global dictionary index, cluster id and coefficients from the residual
// layers, residual table layer c·(P+1) + i), must equal Spmm::evaluate for every texel, several
// directions and every residual switch; validate_material rejects each class of bad data the
// shader must never see; spmm_fragment_fetches and spmm_residual_mode follow the documented
// formulas.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/spmm.hpp"
#include "btflod/offline/packing/spmm_packing.hpp"

namespace btflod {
namespace {

float from_bits(uint32_t u) {
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

// The spmm program's arithmetic on the packed data (glsl_generator.hpp piece_spmm).
glm::vec3 packed_eval(const SpmmMaterialData& m, int x, int y, glm::vec3 wl, glm::vec3 wv, const AngularSample& ls,
                      const AngularSample& vs, uint32_t mode) {
  const size_t n = static_cast<size_t>(m.width) * m.height, t = static_cast<size_t>(y) * m.width + x;
  glm::vec3 acc(0.0f);
  for (size_t k = 0; k < m.slots; ++k) {
    const uint32_t* s = &m.texels[(k * n + t) * 4];
    if (s[0] == 0xffffffffu) break;
    const size_t row = s[0] / kSpmmBasesPerRow, col = 2 * (s[0] % kSpmmBasesPerRow);
    const float* p = &m.dictionary[(row * 2 * kSpmmBasesPerRow + col) * 4];
    AnalyticBasis b;
    b.model = static_cast<AnalyticModel>(static_cast<uint32_t>(p[0]));
    b.kappa = {p[1], p[2], p[3]};
    b.normal = glm::vec3(p[4], p[5], p[6]);
    acc += evaluate_analytic_basis(b, wl, wv) * glm::vec3(from_bits(s[1]), from_bits(s[2]), from_bits(s[3]));
  }
  if (mode == 1u) return acc;
  const uint32_t P = m.residual_components, use = mode == 0u ? P : std::min(mode - 2u, P);
  auto elem = [&](size_t e) { return m.texels[((m.slots + e / 4) * n + t) * 4 + e % 4]; };
  const size_t base = static_cast<size_t>(elem(0)) * (P + 1);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      const float w = ls.weight[static_cast<size_t>(i)] * vs.weight[static_cast<size_t>(j)];
      if (w <= 0.0f) continue;
      auto at = [&](size_t layer, int c) {
        return m.residual[((layer * m.view_count + vs.index[static_cast<size_t>(j)]) * m.light_count +
                           ls.index[static_cast<size_t>(i)]) *
                              4 +
                          static_cast<size_t>(c)];
      };
      for (int c = 0; c < 3; ++c) {
        float e = at(base, c);
        for (uint32_t q = 1; q <= use; ++q) e += from_bits(elem(q)) * at(base + q, c);
        acc[c] += w * e;
      }
    }
  return acc;
}

Spmm small_spmm() {
  const BtfFloat btf = make_low_rank_btf(8, 6, small_direction_set(3, 4, "views"), small_direction_set(3, 5, "lights"),
                                         3, 0.7f, 0.01f, 5, 0.5f);
  SpmmOptions o;
  o.clusters = 3;
  o.representatives = 2;
  o.max_basis_per_texel = 3;
  o.residual_components = 5;  // two residual layers: [cluster, c0, c1, c2] [c3, c4, 0, 0]
  o.lm_evaluations = 40;
  return factorize_spmm(btf, o).value();
}

AngularSample taps(uint32_t a, uint32_t b, uint32_t c, float wa, float wb) {
  AngularSample s;
  s.index = {a, b, c};
  s.weight = {wa, wb, 1.0f - wa - wb};
  return s;
}

TEST(BackendSpmm, PackedLayoutEvaluatesLikeSpmmEvaluate) {
  Spmm p = small_spmm();
  // An empty slot before an occupied one in the source: packing must move occupied slots first.
  ASSERT_TRUE(p.set_weight(0, 0, 0, glm::vec3(0.0f)).ok());
  auto packed = pack_spmm_material(p);
  ASSERT_TRUE(packed.ok()) << packed.message();
  const uint32_t index[3] = {0, 0, 0};
  const float weight[3] = {1.0f, 0.0f, 0.0f};
  ShaderConfig config;
  config.angular.resolution = 1;
  const SpmmMaterialData m = packed->data(AngularTablesData{1, index, weight, index, weight});
  ASSERT_TRUE(validate_material(m, config).ok()) << validate_material(m, config).message();
  EXPECT_EQ(m.texels.size(), (3 + 2) * 48 * 4u);
  EXPECT_EQ(m.residual.size(), 3 * 6 * 11 * 9 * 4u);
  const glm::vec3 dirs[][2] = {
      {glm::normalize(glm::vec3(0.3f, -0.2f, 0.9f)), glm::normalize(glm::vec3(-0.4f, 0.1f, 0.8f))},
      {glm::vec3(0, 0, 1), glm::normalize(glm::vec3(0.7f, 0.2f, 0.4f))}};
  const AngularSample ls = taps(1, 4, 7, 0.5f, 0.3f), vs = taps(2, 0, 8, 0.6f, 0.1f);
  double worst = 0.0, scale = 0.0;
  for (const auto& d : dirs)
    for (const SpmmEvalOptions& o : {SpmmEvalOptions{true, -1}, SpmmEvalOptions{true, 2}, SpmmEvalOptions{true, 0},
                                     SpmmEvalOptions{false, -1}, SpmmEvalOptions{true, 9}})
      for (int y = 0; y < 6; ++y)
        for (int x = 0; x < 8; ++x) {
          const glm::vec3 want = p.evaluate(x, y, d[0], d[1], ls, vs, o);
          const glm::vec3 got =
              packed_eval(m, x, y, d[0], d[1], ls, vs, spmm_residual_mode(o.residual, o.pca_components));
          for (int c = 0; c < 3; ++c) {
            worst = std::max(worst, static_cast<double>(std::abs(want[c] - got[c])));
            scale = std::max(scale, static_cast<double>(std::abs(want[c])));
          }
        }
  EXPECT_GT(scale, 0.05);
  EXPECT_LE(worst, 1e-5 * scale);
  // The residual switch matters on this material (the comparison above is not vacuous).
  const glm::vec3 full = p.evaluate(3, 2, dirs[0][0], dirs[0][1], ls, vs, {true, -1});
  const glm::vec3 none = p.evaluate(3, 2, dirs[0][0], dirs[0][1], ls, vs, {false, -1});
  EXPECT_GT(glm::length(full - none), 1e-4f);
}

TEST(BackendSpmm, ValidateMaterialRejectsWhatTheShaderMustNotRead) {
  const Spmm p = small_spmm();
  auto packed = pack_spmm_material(p);
  ASSERT_TRUE(packed.ok());
  const uint32_t index[3] = {0, 0, 0};
  const float weight[3] = {1.0f, 0.0f, 0.0f};
  ShaderConfig config;
  config.angular.resolution = 1;
  const AngularTablesData tables{1, index, weight, index, weight};
  auto rejects = [&](PackedSpmm q, const char* word) {
    const VoidResult v = validate_material(q.data(tables), config);
    ASSERT_FALSE(v.ok()) << word;
    EXPECT_EQ(v.status(), Status::invalid_argument);
    EXPECT_NE(v.message().find(word), std::string::npos) << v.message();
  };
  const size_t n = 48;
  {
    PackedSpmm q = *packed;
    q.texels[0] = q.info.bases;  // slot 0 of texel 0 names a basis past the dictionary
    rejects(q, "basis");
  }
  {
    PackedSpmm q = *packed;
    q.texels[0] = 0xffffffffu;  // an empty slot before an occupied one: the shader stops early
    if (q.texels[(1 * n + 0) * 4] != 0xffffffffu) rejects(q, "after an empty slot");
  }
  {
    PackedSpmm q = *packed;
    q.texels[(3 * n + 5) * 4] = 3;  // cluster id of texel 5 = K
    rejects(q, "cluster 3 of 3");
  }
  {
    PackedSpmm q = *packed;
    const float nan = std::nanf("");
    std::memcpy(&q.texels[2], &nan, sizeof nan);  // α_g of slot 0, texel 0
    rejects(q, "non-finite weight");
  }
  {
    PackedSpmm q = *packed;
    q.dictionary[0] = 7.0f;  // model id past Ashikhmin-Shirley
    rejects(q, "model 7");
  }
  {
    PackedSpmm q = *packed;
    q.dictionary[6] = 0.0f;  // n.z = 0: the basis frame degenerates
    rejects(q, "n.z");
  }
  {
    PackedSpmm q = *packed;
    q.residual[4] = INFINITY;
    rejects(q, "residual value");
  }
  {
    PackedSpmm q = *packed;
    q.residual.pop_back();
    rejects(q, "expected");
  }
  {
    PackedSpmm q = *packed;
    q.info.slots = 65;
    rejects(q, "S = 65");
  }
  // The Spmm side: inconsistent arrays are refused before packing.
  Spmm bad = p;
  bad.residual_coef.pop_back();
  EXPECT_EQ(pack_spmm_material(bad).status(), Status::invalid_argument);
}

TEST(BackendSpmm, FetchCountsAndResidualModeFollowTheDocumentedFormulas) {
  EXPECT_EQ(spmm_residual_mode(true, -1), 0u);
  EXPECT_EQ(spmm_residual_mode(false, 3), 1u);
  EXPECT_EQ(spmm_residual_mode(true, 0), 2u);
  EXPECT_EQ(spmm_residual_mode(true, 4), 6u);
  EXPECT_EQ(spmm_residual_layers(0), 1u);
  EXPECT_EQ(spmm_residual_layers(3), 1u);
  EXPECT_EQ(spmm_residual_layers(4), 2u);
  const Spmm p = small_spmm();
  auto packed = pack_spmm_material(p);
  ASSERT_TRUE(packed.ok());
  const SpmmMaterialData m = packed->data({});
  for (uint32_t t = 0; t < 48; ++t) {
    uint32_t used = 0;
    for (size_t k = 0; k < 3; ++k) used += p.slot_basis[t * 3 + k] != kSpmmEmptySlot;
    const uint32_t x = t % 8, y = t / 8;
    const SpmmFetchCount none = spmm_fragment_fetches(m, x, y, 9, 1u);
    EXPECT_EQ(none.texel, std::min(used + 1, 3u));
    EXPECT_EQ(none.dictionary, 2 * used);
    EXPECT_EQ(none.residual + none.angular, 0u);
    const SpmmFetchCount full = spmm_fragment_fetches(m, x, y, 9, 0u);  // P = 5: 2 residual layers
    EXPECT_EQ(full.texel, none.texel + 2);
    EXPECT_EQ(full.angular, 4u);
    EXPECT_EQ(full.residual, 9u * 6u);
    const SpmmFetchCount two = spmm_fragment_fetches(m, x, y, 4, spmm_residual_mode(true, 2));
    EXPECT_EQ(two.texel, none.texel + 1);
    EXPECT_EQ(two.residual, 4u * 3u);
    EXPECT_EQ(spmm_fragment_fetches(m, x, y, 9, spmm_residual_mode(true, 99)).residual, full.residual);
  }
}

}  // namespace
}  // namespace btflod
