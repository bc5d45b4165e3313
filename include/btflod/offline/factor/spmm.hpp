// btflod — the Sparse Parametric Mixture Model (SPMM), paper 003 §3 after its ref. [8] (Wu,
// Dorsey, Rushmeier 2011): every texel t is a sparse non-negative combination of analytic
// basis functions plus a clustered-PCA residual,
//
//   BTF(t, ω_i, ω_o) = Σ_j α_j^t ρ_j(ω_i, ω_o) + ε(t, ω_i, ω_o)                      (eq. 1)
//   ρ_j(ω_i, ω_o)    = f_j(κ_j, R(ω_i), R(ω_o)) (n_j·ω_i)                               (eq. 2)
//   ε(t, ω_i, ω_o)   = ε̄(c, ω_i, ω_o) + Σ_{i<N_PCA} coef_i(t) b_i(c, ω_i, ω_o)          (eq. 3)
//
// with ρ_j from offline/factor/analytic_brdf.hpp (seven models, each with its own normal n_j), α_j^t an
// RGB weight and c the texel's cluster.
//
// Fitting (factorize_spmm), as paper 003 §3 describes ref. [8]:
//  1. texels are clustered by similarity of their ABRDFs (k-means, farthest-point seeds);
//  2. per cluster, representatives are chosen by sub-clustering (k-means inside the cluster,
//     the member nearest each sub-centroid), and a dictionary of basis functions is fitted to
//     them: a Lambert term with n_j = +z, then per representative `lobes_per_representative`
//     lobes fitted greedily to what the previous ones left, each time the best of the enabled
//     models by non-linear least squares over (κ_j, n_j) — Levenberg–Marquardt
//     (offline/factor/levenberg_marquardt.hpp) on the variable-projection residual y − α*(κ, n)·ρ(κ, n),
//     α* ≥ 0 in closed form. Paper 003 names IPOPT for this step; bounded parameters are
//     handled here by a smooth change of variables (logistic, on a log scale for exponents and
//     roughnesses) instead of an interior-point method;
//  3. the weights α of every texel by non-negative stagewise LASSO (BLasso, Zhao & Yu 2007,
//     paper 003 ref. [28]) on the cluster's dictionary, all three colour channels in one path;
//     the number of distinct basis functions a texel may use is capped at max_basis_per_texel
//     (the sparsity option: the paper's #BF is the mean number of non-zero weights,
//     mean_basis_per_texel());
//  4. the residual ε over the measured directions, per cluster its mean and N_PCA principal
//     components with per-texel coefficients (eq. 3), read at run time through any of btflod's
//     angular interpolators (an AngularSample per direction, 3 × 3 taps).
// Deterministic for any thread count (parallel loops write disjoint, index-addressed results).
//
// Evaluation is the CPU oracle of the shaders: N_PCA is selectable from 0 to the stored maximum
// at run time and the residual can be skipped (paper 003 §5.2, "no-RES"). Editing (set_weight,
// set_basis_params, set_basis_normal, …) changes α, κ_j or n_j and re-evaluates without
// refitting; the residual is left as fitted.
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/factor/analytic_brdf.hpp"
#include "btflod/offline/factor/factor_file.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/levenberg_marquardt.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"

namespace btflod {

/// Slot value of an unused weight slot.
inline constexpr uint16_t kSpmmEmptySlot = 0xffff;
/// Bitmask of every analytic model (bit = AnalyticModel id).
inline constexpr uint32_t kSpmmAllModels = (1u << kAnalyticModelCount) - 1u;

/// Options of factorize_spmm(). Defaults are small enough for a 64 × 64 material in seconds;
/// paper 003's data sets used 32 clusters and 8 representatives per cluster.
struct SpmmOptions {
  int clusters = 4;                      ///< K (k-means over texel ABRDFs), ≤ 65535
  int representatives = 4;               ///< sub-clusters per cluster (paper 003 §5.1: k = 8)
  int lobes_per_representative = 2;      ///< greedy lobes fitted to each representative
  uint32_t model_mask = kSpmmAllModels;  ///< models the dictionary may use (bit = AnalyticModel id)
  int max_basis_per_texel = 4;           ///< sparsity cap: distinct basis functions per texel (#BF ≤ this)
  int residual_components = 4;           ///< maximum N_PCA stored per cluster (0 = mean only)
  int kmeans_iterations = 8;             ///< Lloyd iterations of the clustering and sub-clustering
  int fit_samples = 1024;                ///< direction pairs used by the dictionary fit (strided subset)
  int lm_evaluations = 200;              ///< residual evaluations per Levenberg–Marquardt fit
  float lasso_step = 0.005f;             ///< BLasso step ε as a fraction of the largest 1-basis LS weight
  int lasso_max_steps = 4000;            ///< BLasso steps per texel
  SvdOptions svd{};                      ///< residual PCA and the thread pool (svd.pool)
};

/// Run-time evaluation switches (paper 003 §5.2, Table 4).
struct SpmmEvalOptions {
  bool residual = true;     ///< false: analytic part only ("no-RES")
  int pca_components = -1;  ///< N_PCA used, clamped to [0, stored]; −1 = all stored
};

/// The SPMM representation of a BTF.
struct Spmm {
  BtfShape shape;
  int slots = 0;                ///< weight slots per texel (= max_basis_per_texel of the fit)
  int residual_components = 0;  ///< N_PCA stored per cluster
  /// Dictionary of each cluster (ρ_j of eq. 2); slot indices refer to these.
  std::vector<std::vector<AnalyticBasis>> dictionaries;
  /// Cluster per texel (texel = y·W + x).
  std::vector<uint16_t> cluster_of;
  /// Per texel `slots` dictionary indices (kSpmmEmptySlot = unused), n × S.
  std::vector<uint16_t> slot_basis;
  /// Per texel and slot an RGB weight α ≥ 0, n × S × 3.
  std::vector<float> slot_weight;
  /// Residual mean ε̄ per cluster, K × d (d = n_view·n_light·3, index (v·n_light + l)·3 + c).
  std::vector<float> residual_mean;
  /// Residual principal components b_i, K × d × P (cluster, angular index, component).
  std::vector<float> residual_basis;
  /// Residual coefficients coef_i(t), n × P.
  std::vector<float> residual_coef;

  int clusters() const noexcept { return static_cast<int>(dictionaries.size()); }
  size_t angular_size() const noexcept { return shape.view_count() * shape.light_count() * 3; }
  size_t texel_index(int x, int y) const noexcept {
    return static_cast<size_t>(y) * static_cast<size_t>(shape.width) + static_cast<size_t>(x);
  }
  /// The paper's #BF: mean number of non-zero weights (occupied slots) per texel.
  double mean_basis_per_texel() const noexcept {
    size_t used = 0;
    for (uint16_t s : slot_basis) used += s != kSpmmEmptySlot;
    return shape.texel_count() ? static_cast<double>(used) / static_cast<double>(shape.texel_count()) : 0.0;
  }

