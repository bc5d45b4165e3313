// offline/packing/representation_packing.hpp and the *MaterialData checks of runtime/backend/backend.hpp, without
// a GPU: the packed textures, read back with the addressing of the generated laplacian, lpca and
// pca_views programs (emulated here texel for texel), reproduce the CPU twins built on the
// representations' evaluators; hostile material descriptions are rejected with a message.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/packing/representation_packing.hpp"

namespace btflod {
namespace {

constexpr uint32_t kRes = 16;  // angular table resolution

BtfFloat small_btf() {
  return make_low_rank_btf(8, 8, small_direction_set(3, 4, "views"), small_direction_set(3, 5, "lights"), 3, 0.7f,
                           0.01f, 5, 0.5f);
}

/// Nearest-direction tables (each texel: the closest direction, weight 1, then the next two with
/// weight 0) — simple, deterministic and valid for every program.
struct Tables {
  std::vector<uint32_t> li, vi;
  std::vector<float> lw, vw;
  AngularTablesData data;
};
void fill(const DirectionSet& dirs, DirectionParameterisation p, std::vector<uint32_t>& idx, std::vector<float>& w) {
  idx.assign(kRes * kRes * 3, 0);
  w.assign(kRes * kRes * 3, 0.0f);
  for (uint32_t y = 0; y < kRes; ++y)
    for (uint32_t x = 0; x < kRes; ++x) {
      const glm::vec2 c((static_cast<float>(x) + 0.5f) / kRes, (static_cast<float>(y) + 0.5f) / kRes);
      std::vector<std::pair<float, uint32_t>> d;
      for (uint32_t i = 0; i < dirs.size(); ++i)
        d.emplace_back(glm::length(glm::vec2(shader_direction_to_unit_square(p, dirs[i].vector)) - c), i);
      std::sort(d.begin(), d.end());
      const float a = 1.0f / (d[0].first + 0.05f), b = 1.0f / (d[1].first + 0.05f), e = 1.0f / (d[2].first + 0.05f);
      const size_t o = (static_cast<size_t>(y) * kRes + x) * 3;
      for (size_t k = 0; k < 3; ++k) idx[o + k] = d[k].second;
      w[o] = a / (a + b + e);
      w[o + 1] = b / (a + b + e);
      w[o + 2] = e / (a + b + e);
    }
}
Tables make_tables(const BtfFloat& btf, DirectionParameterisation p) {
  Tables t;
  fill(btf.lights(), p, t.li, t.lw);
  fill(btf.views(), p, t.vi, t.vw);
  t.data = AngularTablesData{kRes, t.li, t.lw, t.vi, t.vw};
  return t;
}

ShaderConfig config() {
  ShaderConfig c;
  c.angular.resolution = kRes;
  return c;
}

glm::vec3 random_dir(uint32_t& s) {
  s = s * 1664525u + 1013904223u;
  const float a = static_cast<float>(s >> 8) / 16777216.0f;
  s = s * 1664525u + 1013904223u;
  const float b = static_cast<float>(s >> 8) / 16777216.0f;
  const float theta = 1.45f * a, phi = 6.2831853f * b;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}
glm::vec2 random_uv(uint32_t& s) {
  s = s * 1664525u + 1013904223u;
  const float a = static_cast<float>(s >> 8) / 16777216.0f;
  s = s * 1664525u + 1013904223u;
  return {a, static_cast<float>(s >> 8) / 16777216.0f};
}

void expect_near3(glm::vec3 a, glm::vec3 b, const char* what) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-4f * (1.0f + std::abs(b[c]))) << what << " channel " << c;
}

