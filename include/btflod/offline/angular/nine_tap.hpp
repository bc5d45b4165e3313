// btflod — the 9-tap light × view combination: one AngularSample for the light direction and
// one for the view direction give nine (light index, view index) taps whose weights are the
// products of the two (paper 000 §4: "for all 9 combinations … blend according to the
// barycentric weights"; paper 004 §4.4.3: C_f = Σ_u b_iu Σ_v b_ov C_uv).
#pragma once

#include <array>
#include <cstdint>
#include <utility>

#include "btflod/offline/angular/angular_sample.hpp"

namespace btflod {

/// Nine taps; weight[k] = light.weight[k / 3] · view.weight[k % 3]. The weights are ≥ 0 and
/// sum to 1 when both inputs do.
struct NineTapSample {
  std::array<uint32_t, 9> light_index{};
  std::array<uint32_t, 9> view_index{};
  std::array<float, 9> weight{};
};

/// Combines a light and a view sample into nine taps. noexcept, allocation-free.
inline NineTapSample combine_nine_tap(const AngularSample& light, const AngularSample& view) noexcept {
  NineTapSample out;
  for (int u = 0; u < 3; ++u)
    for (int v = 0; v < 3; ++v) {
      const int k = u * 3 + v;
      out.light_index[k] = light.index[u];
      out.view_index[k] = view.index[v];
      out.weight[k] = light.weight[u] * view.weight[v];
    }
  return out;
}

/// Σ_k weight[k] · fetch(light_index[k], view_index[k]), skipping taps of weight 0 (so unused
/// slots never fetch). `fetch` returns any type with T + T and float · T (float, glm::vec3…);
/// T{} must be the zero value. noexcept when fetch is.
template <class Fetch>
auto evaluate_nine_tap(const NineTapSample& taps, Fetch&& fetch) noexcept(noexcept(fetch(0u, 0u))) {
  using T = decltype(fetch(0u, 0u));
  T sum{};
  for (int k = 0; k < 9; ++k)
    if (taps.weight[k] != 0.0f) sum = sum + taps.weight[k] * fetch(taps.light_index[k], taps.view_index[k]);
  return sum;
}

/// Interpolates a tabulated light × view function with any two interpolators (usually the
/// same one twice): returns Σ w · fetch(l, v) over the nine taps of light and view. noexcept
/// when fetch is; allocation-free.
template <class LightInterp, class ViewInterp, class Fetch>
auto interpolate_light_view(const LightInterp& light_interp, const ViewInterp& view_interp, glm::vec3 light,
                            glm::vec3 view, Fetch&& fetch) noexcept(noexcept(fetch(0u, 0u))) {
  return evaluate_nine_tap(combine_nine_tap(light_interp.query(light), view_interp.query(view)),
                           std::forward<Fetch>(fetch));
}

}  // namespace btflod
