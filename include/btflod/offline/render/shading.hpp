// btflod — shading a ray-traced hit with any btflod representation (paper 003 §4.2): the
// material's CPU evaluator at the hit's texel, with the 9-tap light × view angular
// interpolation over the measured directions (offline/angular/nine_tap.hpp: three light taps × three
// view taps located by the regular-grid + per-triangle inverse of paper 003 eq. 8), plus the
// two non-BTF kinds a scene needs: Lambertian surfaces and perfect mirrors (§4.1).
//
// Value convention: a BTF sample is ρ·cos θ_l (the "apparent BRDF" Bonn BTFs and the
// synthesiser store, offline/btf/synthesizer.hpp), so the radiance reflected towards the viewer from a
// point light of intensity I at distance d is value · I / d², and the f_r·cos(n, ω_i) product
// of paper 003 eq. 4–5 is exactly the stored value.
//
// Set-up (BtfMaterial::build) allocates; evaluate()/shade_*() are noexcept, allocation-free and
// thread-safe on const data.
#pragma once

#include <cmath>
#include <memory>
#include <type_traits>
#include <utility>

#include <glm/glm.hpp>

#include "btflod/core/result.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/nine_tap.hpp"
#include "btflod/offline/angular/parameterization.hpp"
#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/math/math.hpp"

namespace btflod {

/// How much work a BTF evaluation may do. `interactive` is what a renderer uses while the
/// camera moves: SPMM evaluates its analytic mixture only, without the residual (paper 003
/// §5.4); representations with a level-of-detail knob evaluate a coarser, cheaper level
/// (Laplacian PCA: one band up, λ = 1); the others are unchanged. A representation added to
/// AnyFactorization with a cheaper evaluation path gets it here, in evaluate_representation().
enum class ShadeQuality : uint8_t { full, interactive };

/// Evaluates representation `f` at texel (x, y) for the nine taps of a light and a view
/// AngularSample. Works for every alternative of AnyFactorization: one with an LOD parameter
/// (evaluate(x, y, light, view, lod)) gets lod 0 at `full` and 1 at `interactive`. Returns
/// linear RGB (ρ·cos θ_l). Preconditions: x, y inside the representation; sample indices
/// < its direction counts. noexcept.
inline glm::vec3 evaluate_representation(const AnyFactorization& f, int x, int y, const AngularSample& light,
                                         const AngularSample& view,
                                         ShadeQuality quality = ShadeQuality::full) noexcept {
  return std::visit(
      [&](const auto& r) -> glm::vec3 {
        if constexpr (std::is_same_v<std::decay_t<decltype(r)>, Spmm>) {
          // paper 003 §5.4: no residual (ε of eq. 3) while the camera moves.
          SpmmEvalOptions options;
          options.residual = quality == ShadeQuality::full;
          return r.evaluate(x, y, light, view, options);
        } else if constexpr (requires { r.evaluate(x, y, light, view, 0.0f); }) {
          const float lod = quality == ShadeQuality::interactive ? 1.0f : 0.0f;
          return r.evaluate(x, y, light, view, lod);
        } else {
          return r.evaluate(x, y, light, view);
        }
      },
      f);
}

/// A BTF material for a ray tracer: one representation and the angular interpolators of its
/// light and view direction sets. Texture coordinates repeat (wrap) over the material;
/// (0, 0) is the corner of texel (0, 0), v grows with texel rows. Texel lookup is nearest
/// (the representations store per-texel weights; a tracer with one primary ray per pixel, as
/// paper 003's, filters nothing either). Movable; evaluate() is thread-safe.
class BtfMaterial {
 public:
  /// Builds the interpolators (allocates). Returns invalid_argument for an empty
  /// representation, or the triangulation's error when a direction set has fewer than three
  /// distinct directions.
  static Result<BtfMaterial> build(std::shared_ptr<const AnyFactorization> representation) {
    if (!representation) return make_error(Status::invalid_argument, "BtfMaterial: no representation");
    const BtfShape& shape = factorization_shape(*representation);
    if (shape.width <= 0 || shape.height <= 0 || shape.views.empty() || shape.lights.empty())
      return make_error(Status::invalid_argument,
                        "BtfMaterial: empty representation (%d x %d texels, %zu views, %zu lights)", shape.width,
                        shape.height, shape.views.size(), shape.lights.size());
    auto li = ExactGridInterpolator<ParabolicMap>::build(shape.lights);
    if (!li) return make_error(li.status(), "BtfMaterial: light directions: %s", li.message().c_str());
    auto vi = ExactGridInterpolator<ParabolicMap>::build(shape.views);
    if (!vi) return make_error(vi.status(), "BtfMaterial: view directions: %s", vi.message().c_str());
    BtfMaterial m;
    m.representation_ = std::move(representation);
    m.light_interp_ = std::move(*li);
    m.view_interp_ = std::move(*vi);
    m.width_ = shape.width;
    m.height_ = shape.height;
    return m;
  }

  /// ρ·cos θ_l at texture coordinates uv for a light and a view direction in the surface's
  /// tangent frame (unit, z = normal). Directions below the horizon (z ≤ 0) give 0: the surface
  /// neither receives light from behind nor is seen from behind. noexcept.
  glm::vec3 evaluate(glm::vec2 uv, glm::vec3 light_local, glm::vec3 view_local,
                     ShadeQuality quality = ShadeQuality::full) const noexcept {
    if (!(light_local.z > 0.0f) || !(view_local.z > 0.0f)) return glm::vec3(0.0f);
    const int x = wrap_index(uv.x, width_), y = wrap_index(uv.y, height_);
    const AngularSample l = light_interp_.query(light_local);
    const AngularSample v = view_interp_.query(view_local);
    return evaluate_representation(*representation_, x, y, l, v, quality);
  }