TEST(BackendRepresentations, LaplacianPackedTexturesReproduceEq7) {
  const BtfFloat btf = small_btf();
  LaplacianPcaOptions opt;
  opt.mip_count = 2;
  opt.components = {3, 2, 1};
  auto lap = factorize_laplacian_pca(btf, opt);
  ASSERT_TRUE(lap.ok()) << lap.message();
  auto packed = pack_laplacian_material(*lap);
  ASSERT_TRUE(packed.ok()) << packed.message();
  const Tables t = make_tables(btf, DirectionParameterisation::parabolic);
  const LaplacianMaterialData m = packed->data(t.data);
  ASSERT_TRUE(validate_material(m, config()).ok());
  ASSERT_EQ(m.components, 6u);
  const size_t C = m.components, L = m.light_count, V = m.view_count;
  uint32_t s = 3;
  for (int i = 0; i < 200; ++i) {
    const glm::vec2 uv = random_uv(s);
    const glm::vec3 wl = random_dir(s), wv = random_dir(s);
    const float d = std::exp2(2.4f * static_cast<float>(i) / 200.0f);  // λ from 0 to 2.4 (clamped at 2)
    const glm::vec3 want = reference_laplacian(*lap, t.data, DirectionParameterisation::parabolic, uv, wl, wv, d);
    // The generated program: nearest directions, eq. 7 weights, D_k at texel >> k, YCbCr → RGB.
    const uint32_t l = angular_table_sample(t.data, 0, DirectionParameterisation::parabolic, true, wl).index[0];
    const uint32_t v = angular_table_sample(t.data, 1, DirectionParameterisation::parabolic, true, wv).index[0];
    const float lambda = std::clamp(std::log2(d), 0.0f, static_cast<float>(m.max_level));
    glm::vec3 acc(m.mean[(v * L + l) * 4], m.mean[(v * L + l) * 4 + 1], m.mean[(v * L + l) * 4 + 2]);
    const glm::ivec2 t0 = representation_texel(uv, static_cast<int>(m.width), static_cast<int>(m.height));
    size_t woff = 0;
    for (uint32_t k = 0; k <= m.max_level; ++k) {
      const uint32_t wk = std::max(1u, m.width >> k), hk = std::max(1u, m.height >> k);
      const float w = std::clamp(1.0f - lambda + static_cast<float>(k), 0.0f, 1.0f);
      for (size_t j = 0; j < C && w > 0.0f; ++j) {
        const size_t x = static_cast<size_t>(t0.x) >> k, y = static_cast<size_t>(t0.y) >> k;
        const float dkj = m.weights[woff + (((j / 4) * hk + y) * wk + x) * 4 + j % 4];
        const float* e = &m.eigen[(((k * C + j) * V + v) * L + l) * 4];
        acc += w * dkj * glm::vec3(e[0], e[1], e[2]);
      }
      woff += ((C + 3) / 4) * wk * hk * 4;
    }
    const glm::vec3 rgb(acc.x + 1.402f * acc.z, acc.x - 0.344136f * acc.y - 0.714136f * acc.z, acc.x + 1.772f * acc.y);
    expect_near3(rgb, want, "laplacian");
  }
}

