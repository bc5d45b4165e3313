// btflod — factor/'s Laplacian-pyramid PCA, local PCA and PCA-k representations packed into the
// GPU layouts of the laplacian, lpca and pca_views programs (backend.hpp's *MaterialData,
// docs/shaders.md), and CPU twins of exactly what those programs compute, built on the
// representations' own CPU evaluators (the oracle of the golden tests).
//
// Set-up code: the pack_* functions allocate and are not meant for per-frame use. The
// reference_* functions are noexcept, allocation-free and thread-safe on const data.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/result.hpp"
#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/angular/parameterization.hpp"
#include "btflod/offline/angular/table_lookup.hpp"
#include "btflod/offline/factor/laplacian_pca.hpp"
#include "btflod/offline/factor/local_pca.hpp"
#include "btflod/offline/factor/pca_views.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod {

/// Texel ⌊fract(uv)·(w, h)⌋, clamped — the shaders' texelFetch address. noexcept.
inline glm::ivec2 representation_texel(glm::vec2 uv, int w, int h) noexcept {
  const float u = uv.x - std::floor(uv.x), v = uv.y - std::floor(uv.y);
  return {std::clamp(static_cast<int>(u * static_cast<float>(w)), 0, w - 1),
          std::clamp(static_cast<int>(v * static_cast<float>(h)), 0, h - 1)};
}

// --- Laplacian-pyramid PCA (paper 001) ------------------------------------------------------

/// Owning storage of a packed Laplacian material; data() views it.
struct PackedLaplacian {
  LaplacianMaterialData info;  ///< counts; spans are filled by data()
  std::vector<float> eigen, weights, mean;
  /// The material with spans into this object and the given angular tables (kept alive by the caller).
  LaplacianMaterialData data(const AngularTablesData& angular) const {
    LaplacianMaterialData d = info;
    d.eigen = eigen;
    d.weights = weights;
    d.mean = mean;
    d.angular = angular;
    return d;
  }
};

/// Packs `p` for the laplacian program: component j of level k is Y component j (j < n_Y), then
/// Cb, then Cr, each in its own rgb slot of E_kj; C = the largest n_Y + n_Cb + n_Cr of any level.
/// Returns invalid_argument when the finest size is not a power of two (GPU mips halve by
/// flooring, the pyramid by rounding up). Allocates.
inline Result<PackedLaplacian> pack_laplacian_material(const LaplacianPca& p) {
  const uint32_t w = static_cast<uint32_t>(p.shape.width), h = static_cast<uint32_t>(p.shape.height);
  if (p.mips.empty() || !detail::is_pow2(w) || !detail::is_pow2(h))
    return make_error(Status::invalid_argument, "pack_laplacian_material: %ux%u with %zu levels (need powers of two)",
                      w, h, p.mips.size());
  PackedLaplacian out;
  LaplacianMaterialData& m = out.info;
  m.max_level = static_cast<uint32_t>(p.lambda_max());
  m.light_count = static_cast<uint32_t>(p.shape.light_count());
  m.view_count = static_cast<uint32_t>(p.shape.view_count());
  m.width = w;
  m.height = h;
  m.ycbcr = true;
  for (const LaplacianMip& mip : p.mips)
    m.components = std::max<uint32_t>(m.components,
                                      static_cast<uint32_t>(mip.components[0] + mip.components[1] + mip.components[2]));
  m.components = std::max(m.components, 1u);
  const size_t C = m.components, groups = (C + 3) / 4, lights = m.light_count, views = m.view_count;
  out.eigen.assign((m.max_level + 1) * C * lights * views * 4, 0.0f);
  out.weights.assign(detail::laplacian_weight_floats(m), 0.0f);
  out.mean.assign(lights * views * 4, 0.0f);
  size_t woff = 0;
  for (uint32_t k = 0; k <= m.max_level; ++k) {
    const LaplacianMip& mip = p.mips[k];
    const uint32_t wk = std::max(1u, w >> k), hk = std::max(1u, h >> k);
    if (static_cast<uint32_t>(mip.width) != wk || static_cast<uint32_t>(mip.height) != hk)
      return make_error(Status::invalid_argument, "pack_laplacian_material: level %u is %dx%d, expected %ux%u", k,
                        mip.width, mip.height, wk, hk);
    size_t j = 0;
    for (size_t ch = 0; ch < 3; ++ch) {
      const size_t n = static_cast<size_t>(mip.components[ch]);
      for (size_t jj = 0; jj < n; ++jj, ++j) {
        const size_t layer = k * C + j;
        for (size_t v = 0; v < views; ++v)
          for (size_t l = 0; l < lights; ++l)
            out.eigen[((layer * views + v) * lights + l) * 4 + ch] = mip.eigen[ch][(v * lights + l) * n + jj];
        for (size_t y = 0; y < hk; ++y)
          for (size_t x = 0; x < wk; ++x)
            out.weights[woff + (((j / 4) * hk + y) * wk + x) * 4 + j % 4] = mip.weights[ch][(y * wk + x) * n + jj];
      }
    }
    woff += groups * wk * hk * 4;
  }
  for (size_t v = 0; v < views; ++v)
    for (size_t l = 0; l < lights; ++l) {
      float* o = out.mean.data() + (v * lights + l) * 4;
      o[0] = p.phong.evaluate(p.shape.lights[l].vector, p.shape.views[v].vector);  // paper 001 eq. 5
      o[1] = p.cb_mean;                                                            // eq. 6
      o[2] = p.cr_mean;
    }
  return out;
}

