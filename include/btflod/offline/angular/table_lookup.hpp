// btflod — the CPU twin of the shaders' angular table lookup (btflod_angular() in the generated
// GLSL/HLSL): a light or view direction in the local frame → its table texel → the 3 directions
// and weights the Delaunay interpolation (paper 002) stored there. Used by the CPU reference,
// the representation packers' evaluators and the samples' CPU images.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod {

/// CPU twin of the generated btflod_angular(): the table texel of direction `d` (local frame)
/// for `layer` 0 = light, 1 = view, its 3 indices and weights; with `nearest`, the first index
/// of largest weight with weight 1. Precondition: the tables are validated. noexcept.
inline AngularSample angular_table_sample(const AngularTablesData& t, int layer, DirectionParameterisation p,
                                          bool nearest, glm::vec3 d) noexcept {
  const glm::ivec2 tx = shader_table_texel(shader_direction_to_unit_square(p, d), t.resolution);
  const size_t o = (static_cast<size_t>(tx.y) * t.resolution + static_cast<size_t>(tx.x)) * 3;
  const std::span<const uint32_t> idx = layer == 0 ? t.light_index : t.view_index;
  const std::span<const float> w = layer == 0 ? t.light_weight : t.view_weight;
  AngularSample s;
  for (size_t k = 0; k < 3; ++k) {
    s.index[k] = idx[o + k];
    s.weight[k] = w[o + k];
  }
  if (nearest) {
    size_t k = 0;
    if (s.weight[1] > s.weight[0]) k = 1;
    if (s.weight[2] > s.weight[k]) k = 2;
    s.index = {s.index[k], s.index[k], s.index[k]};
    s.weight = {1.0f, 0.0f, 0.0f};
  }
  return s;
}

}  // namespace btflod