  /// Σ_j α_j ρ_j(ω_i, ω_o) at texel (x, y) for unit directions in the surface frame (eq. 1
  /// without ε). Thread-safe, allocation-free. Precondition: (x, y) in range.
  glm::vec3 evaluate_analytic(int x, int y, glm::vec3 light, glm::vec3 view) const noexcept {
    const size_t t = texel_index(x, y), s = static_cast<size_t>(slots);
    const auto& dict = dictionaries[cluster_of[t]];
    glm::vec3 out(0.0f);
    for (size_t k = 0; k < s; ++k) {
      const uint16_t j = slot_basis[t * s + k];
      if (j == kSpmmEmptySlot) continue;
      const float rho = evaluate_analytic_basis(dict[j], light, view);
      const float* a = slot_weight.data() + (t * s + k) * 3;
      out += rho * glm::vec3(a[0], a[1], a[2]);
    }
    return out;
  }
  /// ε of eq. 3 at a measured (view, light) pair with the first `n_pca` components (clamped).
  /// Thread-safe, allocation-free. Precondition: indices in range.
  glm::vec3 evaluate_residual_measured(int x, int y, uint32_t view, uint32_t light, int n_pca) const noexcept {
    const size_t t = texel_index(x, y), j = cluster_of[t], d = angular_size();
    const size_t p = static_cast<size_t>(residual_components);
    const size_t use = static_cast<size_t>(std::clamp(n_pca, 0, residual_components));
    const size_t row = (static_cast<size_t>(view) * shape.light_count() + light) * 3;
    const float* m = residual_mean.data() + j * d + row;
    glm::vec3 out(m[0], m[1], m[2]);
    const float* coef = residual_coef.data() + t * p;
    for (int c = 0; c < 3; ++c) {
      const float* b = residual_basis.data() + (j * d + row + static_cast<size_t>(c)) * p;
      float s = 0.0f;
      for (size_t k = 0; k < use; ++k) s += coef[k] * b[k];
      out[c] += s;
    }
    return out;
  }
  /// Eq. 1 at texel (x, y): analytic part at the exact unit directions `light`, `view`
  /// (surface frame) plus the residual interpolated from the measured directions through the
  /// taps `light_taps`, `view_taps` (any angular interpolator's query of the same directions).
  /// Thread-safe, allocation-free. Precondition: indices in range.
  glm::vec3 evaluate(int x, int y, glm::vec3 light, glm::vec3 view, const AngularSample& light_taps,
                     const AngularSample& view_taps, const SpmmEvalOptions& options = {}) const noexcept {
    glm::vec3 out = evaluate_analytic(x, y, light, view);
    if (!options.residual) return out;
    const int n_pca = options.pca_components < 0 ? residual_components : options.pca_components;
    return out + combine_angular_taps(light_taps, view_taps, [&](uint32_t vi, uint32_t li) {
             return evaluate_residual_measured(x, y, vi, li, n_pca);
           });
  }
  /// evaluate() with the taps taken from angular interpolators built over shape.lights and
  /// shape.views (any btflod interpolator: exact grid, lookup table, nearest, ring search).
  template <AngularInterpolator LightInterp, AngularInterpolator ViewInterp>
  glm::vec3 evaluate(int x, int y, glm::vec3 light, glm::vec3 view, const LightInterp& light_interp,
                     const ViewInterp& view_interp, const SpmmEvalOptions& options = {}) const noexcept {
    return evaluate(x, y, light, view, light_interp.query(light), view_interp.query(view), options);
  }
  /// Eq. 1 tabulated like the other representations: evaluate_measured() at the 3 × 3 taps of
  /// a light and a view AngularSample, weights multiplied (the analytic part is then also read
  /// at the measured directions). Thread-safe, allocation-free.
  glm::vec3 evaluate(int x, int y, const AngularSample& light, const AngularSample& view,
                     const SpmmEvalOptions& options = {}) const noexcept {
    return combine_angular_taps(light, view,
                                [&](uint32_t vi, uint32_t li) { return evaluate_measured(x, y, vi, li, options); });
  }
  /// Eq. 1 at a measured (view, light) pair. Thread-safe, allocation-free.
  glm::vec3 evaluate_measured(int x, int y, uint32_t view, uint32_t light,
                              const SpmmEvalOptions& options = {}) const noexcept {
    glm::vec3 out = evaluate_analytic(x, y, shape.lights[light].vector, shape.views[view].vector);
    if (!options.residual) return out;
    return out + evaluate_residual_measured(x, y, view, light,
                                            options.pca_components < 0 ? residual_components : options.pca_components);
  }
  /// The whole BTF at the measured directions (allocates).
  BtfFloat reconstruct(const SpmmEvalOptions& options = {}) const {
    return reconstruct_measured(
        shape, [&](int x, int y, uint32_t v, uint32_t l) { return evaluate_measured(x, y, v, l, options); });
  }

  /// Stored bytes: 28 per basis (u32 model, 3 float κ, float normal), u16 cluster ids, u16
  /// slot indices, float RGB weights, float residual means, components and coefficients.
  size_t size_bytes() const noexcept {
    size_t basis = 0;
    for (const auto& d : dictionaries) basis += d.size();
    return basis * 28 + cluster_of.size() * 2 + slot_basis.size() * 2 + slot_weight.size() * 4 +
           residual_mean.size() * 4 + residual_basis.size() * 4 + residual_coef.size() * 4;
  }
  double compression_ratio() const noexcept {
    return static_cast<double>(shape.float_bytes()) / static_cast<double>(size_bytes());
  }

  // --- editing (offline; not per frame) -------------------------------------------------------

