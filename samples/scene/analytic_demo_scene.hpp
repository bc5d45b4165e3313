// btflod samples — the demo scene (scene/demo_scene.hpp) as analytic shapes for the CPU
// ray-casters (offline/render/cpu_reference.hpp): the demo's CPU fallback and raw-BTF reference, and the
// progressive and visibility tools. Same layout as the triangle meshes (DemoLayout), and the same
// texture frames: the ground's uv.y runs along −z, the tori are parameterised as make_torus.
#pragma once

#include <cstdint>

#include "btflod/offline/render/cpu_reference.hpp"
#include "scene/demo_scene.hpp"

namespace btflod::scene {

/// The plane (material 0) and DemoLayout::kDefaultTori tori (materials 1 … n − 1 in turn) of
/// make_demo_scene(material_count). Allocates.
inline Scene analytic_demo_scene(uint32_t material_count) {
  using L = DemoLayout;
  Scene scene;
  const float far_edge = L::kGroundOrigin + L::kGroundSize;  // v = 0 at z = +6, v runs along −z
  scene.add(Shape::plane(0, {L::kGroundOrigin, 0.0f, far_edge}, {1, 0, 0}, {0, 0, -1}, L::kGroundSize, L::kGroundSize,
                         {L::kGroundRepeat, L::kGroundRepeat}));
  for (uint32_t i = 0; i < L::kDefaultTori; ++i)
    scene.add(Shape::torus(L::torus_material(i, material_count), L::torus_center(i, L::kDefaultTori), L::kTorusMajor,
                           L::kTorusMinor, {L::kTorusRepeatU, L::kTorusRepeatV}));
  return scene;
}

}  // namespace btflod::scene
