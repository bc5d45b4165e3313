// btflod — the angular lookup table of paper 000 §4: a triangulation of measured directions in a
// hemisphere parameterisation's [0, 1]² square, rasterised into an index image (3 × uint32 per
// texel: the enclosing triangle's direction indices) and a weight image (3 × float: the
// barycentric weights at the texel centre). Texel (x, y) covers st ∈ [x/R, (x+1)/R) ×
// [y/R, (y+1)/R); image row y is t, so a shader uploading row 0 first samples it at
// t = (y + 0.5)/R with nearest filtering. Texels outside the hull hold the nearest hull point's
// weights (TriangleGridLocator).
//
// Runtime set-up code on core vectors (no GLM): an engine rasterises a streamed material's tables
// at load time (bsvtf_angular_tables.hpp); the offline LookupTableInterpolator uses the same
// functions. Allocates (the images); thread-safe (no shared state).
#pragma once

#include <cstdint>

#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/vec.hpp"
#include "btflod/runtime/angular/angular_sample.hpp"
#include "btflod/runtime/angular/triangle_locator.hpp"

namespace btflod {

namespace detail {
/// The table resolutions the lookup interpolators accept: 1 … 8192. Returns invalid_argument
/// "<table>: resolution R outside [1, 8192]" otherwise.
inline VoidResult check_lookup_resolution(const char* table, int resolution) {
  if (resolution < 1 || resolution > 8192)
    return make_error(Status::invalid_argument, "%s: resolution %d outside [1, 8192]", table, resolution);
  return {};
}
/// Calls f(x, y, st) for every texel of a resolution × resolution table over the unit square,
/// row by row: st = ((x + 0.5) / R, (y + 0.5) / R) is the texel centre.
template <class F>
void for_each_texel_centre(int resolution, F&& f) {
  for (int y = 0; y < resolution; ++y)
    for (int x = 0; x < resolution; ++x)
      f(x, y,
        Vector2f((static_cast<float>(x) + 0.5f) / static_cast<float>(resolution),
                 (static_cast<float>(y) + 0.5f) / static_cast<float>(resolution)));
}
}  // namespace detail

/// The index and weight images of one lookup table (file comment), resolution × resolution × 3.
struct AngularLookupImages {
  Image<uint32_t> indices;
  Image<float> weights;
};

/// Rasterises the triangulation behind `locator` at `resolution` (1 … 8192): every texel holds
/// locator.locate(texel centre). Returns invalid_argument for a resolution outside [1, 8192].
/// Precondition: locator was built from a valid triangulation (a default-constructed locator
/// gives default samples). Allocates 24 · resolution² bytes; thread-safe.
inline Result<AngularLookupImages> rasterise_angular_lookup(const TriangleGridLocator& locator, int resolution) {
  if (auto ok = detail::check_lookup_resolution("lookup table", resolution); !ok) return ok.error();
  AngularLookupImages out{Image<uint32_t>(resolution, resolution, 3), Image<float>(resolution, resolution, 3)};
  detail::for_each_texel_centre(resolution, [&](int x, int y, Vector2f st) {
    const AngularSample s = locator.locate(st);
    for (int c = 0; c < 3; ++c) {
      out.indices.at(x, y, c) = s.index[c];
      out.weights.at(x, y, c) = s.weight[c];
    }
  });
  return out;
}

}  // namespace btflod