  /// Sets the RGB weight α of dictionary entry `basis` at texel (x, y): an existing slot is
  /// overwritten, a new one takes a free slot; α = 0 frees the slot. Returns invalid_argument
  /// for a texel or basis out of range, a negative or non-finite α, or no free slot (nothing
  /// is changed then). Not thread-safe against concurrent evaluation.
  VoidResult set_weight(int x, int y, int basis, glm::vec3 alpha) {
    if (x < 0 || y < 0 || x >= shape.width || y >= shape.height)
      return make_error(Status::invalid_argument, "spmm: texel (%d, %d) outside %dx%d", x, y, shape.width,
                        shape.height);
    const size_t t = texel_index(x, y), s = static_cast<size_t>(slots);
    const int count = static_cast<int>(dictionaries[cluster_of[t]].size());
    if (basis < 0 || basis >= count)
      return make_error(Status::invalid_argument, "spmm: basis %d outside the %d of cluster %u", basis, count,
                        cluster_of[t]);
    if (!(alpha.x >= 0.0f && alpha.y >= 0.0f && alpha.z >= 0.0f) || !std::isfinite(alpha.x) ||
        !std::isfinite(alpha.y) || !std::isfinite(alpha.z))
      return make_error(Status::invalid_argument, "spmm: weight (%g, %g, %g) must be finite and >= 0",
                        static_cast<double>(alpha.x), static_cast<double>(alpha.y), static_cast<double>(alpha.z));
    size_t slot = s;
    for (size_t k = 0; k < s && slot == s; ++k)
      if (slot_basis[t * s + k] == basis) slot = k;
    for (size_t k = 0; k < s && slot == s; ++k)
      if (slot_basis[t * s + k] == kSpmmEmptySlot) slot = k;
    if (slot == s)
      return make_error(Status::invalid_argument, "spmm: texel (%d, %d) has no free slot (%d used)", x, y, slots);
    const bool zero = alpha == glm::vec3(0.0f);
    slot_basis[t * s + slot] = zero ? kSpmmEmptySlot : static_cast<uint16_t>(basis);
    for (int c = 0; c < 3; ++c) slot_weight[(t * s + slot) * 3 + static_cast<size_t>(c)] = zero ? 0.0f : alpha[c];
    return {};
  }
  /// The RGB weight of dictionary entry `basis` at texel (x, y) (0 when unused or out of range).
  glm::vec3 weight(int x, int y, int basis) const noexcept {
    if (x < 0 || y < 0 || x >= shape.width || y >= shape.height) return glm::vec3(0.0f);
    const size_t t = texel_index(x, y), s = static_cast<size_t>(slots);
    for (size_t k = 0; k < s; ++k)
      if (slot_basis[t * s + k] == basis) {
        const float* a = slot_weight.data() + (t * s + k) * 3;
        return {a[0], a[1], a[2]};
      }
    return glm::vec3(0.0f);
  }
  /// Multiplies α of dictionary entry `basis` by `factor` (per channel, finite, ≥ 0) in every
  /// texel of `cluster` that uses it. Errors: cluster/basis out of range, bad factor.
  VoidResult scale_cluster_weight(int cluster, int basis, glm::vec3 factor) {
    if (auto s = check_basis(cluster, basis); !s) return s;
    if (!(factor.x >= 0.0f && factor.y >= 0.0f && factor.z >= 0.0f) || !std::isfinite(factor.x) ||
        !std::isfinite(factor.y) || !std::isfinite(factor.z))
      return make_error(Status::invalid_argument, "spmm: scale factor must be finite and >= 0");
    const size_t s = static_cast<size_t>(slots);
    for (size_t t = 0; t < cluster_of.size(); ++t) {
      if (cluster_of[t] != cluster) continue;
      for (size_t k = 0; k < s; ++k)
        if (slot_basis[t * s + k] == basis)
          for (int c = 0; c < 3; ++c) slot_weight[(t * s + k) * 3 + static_cast<size_t>(c)] *= factor[c];
    }
    return {};
  }
  /// Sets α of dictionary entry `basis` to `alpha` in every texel of `cluster` (as set_weight);
  /// checked first for every texel, so on error (no free slot somewhere) nothing changes.
  VoidResult set_cluster_weight(int cluster, int basis, glm::vec3 alpha) {
    if (auto s = check_basis(cluster, basis); !s) return s;
    const size_t s = static_cast<size_t>(slots);
    for (size_t t = 0; t < cluster_of.size(); ++t) {
      if (cluster_of[t] != cluster) continue;
      bool ok = false;
      for (size_t k = 0; k < s && !ok; ++k)
        ok = slot_basis[t * s + k] == basis || slot_basis[t * s + k] == kSpmmEmptySlot;
      if (!ok && alpha != glm::vec3(0.0f))
        return make_error(Status::invalid_argument, "spmm: texel %zu of cluster %d has no free slot", t, cluster);
    }
    for (size_t t = 0; t < cluster_of.size(); ++t)
      if (cluster_of[t] == cluster) {
        const int x = static_cast<int>(t % static_cast<size_t>(shape.width));
        const int y = static_cast<int>(t / static_cast<size_t>(shape.width));
        bool used = false;
        for (size_t k = 0; k < s; ++k) used = used || slot_basis[t * s + k] == basis;
        if (used || alpha != glm::vec3(0.0f))
          if (auto r = set_weight(x, y, basis, alpha); !r) return r;
      }
    return {};
  }
  /// Replaces κ of dictionary entry `basis` of `cluster` (every texel using it changes).
  /// `kappa` holds analytic_param_count() values; range-checked (validate_analytic_basis).
  VoidResult set_basis_params(int cluster, int basis, std::span<const float> kappa) {
    if (auto s = check_basis(cluster, basis); !s) return s;
    AnalyticBasis b = dictionaries[static_cast<size_t>(cluster)][static_cast<size_t>(basis)];
    const size_t count = static_cast<size_t>(analytic_param_count(b.model));
    if (kappa.size() != count)
      return make_error(Status::invalid_argument, "spmm: %s takes %zu parameters, got %zu",
                        analytic_model_name(b.model), count, kappa.size());
    for (size_t i = 0; i < count; ++i) b.kappa[i] = kappa[i];
    if (auto s = validate_analytic_basis(b); !s) return make_error(Status::invalid_argument, "%s", s.message().c_str());
    dictionaries[static_cast<size_t>(cluster)][static_cast<size_t>(basis)] = b;
    return {};
  }
  /// Replaces the normal n_j of dictionary entry `basis` of `cluster` (normalised here; must be
  /// finite, non-zero and tilted at most to n.z ≥ kAnalyticMinNormalZ after normalisation).
  VoidResult set_basis_normal(int cluster, int basis, glm::vec3 normal) {
    if (auto s = check_basis(cluster, basis); !s) return s;
    const float len = std::sqrt(glm::dot(normal, normal));
    if (!(len > 1e-12f) || !std::isfinite(len))
      return make_error(Status::invalid_argument, "spmm: normal must be finite and non-zero");
    AnalyticBasis b = dictionaries[static_cast<size_t>(cluster)][static_cast<size_t>(basis)];
    b.normal = normal / len;
    if (auto s = validate_analytic_basis(b); !s) return make_error(Status::invalid_argument, "%s", s.message().c_str());
    dictionaries[static_cast<size_t>(cluster)][static_cast<size_t>(basis)] = b;
    return {};
  }
  /// Gives texel (x, y) its own copy of dictionary entry `basis` (appended to its cluster's
  /// dictionary, the texel's slot re-pointed), so that set_basis_params / set_basis_normal on
  /// the returned index edit this texel only. Errors: out of range, basis not used by the
  /// texel, dictionary full (65535 entries).
  Result<int> make_texel_basis(int x, int y, int basis) {
    if (x < 0 || y < 0 || x >= shape.width || y >= shape.height)
      return make_error(Status::invalid_argument, "spmm: texel (%d, %d) outside %dx%d", x, y, shape.width,
                        shape.height);
    const size_t t = texel_index(x, y), s = static_cast<size_t>(slots);
    auto& dict = dictionaries[cluster_of[t]];
    if (dict.size() >= kSpmmEmptySlot)
      return make_error(Status::invalid_argument, "spmm: dictionary of cluster %u is full", cluster_of[t]);
    for (size_t k = 0; k < s; ++k)
      if (basis >= 0 && slot_basis[t * s + k] == basis) {
        dict.push_back(dict[static_cast<size_t>(basis)]);
        slot_basis[t * s + k] = static_cast<uint16_t>(dict.size() - 1);
        return static_cast<int>(dict.size() - 1);
      }
    return make_error(Status::invalid_argument, "spmm: texel (%d, %d) does not use basis %d", x, y, basis);
  }

