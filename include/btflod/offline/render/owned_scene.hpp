// btflod — a scene that owns its meshes, materials and lights and hands the integrator its
// non-owning RenderScene view (offline/render/integrator.hpp). Copies and moves keep the view valid
// (copies re-point their mesh spans at their own vertex data). Set-up code: allocates.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/offline/render/integrator.hpp"
#include "btflod/offline/render/primitives.hpp"

namespace btflod {

/// Owns everything a RenderScene points at. `meshes[i]` views `data[i]` with material
/// `mesh_material[i]`; the fields are public so callers can edit vertices, materials and
/// lights in place (vertex edits show through the views; resizing `data[i]` needs rebuild()).
/// `geometry_key` counts add() calls, so a caller can key progressive accumulation
/// (SceneKeys) on geometry changes.
struct OwnedScene {
  std::vector<TriangleMeshData> data;
  std::vector<uint32_t> mesh_material;
  std::vector<SceneMesh> meshes;
  std::vector<SurfaceMaterial> materials;
  std::vector<PointLight> points;
  std::vector<AreaLight> areas;
  AmbientLight ambient;
  glm::vec3 background{0.0f};
  uint64_t geometry_key = 1;

  OwnedScene() = default;
  /// Deep copy; the copy's mesh views point at its own vertex data.
  OwnedScene(const OwnedScene& o)
      : data(o.data),
        mesh_material(o.mesh_material),
        materials(o.materials),
        points(o.points),
        areas(o.areas),
        ambient(o.ambient),
        background(o.background),
        geometry_key(o.geometry_key) {
    rebuild();
  }
  OwnedScene& operator=(const OwnedScene& o) {
    if (this != &o) *this = OwnedScene(o);
    return *this;
  }
  // A moved vector keeps its heap buffer, so the moved views stay valid.
  OwnedScene(OwnedScene&&) noexcept = default;
  OwnedScene& operator=(OwnedScene&&) noexcept = default;

  /// Adds a mesh drawn with material index `material` (not checked here:
  /// validate_render_scene() names a bad index). Bumps geometry_key. Allocates.
  void add(TriangleMeshData m, uint32_t material) {
    data.push_back(std::move(m));
    mesh_material.push_back(material);
    rebuild();
    ++geometry_key;
  }
  /// Re-creates the mesh views from data and mesh_material (after resizing a mesh in place).
  void rebuild() {
    meshes.clear();
    for (size_t i = 0; i < data.size() && i < mesh_material.size(); ++i)
      meshes.push_back(data[i].mesh(mesh_material[i]));
  }
  /// The integrator's view of the scene; valid while this object lives and is not modified
  /// structurally (add(), rebuild(), resizing a vector).
  RenderScene view() const noexcept { return RenderScene{meshes, materials, points, areas, ambient, background}; }
  /// Total number of triangles.
  size_t triangle_count() const noexcept {
    size_t n = 0;
    for (const auto& d : data) n += d.triangle_count();
    return n;
  }
};

}  // namespace btflod
