// Tests of the Sparse Parametric Mixture Model (offline/factor/spmm.hpp, paper 003 §3): the fit on a
// BTF built from known analytic lobes, the residual (eq. 3) with N_PCA from 0 to max and "no
// residual", non-negative stagewise LASSO and its sparsity cap, determinism across thread
// counts, edits with a predictable physical effect, storage round trip and hostile files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/spmm.hpp"

namespace btflod {
namespace {

constexpr float kPi = 3.14159265f;

// Two materials in vertical halves: left = Lambert + Blinn–Phong (e = 30) with per-texel
// weights, right = Oren–Nayar (σ = 0.4) + Ward (0.25, 0.25); plus a small per-texel
// "shadowing" factor that no analytic lobe has (what the residual must catch).
BtfFloat two_material_btf(int w = 8, int h = 6) {
  BtfFloat btf(w, h, small_direction_set(3, 6, "v"), small_direction_set(4, 8, "l"));
  AnalyticBasis lam, bp, on, ward;
  bp.model = AnalyticModel::blinn_phong;
  bp.kappa = {30.0f, 0, 0};
  on.model = AnalyticModel::oren_nayar;
  on.kappa = {0.4f, 0, 0};
  ward.model = AnalyticModel::ward;
  ward.kappa = {0.25f, 0.25f, 0};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float u = static_cast<float>(x + 2 * y) / static_cast<float>(w + 2 * h);
      for (size_t v = 0; v < btf.view_count(); ++v)
        for (size_t l = 0; l < btf.light_count(); ++l) {
          const glm::vec3 wi = btf.lights()[l].vector, wo = btf.views()[v].vector;
          glm::vec3 c;
          if (x < w / 2)
            c = (0.5f + 0.3f * u) * glm::vec3(0.8f, 0.3f, 0.2f) * evaluate_analytic_basis(lam, wi, wo) +
                (0.2f + 0.1f * u) * glm::vec3(1.0f) * evaluate_analytic_basis(bp, wi, wo);
          else
            c = (0.6f - 0.2f * u) * glm::vec3(0.2f, 0.5f, 0.7f) * evaluate_analytic_basis(on, wi, wo) +
                0.15f * glm::vec3(1.0f, 0.9f, 0.8f) * evaluate_analytic_basis(ward, wi, wo);
          c *= 1.0f - 0.1f * u * (1.0f - wi.z);  // texel-dependent shadowing
          for (int ch = 0; ch < 3; ++ch) btf.at(x, y, v, l, ch) = c[ch];
        }
    }
  return btf;
}

double rms(const BtfFloat& a, const BtfFloat& b) {
  double s = 0.0;
  for (size_t i = 0; i < a.samples().size(); ++i) {
    const double d = static_cast<double>(a.samples()[i]) - b.samples()[i];
    s += d * d;
  }
  return std::sqrt(s / static_cast<double>(a.samples().size()));
}

SpmmOptions small_options() {
  SpmmOptions o;
  o.clusters = 2;
  o.representatives = 2;
  o.lobes_per_representative = 2;
  o.max_basis_per_texel = 3;
  o.residual_components = 3;
  o.fit_samples = 400;
  return o;
}

const Spmm& fitted() {
  static const Spmm p = [] {
    auto r = factorize_spmm(two_material_btf(), small_options());
    EXPECT_TRUE(r.ok()) << r.message();
    return std::move(*r);
  }();
  return p;
}

TEST(FactorSpmm, FitsMixtureAndSeparatesMaterials) {
  const auto btf = two_material_btf();
  const Spmm& p = fitted();
  ASSERT_EQ(p.clusters(), 2);
  // The two halves end up in different clusters, each half in one.
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x)
      EXPECT_EQ(p.cluster_of[p.texel_index(x, y)], p.cluster_of[p.texel_index(x < 4 ? 0 : 7, 0)]);
  EXPECT_NE(p.cluster_of[0], p.cluster_of[7]);
  // Every dictionary starts with Lambert at +z and holds valid bases.
  for (const auto& d : p.dictionaries) {
    ASSERT_FALSE(d.empty());
    EXPECT_EQ(d[0].model, AnalyticModel::lambert);
    for (const auto& b : d) EXPECT_TRUE(validate_analytic_basis(b).ok());
  }
  // The analytic part alone explains the data well (the lobes were analytic), and the weights
  // are non-negative and sparse (≤ the cap).
  double signal = 0.0;
  for (float v : btf.samples()) signal += static_cast<double>(v) * v;
  signal = std::sqrt(signal / static_cast<double>(btf.samples().size()));
  const double no_res = rms(btf, p.reconstruct({.residual = false}));
  EXPECT_LT(no_res, 0.15 * signal) << "signal " << signal;
  for (float a : p.slot_weight) EXPECT_GE(a, 0.0f);
  EXPECT_LE(p.mean_basis_per_texel(), 3.0);
  EXPECT_GE(p.mean_basis_per_texel(), 1.0);
}