/// What the laplacian program computes at texture coordinate uv for local directions wl, wv and
/// scaled eye distance d·lod.z, through LaplacianPca::evaluate_measured (eq. 7): the nearest
/// table directions, λ = clamp(log2(d·lod.z), 0, λmax), texel ⌊fract(uv)·(W, H)⌋. RGB (not
/// multiplied by the light colour). noexcept.
inline glm::vec3 reference_laplacian(const LaplacianPca& p, const AngularTablesData& tables,
                                     DirectionParameterisation param, glm::vec2 uv, glm::vec3 wl, glm::vec3 wv,
                                     float scaled_distance) noexcept {
  const AngularSample ls = angular_table_sample(tables, 0, param, true, wl);
  const AngularSample vs = angular_table_sample(tables, 1, param, true, wv);
  const float lambda =
      std::clamp(std::log2(std::max(scaled_distance, 1e-20f)), 0.0f, static_cast<float>(p.lambda_max()));
  const glm::ivec2 t = representation_texel(uv, p.shape.width, p.shape.height);
  return p.evaluate_measured(t.x, t.y, vs.index[0], ls.index[0], lambda);
}

// --- Local PCA (paper 002) ------------------------------------------------------------------

namespace detail {
inline glm::vec3 unit_square_to_direction(DirectionParameterisation p, glm::vec2 st) noexcept {
  return p == DirectionParameterisation::parabolic ? ParabolicMap::from_square(st)
                                                   : ElevatedConcentricMap::from_square(st);
}
}  // namespace detail

/// Owning storage of a packed LPCA material; data() views it.
struct PackedLpca {
  LpcaMaterialData info;
  std::vector<uint32_t> cluster;
  std::vector<float> weights;
  std::vector<int8_t> volume;
  /// s_{k,j}: the 8-bit scale of slot j of cluster k (index k·(C+1) + j), folded into weights.
  std::vector<float> scales;
  LpcaMaterialData data() const {
    LpcaMaterialData d = info;
    d.cluster = cluster;
    d.weights = weights;
    d.volume = volume;
    return d;
  }
};

