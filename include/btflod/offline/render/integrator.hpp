// btflod — the illumination model of paper 003 §4.1 for any ray tracer (offline/render/surface.hpp's
// RayTracer concept): point lights with one shadow ray each; rectangular area lights sampled
// progressively, one shadow ray per pixel per frame, accumulated in an image-space buffer and
// scaled by Ω·L_e/N at display (eq. 4–5); ambient occlusion with one cosine-distributed ray of
// length r per pixel per frame (eq. 6–7); one perfect specular reflection ray per bounce for
// mirror materials. The progressive buffers reset when the camera, the geometry or a light's
// position changes, and not when only a light's emitted radiance (or intensity) changes: the
// accumulated sums hold no L_e, it is applied at display.
//
// Use: ProgressiveAccumulator::allocate() once; per frame begin_frame(keys), render_pixels()
// over disjoint pixel rectangles (any number of threads: every pixel draws its random numbers
// from PixelRng keyed by (seed, pixel, accumulated frame index), so the image is identical for
// any thread count and tiling), end_frame(), resolve(). Per-frame functions are noexcept and
// allocation-free.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/math/math.hpp"
#include "btflod/offline/render/sampling.hpp"
#include "btflod/offline/render/shading.hpp"
#include "btflod/offline/render/surface.hpp"