TEST(FactorSpmm, ResidualImprovesMonotonicallyWithNpca) {
  // Paper 003 Table 4: no-RES, then N_PCA = 0 (mean only) … max; the error never grows and
  // the mean alone already helps.
  const auto btf = two_material_btf();
  const Spmm& p = fitted();
  std::vector<double> e;
  e.push_back(rms(btf, p.reconstruct({.residual = false})));
  for (int k = 0; k <= p.residual_components; ++k)
    e.push_back(rms(btf, p.reconstruct({.residual = true, .pca_components = k})));
  for (size_t i = 1; i < e.size(); ++i) EXPECT_LE(e[i], e[i - 1] + 1e-7) << i;
  EXPECT_LT(e[1], e[0]);
  EXPECT_LT(e.back(), 0.5 * e[0]);
  // −1 = all stored, out-of-range counts clamp.
  EXPECT_EQ(rms(btf, p.reconstruct({.residual = true, .pca_components = -1})), e.back());
  EXPECT_EQ(rms(btf, p.reconstruct({.residual = true, .pca_components = 99})), e.back());
}

TEST(FactorSpmm, ResidualWithAllComponentsIsExact) {
  // With N_PCA ≥ members − 1 the residual's PCA of a cluster is complete: eq. 1 + eq. 3
  // reconstruct the data exactly.
  const auto btf =
      make_low_rank_btf(4, 4, small_direction_set(2, 3, "v"), small_direction_set(3, 3, "l"), 2, 0.5f, 0.0f, 3);
  SpmmOptions o = small_options();
  o.clusters = 1;
  o.residual_components = 15;
  auto p = factorize_spmm(btf, o);
  ASSERT_TRUE(p.ok()) << p.message();
  EXPECT_LT(rms(btf, p->reconstruct()), 1e-5);
  EXPECT_GT(rms(btf, p->reconstruct({.residual = true, .pca_components = 2})), 1e-3);
}