  /// The nine (light, view) taps and weights used for a pair of local directions (what
  /// evaluate() combines), for inspection and tests.
  NineTapSample taps(glm::vec3 light_local, glm::vec3 view_local) const noexcept {
    return combine_nine_tap(light_interp_.query(light_local), view_interp_.query(view_local));
  }

  /// The angular samples (three taps and weights each) evaluate() uses for a light and a view
  /// direction in the tangent frame, for callers that evaluate the representation themselves
  /// (e.g. with their own SpmmEvalOptions). noexcept.
  AngularSample light_sample(glm::vec3 light_local) const noexcept { return light_interp_.query(light_local); }
  AngularSample view_sample(glm::vec3 view_local) const noexcept { return view_interp_.query(view_local); }

  /// The shaded representation (shared, immutable).
  const AnyFactorization& representation() const noexcept { return *representation_; }
  /// Texels per row and per column of the representation.
  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }

  /// Texel index of texture coordinate u over n texels, repeating. NaN/inf map to 0. noexcept.
  static int wrap_index(float u, int n) noexcept {
    if (!std::isfinite(u)) return 0;
    const float f = u - std::floor(u);
    const int i = static_cast<int>(f * static_cast<float>(n));
    return i < 0 ? 0 : (i >= n ? n - 1 : i);
  }

 private:
  std::shared_ptr<const AnyFactorization> representation_;
  ExactGridInterpolator<ParabolicMap> light_interp_, view_interp_;
  int width_ = 0, height_ = 0;
};

/// What a surface is made of. A `btf` surface points at a BtfMaterial (not owned; must outlive
/// the scene); `lambertian` reflects albedo/π; `mirror` is a perfect specular reflector that
/// reflects `mirror_reflectance` of the radiance arriving along the mirrored direction (paper
/// 003 §4.1: one reflection ray).
struct SurfaceMaterial {
  enum class Kind : uint8_t { lambertian, btf, mirror };
  Kind kind = Kind::lambertian;
  glm::vec3 albedo{0.7f};
  const BtfMaterial* btf = nullptr;
  glm::vec3 mirror_reflectance{0.9f};

  /// A Lambertian surface (albedo per channel, in [0, 1] for energy conservation).
  static SurfaceMaterial lambertian(glm::vec3 albedo) noexcept { return {Kind::lambertian, albedo, nullptr, {}}; }
  /// A BTF surface; `m` must outlive every scene using it.
  static SurfaceMaterial textured(const BtfMaterial& m) noexcept { return {Kind::btf, {}, &m, {}}; }
  /// A perfect mirror reflecting `reflectance` per channel.
  static SurfaceMaterial mirror(glm::vec3 reflectance) noexcept { return {Kind::mirror, {}, nullptr, reflectance}; }
};

/// f_r·cos(n, ω_i) of a non-mirror material for local light and view directions (unit, z = n):
/// the BTF value (ρ·cos θ_l) or albedo/π·cos θ_l. 0 below the horizon, and 0 for mirrors
/// (they only reflect along one direction; see reflect_direction()). noexcept.
inline glm::vec3 shade_reflectance_cos(const SurfaceMaterial& m, glm::vec2 uv, glm::vec3 light_local,
                                       glm::vec3 view_local, ShadeQuality quality = ShadeQuality::full) noexcept {
  switch (m.kind) {
    case SurfaceMaterial::Kind::btf:
      return m.btf != nullptr ? m.btf->evaluate(uv, light_local, view_local, quality) : glm::vec3(0.0f);
    case SurfaceMaterial::Kind::lambertian:
      if (!(light_local.z > 0.0f) || !(view_local.z > 0.0f)) return glm::vec3(0.0f);
      return m.albedo * (light_local.z / kPi);
    case SurfaceMaterial::Kind::mirror:
      return glm::vec3(0.0f);
  }
  return glm::vec3(0.0f);
}

/// Reflectance for uniform ambient light, ∫ f_r cos dω_i over the hemisphere, so that the
/// ambient term of paper 003 §4.1 is L_ambient · A(p) · this. Lambertian: the albedo. BTF: the
/// representation holds no hemispherical integral, so π · (ρ·cos θ_l) with the light along the
/// normal stands for it (exact for a Lambertian BTF, an estimate otherwise). noexcept.
inline glm::vec3 ambient_reflectance(const SurfaceMaterial& m, glm::vec2 uv, glm::vec3 view_local,
                                     ShadeQuality quality = ShadeQuality::full) noexcept {
  switch (m.kind) {
    case SurfaceMaterial::Kind::btf:
      return m.btf != nullptr ? kPi * m.btf->evaluate(uv, glm::vec3(0, 0, 1), view_local, quality) : glm::vec3(0.0f);
    case SurfaceMaterial::Kind::lambertian:
      return view_local.z > 0.0f ? m.albedo : glm::vec3(0.0f);
    case SurfaceMaterial::Kind::mirror:
      return glm::vec3(0.0f);
  }
  return glm::vec3(0.0f);
}

/// The perfect specular reflection of incoming direction `incident` (pointing towards the
/// surface) about unit normal n. noexcept.
inline glm::vec3 reflect_direction(glm::vec3 incident, glm::vec3 n) noexcept {
  return incident - 2.0f * glm::dot(incident, n) * n;
}

}  // namespace btflod