namespace btflod {

/// An isotropic point light: radiant intensity per colour channel (W/sr). The radiance it
/// reflects towards the viewer is (ρ·cos θ_l) · intensity / d².
struct PointLight {
  glm::vec3 position{0.0f};
  glm::vec3 intensity{1.0f};
};

/// A one-sided rectangular area light corner + s·edge_u + t·edge_v (s, t ∈ [0, 1], edges
/// perpendicular) emitting constant radiance L_e on the side of cross(edge_u, edge_v) (paper
/// 003 eq. 5 assumes L_e constant over the light and directions).
struct AreaLight {
  glm::vec3 corner{0.0f};
  glm::vec3 edge_u{1, 0, 0};
  glm::vec3 edge_v{0, 0, 1};
  glm::vec3 radiance{1.0f};
  /// Unit normal of the emitting side.
  glm::vec3 normal() const noexcept { return glm::normalize(glm::cross(edge_u, edge_v)); }
};

/// A pinhole camera; pixel (x, y) covers [x, x + 1) × [y, y + 1), y grows downwards, one
/// primary ray through each pixel centre (as paper 003: one primary ray per pixel).
struct PinholeCamera {
  glm::vec3 eye{0.0f, 1.0f, 4.0f};
  glm::vec3 target{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float fov_y_degrees = 50.0f;
  uint32_t width = 64, height = 64;

  /// The primary ray through continuous pixel coordinates (px, py). noexcept.
  TraceRay ray(float px, float py) const noexcept {
    const glm::vec3 f = glm::normalize(target - eye);
    const glm::vec3 r = glm::normalize(glm::cross(f, up));
    const glm::vec3 u = glm::cross(r, f);
    const float th = std::tan(degrees_to_radians(fov_y_degrees) * 0.5f);
    const float aspect = static_cast<float>(width) / static_cast<float>(std::max(height, 1u));
    const float sx = (2.0f * px / static_cast<float>(width) - 1.0f) * th * aspect;
    const float sy = (1.0f - 2.0f * py / static_cast<float>(height)) * th;
    TraceRay ray;
    ray.origin = eye;
    ray.direction = glm::normalize(f + sx * r + sy * u);
    return ray;
  }
};

/// Ambient light for the occlusion term: uniform radiance `radiance` from every unoccluded
/// direction within `radius` (paper 003 eq. 6; r is the occlusion radius).
struct AmbientLight {
  glm::vec3 radiance{0.0f};
  float radius = 1.0f;
};

/// Everything the integrator reads (spans into caller-owned data). meshes[i].material indexes
/// materials.
struct RenderScene {
  std::span<const SceneMesh> meshes;
  std::span<const SurfaceMaterial> materials;
  std::span<const PointLight> point_lights;
  std::span<const AreaLight> area_lights;
  AmbientLight ambient;
  glm::vec3 background{0.0f};
};

/// Checks a scene before rendering: every mesh passes validate_trace_mesh(), every material
/// index exists, every BTF material has its BtfMaterial, lights are finite with non-negative
/// emission and area lights have perpendicular, non-zero edges, the AO radius is finite and
/// > 0. Returns invalid_argument naming the offender. Allocation-free; safe for untrusted data.
inline VoidResult validate_render_scene(const RenderScene& scene) {
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    if (auto ok = validate_trace_mesh(scene.meshes[i]); !ok)
      return make_error(Status::invalid_argument, "mesh %zu: %s", i, ok.message().c_str());
    if (scene.meshes[i].material >= scene.materials.size())
      return make_error(Status::invalid_argument, "mesh %zu: material %u of %zu", i, scene.meshes[i].material,
                        scene.materials.size());
  }
  for (size_t i = 0; i < scene.materials.size(); ++i)
    if (scene.materials[i].kind == SurfaceMaterial::Kind::btf && scene.materials[i].btf == nullptr)
      return make_error(Status::invalid_argument, "material %zu: BTF material without a representation", i);
  const auto finite3 = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  const auto nonneg3 = [&](glm::vec3 v) { return finite3(v) && v.x >= 0.0f && v.y >= 0.0f && v.z >= 0.0f; };
  for (size_t i = 0; i < scene.point_lights.size(); ++i)
    if (!finite3(scene.point_lights[i].position) || !nonneg3(scene.point_lights[i].intensity))
      return make_error(Status::invalid_argument, "point light %zu: non-finite position or negative intensity", i);
  for (size_t i = 0; i < scene.area_lights.size(); ++i) {
    const AreaLight& a = scene.area_lights[i];
    if (!finite3(a.corner) || !finite3(a.edge_u) || !finite3(a.edge_v) || !nonneg3(a.radiance))
      return make_error(Status::invalid_argument, "area light %zu: non-finite geometry or negative radiance", i);
    const float lu = glm::length(a.edge_u), lv = glm::length(a.edge_v);
    if (!(lu > 0.0f) || !(lv > 0.0f) || std::abs(glm::dot(a.edge_u, a.edge_v)) > 1e-4f * lu * lv)
      return make_error(Status::invalid_argument, "area light %zu: edges must be non-zero and perpendicular", i);
  }
  if (!(scene.ambient.radius > 0.0f) || !std::isfinite(scene.ambient.radius) || !nonneg3(scene.ambient.radiance))
    return make_error(Status::invalid_argument, "ambient light: radius must be finite and > 0, radiance >= 0");
  return {};
}

/// Per-frame switches of the integrator.
struct RenderSettings {
  uint64_t seed = 1;
  bool area_lights = true;        ///< the progressive area-light term (eq. 5)
  bool ambient_occlusion = true;  ///< the progressive AO term (eq. 7)
  uint32_t max_mirror_bounces = 2;
  ShadeQuality quality = ShadeQuality::full;
  /// Shadow/AO/reflection rays start this far along the geometric normal (scene units).
  float ray_offset = 1e-4f;
};

/// What changed since the previous frame, as keys: the caller hashes or counts whatever its
/// camera, geometry and light positions are (hash_camera(), hash_light_geometry()); a change in
/// any key resets the accumulation. Emitted radiance is deliberately not a key.
struct SceneKeys {
  uint64_t camera = 0;
  uint64_t geometry = 0;
  uint64_t light_positions = 0;
  /// Equal keys: nothing that invalidates the sums changed.
  bool operator==(const SceneKeys&) const = default;
};

/// Why begin_frame() reset the buffers (none when it kept accumulating).
enum class ResetReason : uint8_t { none, first_frame, camera, geometry, light_position };

/// Hash of raw float bit patterns (splitmix64 chain). noexcept.
inline uint64_t hash_floats(std::span<const float> values, uint64_t h = 0x243F6A8885A308D3ull) noexcept {
  for (float f : values) {
    uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    h = mix_bits64(h ^ bits);
  }
  return h;
}

/// Key of a camera (position, orientation, field of view and image size). noexcept.
inline uint64_t hash_camera(const PinholeCamera& c) noexcept {
  const float v[] = {c.eye.x,
                     c.eye.y,
                     c.eye.z,
                     c.target.x,
                     c.target.y,
                     c.target.z,
                     c.up.x,
                     c.up.y,
                     c.up.z,
                     c.fov_y_degrees,
                     static_cast<float>(c.width),
                     static_cast<float>(c.height)};
  return hash_floats(v);
}

/// Key of the lights' positions and shapes only — intensities and radiances are left out, so
/// changing them keeps the accumulation (paper 003 §4.1). noexcept.
inline uint64_t hash_light_geometry(std::span<const PointLight> points, std::span<const AreaLight> areas) noexcept {
  uint64_t h = mix_bits64(points.size() * 31 + areas.size());
  for (const PointLight& p : points) h = hash_floats(std::span<const float>(&p.position.x, 3), h);
  for (const AreaLight& a : areas) {
    const float v[] = {a.corner.x, a.corner.y, a.corner.z, a.edge_u.x, a.edge_u.y,
                       a.edge_u.z, a.edge_v.x, a.edge_v.y, a.edge_v.z};
    h = hash_floats(v, h);
  }
  return h;
}

/// Rays traced by render_pixels(), by purpose.
struct RayCounts {
  uint64_t primary = 0;    ///< camera rays and mirror reflection rays (closest hit)
  uint64_t shadow = 0;     ///< point- and area-light shadow rays (any hit)
  uint64_t occlusion = 0;  ///< AO rays (any hit)
  /// All rays.
  uint64_t total() const noexcept { return primary + shadow + occlusion; }
  /// Adds another tile's counts.
  RayCounts& operator+=(const RayCounts& o) noexcept {
    primary += o.primary, shadow += o.shadow, occlusion += o.occlusion;
    return *this;
  }
};

/// The image-space buffers of progressive refinement (paper 003 §4.1). Per pixel: the direct
/// term of this frame (point lights, plus emitters seen directly; recomputed every frame), the
/// ambient reflectance of the shading point (times the mirror throughput), per area light the
/// running sum Σ_k Ω_p·f_r·cos·V (eq. 5 with the pixel's constant Ω_p inside the sum) and the
/// AO running sum Σ_k V (eq. 7). N = frames() is the number of samples in each sum.
class ProgressiveAccumulator {
 public:
  /// Allocates the buffers for a width × height image and `area_lights` area lights and marks
  /// them for reset. Returns invalid_argument for a zero or too large size.
  VoidResult allocate(uint32_t width, uint32_t height, uint32_t area_lights) {
    if (width == 0 || height == 0 || width > 16384 || height > 16384 || area_lights > 64)
      return make_error(Status::invalid_argument, "accumulator: %u x %u pixels, %u area lights", width, height,
                        area_lights);
    width_ = width, height_ = height, area_count_ = area_lights;
    const size_t n = static_cast<size_t>(width) * height;
    direct_.assign(n, glm::vec3(0.0f));
    ambient_albedo_.assign(n, glm::vec3(0.0f));
    area_sum_.assign(n * area_lights, glm::vec3(0.0f));
    ao_sum_.assign(n, 0.0f);
    frames_ = 0;
    has_keys_ = false;
    return {};
  }