TEST(FactorSpmm, StagewiseLassoOnOrthogonalDesign) {
  // G = I: the non-negative lasso path ends at max(0, c) (to the step size), and the cap keeps
  // the largest coordinates.
  const Eigen::MatrixXd g = Eigen::MatrixXd::Identity(4, 4);
  Eigen::VectorXd c(12);
  c << 1.0, -0.5, 0.3, 0.05, 0.8, 0.0, 0.2, 0.0, 0.6, -1.0, 0.1, 0.0;
  Eigen::VectorXd beta;
  detail::spmm_blasso(g, c, 4, 0.001, 100000, beta);
  for (Eigen::Index k = 0; k < 12; ++k) EXPECT_NEAR(beta[k], std::max(0.0, c[k]), 2e-3) << k;
  detail::spmm_blasso(g, c, 1, 0.001, 100000, beta);  // one basis: j = 0 (c = 1, 0.8, 0.6)
  for (Eigen::Index k = 0; k < 12; ++k) EXPECT_NEAR(beta[k], k % 4 == 0 ? c[k] : 0.0, 2e-3) << k;
  // Correlated design: the solution still satisfies the KKT conditions of NNLS (gradient ≥ 0
  // where β = 0, ≈ 0 where β > 0) to the step size.
  Eigen::MatrixXd b(6, 3);
  b << 1, 0.9, 0, 0, 0.4, 1, 1, 1, 0.2, 0.3, 0, 1, 0, 0.1, 0.5, 1, 0.8, 0;
  const Eigen::MatrixXd gg = b.transpose() * b;
  Eigen::VectorXd y(6);
  y << 1, 0.5, 1.2, 0.4, 0.3, 0.9;
  Eigen::VectorXd cc(9);
  for (int ch = 0; ch < 3; ++ch) cc.segment(ch * 3, 3) = b.transpose() * (y * (1.0 + ch));
  detail::spmm_blasso(gg, cc, 3, 0.0005, 200000, beta);
  for (int ch = 0; ch < 3; ++ch) {
    const Eigen::VectorXd grad = gg * beta.segment(ch * 3, 3) - cc.segment(ch * 3, 3);
    for (int j = 0; j < 3; ++j) {
      if (beta[ch * 3 + j] > 0.0)
        EXPECT_NEAR(grad[j], 0.0, 0.02 * (1.0 + ch));
      else
        EXPECT_GE(grad[j], -0.02 * (1.0 + ch));
    }
  }
}

TEST(FactorSpmm, SparsityCapBoundsBasisPerTexel) {
  const auto btf = two_material_btf();
  SpmmOptions o = small_options();
  o.max_basis_per_texel = 1;
  auto one = factorize_spmm(btf, o);
  ASSERT_TRUE(one.ok()) << one.message();
  EXPECT_LE(one->mean_basis_per_texel(), 1.0);
  for (size_t t = 0; t < btf.texel_count(); ++t) EXPECT_LE(one->slots, 1);
  // A larger cap fits the analytic part at least as well.
  EXPECT_LE(rms(btf, fitted().reconstruct({.residual = false})),
            rms(btf, one->reconstruct({.residual = false})) + 1e-6);
}

TEST(FactorSpmm, DeterministicForAnyThreadCount) {
  const auto btf = two_material_btf();
  ThreadPool one(1), three(3);
  SpmmOptions a = small_options(), b = small_options();
  a.svd.pool = &one;
  b.svd.pool = &three;
  auto pa = factorize_spmm(btf, a), pb = factorize_spmm(btf, b);
  ASSERT_TRUE(pa.ok() && pb.ok());
  EXPECT_EQ(pa->serialize(), pb->serialize());
}

TEST(FactorSpmm, EvaluateThroughInterpolatorsMatchesMeasured) {
  const Spmm& p = fitted();
  auto li = ExactGridInterpolator<ParabolicMap>::build(p.shape.lights);
  auto vi = ExactGridInterpolator<ParabolicMap>::build(p.shape.views);
  ASSERT_TRUE(li.ok() && vi.ok());
  for (uint32_t v : {0u, 5u, 12u})
    for (uint32_t l : {0u, 9u, 24u}) {
      const glm::vec3 a = p.evaluate(3, 2, p.shape.lights[l].vector, p.shape.views[v].vector, *li, *vi);
      const glm::vec3 b = p.evaluate_measured(3, 2, v, l);
      EXPECT_NEAR(glm::length(a - b), 0.0f, 1e-4f * std::max(1.0f, glm::length(b))) << v << " " << l;
    }
}

