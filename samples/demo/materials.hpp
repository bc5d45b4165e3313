// btflod-demo — material preparation: synthesise small procedural BTFs, factorise them (FMF,
// paper 000 eq. 4–5), lay the eigen-textures out as a virtual texture, build the .bsvtf
// streaming container, and the angular lookup tables the shaders read (paper 000 §4).
#pragma once

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "btflod/angular/interpolators.hpp"
#include "btflod/angular/parameterization.hpp"
#include "btflod/backend/backend.hpp"
#include "btflod/btf/synthesizer.hpp"
#include "btflod/codec/container.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/factor/fmf.hpp"
#include "btflod/vt/tile_pyramid.hpp"
#include "common/bsvtf_input.hpp"

namespace btflod::demo {

/// Settings of the material preparation.
struct MaterialSettings {
  int size = 32;                 ///< synthesised texels per side
  uint32_t repeat = 8;           ///< the virtual texture holds the material tiled repeat × repeat
  uint32_t components = 8;       ///< FMF rank C (2 RGBA virtual textures)
  uint32_t tile_size = 32;       ///< T
  uint32_t border = 4;           ///< B (T + 2B must be a multiple of 8)
  uint32_t angular_resolution = 32;
  float quality = 60.0f;         ///< tile codec quality
  uint64_t seed = 1;
};

/// The small direction set of the demo (views and lights): rings at θ = 0, 30, 55, 75° with
/// 1, 6, 8, 8 directions — far fewer than UBO2003's 81 so that synthesis and FMF stay fast.
inline DirectionSet demo_directions() {
  const float thetas[] = {0.0f, 30.0f, 55.0f, 75.0f};
  const int counts[] = {1, 6, 8, 8};
  const float offsets[] = {0.0f, 0.0f, 22.5f, 0.0f};
  return DirectionSet::from_rings("demo-23", thetas, counts, offsets, false);
}

/// One material ready for both renderers.
struct DemoMaterial {
  std::string name;
  uint32_t light_count = 0, view_count = 0;
  uint32_t components = 0;
  std::vector<float> u;          ///< backend layout ((light·views + view)·3 + colour)·C + c
  Image<float> eigen_textures;   ///< V'·Σ tiled: M × N × C
  std::vector<uint32_t> light_index, view_index;
  std::vector<float> light_weight, view_weight;
  uint32_t angular_resolution = 0;
  EigenTextures eigen;            ///< for the tile pyramid
  std::string bsvtf_path;
  std::vector<uint8_t> bsvtf;     ///< the container bytes
  double fmf_relative_error = 0;  ///< ‖BTF − U·Vᵀ‖ / ‖BTF‖ on the synthesised material
  uint32_t finest_level = 0;