  /// Starts a frame: when `keys` differ from the previous frame's (or on the first frame) the
  /// sums and N are cleared. Returns why it reset (ResetReason::none when it did not). noexcept.
  ResetReason begin_frame(const SceneKeys& keys) noexcept {
    ResetReason reason = ResetReason::none;
    if (!has_keys_)
      reason = ResetReason::first_frame;
    else if (keys.camera != keys_.camera)
      reason = ResetReason::camera;
    else if (keys.geometry != keys_.geometry)
      reason = ResetReason::geometry;
    else if (keys.light_positions != keys_.light_positions)
      reason = ResetReason::light_position;
    keys_ = keys;
    has_keys_ = true;
    if (reason != ResetReason::none) clear();
    return reason;
  }
  /// Clears the sums and N (keeps the keys). noexcept.
  void clear() noexcept {
    std::fill(area_sum_.begin(), area_sum_.end(), glm::vec3(0.0f));
    std::fill(ao_sum_.begin(), ao_sum_.end(), 0.0f);
    frames_ = 0;
  }
  /// Ends a frame: every pixel has added one sample, N grows by one. noexcept.
  void end_frame() noexcept { ++frames_; }

  /// N: samples accumulated per pixel since the last reset.
  uint32_t frames() const noexcept { return frames_; }
  /// Image size and area-light count given to allocate().
  uint32_t width() const noexcept { return width_; }
  uint32_t height() const noexcept { return height_; }
  uint32_t area_light_count() const noexcept { return area_count_; }