// One texel with a Lambert and a Blinn–Phong basis (no residual), built by hand.
Spmm hand_spmm() {
  Spmm p;
  p.shape = BtfShape{2, 1, small_direction_set(2, 4, "v"), small_direction_set(2, 4, "l")};
  p.slots = 2;
  p.residual_components = 0;
  AnalyticBasis lam, bp;
  bp.model = AnalyticModel::blinn_phong;
  bp.kappa = {200.0f, 0, 0};
  p.dictionaries = {{lam, bp}};
  p.cluster_of = {0, 0};
  p.slot_basis = {0, 1, 0, 1};
  p.slot_weight = {0.5f, 0.5f, 0.5f, 0.1f, 0.1f, 0.1f, 0.5f, 0.5f, 0.5f, 0.1f, 0.1f, 0.1f};
  p.residual_mean.assign(p.angular_size(), 0.0f);
  return p;
}

glm::vec3 brightest_view(const Spmm& p, int x, glm::vec3 light) {
  glm::vec3 best(0.0f);
  float bv = -1.0f;
  for (int i = 0; i <= 180; ++i)
    for (int j = 0; j < 360; j += 2) {
      const float t = static_cast<float>(i) * 0.5f * kPi / 180.0f, ph = static_cast<float>(j) * kPi / 180.0f;
      const glm::vec3 v(std::sin(t) * std::cos(ph), std::sin(t) * std::sin(ph), std::cos(t));
      const float val = p.evaluate_analytic(x, 0, light, v).g;
      if (val > bv) bv = val, best = v;
    }
  return best;
}

TEST(FactorSpmm, EditsHaveThePredictedPhysicalEffect) {
  Spmm p = fitted();
  const auto before = p.reconstruct();
  // Raising the Lambert weight of a texel by Δ raises it by Δ·cos θ_l/π at every direction
  // pair (residual untouched), and no other texel changes.
  const glm::vec3 a0 = p.weight(1, 1, 0);
  const glm::vec3 delta(0.2f, 0.1f, 0.3f);
  ASSERT_TRUE(p.set_weight(1, 1, 0, a0 + delta).ok());
  const auto after = p.reconstruct();
  for (size_t v = 0; v < p.shape.view_count(); ++v)
    for (size_t l = 0; l < p.shape.light_count(); ++l) {
      const float cosl = p.shape.lights[l].vector.z;
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR(after.at(1, 1, v, l, ch) - before.at(1, 1, v, l, ch), delta[ch] * cosl / kPi, 1e-5f);
        EXPECT_EQ(after.at(2, 1, v, l, ch), before.at(2, 1, v, l, ch));
      }
    }
  // Scaling a cluster's weight scales the contribution of every texel of the cluster.
  const int c = p.cluster_of[p.texel_index(0, 0)];
  const glm::vec3 w00 = p.weight(0, 0, 0);
  ASSERT_TRUE(p.scale_cluster_weight(c, 0, glm::vec3(2.0f)).ok());
  EXPECT_EQ(p.weight(0, 0, 0), 2.0f * w00);

  // Rotating n_j of a specular basis moves the highlight to the mirror direction about n_j.
  Spmm h = hand_spmm();
  const glm::vec3 light = glm::normalize(glm::vec3(0.5f, 0.0f, 0.866f));
  const glm::vec3 m0 = brightest_view(h, 0, light);
  EXPECT_GT(glm::dot(m0, glm::vec3(-light.x, -light.y, light.z)), 0.9995f);
  const glm::vec3 n = glm::normalize(glm::vec3(0.0f, 0.17f, 1.0f));  // ~10° towards +y
  ASSERT_TRUE(h.set_basis_normal(0, 1, n).ok());
  const glm::vec3 m1 = brightest_view(h, 0, light);
  const glm::vec3 mirror = 2.0f * glm::dot(light, n) * n - light;
  EXPECT_GT(glm::dot(m1, mirror), 0.9995f);
  EXPECT_LT(glm::dot(m1, m0), 0.99f);  // it moved
  // κ edit: a sharper exponent raises the peak (normalised lobe).
  const float peak = h.evaluate_analytic(0, 0, light, mirror).g;
  const float sharp[] = {800.0f};
  ASSERT_TRUE(h.set_basis_params(0, 1, sharp).ok());
  EXPECT_GT(h.evaluate_analytic(0, 0, light, mirror).g, 2.0f * peak);
  // A texel-only edit: texel 1 gets its own copy, texel 0 keeps the shared basis.
  const glm::vec3 t0 = h.evaluate_analytic(0, 0, light, mirror);
  auto own = h.make_texel_basis(1, 0, 1);
  ASSERT_TRUE(own.ok());
  ASSERT_TRUE(h.set_basis_normal(0, *own, glm::vec3(0, 0, 1)).ok());
  EXPECT_EQ(h.evaluate_analytic(0, 0, light, mirror), t0);
  EXPECT_LT(h.evaluate_analytic(1, 0, light, mirror).g, 0.5f * t0.g);
}