  /// The backend description (spans into this object).
  FmfMaterialData data(bool with_textures) const {
    FmfMaterialData d;
    d.components = components;
    d.light_count = light_count;
    d.view_count = view_count;
    d.eigen_abrdfs = u;
    if (with_textures) d.eigen_textures = eigen_textures.view();
    d.mipmaps = true;
    d.angular = AngularTablesData{angular_resolution, light_index, light_weight, view_index, view_weight};
    return d;
  }
};

/// Synthesises material `index` (cloth, stone, leather, tiles in turn, seed + index), factorises
/// it, builds its .bsvtf container into `out_dir` and its lookup tables. Allocates; slow part of
/// the demo (seconds).
inline Result<DemoMaterial> prepare_material(uint32_t index, const MaterialSettings& s, const std::string& out_dir) {
  const SynthMaterial kinds[] = {SynthMaterial::cloth, SynthMaterial::stone, SynthMaterial::leather, SynthMaterial::tiles};
  const SynthMaterial kind = kinds[index % 4];
  SynthesisOptions so;
  so.views = demo_directions();
  so.lights = demo_directions();
  auto btf = synthesize_material(kind, s.size, s.size, s.seed + index, so);
  if (!btf) return btf.error();
  FmfOptions fo;
  fo.components = static_cast<int>(s.components);
  auto fmf = factorize_fmf(*btf, fo);
  if (!fmf) return fmf.error();
  DemoMaterial m;
  m.name = std::string(material_name(kind)) + "-" + std::to_string(index);
  m.light_count = static_cast<uint32_t>(btf->light_count());
  m.view_count = static_cast<uint32_t>(btf->view_count());
  m.components = s.components;
  const uint32_t C = s.components, L = m.light_count, V = m.view_count;
  // Relative reconstruction error of the rank-C factorisation (eq. 4).
  {
    double se = 0, ss = 0;
    for (int y = 0; y < btf->height(); ++y)
      for (int x = 0; x < btf->width(); ++x)
        for (uint32_t v = 0; v < V; ++v)
          for (uint32_t l = 0; l < L; ++l) {
            const glm::vec3 r = fmf->evaluate_measured(x, y, v, l);
            const auto img = btf->image(v, l);
            for (int c = 0; c < 3; ++c) {
              const double a = img.at(x, y, c);
              se += (a - r[c]) * (a - r[c]);
              ss += a * a;
            }
          }
    m.fmf_relative_error = ss > 0 ? std::sqrt(se / ss) : 0.0;
  }
  // U: FMF rows (v·n_light + l)·3 + colour → backend/EigenTextures rows (l·n_view + v)·3 + colour.
  m.u.resize(static_cast<size_t>(L) * V * 3 * C);
  for (uint32_t l = 0; l < L; ++l)
    for (uint32_t v = 0; v < V; ++v)
      for (uint32_t col = 0; col < 3; ++col)
        for (uint32_t c = 0; c < C; ++c)
          m.u[((static_cast<size_t>(l) * V + v) * 3 + col) * C + c] = fmf->u[((static_cast<size_t>(v) * L + l) * 3 + col) * C + c];
  // V'·Σ tiled repeat × repeat (the material is tileable), so the virtual texture has several levels.
  const int w = btf->width(), h = btf->height();
  const int M = w * static_cast<int>(s.repeat), N = h * static_cast<int>(s.repeat);
  m.eigen_textures = Image<float>(M, N, static_cast<int>(C));
  for (int y = 0; y < N; ++y)
    for (int x = 0; x < M; ++x)
      for (uint32_t c = 0; c < C; ++c)
        m.eigen_textures.at(x, y, static_cast<int>(c)) = fmf->v[(static_cast<size_t>(y % h) * w + (x % w)) * C + c];
  m.eigen.textures = m.eigen_textures;
  m.eigen.angular = m.u;
  m.eigen.light_count = L;
  m.eigen.view_count = V;
  // Angular lookup tables (paper 000 §4): the rasterised Delaunay triangulation in the parabolic map.
  auto lt = LookupTableInterpolator<ParabolicMap>::build(btf->lights(), static_cast<int>(s.angular_resolution));
  if (!lt) return lt.error();
  auto vt = LookupTableInterpolator<ParabolicMap>::build(btf->views(), static_cast<int>(s.angular_resolution));
  if (!vt) return vt.error();
  m.angular_resolution = s.angular_resolution;
  const auto copy_table = [](const auto& t, std::vector<uint32_t>& idx, std::vector<float>& wt) {
    const auto& ii = t.index_table();
    const auto& ww = t.weight_table();
    idx.assign(ii.elements().begin(), ii.elements().end());
    wt.assign(ww.elements().begin(), ww.elements().end());
  };
  copy_table(*lt, m.light_index, m.light_weight);
  copy_table(*vt, m.view_index, m.view_weight);

  // Tile pyramid and .bsvtf container (closed-loop residual codec, paper 000 §6).
  // Every demo material is repeated over its object (scene/demo_scene.hpp; the shader wraps uv
  // with fract, FMF samples with GL_REPEAT): wrapped outer borders, no seam at the repeat.
  auto pyramid = TilePyramid::build(m.eigen, s.tile_size, s.border, TileEdge::wrap);
  if (!pyramid) return pyramid.error();
  m.finest_level = pyramid->geometry().finest_level;
  BsvtfMetadata md;
  md.material_name = m.name;
  md.width = static_cast<uint32_t>(M);
  md.height = static_cast<uint32_t>(N);
  md.tile_size = s.tile_size;
  md.border = s.border;
  md.level_count = pyramid->geometry().level_count();
  md.component_count = C;
  md.u_rows = L * V * 3;
  samples::set_bsvtf_directions(md, btf->lights(), btf->views());
  const samples::BsvtfTileInputs inputs =
      samples::bsvtf_tiles_from_pyramid(*pyramid, md.level_count, s.tile_size, s.border);
  BsvtfBuildOptions bo;
  bo.quality = s.quality;
  auto file = build_bsvtf(md, m.u, inputs.tiles, bo);
  if (!file) return file.error();
  m.bsvtf = std::move(*file);
  m.bsvtf_path = (std::filesystem::path(out_dir) / (m.name + ".bsvtf")).string();
  if (auto w2 = write_file_bytes(m.bsvtf_path, m.bsvtf); !w2) return w2.error();
  return m;
}

}  // namespace btflod::demo