TEST(BackendRepresentations, LpcaVolumeReproducesQuadrilinearEvaluate) {
  const BtfFloat btf = small_btf();
  LocalPcaOptions opt;
  opt.clusters = 2;
  opt.components = 2;
  opt.max_iterations = 2;
  auto lpca = factorize_local_pca(btf, opt);
  ASSERT_TRUE(lpca.ok()) << lpca.message();
  constexpr auto kParam = DirectionParameterisation::elevated_concentric;
  const Tables t = make_tables(btf, kParam);
  constexpr uint32_t R = 4;
  auto packed = pack_lpca_material(*lpca, R, kParam, t.data);
  ASSERT_TRUE(packed.ok()) << packed.message();
  const LpcaMaterialData m = packed->data();
  ASSERT_TRUE(validate_material(m, config()).ok());
  const size_t C = m.components, W = (C + 1) * R, H = m.clusters * R, n = m.width * m.height;
  // paper 002 §6.3: every (cluster, slot) block is quantised on its own, so each non-zero block
  // uses the full snorm8 range, and α'_0 of a texel is its cluster's mean scale.
  for (size_t k = 0; k < m.clusters; ++k)
    for (size_t j = 0; j <= C; ++j) {
      int peak = 0;
      for (size_t z = 0; z < static_cast<size_t>(R) * R; ++z)
        for (size_t y = k * R; y < (k + 1) * R; ++y)
          for (size_t x = j * R; x < (j + 1) * R; ++x)
            for (size_t c = 0; c < 3; ++c)
              peak = std::max(peak, std::abs(int{m.volume[((z * H + y) * W + x) * 4 + c]}));
      EXPECT_EQ(peak, packed->scales[k * (C + 1) + j] > 0.0f ? 127 : 0) << "cluster " << k << " slot " << j;
    }
  for (size_t tx = 0; tx < n; ++tx) EXPECT_EQ(m.weights[tx * 4], packed->scales[m.cluster[tx] * (C + 1)]);
  // Trilinear read of the snorm8 volume (q/127) at continuous texel coordinates (centres at
  // i + 0.5, clamped), as the hardware filter does.
  auto volume = [&](float x, float y, float z) {
    const float c[3] = {x - 0.5f, y - 0.5f, z - 0.5f};
    const size_t nn[3] = {W, H, static_cast<size_t>(R) * R};
    size_t i0[3], i1[3];
    float f[3];
    for (int a = 0; a < 3; ++a) {
      const float fl = std::floor(c[a]);
      f[a] = c[a] - fl;
      i0[a] = static_cast<size_t>(std::clamp(fl, 0.0f, static_cast<float>(nn[a] - 1)));
      i1[a] = static_cast<size_t>(std::clamp(fl + 1.0f, 0.0f, static_cast<float>(nn[a] - 1)));
    }
    glm::vec3 acc(0.0f);
    for (int k = 0; k < 8; ++k) {
      const size_t xi = k & 1 ? i1[0] : i0[0], yi = k & 2 ? i1[1] : i0[1], zi = k & 4 ? i1[2] : i0[2];
      const float w = (k & 1 ? f[0] : 1 - f[0]) * (k & 2 ? f[1] : 1 - f[1]) * (k & 4 ? f[2] : 1 - f[2]);
      const int8_t* p = &m.volume[((zi * H + yi) * W + xi) * 4];
      acc += w * glm::vec3(p[0], p[1], p[2]) / 127.0f;
    }
    return acc;
  };
  uint32_t s = 9;
  double max_err = 0.0;
  for (int i = 0; i < 200; ++i) {
    const glm::vec2 uv = random_uv(s);
    const glm::vec3 wl = random_dir(s), wv = random_dir(s);
    const glm::vec3 want = reference_lpca_packed(m, uv, wl, wv);
    // The generated program (paper 002 §6.2): cell(s) = 0.5 + s(R−1) texels inside a cell.
    const glm::vec2 sv = shader_direction_to_unit_square(kParam, wv), sl = shader_direction_to_unit_square(kParam, wl);
    const glm::ivec2 tx = representation_texel(uv, static_cast<int>(m.width), static_cast<int>(m.height));
    const size_t texel = static_cast<size_t>(tx.y) * m.width + static_cast<size_t>(tx.x);
    const float k = static_cast<float>(m.cluster[texel]);
    const float tl = std::clamp(sl.y, 0.0f, 1.0f) * (R - 1);
    const float i0 = std::min(std::floor(tl), static_cast<float>(R - 1)),
                i1 = std::min(i0 + 1.0f, static_cast<float>(R - 1));
    auto cell = [&](float v) { return 0.5f + std::clamp(v, 0.0f, 1.0f) * (R - 1); };
    glm::vec3 acc(0.0f);
    float alpha_sum = 0.0f;
    for (size_t j = 0; j <= C; ++j) {
      const float alpha = m.weights[((j / 4) * n + texel) * 4 + j % 4];  // α'_j, scale folded in
      alpha_sum += std::abs(alpha);
      const float x = static_cast<float>(j * R) + cell(sv.x), y = k * R + cell(sv.y);
      const glm::vec3 e0 = volume(x, y, i0 * R + cell(sl.x)), e1 = volume(x, y, i1 * R + cell(sl.x));
      acc += alpha * (e0 + (e1 - e0) * (tl - i0));
    }
    expect_near3(acc, want, "lpca");
    // Against the float oracle on LocalPca::evaluate: off by the rounding of each texel only,
    // |Δ| ≤ Σ_j |α'_j|·0.5/127 (a wrong scale or unfolded weight is off by far more).
    const glm::vec3 oracle = reference_lpca(*lpca, R, kParam, t.data, false, uv, wl, wv);
    for (int c = 0; c < 3; ++c) {
      EXPECT_LE(std::abs(want[c] - oracle[c]), alpha_sum * 0.5f / 127.0f + 1e-5f) << "channel " << c;
      max_err = std::max(max_err, static_cast<double>(std::abs(want[c] - oracle[c])));
    }
  }
  EXPECT_GT(max_err, 0.0) << "the volume must be quantised";
}