TEST(FactorSpmm, EditsRejectBadInput) {
  Spmm h = hand_spmm();
  EXPECT_FALSE(h.set_weight(5, 0, 0, glm::vec3(1)).ok());
  EXPECT_FALSE(h.set_weight(0, 0, 7, glm::vec3(1)).ok());
  EXPECT_FALSE(h.set_weight(0, 0, 0, glm::vec3(-1, 0, 0)).ok());
  EXPECT_FALSE(h.set_weight(0, 0, 0, glm::vec3(NAN, 0, 0)).ok());
  EXPECT_FALSE(h.set_basis_params(3, 0, {}).ok());
  const float nan[] = {NAN};
  const float big[] = {1e6f};
  EXPECT_FALSE(h.set_basis_params(0, 1, nan).ok());
  EXPECT_FALSE(h.set_basis_params(0, 1, big).ok());
  EXPECT_FALSE(h.set_basis_params(0, 0, nan).ok());  // Lambert takes none
  EXPECT_FALSE(h.set_basis_normal(0, 1, glm::vec3(1, 0, 0)).ok());
  EXPECT_FALSE(h.set_basis_normal(0, 1, glm::vec3(0)).ok());
  EXPECT_FALSE(h.scale_cluster_weight(0, 9, glm::vec3(1)).ok());
  EXPECT_FALSE(h.make_texel_basis(0, 0, 5).ok());
  // Both slots used: a third basis has no room, and nothing changed.
  h.dictionaries[0].push_back(AnalyticBasis{});
  EXPECT_FALSE(h.set_weight(0, 0, 2, glm::vec3(1)).ok());
  EXPECT_FALSE(h.set_cluster_weight(0, 2, glm::vec3(1)).ok());
  EXPECT_EQ(h.weight(0, 0, 2), glm::vec3(0));
  // Freeing a slot (α = 0) makes room.
  ASSERT_TRUE(h.set_weight(0, 0, 1, glm::vec3(0)).ok());
  EXPECT_TRUE(h.set_weight(0, 0, 2, glm::vec3(1)).ok());
}

TEST(FactorSpmm, OptionsAndCancellation) {
  const auto btf = two_material_btf();
  SpmmOptions o = small_options();
  o.clusters = 0;
  EXPECT_EQ(factorize_spmm(btf, o).status(), Status::invalid_argument);
  o = small_options();
  o.model_mask = 0;
  EXPECT_EQ(factorize_spmm(btf, o).status(), Status::invalid_argument);
  o = small_options();
  o.max_basis_per_texel = 0;
  EXPECT_EQ(factorize_spmm(btf, o).status(), Status::invalid_argument);
  EXPECT_EQ(factorize_spmm(BtfFloat{}, small_options()).status(), Status::invalid_argument);
  auto r = factorize_spmm(btf, small_options(), [](std::string_view, double) { return false; });
  EXPECT_EQ(r.status(), Status::cancelled);
}