/// Packs `p` for the lpca program with an R⁴ grid (paper 002 §6.2). Each grid direction (inverse
/// of `param`, see LpcaMaterialData) is resampled from the measured directions through
/// `tables` (rastered over the same `param`; barycentric unless `nearest`): the cluster means and
/// eigen-BRDFs (q/127 when quantised) are combined over the 3 × 3 taps like LocalPca::evaluate.
/// The resampled volume is then quantised to snorm8 per (cluster, slot) block and the scales
/// are folded into the per-texel weights (paper 002 §6.3, see LpcaMaterialData). Returns
/// invalid_argument for R outside 2..64 or tables that do not name p's directions. Allocates
/// K·(C+1)·R⁴·4 floats of scratch and as many bytes for the volume.
inline Result<PackedLpca> pack_lpca_material(const LocalPca& p, uint32_t grid_resolution,
                                             DirectionParameterisation param, const AngularTablesData& tables,
                                             bool nearest = false) {
  const uint32_t R = grid_resolution;
  const uint32_t lights = static_cast<uint32_t>(p.shape.light_count()),
                 views = static_cast<uint32_t>(p.shape.view_count());
  if (R < 2 || R > 64 || p.clusters < 1 || p.components < 1)
    return make_error(Status::invalid_argument, "pack_lpca_material: R = %u, K = %d, C = %d", R, p.clusters,
                      p.components);
  if (VoidResult v = detail::check_angular(tables, lights, views, tables.resolution); !v) return v.error();
  PackedLpca out;
  LpcaMaterialData& m = out.info;
  m.components = static_cast<uint32_t>(p.components);
  m.clusters = static_cast<uint32_t>(p.clusters);
  m.grid_resolution = R;
  m.width = static_cast<uint32_t>(p.shape.width);
  m.height = static_cast<uint32_t>(p.shape.height);
  m.parameterisation = param;
  const size_t n = p.shape.texel_count(), C = m.components, K = m.clusters, d = p.angular_size();
  out.cluster.assign(p.cluster_of.begin(), p.cluster_of.end());
  // Angular samples of the R² grid directions (view: (s_v, t_v) = (a, b)/(R−1); light likewise).
  std::vector<AngularSample> grid_view(static_cast<size_t>(R) * R), grid_light(static_cast<size_t>(R) * R);
  const float step = 1.0f / static_cast<float>(R - 1);
  for (uint32_t b = 0; b < R; ++b)
    for (uint32_t a = 0; a < R; ++a) {
      const glm::vec3 dir = detail::unit_square_to_direction(
          param, glm::vec2(static_cast<float>(a) * step, static_cast<float>(b) * step));
      grid_view[b * R + a] = angular_table_sample(tables, 1, param, nearest, dir);
      grid_light[b * R + a] = angular_table_sample(tables, 0, param, nearest, dir);
    }
  const size_t W = (C + 1) * R, H = K * R;
  std::vector<float> volume(W * H * R * R * 4, 0.0f);
  auto at = [&](size_t k, size_t j, uint32_t a, uint32_t b, uint32_t c, uint32_t i) {
    return (((static_cast<size_t>(i) * R + c) * H + k * R + b) * W + j * R + a) * 4;
  };
  for (size_t k = 0; k < K; ++k)
    for (size_t j = 0; j <= C; ++j) {
      // E_kj at measured (view, light, colour): j = 0 the mean, else eigen-BRDF j − 1.
      auto value = [&](uint32_t v, uint32_t l, size_t c) -> float {
        const size_t row = (static_cast<size_t>(v) * lights + l) * 3 + c;
        if (j == 0) return p.means[k * d + row];
        const size_t e = (k * d + row) * C + (j - 1);
        return p.quantized ? static_cast<float>(p.eigen_q[e]) * (1.0f / 127.0f) : p.eigen[e];
      };
      for (uint32_t i = 0; i < R; ++i)          // t_l slab
        for (uint32_t c = 0; c < R; ++c)        // s_l
          for (uint32_t b = 0; b < R; ++b)      // t_v
            for (uint32_t a = 0; a < R; ++a) {  // s_v
              const AngularSample& vs = grid_view[b * R + a];
              const AngularSample& ls = grid_light[i * R + c];
              float* o = volume.data() + at(k, j, a, b, c, i);
              for (size_t vi = 0; vi < 3; ++vi)
                for (size_t li = 0; li < 3; ++li) {
                  const float w = vs.weight[vi] * ls.weight[li];
                  if (w == 0.0f) continue;
                  for (size_t col = 0; col < 3; ++col) o[col] += w * value(vs.index[vi], ls.index[li], col);
                }
            }
    }
  // paper 002 §6.3: every eigen-BRDF (here: every resampled (k, j) block, rgb together) is
  // quantised separately to 8 bits with its scale s_{k,j} = max |v|; q/127 is the snorm8 value.
  out.scales.assign(K * (C + 1), 0.0f);
  out.volume.assign(volume.size(), 0);
  for (size_t k = 0; k < K; ++k)
    for (size_t j = 0; j <= C; ++j) {
      float s = 0.0f;
      for (uint32_t i = 0; i < R; ++i)
        for (uint32_t c = 0; c < R; ++c)
          for (uint32_t b = 0; b < R; ++b)
            for (uint32_t a = 0; a < R; ++a)
              for (size_t col = 0; col < 3; ++col) s = std::max(s, std::abs(volume[at(k, j, a, b, c, i) + col]));
      out.scales[k * (C + 1) + j] = s;
      const float inv = s > 0.0f ? 127.0f / s : 0.0f;
      for (uint32_t i = 0; i < R; ++i)
        for (uint32_t c = 0; c < R; ++c)
          for (uint32_t b = 0; b < R; ++b)
            for (uint32_t a = 0; a < R; ++a)
              for (size_t col = 0; col < 3; ++col) {
                const size_t e = at(k, j, a, b, c, i) + col;
                out.volume[e] = static_cast<int8_t>(std::clamp(std::lround(volume[e] * inv), -127L, 127L));
              }
    }
  // Weights α'_j = α_j·s_{k,j}, α'_0 = s_{k,0} (the mean's weight is 1), slot j in layer j/4.
  out.weights.assign(n * 4 * ((C + 4) / 4), 0.0f);
  for (size_t t = 0; t < n; ++t) {
    const size_t k = p.cluster_of[t];
    for (size_t j = 0; j <= C; ++j) {
      const float alpha = j == 0 ? 1.0f : p.weights[t * C + j - 1];
      out.weights[((j / 4) * n + t) * 4 + j % 4] = alpha * out.scales[k * (C + 1) + j];
    }
  }
  return out;
}