TEST(BackendRepresentations, PcaViewsPackedTexturesReproduceEvaluate) {
  const BtfFloat btf = small_btf();
  for (int k : {1, 4, 9}) {  // PCA-RF, a partial last group (9 = 4 + 4 + 1), PCA-BTF
    PcaViewsOptions opt;
    opt.views_per_group = k;
    opt.components = 3;
    auto pca = factorize_pca_views(btf, opt);
    ASSERT_TRUE(pca.ok()) << pca.message();
    auto packed = pack_pca_views_material(*pca);
    ASSERT_TRUE(packed.ok()) << packed.message();
    const Tables t = make_tables(btf, DirectionParameterisation::parabolic);
    const PcaViewsMaterialData m = packed->data(t.data);
    ASSERT_TRUE(validate_material(m, config()).ok()) << "k = " << k;
    const size_t C = m.components, layers = (C + 4) / 4, n = static_cast<size_t>(m.width) * m.height;
    uint32_t s = 17;
    for (int i = 0; i < 100; ++i) {
      const glm::vec2 uv = random_uv(s);
      const glm::vec3 wl = random_dir(s), wv = random_dir(s);
      const glm::vec3 want = reference_pca_views(*pca, t.data, DirectionParameterisation::parabolic, false, uv, wl, wv);
      const AngularSample ls = angular_table_sample(t.data, 0, DirectionParameterisation::parabolic, false, wl);
      const AngularSample vs = angular_table_sample(t.data, 1, DirectionParameterisation::parabolic, false, wv);
      const glm::ivec2 tx = representation_texel(uv, static_cast<int>(m.width), static_cast<int>(m.height));
      const size_t texel = static_cast<size_t>(tx.y) * m.width + static_cast<size_t>(tx.x);
      glm::vec3 acc(0.0f);
      for (size_t j = 0; j < 3; ++j)
        for (size_t q = 0; q < 3; ++q) {
          const float w = ls.weight[q] * vs.weight[j];
          if (w <= 0.0f) continue;
          const size_t view = vs.index[j], base = (view / m.views_per_group) * layers,
                       row = ls.index[q] + m.light_count * view;
          auto lc = [&](size_t c) { return m.l[((base + c / 4) * n + texel) * 4 + c % 4]; };
          glm::vec3 val(lc(0));
          for (size_t c = 1; c <= C; ++c) {
            const float* r = &m.r[(row * C + c - 1) * 4];
            val += lc(c) * glm::vec3(r[0], r[1], r[2]);  // paper 004 §4.3.2
          }
          acc += w * val;
        }
      expect_near3(acc, want, "pca_views");
    }
  }
}