  // --- storage ---------------------------------------------------------------------------------

  /// Serialises (SHAP; META = K, S, P, total basis count; DICT = per cluster its basis count
  /// (u32), then per basis u32 model id, 3 × f32 κ, 3 × f32 normal; CLID u16; SIDX u16 n × S;
  /// SWGT f32 n × S × 3; RMEA f32 K × d; RBAS f32 K × d × P; RCOF f32 n × P).
  std::vector<uint8_t> serialize() const {
    FactorFileWriter w(FactorKind::spmm);
    w.add_shape(shape);
    size_t total = 0;
    for (const auto& d : dictionaries) total += d.size();
    ByteWriter meta;
    meta.u32(static_cast<uint32_t>(dictionaries.size()));
    meta.u32(static_cast<uint32_t>(slots));
    meta.u32(static_cast<uint32_t>(residual_components));
    meta.u32(static_cast<uint32_t>(total));
    w.add(factor_tag("META"), meta.take());
    ByteWriter dict;
    for (const auto& d : dictionaries) dict.u32(static_cast<uint32_t>(d.size()));
    for (const auto& d : dictionaries)
      for (const auto& b : d) {
        dict.u32(static_cast<uint32_t>(b.model));
        for (float k : b.kappa) dict.f32(k);
        for (int c = 0; c < 3; ++c) dict.f32(b.normal[c]);
      }
    w.add(factor_tag("DICT"), dict.take());
    w.add_array<uint16_t>(factor_tag("CLID"), cluster_of);
    w.add_array<uint16_t>(factor_tag("SIDX"), slot_basis);
    w.add_array<float>(factor_tag("SWGT"), slot_weight);
    w.add_array<float>(factor_tag("RMEA"), residual_mean);
    w.add_array<float>(factor_tag("RBAS"), residual_basis);
    w.add_array<float>(factor_tag("RCOF"), residual_coef);
    return w.finish();
  }
  /// Parses a serialised SPMM. Safe for untrusted input: counts are checked against the shape
  /// and the file size before allocation, every model id is known and every κ and normal in
  /// range (validate_analytic_basis), every cluster id < K, every slot index < its cluster's
  /// dictionary size, weights finite and ≥ 0 (every float section is checked finite).
  static Result<Spmm> deserialize(std::span<const uint8_t> bytes) {
    auto head = parse_factor_file_head(bytes, FactorKind::spmm, "SPMM");
    if (!head) return head.error();
    const FactorFile& file = head->file;
    Spmm p;
    p.shape = std::move(head->shape);
    ByteReader r(head->meta);
    const uint32_t k = r.u32(), s = r.u32(), pc = r.u32(), total = r.u32();
    const size_t d = p.angular_size(), n = p.shape.texel_count();
    if (!r.ok() || r.remaining() != 0 || k == 0 || k > 65535 || k > n || s == 0 || s > 64 || pc > d || total < k)
      return make_error(Status::bad_data,
                        "SPMM: META (K=%u, slots=%u, N_PCA=%u, bases=%u) invalid for %zu texels, d=%zu", k, s, pc,
                        total, n, d);
    // Lower bound of the payload by division (no overflow): K·d residual means, n·S slots.
    if (d > bytes.size() / (4 * static_cast<size_t>(k)) ||
        static_cast<size_t>(pc) + 1 > bytes.size() / (4 * (k * d + n)) ||
        static_cast<size_t>(s) > bytes.size() / (14 * n) || total > bytes.size() / 28)
      return make_error(Status::short_output,
                        "SPMM: K=%u, slots=%u, N_PCA=%u, %u bases need more than the %zu bytes of the file", k, s, pc,
                        total, bytes.size());
    p.slots = static_cast<int>(s);
    p.residual_components = static_cast<int>(pc);
    auto dict = file.section(factor_tag("DICT"));
    if (!dict) return dict.error();
    if (dict->size() != static_cast<size_t>(k) * 4 + static_cast<size_t>(total) * 28)
      return make_error(Status::bad_data, "SPMM: DICT has %zu bytes, expected %zu for K=%u and %u bases", dict->size(),
                        static_cast<size_t>(k) * 4 + static_cast<size_t>(total) * 28, k, total);
    ByteReader dr(*dict);
    std::vector<uint32_t> counts(k);
    uint64_t sum = 0;
    for (auto& c : counts) {
      c = dr.u32();
      sum += c;
      if (c == 0 || c >= kSpmmEmptySlot)
        return make_error(Status::bad_data, "SPMM: a cluster has %u basis functions (expected 1..65534)", c);
    }
    if (sum != total)
      return make_error(Status::bad_data, "SPMM: cluster dictionaries hold %llu bases, META says %u",
                        static_cast<unsigned long long>(sum), total);
    p.dictionaries.resize(k);
    for (uint32_t j = 0; j < k; ++j) {
      p.dictionaries[j].resize(counts[j]);
      for (uint32_t i = 0; i < counts[j]; ++i) {
        AnalyticBasis b;
        auto model = analytic_model_from_id(dr.u32());
        for (float& v : b.kappa) v = dr.f32();
        for (int c = 0; c < 3; ++c) b.normal[c] = dr.f32();
        if (!model) return make_error(Status::bad_data, "SPMM: cluster %u basis %u: %s", j, i, model.message().c_str());
        b.model = *model;
        if (auto v = validate_analytic_basis(b); !v)
          return make_error(Status::bad_data, "SPMM: cluster %u basis %u: %s", j, i, v.message().c_str());
        p.dictionaries[j][i] = b;
      }
    }
    if (auto e = file.read_array<uint16_t>(factor_tag("CLID"), n, p.cluster_of); !e) return e.error();
    for (size_t t = 0; t < n; ++t)
      if (p.cluster_of[t] >= k)
        return make_error(Status::bad_data, "SPMM: texel %zu has cluster %u, K = %u", t, p.cluster_of[t], k);
    if (auto e = file.read_array<uint16_t>(factor_tag("SIDX"), n * s, p.slot_basis); !e) return e.error();
    for (size_t t = 0; t < n; ++t)
      for (size_t q = 0; q < s; ++q) {
        const uint16_t j = p.slot_basis[t * s + q];
        if (j != kSpmmEmptySlot && j >= counts[p.cluster_of[t]])
          return make_error(Status::bad_data, "SPMM: texel %zu slot %zu uses basis %u, cluster %u has %u", t, q, j,
                            p.cluster_of[t], counts[p.cluster_of[t]]);
      }
    if (auto e = file.read_array<float>(factor_tag("SWGT"), n * s * 3, p.slot_weight); !e) return e.error();
    for (size_t i = 0; i < p.slot_weight.size(); ++i)
      if (p.slot_weight[i] < 0.0f) return make_error(Status::bad_data, "SPMM: weight %zu is negative", i);
    if (auto e = file.read_array<float>(factor_tag("RMEA"), k * d, p.residual_mean); !e) return e.error();
    if (auto e = file.read_array<float>(factor_tag("RBAS"), k * d * pc, p.residual_basis); !e) return e.error();
    if (auto e = file.read_array<float>(factor_tag("RCOF"), n * pc, p.residual_coef); !e) return e.error();
    return p;
  }