TEST(FactorSpmm, SerialisesAndRoundTripsThroughAnyFactorization) {
  const Spmm& p = fitted();
  const auto bytes = p.serialize();
  auto q = Spmm::deserialize(bytes);
  ASSERT_TRUE(q.ok()) << q.message();
  EXPECT_EQ(q->serialize(), bytes);
  EXPECT_EQ(q->evaluate_measured(7, 5, 3, 4), p.evaluate_measured(7, 5, 3, 4));
  auto any = parse_factorization(bytes);
  ASSERT_TRUE(any.ok()) << any.message();
  EXPECT_STREQ(factorization_name(*any), "spmm");
  EXPECT_EQ(factorization_size_bytes(*any), p.size_bytes());
  EXPECT_GT(p.compression_ratio(), 0.0);
  // The seed of the factor reader's fuzz corpus.
  const auto dir = std::filesystem::path(BTFLOD_TEST_TMP_DIR) / "factor_seeds";
  std::filesystem::create_directories(dir);
  Spmm tiny = hand_spmm();
  ASSERT_TRUE(write_file_bytes((dir / "spmm.bfr").string(), tiny.serialize()).ok());
}

TEST(FactorSpmm, RejectsHostileFiles) {
  auto reject = [](Spmm s, const char* what) -> std::string {
    auto r = Spmm::deserialize(s.serialize());
    EXPECT_FALSE(r.ok()) << what;
    if (r.ok()) return {};
    EXPECT_EQ(r.status(), Status::bad_data) << what << ": " << r.message();
    return r.message();
  };
  {
    Spmm s = hand_spmm();
    s.dictionaries[0][1].model = static_cast<AnalyticModel>(12);
    EXPECT_NE(reject(s, "model id").find("unknown model id 12"), std::string::npos);
  }
  {
    Spmm s = hand_spmm();
    s.dictionaries[0][1].kappa[0] = NAN;
    EXPECT_NE(reject(s, "NaN kappa").find("exponent"), std::string::npos);
  }
  {
    Spmm s = hand_spmm();
    s.dictionaries[0][1].kappa[0] = 0.1f;
    reject(s, "kappa range");
  }
  {
    Spmm s = hand_spmm();
    s.dictionaries[0][1].normal = glm::vec3(0, 0, -1);
    reject(s, "normal");
  }
  {
    Spmm s = hand_spmm();
    s.cluster_of[1] = 1;
    EXPECT_NE(reject(s, "cluster id").find("cluster 1, K = 1"), std::string::npos);
  }
  {
    Spmm s = hand_spmm();
    s.slot_basis[1] = 2;
    EXPECT_NE(reject(s, "slot").find("uses basis 2"), std::string::npos);
  }
  {
    Spmm s = hand_spmm();
    s.slot_weight[0] = -1.0f;
    reject(s, "negative weight");
  }
  {
    Spmm s = hand_spmm();
    s.residual_mean[0] = NAN;
    reject(s, "NaN residual");
  }
  // Truncated files and a wrong kind.
  const auto bytes = hand_spmm().serialize();
  for (size_t cut : {size_t{0}, size_t{10}, bytes.size() / 2, bytes.size() - 1})
    EXPECT_FALSE(Spmm::deserialize(std::span<const uint8_t>(bytes.data(), cut)).ok()) << cut;
  LocalPcaOptions lo;
  lo.clusters = 1;
  lo.components = 1;
  auto lp = factorize_local_pca(two_material_btf(4, 2), lo);
  ASSERT_TRUE(lp.ok());
  EXPECT_FALSE(Spmm::deserialize(lp->serialize()).ok());
}