  /// Writes the display image (linear RGB, out must be width × height × ≥ 3 channels):
  /// direct + Σ_l L_e,l · S_l / N (eq. 5) + L_ambient · ambient reflectance · S_AO / N (eq. 7,
  /// see integrator note there) using the CURRENT emission of `area_lights` and `ambient`, so a
  /// radiance change shows without resetting. With N = 0 the progressive terms are 0. Returns
  /// false (out untouched) on a size mismatch. noexcept.
  bool resolve(std::span<const AreaLight> area_lights, const AmbientLight& ambient,
               ImageView<float> out) const noexcept {
    if (out.width() != static_cast<int>(width_) || out.height() != static_cast<int>(height_) || out.channels() < 3 ||
        area_lights.size() != area_count_)
      return false;
    const float inv_n = frames_ > 0 ? 1.0f / static_cast<float>(frames_) : 0.0f;
    for (uint32_t y = 0; y < height_; ++y)
      for (uint32_t x = 0; x < width_; ++x) {
        const size_t p = static_cast<size_t>(y) * width_ + x;
        glm::vec3 c = direct_[p];
        for (uint32_t l = 0; l < area_count_; ++l)
          c += area_lights[l].radiance * area_sum_[p * area_count_ + l] * inv_n;
        c += ambient.radiance * ambient_albedo_[p] * (ao_sum_[p] * inv_n);
        for (int k = 0; k < 3; ++k) out.at(static_cast<int>(x), static_cast<int>(y), k) = c[k];
      }
    return true;
  }

  /// The AO estimate ⟨A(p)⟩ = S_AO / N of pixel (x, y) (eq. 7; 0 when N = 0). noexcept.
  float ambient_occlusion(uint32_t x, uint32_t y) const noexcept {
    return frames_ > 0 ? ao_sum_[static_cast<size_t>(y) * width_ + x] / static_cast<float>(frames_) : 0.0f;
  }

  /// Per-pixel buffers (pixel p = y·width + x) for render_pixels() or another integrator: the
  /// direct term and ambient reflectance are overwritten each frame, the sums accumulate. Each
  /// pixel must be written by one thread per frame. Preconditions: p < width·height, light <
  /// area_light_count(). noexcept.
  glm::vec3& direct(size_t p) noexcept { return direct_[p]; }
  glm::vec3& ambient_albedo(size_t p) noexcept { return ambient_albedo_[p]; }
  glm::vec3& area_sum(size_t p, uint32_t light) noexcept { return area_sum_[p * area_count_ + light]; }
  float& ao_sum(size_t p) noexcept { return ao_sum_[p]; }