 private:
  VoidResult check_basis(int cluster, int basis) const {
    if (cluster < 0 || cluster >= clusters())
      return make_error(Status::invalid_argument, "spmm: cluster %d outside [0, %d)", cluster, clusters());
    const int count = static_cast<int>(dictionaries[static_cast<size_t>(cluster)].size());
    if (basis < 0 || basis >= count)
      return make_error(Status::invalid_argument, "spmm: basis %d outside the %d of cluster %d", basis, count, cluster);
    return {};
  }
};

namespace detail {

/// Deterministic k-means over the columns `ids` of x: farthest-point seeds (the first farthest
/// from the mean), then Lloyd iterations; an emptied cluster is re-seeded with the point
/// farthest from its centroid. Returns the label per id (0..k−1) and the centroids (d × k).
inline std::vector<int> spmm_kmeans(const Eigen::MatrixXf& x, const std::vector<Eigen::Index>& ids, int k,
                                    int iterations, Eigen::MatrixXf& centroids, ThreadPool& pool) {
  using Eigen::Index;
  const size_t m = ids.size();
  const Index d = x.rows();
  k = static_cast<int>(std::min<size_t>(static_cast<size_t>(k), m));
  std::vector<int> label(m, 0);
  centroids.setZero(d, k);
  if (m == 0 || k <= 0) return label;
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(d);
  for (Index t : ids) mean += x.col(t).cast<double>();
  mean /= static_cast<double>(m);
  std::vector<double> dist(m, std::numeric_limits<double>::infinity());
  size_t seed = 0;
  double best = -1.0;
  for (size_t i = 0; i < m; ++i) {
    const double dd = (x.col(ids[i]).cast<double>() - mean).squaredNorm();
    if (dd > best) best = dd, seed = i;
  }
  for (int j = 0; j < k; ++j) {
    centroids.col(j) = x.col(ids[seed]);
    pool.parallel_for(0, m, 256, [&](size_t a, size_t b) {
      for (size_t i = a; i < b; ++i) {
        const double dd = (x.col(ids[i]) - centroids.col(j)).squaredNorm();
        if (dd < dist[i]) dist[i] = dd, label[i] = j;
      }
    });
    double far = -1.0;
    for (size_t i = 0; i < m; ++i)
      if (dist[i] > far) far = dist[i], seed = i;
  }
  for (int it = 0; it < iterations; ++it) {
    // Update.
    Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(d, k);
    std::vector<size_t> count(static_cast<size_t>(k), 0);
    for (size_t i = 0; i < m; ++i) {
      sum.col(label[i]) += x.col(ids[i]).cast<double>();
      ++count[static_cast<size_t>(label[i])];
    }
    for (int j = 0; j < k; ++j)
      if (count[static_cast<size_t>(j)])
        centroids.col(j) = (sum.col(j) / static_cast<double>(count[static_cast<size_t>(j)])).cast<float>();
    // Assign.
    bool changed = false;
    std::vector<int> next(m);
    pool.parallel_for(0, m, 256, [&](size_t a, size_t b) {
      for (size_t i = a; i < b; ++i) {
        int bj = 0;
        double bd = std::numeric_limits<double>::infinity();
        for (int j = 0; j < k; ++j) {
          const double dd = (x.col(ids[i]) - centroids.col(j)).squaredNorm();
          if (dd < bd) bd = dd, bj = j;
        }
        next[i] = bj;
        dist[i] = bd;
      }
    });
    std::fill(count.begin(), count.end(), 0);
    for (int l : next) ++count[static_cast<size_t>(l)];
    for (int j = 0; j < k; ++j)
      if (count[static_cast<size_t>(j)] == 0) {
        size_t worst = m;
        for (size_t i = 0; i < m; ++i)
          if (count[static_cast<size_t>(next[i])] > 1 && (worst == m || dist[i] > dist[worst])) worst = i;
        if (worst == m) continue;
        --count[static_cast<size_t>(next[worst])];
        next[worst] = j;
        dist[worst] = 0.0;
        ++count[static_cast<size_t>(j)];
      }
    changed = next != label;
    label = std::move(next);
    if (!changed) break;
  }
  return label;
}

/// The data of one dictionary fit: grey target values at a subset of direction pairs.
struct SpmmFitData {
  std::vector<glm::vec3> light, view;
};

inline double spmm_logistic(double u) { return 1.0 / (1.0 + std::exp(-u)); }

/// Maps unconstrained u to a basis of `model` (κ_i through a logistic into its range, on a log
/// scale where flagged; the normal as normalize(s·tanh u_a, s·tanh u_b, 1), tilt ≤ 60°).
inline AnalyticBasis spmm_basis_from(AnalyticModel model, const Eigen::VectorXd& u) {
  AnalyticBasis b;
  b.model = model;
  const auto info = analytic_param_info(model);
  for (size_t i = 0; i < info.size(); ++i) {
    const double f = spmm_logistic(u[static_cast<Eigen::Index>(i)]);
    double v;
    if (info[i].log_scale)
      v = std::exp(std::log(info[i].min) + f * (std::log(info[i].max) - std::log(info[i].min)));
    else
      v = info[i].min + f * (info[i].max - info[i].min);
    b.kappa[i] = std::clamp(static_cast<float>(v), info[i].min, info[i].max);
  }
  const Eigen::Index o = static_cast<Eigen::Index>(info.size());
  const double s = 1.7320508;  // tan 60°
  const glm::vec3 n(static_cast<float>(s * std::tanh(u[o])), static_cast<float>(s * std::tanh(u[o + 1])), 1.0f);
  b.normal = glm::normalize(n);
  return b;
}

/// Inverse of spmm_basis_from for κ (normal = +z).
inline Eigen::VectorXd spmm_params_to(AnalyticModel model, std::span<const float> kappa) {
  const auto info = analytic_param_info(model);
  Eigen::VectorXd u = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(info.size()) + 2);
  for (size_t i = 0; i < info.size(); ++i) {
    double f;
    if (info[i].log_scale)
      f = (std::log(kappa[i]) - std::log(info[i].min)) / (std::log(info[i].max) - std::log(info[i].min));
    else
      f = (kappa[i] - info[i].min) / (info[i].max - info[i].min);
    f = std::clamp(f, 1e-3, 1.0 - 1e-3);
    u[static_cast<Eigen::Index>(i)] = std::log(f / (1.0 - f));
  }
  return u;
}

/// Fits one basis of `model` to `target` (variable projection, α* ≥ 0 closed form) by LM from
/// the best of a few starting points. Returns the basis, writes α* and the squared error.
AnalyticBasis spmm_fit_basis(AnalyticModel model, const SpmmFitData& data, const Eigen::VectorXd& target,
                             int max_evaluations, double& alpha, double& cost);

/// Non-negative stagewise LASSO (BLasso, Zhao & Yu 2007, with the constraint β ≥ 0) of one
/// texel on the quadratic loss L(β) = ‖y‖² − 2cᵀβ + βᵀGβ over 3·M coordinates (channel-major:
/// coordinate ch·M + j), G = blockdiag(g, g, g) with g = BᵀB (M × M). At most `cap` distinct
/// basis functions j may be non-zero. Forward steps add ε to the coordinate that lowers L most;
/// backward steps remove ε when that lowers the penalised loss L + λ‖β‖₁; λ decreases along
/// the path, which ends when no forward step lowers L (λ ≤ 0) or after max_steps.
inline void spmm_blasso(const Eigen::MatrixXd& g, const Eigen::VectorXd& c, int cap, double step_fraction,
                        int max_steps, Eigen::VectorXd& beta) {
  const Eigen::Index mm = g.rows(), dim = 3 * mm;
  beta.setZero(dim);
  double scale = 0.0;
  for (Eigen::Index k = 0; k < dim; ++k) {
    const double gkk = g(k % mm, k % mm);
    if (gkk > 0.0) scale = std::max(scale, c[k] / gkk);
  }
  if (!(scale > 0.0)) return;
  const double eps = step_fraction * scale;
  Eigen::VectorXd gb = Eigen::VectorXd::Zero(dim);  // G·β
  std::vector<int> channels_used(static_cast<size_t>(mm), 0);
  int used = 0;
  const double xi = 1e-12 * c.cwiseAbs().maxCoeff() * eps;
  auto apply = [&](Eigen::Index k, double delta) {
    const Eigen::Index ch = k / mm, j = k % mm;
    const bool was = beta[k] > 0.0;
    beta[k] = std::max(0.0, beta[k] + delta);
    gb.segment(ch * mm, mm) += delta * g.col(j);
    const bool is = beta[k] > 0.0;
    if (was != is) {
      int& u = channels_used[static_cast<size_t>(j)];
      if (is) {
        if (u++ == 0) ++used;
      } else if (--u == 0) {
        --used;
      }
    }
  };
  auto forward = [&](double& delta_loss) {
    Eigen::Index best = -1;
    double bd = 0.0;
    for (Eigen::Index k = 0; k < dim; ++k) {
      const Eigen::Index j = k % mm;
      if (channels_used[static_cast<size_t>(j)] == 0 && used >= cap) continue;
      const double dl = -2.0 * eps * (c[k] - gb[k]) + eps * eps * g(j, j);
      if (dl < bd) bd = dl, best = k;
    }
    delta_loss = bd;
    return best;
  };
  double dl = 0.0;
  Eigen::Index k0 = forward(dl);
  if (k0 < 0) return;
  apply(k0, eps);
  double lambda = -dl / eps;
  for (int step = 1; step < max_steps; ++step) {
    // Backward step.
    Eigen::Index bk = -1;
    double bdl = std::numeric_limits<double>::infinity(), bsize = 0.0;
    for (Eigen::Index k = 0; k < dim; ++k) {
      if (beta[k] <= 0.0) continue;
      const double s = std::min(eps, beta[k]);
      const double d = 2.0 * s * (c[k] - gb[k]) + s * s * g(k % mm, k % mm);
      if (d < bdl) bdl = d, bk = k, bsize = s;
    }
    if (bk >= 0 && bdl - lambda * bsize < -xi) {
      apply(bk, -bsize);
      continue;
    }
    const Eigen::Index fk = forward(dl);
    if (fk < 0) break;
    apply(fk, eps);
    lambda = std::min(lambda, (-dl - xi) / eps);
    if (lambda <= 0.0) break;
  }
}

}  // namespace detail

