// btflod — factor/'s SPMM (paper 003 eq. 1–3) packed into the GPU layout of the spmm program
// (backend.hpp's SpmmMaterialData, docs/shaders.md), the CPU twin of what that program computes
// (Spmm::evaluate, the oracle of the golden tests) and the count of texture fetches it issues.
//
// Set-up code: pack_spmm_material allocates and is not meant for per-frame use. reference_spmm
// and spmm_fragment_fetches are noexcept, allocation-free and thread-safe on const data.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/result.hpp"
#include "btflod/offline/factor/spmm.hpp"
#include "btflod/offline/packing/representation_packing.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod {

/// Owning storage of a packed SPMM material; data() views it.
struct PackedSpmm {
  SpmmMaterialData info;  ///< counts; spans are filled by data()
  std::vector<uint32_t> texels;
  std::vector<float> dictionary, residual;
  /// First global dictionary index of each cluster (basis j of cluster c is entry first[c] + j).
  std::vector<uint32_t> first_basis;
  /// The material with spans into this object and the given angular tables (kept alive by the caller).
  SpmmMaterialData data(const AngularTablesData& angular) const {
    SpmmMaterialData d = info;
    d.texels = texels;
    d.dictionary = dictionary;
    d.residual = residual;
    d.angular = angular;
    return d;
  }
};

/// Packs `p` for the spmm program (layout in SpmmMaterialData): the cluster dictionaries are
/// concatenated into one global dictionary, each texel's occupied slots are moved first (their
/// order does not change the sum of eq. 1), the residual mean and components become layers of
/// the residual table. Returns invalid_argument for an empty representation, more than 64 slots
/// or components, K·(P+1) > 2048 or a texel larger than 16384 (the GPU limits validate_material
/// checks). Allocates about the size of the representation.
inline Result<PackedSpmm> pack_spmm_material(const Spmm& p) {
  const size_t n = p.shape.texel_count(), S = static_cast<size_t>(p.slots),
               P = static_cast<size_t>(p.residual_components);
  const size_t K = static_cast<size_t>(p.clusters()), lights = p.shape.light_count(), views = p.shape.view_count();
  size_t total = 0;
  for (const auto& d : p.dictionaries) total += d.size();
  if (n == 0 || S == 0 || S > 64 || P > 64 || K == 0 || K * (P + 1) > 2048 || total == 0 || p.shape.width > 16384 ||
      p.shape.height > 16384 || p.cluster_of.size() != n || p.slot_basis.size() != n * S ||
      p.slot_weight.size() != n * S * 3 || p.residual_mean.size() != K * p.angular_size() ||
      p.residual_basis.size() != K * p.angular_size() * P || p.residual_coef.size() != n * P)
    return make_error(Status::invalid_argument,
                      "pack_spmm_material: %zu texels, S = %zu, P = %zu, K = %zu, %zu bases (expected S 1..64, P "
                      "0..64, K·(P+1) ≤ 2048, consistent arrays)",
                      n, S, P, K, total);
  PackedSpmm out;
  SpmmMaterialData& m = out.info;
  m.slots = static_cast<uint32_t>(S);
  m.residual_components = static_cast<uint32_t>(P);
  m.clusters = static_cast<uint32_t>(K);
  m.bases = static_cast<uint32_t>(total);
  m.light_count = static_cast<uint32_t>(lights);
  m.view_count = static_cast<uint32_t>(views);
  m.width = static_cast<uint32_t>(p.shape.width);
  m.height = static_cast<uint32_t>(p.shape.height);
  // Dictionary: 2 RGBA texels per basis, kSpmmBasesPerRow per row (paper 003 eq. 2: model, κ_j, n_j).
  out.first_basis.resize(K);
  const size_t rows = (total + kSpmmBasesPerRow - 1) / kSpmmBasesPerRow;
  out.dictionary.assign(rows * 2 * kSpmmBasesPerRow * 4, 0.0f);
  size_t g = 0;
  for (size_t c = 0; c < K; ++c) {
    out.first_basis[c] = static_cast<uint32_t>(g);
    for (const AnalyticBasis& b : p.dictionaries[c]) {
      float* o = &out.dictionary[((g / kSpmmBasesPerRow) * 2 * kSpmmBasesPerRow + 2 * (g % kSpmmBasesPerRow)) * 4];
      o[0] = static_cast<float>(static_cast<uint32_t>(b.model));
      o[1] = b.kappa[0];
      o[2] = b.kappa[1];
      o[3] = b.kappa[2];
      o[4] = b.normal.x;
      o[5] = b.normal.y;
      o[6] = b.normal.z;
      ++g;
    }
  }
  // Per-texel layers: slots (occupied first), then [cluster, coef_0 … coef_{P−1}] 4 per texel.
  const size_t rl = spmm_residual_layers(static_cast<uint32_t>(P));
  out.texels.assign((S + rl) * n * 4, 0u);
  auto bits = [](float f) {
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
  };
  for (size_t t = 0; t < n; ++t) {
    size_t k = 0;
    for (size_t s = 0; s < S; ++s) {
      const uint16_t j = p.slot_basis[t * S + s];
      if (j == kSpmmEmptySlot) continue;
      uint32_t* o = &out.texels[(k++ * n + t) * 4];
      o[0] = out.first_basis[p.cluster_of[t]] + j;
      for (size_t c = 0; c < 3; ++c) o[1 + c] = bits(p.slot_weight[(t * S + s) * 3 + c]);
    }
    for (; k < S; ++k) out.texels[(k * n + t) * 4] = 0xffffffffu;
    for (size_t e = 0; e <= P; ++e)
      out.texels[((S + e / 4) * n + t) * 4 + e % 4] = e == 0 ? p.cluster_of[t] : bits(p.residual_coef[t * P + e - 1]);
  }
  // Residual table: texel (light, view), layer c·(P+1) + i (paper 003 eq. 3).
  out.residual.assign(K * (P + 1) * views * lights * 4, 0.0f);
  const size_t d = p.angular_size();
  for (size_t c = 0; c < K; ++c)
    for (size_t i = 0; i <= P; ++i)
      for (size_t v = 0; v < views; ++v)
        for (size_t l = 0; l < lights; ++l)
          for (size_t col = 0; col < 3; ++col) {
            const size_t row = (v * lights + l) * 3 + col;
            out.residual[(((c * (P + 1) + i) * views + v) * lights + l) * 4 + col] =
                i == 0 ? p.residual_mean[c * d + row] : p.residual_basis[(c * d + row) * P + (i - 1)];
          }
  return out;
}