 private:
  uint32_t width_ = 0, height_ = 0, area_count_ = 0, frames_ = 0;
  SceneKeys keys_{};
  bool has_keys_ = false;
  std::vector<glm::vec3> direct_, ambient_albedo_, area_sum_;
  std::vector<float> ao_sum_;
};

/// Random-number purposes: each term draws from its own stream (PixelRng).
enum RngPurpose : uint32_t { kRngAreaLight = 1, kRngAmbientOcclusion = 2 };

namespace detail {

/// Nearest area light hit along a ray before t_max (lights are not in the tracer's geometry:
/// shadow rays towards them must not be blocked by them). Returns the light index or −1.
inline int intersect_area_lights(std::span<const AreaLight> lights, const TraceRay& ray, float& t_max) noexcept {
  int best = -1;
  for (size_t i = 0; i < lights.size(); ++i) {
    const AreaLight& a = lights[i];
    const glm::vec3 n = glm::cross(a.edge_u, a.edge_v);
    const float denom = glm::dot(n, ray.direction);
    if (!(denom < 0.0f)) continue;  // one-sided: seen only from the emitting side
    const float t = glm::dot(a.corner - ray.origin, n) / denom;
    if (!(t > ray.t_min) || !(t < t_max)) continue;
    const glm::vec3 q = ray.origin + t * ray.direction - a.corner;
    const float s = glm::dot(q, a.edge_u) / glm::dot(a.edge_u, a.edge_u);
    const float r = glm::dot(q, a.edge_v) / glm::dot(a.edge_v, a.edge_v);
    if (s < 0.0f || s > 1.0f || r < 0.0f || r > 1.0f) continue;
    t_max = t;
    best = static_cast<int>(i);
  }
  return best;
}

}  // namespace detail

/// Renders one frame's contribution for the pixels [x0, x1) × [y0, y1) into `acc`: overwrites
/// their direct term and ambient reflectance, adds one area-light sample per area light and one
/// AO sample to their sums (when enabled). Preconditions: acc allocated for the camera's size
/// and the scene's area-light count; begin_frame() called for this frame; the scene passed
/// validate_render_scene(). Thread-safe for disjoint rectangles of the same frame; noexcept;
/// allocation-free. Adds the rays it traced to `counts`.
template <RayTracer Tracer>
void render_pixels(const RenderScene& scene, const Tracer& tracer, const PinholeCamera& camera,
                   const RenderSettings& settings, ProgressiveAccumulator& acc, uint32_t x0, uint32_t y0, uint32_t x1,
                   uint32_t y1, RayCounts& counts) noexcept {
  const uint32_t sample = acc.frames();
  const uint32_t n_area = static_cast<uint32_t>(scene.area_lights.size());
  for (uint32_t y = y0; y < y1; ++y)
    for (uint32_t x = x0; x < x1; ++x) {
      const size_t p = static_cast<size_t>(y) * acc.width() + x;
      TraceRay ray = camera.ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
      glm::vec3 throughput(1.0f), direct(0.0f), ambient(0.0f);
      bool shaded = false;
      SurfacePoint s;
      const SurfaceMaterial* mat = nullptr;
      for (uint32_t bounce = 0;; ++bounce) {
        const TraceHit hit = tracer.intersect(ray);
        ++counts.primary;
        float t_light = hit.hit ? hit.t : ray.t_max;
        const int light = detail::intersect_area_lights(scene.area_lights, ray, t_light);
        if (light >= 0) {  // an emitter seen directly (or in a mirror)
          direct += throughput * scene.area_lights[static_cast<size_t>(light)].radiance;
          break;
        }
        if (!hit.hit) {
          direct += throughput * scene.background;
          break;
        }
        s = interpolate_surface(scene.meshes[hit.mesh], hit, ray.direction);
        mat = &scene.materials[s.material];
        if (mat->kind == SurfaceMaterial::Kind::mirror) {
          if (bounce >= settings.max_mirror_bounces) break;  // black beyond the last bounce
          throughput *= mat->mirror_reflectance;
          // paper 003 §4.1: one ray along the perfect specular direction.
          const glm::vec3 d = glm::normalize(reflect_direction(ray.direction, s.frame.n));
          ray = TraceRay{s.position + s.geometric_normal * settings.ray_offset, d, 0.0f,
                         std::numeric_limits<float>::infinity()};
          continue;
        }
        shaded = true;
        break;
      }
      if (!shaded) {
        acc.direct(p) = direct;
        acc.ambient_albedo(p) = glm::vec3(0.0f);
        // nothing to shade: the sums get a zero sample (N counts frames, not hits).
        continue;
      }
      const glm::vec3 origin = s.position + s.geometric_normal * settings.ray_offset;
      const glm::vec3 view_local = s.frame.to_local(-ray.direction);
      // Point lights: one shadow ray each (§4.1).
      for (const PointLight& pl : scene.point_lights) {
        const glm::vec3 to = pl.position - origin;
        const float d2 = glm::dot(to, to);
        if (!(d2 > 0.0f)) continue;
        const float d = std::sqrt(d2);
        const glm::vec3 w = to / d;
        if (glm::dot(w, s.geometric_normal) <= 0.0f) continue;
        const glm::vec3 f = shade_reflectance_cos(*mat, s.uv, s.frame.to_local(w), view_local, settings.quality);
        if (f == glm::vec3(0.0f)) continue;
        ++counts.shadow;
        if (tracer.occluded(TraceRay{origin, w, 0.0f, d})) continue;
        direct += throughput * f * pl.intensity / d2;
      }
      acc.direct(p) = direct;
      acc.ambient_albedo(p) = throughput * ambient_reflectance(*mat, s.uv, view_local, settings.quality);
      // Area lights: one shadow ray per light per frame, uniform in solid angle (eq. 4–5).
      if (settings.area_lights && n_area > 0) {
        PixelRng rng = PixelRng::for_pixel(settings.seed, x, y, sample, kRngAreaLight);
        for (uint32_t l = 0; l < n_area; ++l) {
          const AreaLight& a = scene.area_lights[l];
          const glm::vec2 u = rng.next_vec2();  // drawn even when unused: streams stay aligned
          if (glm::dot(origin - a.corner, a.normal()) <= 0.0f) continue;  // behind a one-sided light
          const SphericalRectangle rect = SphericalRectangle::build(origin, a.corner, a.edge_u, a.edge_v);
          if (!rect.valid()) continue;
          const glm::vec3 to = rect.sample(u) - origin;
          const float d = glm::length(to);
          if (!(d > 0.0f)) continue;
          const glm::vec3 w = to / d;
          if (glm::dot(w, s.geometric_normal) <= 0.0f) continue;
          const glm::vec3 f = shade_reflectance_cos(*mat, s.uv, s.frame.to_local(w), view_local, settings.quality);
          if (f == glm::vec3(0.0f)) continue;
          ++counts.shadow;
          if (tracer.occluded(TraceRay{origin, w, 0.0f, d * (1.0f - 1e-4f)})) continue;
          acc.area_sum(p, l) += throughput * f * rect.solid_angle();
        }
      }
      // Ambient occlusion: one cosine-distributed ray of length r per frame (eq. 6–7). With
      // cosine-density samples (pdf cos/π) the estimator of eq. 6's (1/π)∫V cos dω is
      // (1/N)·Σ V; paper 003 writes eq. 7 with an extra 1/π that its ambient term absorbs. Here
      // A(p) ∈ [0, 1] (1 = unoccluded), the display multiplies by L_ambient · reflectance.
      if (settings.ambient_occlusion) {
        PixelRng rng = PixelRng::for_pixel(settings.seed, x, y, sample, kRngAmbientOcclusion);
        const glm::vec3 w = s.frame.to_world(sample_cosine_hemisphere(rng.next_vec2()));
        float v = 0.0f;
        if (glm::dot(w, s.geometric_normal) > 0.0f) {  // below the true surface counts as occluded
          ++counts.occlusion;
          v = tracer.occluded(TraceRay{origin, w, 0.0f, scene.ambient.radius}) ? 0.0f : 1.0f;
        }
        acc.ao_sum(p) += v;
      }
    }
}

}  // namespace btflod