/// Fits the SPMM of `btf` (paper 003 §3; see the file comment for the steps). Deterministic
/// for any thread count. Errors: empty BTF, options out of range (K ∉ [1, min(texels, 65535)],
/// representatives < 1, lobes < 0, no enabled model, max_basis_per_texel ∉ [1, 64],
/// residual_components < 0, fit_samples < 1); Status::cancelled when progress returns false.
/// Memory: one float copy of the BTF (d × texels) plus O(K·d·N_PCA).
Result<Spmm> factorize_spmm(const BtfFloat& btf, const SpmmOptions& options = {},
                            const ProgressCallback& progress = {});

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_FACTOR_IMPLEMENTATION)
// The Levenberg–Marquardt fits (Eigen's LevenbergMarquardt) and the factorisation are compiled once, in the
// implementation TU.
namespace btflod {

namespace detail {
AnalyticBasis spmm_fit_basis(AnalyticModel model, const SpmmFitData& data, const Eigen::VectorXd& target,
                             int max_evaluations, double& alpha, double& cost) {
  const Eigen::Index m = static_cast<Eigen::Index>(data.light.size());
  Eigen::VectorXd values(m);
  auto eval = [&](const Eigen::VectorXd& u, Eigen::VectorXd& r, double* a_out) {
    const AnalyticBasis b = spmm_basis_from(model, u);
    for (Eigen::Index i = 0; i < m; ++i)
      values[i] = evaluate_analytic_basis(b, data.light[static_cast<size_t>(i)], data.view[static_cast<size_t>(i)]);
    const double bb = values.squaredNorm();
    const double a = bb > 0.0 ? std::max(0.0, values.dot(target) / bb) : 0.0;
    r = target - a * values;
    if (a_out) *a_out = a;
  };
  // Starting points: every log-scale parameter at the same fraction of its (log) range.
  const auto info = analytic_param_info(model);
  Eigen::VectorXd best_u;
  double best = std::numeric_limits<double>::infinity();
  Eigen::VectorXd r(m);
  for (double f : {0.15, 0.4, 0.65}) {
    std::array<float, kAnalyticMaxParams> k{};
    for (size_t i = 0; i < info.size(); ++i)
      k[i] = info[i].log_scale ? static_cast<float>(std::exp(std::log(info[i].min) +
                                                             f * (std::log(info[i].max) - std::log(info[i].min))))
                               : info[i].initial;
    const Eigen::VectorXd u = spmm_params_to(model, std::span<const float>(k.data(), info.size()));
    eval(u, r, nullptr);
    const double c = r.squaredNorm();
    if (c < best) best = c, best_u = u;
    if (info.empty()) break;
  }
  if (m > best_u.size()) {
    LeastSquaresOptions lo;
    lo.max_evaluations = max_evaluations;
    lo.tolerance = 1e-8;
    minimize_least_squares_numeric(
        best_u, m, [&](const Eigen::VectorXd& u, Eigen::VectorXd& out) { eval(u, out, nullptr); }, lo);
  }
  eval(best_u, r, &alpha);
  cost = r.squaredNorm();
  return spmm_basis_from(model, best_u);
}
}  // namespace detail

Result<Spmm> factorize_spmm(const BtfFloat& btf, const SpmmOptions& options, const ProgressCallback& progress) {
  using Eigen::Index;
  const size_t n = btf.texel_count(), nl = btf.light_count(), nv = btf.view_count(), nvl = nv * nl, d = nvl * 3;
  if (btf.empty() || options.clusters < 1 || static_cast<size_t>(options.clusters) > n || options.clusters > 65535 ||
      options.representatives < 1 || options.lobes_per_representative < 0 ||
      (options.model_mask & kSpmmAllModels) == 0 || options.max_basis_per_texel < 1 ||
      options.max_basis_per_texel > 64 || options.residual_components < 0 || options.fit_samples < 1 ||
      options.kmeans_iterations < 0 || !(options.lasso_step > 0.0f && options.lasso_step <= 1.0f))
    return make_error(Status::invalid_argument,
                      "factorize_spmm: invalid options (K=%d, representatives=%d, lobes=%d, models=0x%x, #BF cap=%d, "
                      "N_PCA=%d, fit samples=%d, lasso step=%g) for %zu texels",
                      options.clusters, options.representatives, options.lobes_per_representative, options.model_mask,
                      options.max_basis_per_texel, options.residual_components, options.fit_samples,
                      static_cast<double>(options.lasso_step), n);
  ThreadPool& pool = options.svd.pool ? *options.svd.pool : default_thread_pool();
  Eigen::MatrixXf x(static_cast<Index>(d), static_cast<Index>(n));  // columns = texel ABRDFs
  gather_fmf_columns(btf, 0, n, x);
  auto cancelled = [] { return make_error(Status::cancelled, "factorize_spmm cancelled"); };

  // 1. Clusters.
  std::vector<Index> all(n);
  for (size_t t = 0; t < n; ++t) all[t] = static_cast<Index>(t);
  Eigen::MatrixXf centroids;
  const std::vector<int> label =
      detail::spmm_kmeans(x, all, options.clusters, options.kmeans_iterations, centroids, pool);
  const int K = options.clusters;
  std::vector<std::vector<Index>> members(static_cast<size_t>(K));
  for (size_t t = 0; t < n; ++t) members[static_cast<size_t>(label[t])].push_back(static_cast<Index>(t));
  if (!report_progress(progress, "spmm clusters", 0.05)) return cancelled();

  // Direction pairs of the dictionary fit (strided subset of the measured pairs).
  const size_t fit_count = std::min<size_t>(nvl, static_cast<size_t>(options.fit_samples));
  std::vector<size_t> fit_pairs(fit_count);
  for (size_t i = 0; i < fit_count; ++i) fit_pairs[i] = i * nvl / fit_count;
  detail::SpmmFitData fit;
  for (size_t i : fit_pairs) {
    fit.view.push_back(btf.views()[i / nl].vector);
    fit.light.push_back(btf.lights()[i % nl].vector);
  }
  std::vector<AnalyticModel> models;
  for (uint32_t id = 0; id < kAnalyticModelCount; ++id)
    if (options.model_mask & (1u << id)) models.push_back(static_cast<AnalyticModel>(id));

  // 2. Dictionaries: Lambert (n = +z), then greedy lobes per representative.
  Spmm p;
  p.shape = BtfShape{btf.width(), btf.height(), btf.views(), btf.lights()};
  p.slots = options.max_basis_per_texel;
  p.dictionaries.resize(static_cast<size_t>(K));
  const AnalyticBasis lambert{};
  for (int j = 0; j < K; ++j) {
    const auto& mem = members[static_cast<size_t>(j)];
    Eigen::MatrixXf sub;
    const std::vector<int> sl =
        detail::spmm_kmeans(x, mem, options.representatives, options.kmeans_iterations, sub, pool);
    // Representative = the member nearest each sub-centroid.
    std::vector<Index> reps(static_cast<size_t>(sub.cols()), -1);
    std::vector<double> rd(static_cast<size_t>(sub.cols()), std::numeric_limits<double>::infinity());
    for (size_t i = 0; i < mem.size(); ++i) {
      const double dd = (x.col(mem[i]) - sub.col(sl[i])).squaredNorm();
      if (dd < rd[static_cast<size_t>(sl[i])])
        rd[static_cast<size_t>(sl[i])] = dd, reps[static_cast<size_t>(sl[i])] = mem[i];
    }
    std::vector<std::vector<AnalyticBasis>> lobes(reps.size());
    std::atomic<bool> stop{false};
    pool.parallel_for(0, reps.size(), 1, [&](size_t r0, size_t r1) {
      for (size_t ri = r0; ri < r1 && !stop; ++ri) {
        if (reps[ri] < 0) continue;
        Eigen::VectorXd y(static_cast<Index>(fit_count));
        for (size_t i = 0; i < fit_count; ++i) {
          const Index row = static_cast<Index>(fit_pairs[i] * 3);
          y[static_cast<Index>(i)] =
              (static_cast<double>(x(row, reps[ri])) + x(row + 1, reps[ri]) + x(row + 2, reps[ri])) / 3.0;
        }
        // Remove the best non-negative Lambert part first, so lobes describe what it leaves.
        Eigen::VectorXd lam(static_cast<Index>(fit_count));
        for (size_t i = 0; i < fit_count; ++i)
          lam[static_cast<Index>(i)] = evaluate_analytic_basis(lambert, fit.light[i], fit.view[i]);
        y -= std::max(0.0, lam.dot(y) / std::max(lam.squaredNorm(), 1e-30)) * lam;
        for (int lobe = 0; lobe < options.lobes_per_representative; ++lobe) {
          AnalyticBasis best_b;
          double best_cost = std::numeric_limits<double>::infinity(), best_alpha = 0.0;
          for (AnalyticModel m : models) {
            double a = 0.0, c = 0.0;
            const AnalyticBasis b = detail::spmm_fit_basis(m, fit, y, options.lm_evaluations, a, c);
            if (c < best_cost) best_cost = c, best_b = b, best_alpha = a;
          }
          if (!(best_alpha > 0.0)) break;  // nothing left that a non-negative lobe explains
          lobes[ri].push_back(best_b);
          for (size_t i = 0; i < fit_count; ++i)
            y[static_cast<Index>(i)] -= best_alpha * evaluate_analytic_basis(best_b, fit.light[i], fit.view[i]);
        }
      }
    });
    auto& dict = p.dictionaries[static_cast<size_t>(j)];
    dict.push_back(lambert);
    for (const auto& l : lobes) dict.insert(dict.end(), l.begin(), l.end());
    if (!report_progress(progress, "spmm dictionaries", 0.05 + 0.6 * static_cast<double>(j + 1) / K))
      return cancelled();
  }

  // 3. Weights by non-negative stagewise LASSO; x becomes the residual x − Σ α ρ.
  const size_t s = static_cast<size_t>(p.slots);
  p.cluster_of.resize(n);
  for (size_t t = 0; t < n; ++t) p.cluster_of[t] = static_cast<uint16_t>(label[t]);
  p.slot_basis.assign(n * s, kSpmmEmptySlot);
  p.slot_weight.assign(n * s * 3, 0.0f);
  for (int j = 0; j < K; ++j) {
    const auto& dict = p.dictionaries[static_cast<size_t>(j)];
    const Index mm = static_cast<Index>(dict.size());
    Eigen::MatrixXd b(static_cast<Index>(nvl), mm);
    for (size_t i = 0; i < nvl; ++i)
      for (Index q = 0; q < mm; ++q)
        b(static_cast<Index>(i), q) = evaluate_analytic_basis(dict[static_cast<size_t>(q)], btf.lights()[i % nl].vector,
                                                              btf.views()[i / nl].vector);
    const Eigen::MatrixXd g = b.transpose() * b;
    const auto& mem = members[static_cast<size_t>(j)];
    pool.parallel_for(0, mem.size(), 16, [&](size_t i0, size_t i1) {
      Eigen::VectorXd c(3 * mm), beta, y(static_cast<Index>(nvl));
      for (size_t i = i0; i < i1; ++i) {
        const Index t = mem[i];
        for (Index ch = 0; ch < 3; ++ch) {
          for (size_t r = 0; r < nvl; ++r) y[static_cast<Index>(r)] = x(static_cast<Index>(r * 3) + ch, t);
          c.segment(ch * mm, mm) = b.transpose() * y;
        }
        detail::spmm_blasso(g, c, p.slots, options.lasso_step, options.lasso_max_steps, beta);
        size_t slot = 0;
        for (Index q = 0; q < mm; ++q) {
          if (beta[q] <= 0.0 && beta[mm + q] <= 0.0 && beta[2 * mm + q] <= 0.0) continue;
          const size_t at = static_cast<size_t>(t) * s + slot++;
          p.slot_basis[at] = static_cast<uint16_t>(q);
          for (Index ch = 0; ch < 3; ++ch)
            p.slot_weight[at * 3 + static_cast<size_t>(ch)] = static_cast<float>(beta[ch * mm + q]);
          for (size_t r = 0; r < nvl; ++r)
            for (Index ch = 0; ch < 3; ++ch)
              x(static_cast<Index>(r * 3) + ch, t) -=
                  static_cast<float>(beta[ch * mm + q] * b(static_cast<Index>(r), q));
        }
      }
    });
    if (!report_progress(progress, "spmm weights", 0.65 + 0.2 * static_cast<double>(j + 1) / K)) return cancelled();
  }

  // 4. Residual: per cluster mean and N_PCA principal components (eq. 3).
  const size_t pc = static_cast<size_t>(options.residual_components);
  p.residual_components = options.residual_components;
  p.residual_mean.assign(static_cast<size_t>(K) * d, 0.0f);
  p.residual_basis.assign(static_cast<size_t>(K) * d * pc, 0.0f);
  p.residual_coef.assign(n * pc, 0.0f);
  for (int j = 0; j < K; ++j) {
    const auto& mem = members[static_cast<size_t>(j)];
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(static_cast<Index>(d));
    for (Index t : mem) sum += x.col(t).cast<double>();
    const Eigen::VectorXf mean = (sum / static_cast<double>(std::max<size_t>(mem.size(), 1))).cast<float>();
    std::copy(mean.data(), mean.data() + d,
              p.residual_mean.begin() + static_cast<ptrdiff_t>(static_cast<size_t>(j) * d));
    if (pc == 0 || mem.size() < 2) continue;
    auto gather = [&](size_t col0, size_t count, Eigen::MatrixXf& out) {
      for (size_t i = 0; i < count; ++i) out.col(static_cast<Index>(i)) = x.col(mem[col0 + i]) - mean;
    };
    auto svd = truncated_svd(d, mem.size(), static_cast<int>(pc), gather, options.svd);
    if (!svd) return svd.error();
    const Index got = svd->u.cols();
    for (size_t i = 0; i < d; ++i)
      for (Index q = 0; q < got; ++q)
        p.residual_basis[(static_cast<size_t>(j) * d + i) * pc + static_cast<size_t>(q)] =
            svd->u(static_cast<Index>(i), q);
    pool.parallel_for(0, mem.size(), 64, [&](size_t i0, size_t i1) {
      for (size_t i = i0; i < i1; ++i) {
        const Eigen::VectorXf w = svd->u.transpose() * (x.col(mem[i]) - mean);
        for (Index q = 0; q < got; ++q)
          p.residual_coef[static_cast<size_t>(mem[i]) * pc + static_cast<size_t>(q)] = w[q];
      }
    });
    if (!report_progress(progress, "spmm residual", 0.85 + 0.15 * static_cast<double>(j + 1) / K)) return cancelled();
  }
  return p;
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