// The section-level failure classes of the kind-5 reader that a serialised Spmm cannot produce:
// META counts, DICT sizes and counts, unused κ entries, missing sections, counts that need more
// bytes than the file has. Each file is framed with correct CRCs (so the section check, not the
// container, must reject it); the message names the section or quantity.
TEST(FactorSpmm, RejectsInconsistentSections) {
  const Spmm base = hand_spmm();
  // Re-frames base's sections, replacing (or dropping, with an empty optional) one of them.
  auto file_with = [&](const char* tag, std::optional<std::vector<uint8_t>> payload) {
    const auto bytes = base.serialize();  // parse() keeps views into these bytes
    auto parsed = FactorFile::parse(bytes);
    EXPECT_TRUE(parsed.ok());
    FactorFileWriter w(FactorKind::spmm);
    const struct {
      const char* name;
      uint32_t tag;
    } sections[] = {{"SHAP", factor_tag("SHAP")}, {"META", factor_tag("META")}, {"DICT", factor_tag("DICT")},
                    {"CLID", factor_tag("CLID")}, {"SIDX", factor_tag("SIDX")}, {"SWGT", factor_tag("SWGT")},
                    {"RMEA", factor_tag("RMEA")}, {"RBAS", factor_tag("RBAS")}, {"RCOF", factor_tag("RCOF")}};
    for (const auto& t : sections) {
      if (std::string(t.name) == tag) {
        if (payload) w.add(t.tag, *payload);
        continue;
      }
      auto sec = parsed->section(t.tag);
      EXPECT_TRUE(sec.ok()) << t.name;
      w.add(t.tag, std::vector<uint8_t>(sec->begin(), sec->end()));
    }
    return w.finish();
  };
  auto meta = [](uint32_t k, uint32_t s, uint32_t pc, uint32_t total) {
    ByteWriter b;
    b.u32(k);
    b.u32(s);
    b.u32(pc);
    b.u32(total);
    return b.take();
  };
  auto rejected = [](const std::vector<uint8_t>& bytes, const char* word) {
    auto r = Spmm::deserialize(bytes);
    ASSERT_FALSE(r.ok()) << word;
    EXPECT_TRUE(r.status() == Status::bad_data || r.status() == Status::short_output) << r.message();
    EXPECT_NE(r.message().find(word), std::string::npos) << word << ": " << r.message();
  };
  ASSERT_TRUE(Spmm::deserialize(file_with("", std::nullopt)).ok()) << "the re-framed file itself is valid";
  rejected(file_with("META", meta(0, 2, 0, 2)), "META");         // K = 0
  rejected(file_with("META", meta(1, 65, 0, 2)), "slots=65");    // more than 64 slots
  rejected(file_with("META", meta(1, 2, 999, 2)), "N_PCA=999");  // N_PCA > d
  rejected(file_with("META", meta(1, 2, 0, 1)), "DICT has");     // fewer bases than DICT holds
  rejected(file_with("META", meta(3, 2, 0, 2)), "META");         // K > texels
  {
    std::vector<uint8_t> m = meta(1, 2, 0, 2);
    m.push_back(0);
    rejected(file_with("META", m), "META");  // trailing byte
  }
  rejected(file_with("META", std::nullopt), "META");  // missing section
  rejected(file_with("DICT", std::nullopt), "DICT");
  rejected(file_with("RMEA", std::nullopt), "RMEA");
  {
    const auto bytes = base.serialize();  // parse() keeps views into these bytes
    auto parsed = FactorFile::parse(bytes);
    const auto dict = *parsed->section(factor_tag("DICT"));
    std::vector<uint8_t> d(dict.begin(), dict.end());
    rejected(file_with("DICT", std::vector<uint8_t>(d.begin(), d.end() - 1)), "DICT has");  // size
    std::vector<uint8_t> zero = d;
    zero[0] = 0;  // cluster 0 has 0 bases (and the sum no longer matches META)
    rejected(file_with("DICT", zero), "basis functions");
    std::vector<uint8_t> unused = d;
    const float k = 0.5f;
    std::memcpy(unused.data() + 4 + 4, &k, 4);  // κ0 of the Lambert basis (it has no parameters)
    rejected(file_with("DICT", unused), "parameter 0");
  }
  // Counts that need more bytes than the file holds: refused before any allocation.
  rejected(file_with("META", meta(1, 64, 0, 60000)), "need more than");
}

}  // namespace
}  // namespace btflod
