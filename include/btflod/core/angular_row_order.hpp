// btflod core — the order of the angular rows of U (paper 000 eq. 4: one row per light, view
// and colour). Shared by the eigen-textures (runtime/vt/vt_layout.hpp), the container (codec/) and the
// runtime, so no layer needs another to say how U is laid out.
#pragma once

#include <cstdint>

namespace btflod {

/// Order of U's angular rows; rows are (a · n_b + b) · colour_channels + colour.
enum class AngularRowOrder : uint8_t {
  light_major,  ///< a = light, b = view: row = (light · views + view) · channels + colour (shader/, backends)
  view_major,   ///< a = view, b = light: row = (view · lights + light) · channels + colour (offline/factor/fmf.hpp
                ///< files)
  unspecified,  ///< a version-2 container, which did not store it
};

/// Stable name of a row order ("light_major", "view_major", "unspecified").
constexpr const char* angular_row_order_name(AngularRowOrder o) noexcept {
  return o == AngularRowOrder::light_major  ? "light_major"
         : o == AngularRowOrder::view_major ? "view_major"
                                            : "unspecified";
}

/// Row of (light, view, colour) among `lights` × `views` × 3 rows in `order` (light- or view-major).
constexpr uint64_t angular_row(AngularRowOrder order, uint32_t light, uint32_t view, uint32_t colour, uint32_t lights,
                               uint32_t views) noexcept {
  const uint64_t pair =
      order == AngularRowOrder::view_major ? uint64_t{view} * lights + light : uint64_t{light} * views + view;
  return pair * 3 + colour;
}

}  // namespace btflod