/// What the spmm program computes at uv for local directions wl, wv: Spmm::evaluate at the
/// texel ⌊fract(uv)·(W, H)⌋ — the analytic part (eq. 1–2) at the exact directions, the residual
/// (eq. 3) through the tables' 3 × 3 taps (barycentric unless `nearest`) — with the residual
/// switch `options` (ShaderParams::ids.w = spmm_residual_mode(options.residual,
/// options.pca_components)). RGB, not multiplied by the light colour. noexcept.
inline glm::vec3 reference_spmm(const Spmm& p, const AngularTablesData& tables, DirectionParameterisation param,
                                bool nearest, glm::vec2 uv, glm::vec3 wl, glm::vec3 wv,
                                const SpmmEvalOptions& options = {}) noexcept {
  const glm::ivec2 t = representation_texel(uv, p.shape.width, p.shape.height);
  return p.evaluate(t.x, t.y, wl, wv, angular_table_sample(tables, 0, param, nearest, wl),
                    angular_table_sample(tables, 1, param, nearest, wv), options);
}

/// Texture fetches the spmm program issues for one fragment, by kind (docs/shaders.md).
struct SpmmFetchCount {
  uint32_t texel = 0;       ///< spmm_texels: slots read (up to the first empty) + residual layers
  uint32_t dictionary = 0;  ///< spmm_dictionary: 2 per occupied slot (data-addressed: scattered)
  uint32_t angular = 0;     ///< angular tables: 4 (index + weight, light + view) with a residual
  uint32_t residual = 0;    ///< spmm_residual: (1 + n) per tap pair of non-zero weight (scattered)
  uint32_t total() const noexcept { return texel + dictionary + angular + residual; }
};

/// The fetches of the spmm program at texel (x, y) with `taps` tap pairs of non-zero weight
/// (9 for barycentric taps inside a triangle) and residual switch `mode`
/// (spmm_residual_mode()). Precondition: validate_material(m) passed, (x, y) in range. noexcept.
inline SpmmFetchCount spmm_fragment_fetches(const SpmmMaterialData& m, uint32_t x, uint32_t y, uint32_t taps,
                                            uint32_t mode) noexcept {
  const size_t n = static_cast<size_t>(m.width) * m.height, t = static_cast<size_t>(y) * m.width + x;
  SpmmFetchCount f;
  uint32_t used = 0;
  while (used < m.slots && m.texels[(used * n + t) * 4] != 0xffffffffu) ++used;
  f.texel = std::min(used + 1, m.slots);
  f.dictionary = 2 * used;
  if (mode == 1u) return f;
  const uint32_t comps = mode == 0u ? m.residual_components : std::min(mode - 2u, m.residual_components);
  f.texel += comps / 4 + 1;
  f.angular = 4;
  f.residual = taps * (1 + comps);
  return f;
}

}  // namespace btflod
