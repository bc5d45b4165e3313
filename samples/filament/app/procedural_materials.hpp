// The sample's procedural materials (bricks, weave, tiles): rank-8 factorisations (paper 000
// eq. 5: ρ = Σ_c U_c(ωl, ωv) · V_c(x)) over UBO2003's 81 light and 81 view directions — a diffuse
// albedo, a darker fill, a tint, a glossy lobe and four fine-detail terms — with eigen-textures V
// of 256² texels whose finest level carries detail a coarser level does not (so a renderer on the
// wrong level shows it). make_materials.cpp turns them into .bsvtf files; main.cpp --check also
// draws one resident (FMF) from these eigen-textures.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "btflod/offline/angular/directions.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"
#include "sample_config.hpp"

namespace sample {

inline const char* const kMaterialNames[3] = {"bricks", "weave", "tiles"};

inline float pattern(int kind, float x, float y) {                           // x, y in texels; values in [0, 1]
  const float fine = 0.5f + 0.5f * std::sin(0.9f * x) * std::sin(1.1f * y);  // 1–2 texel detail
  if (kind == 0) {                                                           // bricks 32 × 16 texels with mortar
    const float row = std::floor(y / 16.0f), bx = x + (static_cast<int>(row) % 2) * 16.0f;
    const bool mortar = std::fmod(y, 16.0f) < 2.0f || std::fmod(bx, 32.0f) < 2.0f;
    return mortar ? 0.15f + 0.1f * fine : 0.6f + 0.25f * fine + 0.15f * std::sin(row * 3.7f + std::floor(bx / 32.0f));
  }
  if (kind == 1) {  // weave: alternating threads every 8 texels
    const bool over = (static_cast<int>(x / 8.0f) + static_cast<int>(y / 8.0f)) % 2 == 0;
    const float thread = 0.5f + 0.5f * std::cos((over ? x : y) * 0.785f);
    return 0.25f + 0.55f * thread + 0.2f * fine;
  }
  const float cx = std::fmod(x, 64.0f) - 32.0f, cy = std::fmod(y, 64.0f) - 32.0f;  // tiles, round inlays
  return (cx * cx + cy * cy < 400.0f ? 0.9f : 0.35f) - 0.15f * fine;
}

/// Material m (0 bricks, 1 weave, 2 tiles): V′ (256² × 8) and U′ (light-major), and the
/// directions (xyz triples) of its lights and views.
inline btflod::EigenTextures make_eigen(int m, std::vector<float>& directions_xyz) {
  using namespace btflod;
  const DirectionSet dirs = DirectionSet::ubo2003();
  const uint32_t D = static_cast<uint32_t>(dirs.size()), C = kComponents;
  const int M = static_cast<int>(kTexels);
  const float albedo[3][3] = {{0.70f, 0.32f, 0.22f}, {0.25f, 0.38f, 0.62f}, {0.80f, 0.78f, 0.70f}};
  EigenTextures e;
  e.light_count = D;
  e.view_count = D;
  e.textures.resize(M, M, static_cast<int>(C));
  for (int y = 0; y < M; ++y)
    for (int x = 0; x < M; ++x) {
      const float p = pattern(m, static_cast<float>(x), static_cast<float>(y));
      const float q = pattern((m + 1) % 3, static_cast<float>(x) * 0.5f, static_cast<float>(y) * 0.5f);
      const float v[8] = {p,
                          1.0f - p,
                          q - 0.5f,
                          p * q,
                          std::sin(0.7f * x) * p,
                          std::cos(0.6f * y) * p,
                          std::sin(0.35f * (x + y)),
                          std::cos(0.45f * (x - y))};
      for (uint32_t c = 0; c < C; ++c) e.textures.at(x, y, static_cast<int>(c)) = v[c];
    }
  e.angular.assign(size_t{D} * D * 3 * C, 0.0f);
  directions_xyz.clear();
  for (uint32_t i = 0; i < D; ++i)
    for (int k = 0; k < 3; ++k) directions_xyz.push_back(dirs[i].vector[k]);
  for (uint32_t l = 0; l < D; ++l)
    for (uint32_t v = 0; v < D; ++v) {
      const glm::vec3 wl = dirs[l].vector, wv = dirs[v].vector;
      const float cl = std::max(wl.z, 0.0f), cv = std::max(wv.z, 0.0f);
      const glm::vec3 h = glm::normalize(wl + wv);
      const float spec = std::pow(std::max(h.z, 0.0f), 40.0f) * cl;
      const float aniso = (wl.x * wv.x - wl.y * wv.y) * cl;
      for (uint32_t col = 0; col < 3; ++col) {
        float* row = &e.angular[((size_t{l} * D + v) * 3 + col) * C];
        row[0] = albedo[m][col] * cl * 0.9f;                         // diffuse, patterned albedo
        row[1] = 0.15f * cl * albedo[m][col];                        // darker fill between features
        row[2] = (col == 0 ? 0.2f : col == 1 ? 0.05f : -0.1f) * cl;  // tint
        row[3] = 0.8f * spec;                                        // glossy lobe where p·q is high
        row[4] = 0.06f * aniso;                                      // fine anisotropic detail
        row[5] = 0.05f * cl * cv;
        row[6] = 0.04f * cl;  // finest-level detail
        row[7] = 0.04f * cl * (1.0f - cv);
      }
    }
  return e;
}

}  // namespace sample