namespace detail {
/// The cell of the lpca program's 4D direction grid (R points per axis) that local directions
/// wl, wv fall in: grid coordinates g = (s_v, t_v, s_l, t_l) = clamp(unit square of `param`,
/// 0, 1)·(R − 1), split into the lower corner lo[a] = min(⌊g[a]⌋, R − 1) and the fractions
/// fr[a] = g[a] − lo[a]. Precondition: R ≥ 2, finite directions. noexcept.
struct LpcaGridCell {
  uint32_t lo[4];
  float fr[4];
};
inline LpcaGridCell lpca_grid_cell(DirectionParameterisation param, uint32_t R, glm::vec3 wl, glm::vec3 wv) noexcept {
  const float r1 = static_cast<float>(R - 1);
  const glm::vec2 sv = glm::clamp(glm::vec2(shader_direction_to_unit_square(param, wv)), 0.0f, 1.0f) * r1;
  const glm::vec2 sl = glm::clamp(glm::vec2(shader_direction_to_unit_square(param, wl)), 0.0f, 1.0f) * r1;
  const float g[4] = {sv.x, sv.y, sl.x, sl.y};
  LpcaGridCell c;
  for (int a = 0; a < 4; ++a) {
    c.lo[a] = std::min(static_cast<uint32_t>(std::floor(g[a])), R - 1);
    c.fr[a] = g[a] - static_cast<float>(c.lo[a]);
  }
  return c;
}
/// Calls f(w, q) for each of the 16 corners of `cell` whose quadrilinear weight w (the product
/// over the axes of fr[a] or 1 − fr[a], in axis order) is not 0; q[a] = min(lo[a] + bit a of the
/// corner, R − 1) are the corner's grid indices. noexcept if f is.
template <class F>
void for_each_lpca_corner(const LpcaGridCell& cell, uint32_t R, F&& f) {
  for (int corner = 0; corner < 16; ++corner) {
    float w = 1.0f;
    uint32_t q[4];
    for (int a = 0; a < 4; ++a) {
      const uint32_t up = (corner >> a) & 1;
      w *= up ? cell.fr[a] : 1.0f - cell.fr[a];
      q[a] = std::min(cell.lo[a] + up, R - 1);
    }
    if (w == 0.0f) continue;
    f(w, q);
  }
}
}  // namespace detail

