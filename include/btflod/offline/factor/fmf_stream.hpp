// btflod — from a factorised material to a stream: an FMF (offline/factor/fmf.hpp, paper 000 eq. 5) as
// the virtual-texture path's eigen-textures, and its .bsvtf container in one call. Offline.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"

namespace btflod {

/// The unit vectors of a direction set as xyz floats, in the set's order (the container's
/// light_directions / view_directions). Allocates.
inline std::vector<float> direction_vectors(const DirectionSet& set) {
  std::vector<float> out;
  out.reserve(set.size() * 3);
  for (const Direction& d : set)
    for (int k = 0; k < 3; ++k) out.push_back(d.vector[k]);
  return out;
}

/// An FMF as eigen-textures (runtime/vt/vt_layout.hpp, paper 000 eq. 5): V·Σ as the C channels of the
/// texture, texel (x, y) = row y·W + x of fmf.v, exactly; U as `angular`, exactly, in the FMF's
/// own row order, which is VIEW-major — (view · n_light + light) · 3 + colour — and says so
/// (row_order = view_major), which containers built from it store. Allocates (a copy of V and U).
inline EigenTextures eigen_textures_from_fmf(const Fmf& fmf) {
  EigenTextures e;
  const int w = fmf.shape.width, h = fmf.shape.height, c = fmf.components;
  e.textures.resize(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k)
        e.textures.at(x, y, k) =
            fmf.v[(static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)) * static_cast<size_t>(c) +
                  static_cast<size_t>(k)];
  e.angular = fmf.u;
  e.light_count = static_cast<uint32_t>(fmf.shape.light_count());
  e.view_count = static_cast<uint32_t>(fmf.shape.view_count());
  e.transform = fmf.transform;
  e.row_order = AngularRowOrder::view_major;
  return e;
}

/// The complete .bsvtf container of an FMF in one call: its eigen-textures
/// (eigen_textures_from_fmf), U in its view-major row order, its light and view directions with
/// their set names; `options` gives the rest (tile size, border, edge, material name, build
/// options: quality, tolerances, threads, progress) — its directions and set names are replaced. Errors: those of
/// build_bsvtf_from_eigen_textures() (e.g. an FMF whose U does not have lights · views · 3 rows). Deterministic for any
/// thread count. Allocates.
inline Result<std::vector<uint8_t>> build_bsvtf_from_fmf(const Fmf& fmf, BsvtfFromEigenOptions options = {}) {
  options.light_directions = direction_vectors(fmf.shape.lights);
  options.view_directions = direction_vectors(fmf.shape.views);
  options.light_set = fmf.shape.lights.name();
  options.view_set = fmf.shape.views.name();
  return build_bsvtf_from_eigen_textures(eigen_textures_from_fmf(fmf), options);
}

}  // namespace btflod
