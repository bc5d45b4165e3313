// btflod samples — a shared demo scene: BTF-textured tori standing on a textured ground plane
// (the kind of scene of paper 000's figures), triangle meshes for the GPU backends
// (runtime/backend/backend.hpp MeshVertex), a camera fly-through and the matrices/uniforms of one view.
// Used by samples/demo and the golden tests. Header-only; set-up functions allocate.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "btflod/offline/math/math.hpp"
#include "btflod/runtime/backend/backend.hpp"

namespace btflod::scene {

/// A triangle mesh in world space (model matrix = identity) and the material it shows.
struct SceneObject {
  std::vector<MeshVertex> vertices;
  std::vector<uint32_t> indices;
  uint32_t material = 0;
};

/// A ground rectangle y = 0 over [x0, x0 + size] × [z0, z0 + size], facing +y; uv ∈ [0, repeat]².
/// Tangent along +x (uv.x); uv.y runs along −z so that cross(n, t) = cross(+y, +x) = −z is
/// ∂p/∂v (tangent.w = +1).
inline SceneObject make_ground(uint32_t material, float x0, float z0, float size, float repeat) {
  SceneObject o;
  o.material = material;
  const float p[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (const auto& c : p) {
    MeshVertex v{};
    v.position[0] = x0 + c[0] * size;
    v.position[1] = 0.0f;
    v.position[2] = z0 + size - c[1] * size;  // uv.y runs along −z
    v.normal[0] = 0.0f, v.normal[1] = 1.0f, v.normal[2] = 0.0f;
    v.tangent[0] = 1.0f, v.tangent[1] = 0.0f, v.tangent[2] = 0.0f, v.tangent[3] = 1.0f;
    v.uv[0] = c[0] * repeat;
    v.uv[1] = c[1] * repeat;
    o.vertices.push_back(v);
  }
  o.indices = {0, 1, 2, 0, 2, 3};
  return o;
}

/// A torus around the +y axis at `center` (major radius R, tube radius r), `segments` × `sides`
/// quads; uv = (ring angle / 2π · repeat_u, tube angle / 2π · repeat_v). Seam vertices are
/// duplicated so uv grows continuously. Tangent along ∂p/∂u, handedness so that cross(n, t)·w
/// points along ∂p/∂v.
inline SceneObject make_torus(uint32_t material, glm::vec3 center, float R, float r, uint32_t segments, uint32_t sides,
                              float repeat_u, float repeat_v) {
  SceneObject o;
  o.material = material;
  for (uint32_t i = 0; i <= segments; ++i) {
    const float a = kTwoPi * static_cast<float>(i) / static_cast<float>(segments);
    for (uint32_t j = 0; j <= sides; ++j) {
      const float b = kTwoPi * static_cast<float>(j) / static_cast<float>(sides);
      const float ca = std::cos(a), sa = std::sin(a), cb = std::cos(b), sb = std::sin(b);
      MeshVertex v{};
      v.position[0] = center.x + (R + r * cb) * ca;
      v.position[1] = center.y + r * sb;
      v.position[2] = center.z + (R + r * cb) * sa;
      v.normal[0] = cb * ca, v.normal[1] = sb, v.normal[2] = cb * sa;
      v.tangent[0] = -sa, v.tangent[1] = 0.0f, v.tangent[2] = ca;
      v.tangent[3] = -1.0f;  // cross(n, t) = −∂p/∂v / r
      v.uv[0] = static_cast<float>(i) / static_cast<float>(segments) * repeat_u;
      v.uv[1] = static_cast<float>(j) / static_cast<float>(sides) * repeat_v;
      o.vertices.push_back(v);
    }
  }
  const uint32_t row = sides + 1;
  for (uint32_t i = 0; i < segments; ++i)
    for (uint32_t j = 0; j < sides; ++j) {
      const uint32_t a = i * row + j, b = (i + 1) * row + j;
      o.indices.insert(o.indices.end(), {a, b, b + 1, a, b + 1, a + 1});
    }
  return o;
}

/// The demo scene: a ground plane of material 0 and `materials − 1` tori (materials 1, 2, …;
/// when materials = 1 the tori reuse material 0) standing on a ring around the origin.
/// The demo scene's layout, shared by the triangle meshes (make_demo_scene) and the analytic
/// shapes the CPU ray-casters intersect (scene/analytic_demo_scene.hpp), so the two never drift.
struct DemoLayout {
  static constexpr float kGroundOrigin = -6.0f;  ///< ground over [−6, 6]² in x and z
  static constexpr float kGroundSize = 12.0f;
  static constexpr float kGroundRepeat = 6.0f;  ///< uv ∈ [0, 6]²
  static constexpr float kTorusMajor = 0.9f, kTorusMinor = 0.45f;
  static constexpr float kTorusRepeatU = 4.0f, kTorusRepeatV = 2.0f;
  static constexpr uint32_t kDefaultTori = 4;

  /// Centre of torus i of `count`, on a ring of radius 2.6 standing on the ground.
  static glm::vec3 torus_center(uint32_t i, uint32_t count) noexcept {
    const float a = kTwoPi * static_cast<float>(i) / static_cast<float>(count) + 0.4f;
    return {2.6f * std::cos(a), kTorusMinor, 2.6f * std::sin(a)};
  }
  /// Material of torus i: 1, 2, … n − 1 in turn; material 0 when there is only one.
  static uint32_t torus_material(uint32_t i, uint32_t materials) noexcept {
    return materials > 1 ? 1 + i % (materials - 1) : 0;
  }
};

inline std::vector<SceneObject> make_demo_scene(uint32_t materials, uint32_t torus_count = DemoLayout::kDefaultTori) {
  using L = DemoLayout;
  std::vector<SceneObject> objects;
  objects.push_back(make_ground(0, L::kGroundOrigin, L::kGroundOrigin, L::kGroundSize, L::kGroundRepeat));
  for (uint32_t i = 0; i < torus_count; ++i)
    objects.push_back(make_torus(L::torus_material(i, materials), L::torus_center(i, torus_count), L::kTorusMajor,
                                 L::kTorusMinor, 96, 48, L::kTorusRepeatU, L::kTorusRepeatV));
  return objects;
}

/// One view: eye, target, vertical field of view, image size.
struct View {
  glm::vec3 eye{0.0f, 2.0f, 6.0f};
  glm::vec3 target{0.0f, 0.4f, 0.0f};
  float fov_y_degrees = 50.0f;
  uint32_t width = 320;
  uint32_t height = 180;

  /// OpenGL-convention projection × view (clip z in [−w, w], NDC y = +1 at the top row).
  glm::mat4 view_proj() const {
    const glm::mat4 proj = glm::perspective(degrees_to_radians(fov_y_degrees),
                                            static_cast<float>(width) / static_cast<float>(height), 0.05f, 100.0f);
    return proj * glm::lookAt(eye, target, glm::vec3(0.0f, 1.0f, 0.0f));
  }
};

/// The fly-through: frame f of `frames` circles the scene while descending towards the tori, so
/// the needed levels of detail change over the flight. Deterministic.
inline View camera_path(uint32_t frame, uint32_t frames, uint32_t width, uint32_t height) {
  const float t = frames > 1 ? static_cast<float>(frame) / static_cast<float>(frames - 1) : 0.0f;
  View v;
  v.width = width;
  v.height = height;
  const float angle = 0.2f + 1.6f * t;
  const float radius = 7.5f - 4.0f * t;
  v.eye = glm::vec3(radius * std::cos(angle), 3.2f - 1.9f * t, radius * std::sin(angle));
  v.target = glm::vec3(0.6f * std::cos(angle + 0.8f), 0.3f, 0.6f * std::sin(angle + 0.8f));
  return v;
}

/// Shader uniforms of one view with a directional light (the sun) from `light_dir`.
inline ShaderParams view_params(const View& v, glm::vec3 light_dir, glm::vec3 light_color) {
  ShaderParams p;
  p.model_view_proj = v.view_proj();
  p.model = glm::mat4(1.0f);
  p.camera_pos = glm::vec4(v.eye, 1.0f);
  p.light = glm::vec4(glm::normalize(light_dir), 0.0f);
  p.light_color = glm::vec4(light_color, 1.0f);
  return p;
}

}  // namespace btflod::scene