/// What the lpca program computes on the packed (8-bit) material `m` at uv for local
/// directions wl, wv: Σ_j α'_j times the quadrilinear blend over the 16 grid corners of
/// (s_v, t_v, s_l, t_l) (hardware trilinear + the manual t_l lerp of paper 002 §6.2) of the
/// snorm8 texels q/127. RGB, not multiplied by the light colour. Precondition:
/// validate_material(m) passed. noexcept, allocation-free.
inline glm::vec3 reference_lpca_packed(const LpcaMaterialData& m, glm::vec2 uv, glm::vec3 wl, glm::vec3 wv) noexcept {
  const uint32_t R = m.grid_resolution;
  const detail::LpcaGridCell cell = detail::lpca_grid_cell(m.parameterisation, R, wl, wv);
  const glm::ivec2 t = representation_texel(uv, static_cast<int>(m.width), static_cast<int>(m.height));
  const size_t n = static_cast<size_t>(m.width) * m.height;
  const size_t texel = static_cast<size_t>(t.y) * m.width + static_cast<size_t>(t.x), k = m.cluster[texel];
  const size_t C = m.components, W = (C + 1) * R, H = static_cast<size_t>(m.clusters) * R;
  glm::vec3 acc(0.0f);
  for (size_t j = 0; j <= C; ++j) {
    glm::vec3 e(0.0f);
    detail::for_each_lpca_corner(cell, R, [&](float w, const uint32_t(&q)[4]) {
      const int8_t* v = &m.volume[(((static_cast<size_t>(q[3]) * R + q[2]) * H + k * R + q[1]) * W + j * R + q[0]) * 4];
      e += w * glm::vec3(v[0], v[1], v[2]) * (1.0f / 127.0f);
    });
    acc += m.weights[((j / 4) * n + texel) * 4 + j % 4] * e;
  }
  return acc;
}

/// The float oracle of the lpca program (what it would compute on an unquantised volume) at uv
/// for local directions wl, wv: the quadrilinear blend
/// over the 16 grid corners of (s_v, t_v, s_l, t_l) (hardware trilinear + the manual t_l lerp
/// of paper 002 §6.2) of LocalPca::evaluate at the texel ⌊fract(uv)·(W, H)⌋ with each corner's
/// resampled direction taps — equal to the packed volume before its 8-bit quantisation, since
/// evaluate is linear in the eigen-BRDFs; reference_lpca_packed() on the packed material differs
/// from it by at most Σ_j |α'_j|·0.5/127 per channel (rounding of each texel). RGB, not
/// multiplied by the light colour. noexcept.
inline glm::vec3 reference_lpca(const LocalPca& p, uint32_t grid_resolution, DirectionParameterisation param,
                                const AngularTablesData& tables, bool nearest, glm::vec2 uv, glm::vec3 wl,
                                glm::vec3 wv) noexcept {
  const float r1 = static_cast<float>(grid_resolution - 1);
  const detail::LpcaGridCell cell = detail::lpca_grid_cell(param, grid_resolution, wl, wv);
  const glm::ivec2 t = representation_texel(uv, p.shape.width, p.shape.height);
  glm::vec3 acc(0.0f);
  detail::for_each_lpca_corner(cell, grid_resolution, [&](float w, const uint32_t(&q)[4]) {
    const auto unit = [r1](uint32_t i) { return static_cast<float>(i) / r1; };
    const glm::vec3 dv = detail::unit_square_to_direction(param, glm::vec2(unit(q[0]), unit(q[1])));
    const glm::vec3 dl = detail::unit_square_to_direction(param, glm::vec2(unit(q[2]), unit(q[3])));
    acc += w * p.evaluate(t.x, t.y, angular_table_sample(tables, 0, param, nearest, dl),
                          angular_table_sample(tables, 1, param, nearest, dv));
  });
  return acc;
}