TEST(BackendRepresentations, HostileMaterialDescriptionsAreRejected) {
  const BtfFloat btf = small_btf();
  const Tables t = make_tables(btf, DirectionParameterisation::parabolic);
  LaplacianPcaOptions lo;
  lo.mip_count = 2;
  lo.components = {2, 1, 1};
  auto lap = factorize_laplacian_pca(btf, lo);
  ASSERT_TRUE(lap.ok());
  auto pl = pack_laplacian_material(*lap);
  ASSERT_TRUE(pl.ok());
  LaplacianMaterialData m = pl->data(t.data);
  ASSERT_TRUE(validate_material(m, config()).ok());
  {  // truncated weight maps
    LaplacianMaterialData b = m;
    b.weights = b.weights.first(b.weights.size() - 4);
    EXPECT_FALSE(validate_material(b, config()).ok());
  }
  {  // non-power-of-two size
    LaplacianMaterialData b = m;
    b.width = 6;
    EXPECT_FALSE(validate_material(b, config()).ok());
  }
  {  // more levels than the size allows
    LaplacianMaterialData b = m;
    b.max_level = 4;
    EXPECT_FALSE(validate_material(b, config()).ok());
  }
  {  // angular index naming a direction that does not exist
    std::vector<uint32_t> li = t.li;
    li[5] = 1000;
    LaplacianMaterialData b = m;
    b.angular.light_index = li;
    auto r = validate_material(b, config());
    EXPECT_FALSE(r.ok());
    EXPECT_NE(r.message().find("angular index"), std::string::npos) << r.message();
  }
  {  // tables of another resolution than the shaders
    ShaderConfig c = config();
    c.angular.resolution = 32;
    EXPECT_FALSE(validate_material(m, c).ok());
  }
  LocalPcaOptions opt;
  opt.clusters = 2;
  opt.components = 2;
  opt.max_iterations = 1;
  auto lpca = factorize_local_pca(btf, opt);
  ASSERT_TRUE(lpca.ok());
  auto pk = pack_lpca_material(*lpca, 3, DirectionParameterisation::parabolic, t.data);
  ASSERT_TRUE(pk.ok());
  {  // a cluster id ≥ K
    std::vector<uint32_t> cl = pk->cluster;
    cl[7] = 2;
    LpcaMaterialData b = pk->data();
    b.cluster = cl;
    auto r = validate_material(b, config());
    EXPECT_FALSE(r.ok());
    EXPECT_NE(r.message().find("cluster"), std::string::npos) << r.message();
  }
  {  // volume of the wrong size, C = 0, grid resolution 1
    LpcaMaterialData b = pk->data();
    b.volume = b.volume.first(b.volume.size() / 2);
    EXPECT_FALSE(validate_material(b, config()).ok());
    b = pk->data();
    b.components = 0;
    EXPECT_FALSE(validate_material(b, config()).ok());
    b = pk->data();
    b.grid_resolution = 1;
    EXPECT_FALSE(validate_material(b, config()).ok());
  }
  EXPECT_FALSE(pack_lpca_material(*lpca, 1, DirectionParameterisation::parabolic, t.data).ok());
  PcaViewsOptions po;
  po.views_per_group = 3;
  po.components = 2;
  auto pca = factorize_pca_views(btf, po);
  ASSERT_TRUE(pca.ok());
  auto pp = pack_pca_views_material(*pca);
  ASSERT_TRUE(pp.ok());
  {  // k larger than the view count; L for fewer groups
    PcaViewsMaterialData b = pp->data(t.data);
    b.views_per_group = 10;
    EXPECT_FALSE(validate_material(b, config()).ok());
    b = pp->data(t.data);
    b.views_per_group = 1;  // 9 groups: L is too small
    EXPECT_FALSE(validate_material(b, config()).ok());
  }
}

}  // namespace
}  // namespace btflod
