// btflod-raytrace — scenes and materials: the demo's scene (a BTF ground plane and BTF tori,
// samples/scene/demo_scene.hpp) with a mirror sphere, point lights, a rectangular area light
// and ambient light; a Cornell-like box (open at the front) with a ceiling area light, BTF
// floor, back wall and block, coloured Lambertian side walls and a mirror sphere; small
// synthesised BTFs (32 × 32 texels, the demo's 23 directions) in any btflod representation.
// Set-up code: allocates, returns Result.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/laplacian_pca.hpp"
#include "btflod/offline/factor/local_pca.hpp"
#include "btflod/offline/factor/pca_views.hpp"
#include "btflod/offline/render/integrator.hpp"
#include "btflod/offline/render/owned_scene.hpp"
#include "btflod/offline/render/primitives.hpp"
#include "scene/demo_scene.hpp"

namespace btflod::raytrace {

/// The representations a material can use. A representation added to AnyFactorization gets a
/// case in factorize() and a name here; shading needs nothing more (it visits the variant,
/// offline/render/shading.hpp).
enum class Representation : uint8_t { fmf, pca_k, laplacian, lpca, spmm };
inline constexpr Representation kAllRepresentations[] = {
    Representation::fmf, Representation::pca_k, Representation::laplacian, Representation::lpca, Representation::spmm};

inline const char* representation_name(Representation r) noexcept {
  switch (r) {
    case Representation::fmf:
      return "fmf";
    case Representation::pca_k:
      return "pca-k";
    case Representation::laplacian:
      return "laplacian";
    case Representation::lpca:
      return "lpca";
    case Representation::spmm:
      return "spmm";
  }
  return "?";
}

/// The demo's direction set: rings at θ = 0, 30, 55, 75° with 1, 6, 8, 8 directions (23).
inline DirectionSet raytrace_directions() {
  const float thetas[] = {0.0f, 30.0f, 55.0f, 75.0f};
  const int counts[] = {1, 6, 8, 8};
  const float offsets[] = {0.0f, 0.0f, 22.5f, 0.0f};
  return DirectionSet::from_rings("demo-23", thetas, counts, offsets, false);
}

/// Synthesises one material (size × size texels, 23 × 23 directions).
inline Result<BtfFloat> synthesize(SynthMaterial kind, int size, uint64_t seed) {
  SynthesisOptions so;
  so.views = raytrace_directions();
  so.lights = raytrace_directions();
  return synthesize_material(kind, size, size, seed, so);
}

/// Factorises a BTF into representation r with small ranks (fast to build and to evaluate).
inline Result<std::shared_ptr<const AnyFactorization>> factorize(const BtfFloat& btf, Representation r) {
  const auto wrap = [](auto res) -> Result<std::shared_ptr<const AnyFactorization>> {
    if (!res) return res.error();
    return std::make_shared<const AnyFactorization>(std::move(*res));
  };
  switch (r) {
    case Representation::fmf: {
      FmfOptions o;
      o.components = 8;
      return wrap(factorize_fmf(btf, o));
    }
    case Representation::pca_k: {
      PcaViewsOptions o;
      o.components = 4;
      o.views_per_group = 3;
      return wrap(factorize_pca_views(btf, o));
    }
    case Representation::laplacian: {
      LaplacianPcaOptions o;
      o.components = {6, 2, 2};
      return wrap(factorize_laplacian_pca(btf, o));
    }
    case Representation::lpca: {
      LocalPcaOptions o;
      o.clusters = 4;
      o.components = 3;
      o.max_iterations = 6;
      return wrap(factorize_local_pca(btf, o));
    }
    case Representation::spmm: {  // paper 003: small dictionary, #BF ≤ 3, N_PCA = 2
      SpmmOptions o;
      o.clusters = 3;
      o.representatives = 2;
      o.lobes_per_representative = 1;
      o.max_basis_per_texel = 3;
      o.residual_components = 2;
      o.fit_samples = 512;
      o.lasso_max_steps = 1500;
      return wrap(factorize_spmm(btf, o));
    }
  }
  return make_error(Status::invalid_argument, "unknown representation");
}

/// A named BTF material with a stable address (SurfaceMaterial points at it).
struct NamedBtf {
  std::string name;
  Representation representation = Representation::fmf;
  std::unique_ptr<BtfMaterial> material;
};

/// Synthesises and factorises one material.
inline Result<NamedBtf> make_btf(SynthMaterial kind, Representation r, int size, uint64_t seed) {
  auto btf = synthesize(kind, size, seed);
  if (!btf) return btf.error();
  auto rep = factorize(*btf, r);
  if (!rep) return rep.error();
  auto m = BtfMaterial::build(*rep);
  if (!m) return m.error();
  NamedBtf out;
  out.name = std::string(material_name(kind)) + "/" + representation_name(r);
  out.representation = r;
  out.material = std::make_unique<BtfMaterial>(std::move(*m));
  return out;
}

/// Converts the demo scene's object (scene/demo_scene.hpp) to a mesh.
inline TriangleMeshData to_mesh(const scene::SceneObject& o) { return TriangleMeshData{o.vertices, o.indices}; }

/// The demo scene: ground plane (material 0), four tori (materials 1, 2, 3, 1) with
/// `torus_segments` × `torus_sides` quads each, a mirror sphere (material `mirror`) in the
/// middle, `point_lights` point lights on a ring above, one 2 × 2 area light at height 6 and
/// ambient light with AO radius 1. Triangles: 2 + 8·segments·sides + sphere's 3968.
inline OwnedScene demo_scene(std::vector<SurfaceMaterial> materials, uint32_t mirror, uint32_t torus_segments,
                             uint32_t torus_sides, uint32_t point_lights) {
  OwnedScene s;
  s.materials = std::move(materials);
  s.add(to_mesh(scene::make_ground(0, -6.0f, -6.0f, 12.0f, 6.0f)), 0);
  const uint32_t torus_material[4] = {1, 2, 3, 1};
  for (uint32_t i = 0; i < 4; ++i) {
    const float a = kTwoPi * static_cast<float>(i) / 4.0f + 0.4f;
    const glm::vec3 c(2.6f * std::cos(a), 0.45f, 2.6f * std::sin(a));
    s.add(to_mesh(scene::make_torus(torus_material[i], c, 0.9f, 0.45f, torus_segments, torus_sides, 4.0f, 2.0f)),
          torus_material[i]);
  }
  s.add(make_uv_sphere({0.0f, 0.8f, 0.0f}, 0.8f, 64, 32), mirror);
  for (uint32_t i = 0; i < point_lights; ++i) {
    const float a = kTwoPi * static_cast<float>(i) / static_cast<float>(point_lights) + 0.9f;
    s.points.push_back(PointLight{{5.0f * std::cos(a), 5.5f, 5.0f * std::sin(a)}, glm::vec3(60.0f / point_lights)});
  }
  // 2 × 2 at y = 6 facing down: edge_u × edge_v = x × z = −y.
  s.areas.push_back(AreaLight{{-1.0f, 6.0f, -1.0f}, {2.0f, 0, 0}, {0, 0, 2.0f}, glm::vec3(22.0f)});
  s.ambient = AmbientLight{glm::vec3(0.25f), 1.0f};
  s.background = glm::vec3(0.05f, 0.06f, 0.08f);
  return s;
}

/// Torus tessellation for about `triangles` triangles over the four tori (segments = 2·sides).
inline void torus_tessellation(size_t triangles, uint32_t& segments, uint32_t& sides) {
  sides = static_cast<uint32_t>(std::max(3.0, std::round(std::sqrt(static_cast<double>(triangles) / 16.0))));
  segments = 2 * sides;
}

/// The Cornell-like box: interior [−1, 1] × [0, 2] × [−1, 1] open towards +z; materials:
/// floor `floor`, back wall `back`, block `block`, mirror sphere `mirror`, and three
/// Lambertian ones appended (white ceiling, red left, green right). A 0.5 × 0.5 area light
/// under the ceiling, ambient light with AO radius 0.5.
inline OwnedScene cornell_box(std::vector<SurfaceMaterial> materials, uint32_t floor, uint32_t back, uint32_t block,
                              uint32_t mirror) {
  OwnedScene s;
  s.materials = std::move(materials);
  const auto white = static_cast<uint32_t>(s.materials.size());
  s.materials.push_back(SurfaceMaterial::lambertian(glm::vec3(0.75f)));
  s.materials.push_back(SurfaceMaterial::lambertian(glm::vec3(0.7f, 0.12f, 0.1f)));
  s.materials.push_back(SurfaceMaterial::lambertian(glm::vec3(0.12f, 0.6f, 0.15f)));
  // Inward-facing quads (edge_u × edge_v points into the room).
  s.add(make_quad({-1, 0, 1}, {2, 0, 0}, {0, 0, -2}, {2, 2}, 4), floor);      // floor, +y
  s.add(make_quad({-1, 2, -1}, {2, 0, 0}, {0, 0, 2}, {1, 1}, 4), white);      // ceiling, −y
  s.add(make_quad({-1, 0, -1}, {2, 0, 0}, {0, 2, 0}, {2, 2}, 4), back);       // back, +z
  s.add(make_quad({-1, 0, 1}, {0, 0, -2}, {0, 2, 0}, {1, 1}, 4), white + 1);  // left, +x
  s.add(make_quad({1, 0, -1}, {0, 0, 2}, {0, 2, 0}, {1, 1}, 4), white + 2);   // right, −x
  s.add(make_box({-0.65f, 0.0f, -0.55f}, {-0.1f, 1.1f, 0.0f}, false, 2), block);
  s.add(make_uv_sphere({0.45f, 0.35f, 0.25f}, 0.35f, 48, 24), mirror);
  s.areas.push_back(AreaLight{{-0.25f, 1.98f, -0.25f}, {0.5f, 0, 0}, {0, 0, 0.5f}, glm::vec3(40.0f)});
  s.ambient = AmbientLight{glm::vec3(0.1f), 0.5f};
  return s;
}

/// The Cornell box's camera.
inline PinholeCamera cornell_camera(uint32_t width, uint32_t height) {
  PinholeCamera c;
  c.eye = {0.0f, 1.0f, 3.4f};
  c.target = {0.0f, 0.95f, 0.0f};
  c.fov_y_degrees = 38.0f;
  c.width = width, c.height = height;
  return c;
}

/// Frame f of the demo's fly-through (scene::camera_path) as a pinhole camera.
inline PinholeCamera path_camera(uint32_t frame, uint32_t frames, uint32_t width, uint32_t height) {
  const scene::View v = scene::camera_path(frame, frames, width, height);
  PinholeCamera c;
  c.eye = v.eye;
  c.target = v.target;
  c.fov_y_degrees = v.fov_y_degrees;
  c.width = width, c.height = height;
  return c;
}

}  // namespace btflod::raytrace