// --- PCA over k views (paper 004) -----------------------------------------------------------

/// Owning storage of a packed PCA-k material; data() views it.
struct PackedPcaViews {
  PcaViewsMaterialData info;
  std::vector<float> l, r;
  PcaViewsMaterialData data(const AngularTablesData& angular) const {
    PcaViewsMaterialData d = info;
    d.l = l;
    d.r = r;
    d.angular = angular;
    return d;
  }
};

/// Packs `p` for the pca_views program (layouts in PcaViewsMaterialData); groups with fewer
/// components than the largest are zero-padded. Returns invalid_argument for an empty
/// representation. Allocates.
inline Result<PackedPcaViews> pack_pca_views_material(const PcaViews& p) {
  if (p.groups.empty() || p.views_per_group < 1)
    return make_error(Status::invalid_argument, "pack_pca_views_material: %zu groups, k = %d", p.groups.size(),
                      p.views_per_group);
  PackedPcaViews out;
  PcaViewsMaterialData& m = out.info;
  for (const PcaViewGroup& g : p.groups)
    m.components = std::max<uint32_t>(m.components, static_cast<uint32_t>(g.components));
  m.components = std::max(m.components, 1u);
  m.views_per_group = static_cast<uint32_t>(p.views_per_group);
  m.light_count = static_cast<uint32_t>(p.shape.light_count());
  m.view_count = static_cast<uint32_t>(p.shape.view_count());
  m.width = static_cast<uint32_t>(p.shape.width);
  m.height = static_cast<uint32_t>(p.shape.height);
  const size_t C = m.components, layers = (C + 4) / 4, n = p.shape.texel_count(), nl = m.light_count;
  out.l.assign(p.groups.size() * layers * n * 4, 0.0f);
  out.r.assign(C * nl * m.view_count * 4, 0.0f);
  for (size_t b = 0; b < p.groups.size(); ++b) {
    const PcaViewGroup& g = p.groups[b];
    const size_t kk = static_cast<size_t>(g.components) + 1, cols = static_cast<size_t>(g.view_count) * nl * 3;
    for (size_t t = 0; t < n; ++t)
      for (size_t c = 0; c < kk; ++c) out.l[((b * layers + c / 4) * n + t) * 4 + c % 4] = g.l[t * kk + c];
    for (size_t vv = 0; vv < g.view_count; ++vv)
      for (size_t l = 0; l < nl; ++l)
        for (size_t c = 1; c < kk; ++c)
          for (size_t col = 0; col < 3; ++col)
            out.r[(((l + nl * (g.first_view + vv)) * C) + (c - 1)) * 4 + col] = g.r[c * cols + (vv * nl + l) * 3 + col];
  }
  return out;
}

/// What the pca_views program computes at uv for local directions wl, wv: PcaViews::evaluate
/// at the texel ⌊fract(uv)·(W, H)⌋ with the table's 3 × 3 taps (barycentric unless `nearest`).
/// RGB, not multiplied by the light colour. noexcept.
inline glm::vec3 reference_pca_views(const PcaViews& p, const AngularTablesData& tables,
                                     DirectionParameterisation param, bool nearest, glm::vec2 uv, glm::vec3 wl,
                                     glm::vec3 wv) noexcept {
  const glm::ivec2 t = representation_texel(uv, p.shape.width, p.shape.height);
  return p.evaluate(t.x, t.y, angular_table_sample(tables, 0, param, nearest, wl),
                    angular_table_sample(tables, 1, param, nearest, wv));
}

}  // namespace btflod
