// btflod — CPU reference path for the sparse virtual texture loop: a ray-caster of simple
// scenes (planes, spheres, tori with uv and tangent frames) that produces the feedback buffer a
// GPU feedback pass would (paper 000 §3, eqs. 1–2), a CPU copy of the physical tile cache that
// is sampled through the page table (eq. 3 indirection, bilinear inside the bordered tile), FMF
// shading with the 9-tap light × view combination (eq. 5, §4), and the ABRDF error E of eq. 7.
//
// It is the oracle for GPU backends and the engine of the replay harness (samples/tools/replay). All
// per-pixel functions are noexcept, allocation-free and thread-safe on const data; the render_*
// loops are single-threaded and deterministic.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/thread_pool.hpp"
#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/angular/table_lookup.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/offline/math/math.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/lod_selector.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"
#include "btflod/runtime/vt/cache_format.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"

namespace btflod {

struct Ray {
  glm::vec3 origin{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};  ///< unit length
};

/// A ray–surface hit with the texture parameterisation the shader would see.
struct SurfaceHit {
  bool hit = false;
  float t = 0.0f;
  uint32_t material = 0;
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 0.0f, 1.0f};  ///< unit, facing the ray origin
  glm::vec3 dpdu{1.0f, 0.0f, 0.0f};    ///< ∂position/∂texcoord.x (includes the uv scale)
  glm::vec3 dpdv{0.0f, 1.0f, 0.0f};
  glm::vec2 texcoord{0.0f};  ///< texture coordinates, wrapped to [0, 1) (the texture repeats)
};

enum class ShapeKind : uint8_t { plane, sphere, torus };

/// A plane rectangle (origin + u·size_u·axis_u + v·size_v·axis_v, u, v ∈ [0, 1)), a sphere
/// (u = azimuth, v = polar angle) or a torus around +y (u around the major circle, v around
/// the tube). uv_scale repeats the material over the surface.
struct Shape {
  ShapeKind kind = ShapeKind::plane;
  uint32_t material = 0;
  glm::vec3 center{0.0f};              ///< plane: origin corner
  glm::vec3 axis_u{1.0f, 0.0f, 0.0f};  ///< plane only (unit)
  glm::vec3 axis_v{0.0f, 0.0f, 1.0f};  ///< plane only (unit)
  float size_u = 1.0f;                 ///< plane: extent along axis_u; sphere: radius; torus: major radius
  float size_v = 1.0f;                 ///< plane: extent along axis_v; torus: minor radius
  glm::vec2 uv_scale{1.0f, 1.0f};

  /// Rectangle origin + u·size_u·axis_u + v·size_v·axis_v (axes normalised here), two-sided.
  static Shape plane(uint32_t material, glm::vec3 origin, glm::vec3 axis_u, glm::vec3 axis_v, float size_u,
                     float size_v, glm::vec2 uv_scale = {1, 1}) noexcept {
    Shape s = with_placement(ShapeKind::plane, material, origin, uv_scale);
    s.axis_u = glm::normalize(axis_u);
    s.axis_v = glm::normalize(axis_v);
    s.size_u = size_u;
    s.size_v = size_v;
    return s;
  }
  /// Sphere of `radius` around center; u = azimuth / 2π, v = polar angle / π.
  static Shape sphere(uint32_t material, glm::vec3 center, float radius, glm::vec2 uv_scale = {1, 1}) noexcept {
    Shape s = with_placement(ShapeKind::sphere, material, center, uv_scale);
    s.size_u = radius;
    return s;
  }
  /// Torus around +y: major radius `major`, tube radius `minor`; u around the ring, v around the tube.
  static Shape torus(uint32_t material, glm::vec3 center, float major, float minor,
                     glm::vec2 uv_scale = {1, 1}) noexcept {
    Shape s = with_placement(ShapeKind::torus, material, center, uv_scale);
    s.size_u = major;
    s.size_v = minor;
    return s;
  }

 private:
  // A shape of `kind` at `center` with the fields every kind sets; sizes and axes at their defaults.
  static Shape with_placement(ShapeKind kind, uint32_t material, glm::vec3 center, glm::vec2 uv_scale) noexcept {
    Shape s;
    s.kind = kind;
    s.material = material;
    s.center = center;
    s.uv_scale = uv_scale;
    return s;
  }
};

namespace detail {

inline float wrap01(float x) noexcept {
  const float f = x - std::floor(x);
  return f >= 1.0f ? 0.0f : f;
}

// Fills position-derived fields from the shape parameterisation at (u, v) ∈ [0,1)² (before scale).
inline void finish_hit(const Shape& s, float u, float v, SurfaceHit& h) noexcept {
  h.dpdu /= s.uv_scale.x;
  h.dpdv /= s.uv_scale.y;
  h.texcoord = glm::vec2(wrap01(u * s.uv_scale.x), wrap01(v * s.uv_scale.y));
  h.material = s.material;
  h.hit = true;
}

inline bool intersect_plane(const Shape& s, const Ray& r, float t_max, SurfaceHit& h) noexcept {
  const glm::vec3 n = glm::normalize(glm::cross(s.axis_u, s.axis_v));
  const float denom = glm::dot(n, r.direction);
  if (std::abs(denom) < 1e-8f) return false;
  const float t = glm::dot(s.center - r.origin, n) / denom;
  if (!(t > 1e-5f) || t >= t_max) return false;
  const glm::vec3 p = r.origin + t * r.direction;
  const float u = glm::dot(p - s.center, s.axis_u) / s.size_u;
  const float v = glm::dot(p - s.center, s.axis_v) / s.size_v;
  if (u < 0.0f || u >= 1.0f || v < 0.0f || v >= 1.0f) return false;
  h.t = t;
  h.position = p;
  h.normal = denom < 0.0f ? n : -n;
  h.dpdu = s.axis_u * s.size_u;
  h.dpdv = s.axis_v * s.size_v;
  finish_hit(s, u, v, h);
  return true;
}

inline bool intersect_sphere(const Shape& s, const Ray& r, float t_max, SurfaceHit& h) noexcept {
  const glm::vec3 oc = r.origin - s.center;
  const float b = glm::dot(oc, r.direction);
  const float c = glm::dot(oc, oc) - s.size_u * s.size_u;
  const float disc = b * b - c;
  if (disc < 0.0f) return false;
  const float sq = std::sqrt(disc);
  float t = -b - sq;
  if (!(t > 1e-5f)) t = -b + sq;
  if (!(t > 1e-5f) || t >= t_max) return false;
  const glm::vec3 p = r.origin + t * r.direction;
  const glm::vec3 d = (p - s.center) / s.size_u;
  const float theta = std::acos(std::clamp(d.y, -1.0f, 1.0f));
  float phi = std::atan2(d.z, d.x);
  if (phi < 0.0f) phi += kTwoPi;
  const float st = std::sin(theta), ct = std::cos(theta), sp = std::sin(phi), cp = std::cos(phi);
  h.t = t;
  h.position = p;
  h.normal = glm::dot(d, r.direction) < 0.0f ? d : -d;
  h.dpdu = kTwoPi * s.size_u * glm::vec3(-st * sp, 0.0f, st * cp);
  h.dpdv = kPi * s.size_u * glm::vec3(ct * cp, -st, ct * sp);
  if (st < 1e-4f) h.dpdu = kTwoPi * s.size_u * 1e-4f * glm::vec3(-sp, 0.0f, cp);  // pole: keep a frame
  finish_hit(s, phi / kTwoPi, theta / kPi, h);
  return true;
}

inline float torus_sdf(const Shape& s, glm::vec3 p) noexcept {
  const glm::vec3 q = p - s.center;
  const float ring = std::sqrt(q.x * q.x + q.z * q.z) - s.size_u;
  return std::sqrt(ring * ring + q.y * q.y) - s.size_v;
}

inline bool intersect_torus(const Shape& s, const Ray& r, float t_max, SurfaceHit& h) noexcept {
  // Bounding sphere, then sphere tracing of the signed distance (deterministic, 256 steps).
  const float bound = s.size_u + s.size_v;
  const glm::vec3 oc = r.origin - s.center;
  const float b = glm::dot(oc, r.direction);
  const float c = glm::dot(oc, oc) - bound * bound;
  const float disc = b * b - c;
  if (disc < 0.0f) return false;
  const float sq = std::sqrt(disc);
  float t = std::max(-b - sq, 0.0f);
  const float t_end = std::min(-b + sq, t_max);
  const float eps = 1e-5f * bound;
  bool found = false;
  for (int i = 0; i < 256 && t < t_end; ++i) {
    const float d = torus_sdf(s, r.origin + t * r.direction);
    if (d < eps) {
      found = true;
      break;
    }
    t += d;
  }
  if (!found || !(t > 1e-5f) || t >= t_max) return false;
  const glm::vec3 p = r.origin + t * r.direction;
  const glm::vec3 q = p - s.center;
  float u = std::atan2(q.z, q.x);
  if (u < 0.0f) u += kTwoPi;
  const float radial = std::sqrt(q.x * q.x + q.z * q.z) - s.size_u;
  float v = std::atan2(q.y, radial);
  if (v < 0.0f) v += kTwoPi;
  const float cu = std::cos(u), su = std::sin(u), cv = std::cos(v), sv = std::sin(v);
  const glm::vec3 n(cv * cu, sv, cv * su);
  h.t = t;
  h.position = p;
  h.normal = glm::dot(n, r.direction) < 0.0f ? n : -n;
  h.dpdu = kTwoPi * (s.size_u + s.size_v * cv) * glm::vec3(-su, 0.0f, cu);
  h.dpdv = kTwoPi * s.size_v * glm::vec3(-sv * cu, cv, -sv * su);
  finish_hit(s, u / kTwoPi, v / kTwoPi, h);
  return true;
}

}  // namespace detail

/// A list of shapes. Set-up allocates; intersect() is noexcept and thread-safe.
class Scene {
 public:
  /// Adds a shape (allocates; set-up only).
  void add(const Shape& s) { shapes_.push_back(s); }
  /// The shapes in insertion order.
  std::span<const Shape> shapes() const noexcept { return shapes_; }

  /// Closest hit along the ray (hit = false when none). noexcept, allocation-free.
  SurfaceHit intersect(const Ray& r) const noexcept {
    SurfaceHit best;
    float t_max = 1e30f;
    for (const Shape& s : shapes_) {
      SurfaceHit h;
      bool ok = false;
      switch (s.kind) {
        case ShapeKind::plane:
          ok = detail::intersect_plane(s, r, t_max, h);
          break;
        case ShapeKind::sphere:
          ok = detail::intersect_sphere(s, r, t_max, h);
          break;
        case ShapeKind::torus:
          ok = detail::intersect_torus(s, r, t_max, h);
          break;
      }
      if (ok) {
        best = h;
        t_max = h.t;
      }
    }
    return best;
  }

 private:
  std::vector<Shape> shapes_;
};

/// A pinhole camera. Pixel (x, y) covers [x, x+1) × [y, y+1); y grows downwards.
struct Camera {
  glm::vec3 position{0.0f, 0.0f, 5.0f};
  glm::vec3 target{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float fov_y_degrees = 45.0f;
  uint32_t width = 320;
  uint32_t height = 180;

  /// The ray through continuous pixel coordinates (px, py). noexcept.
  Ray ray(float px, float py) const noexcept {
    const glm::vec3 f = glm::normalize(target - position);
    const glm::vec3 r = glm::normalize(glm::cross(f, up));
    const glm::vec3 u = glm::cross(r, f);
    const float th = std::tan(degrees_to_radians(fov_y_degrees) * 0.5f);
    const float aspect = static_cast<float>(width) / static_cast<float>(height);
    const float sx = (2.0f * px / static_cast<float>(width) - 1.0f) * th * aspect;
    const float sy = (1.0f - 2.0f * py / static_cast<float>(height)) * th;
    return Ray{position, glm::normalize(f + sx * r + sy * u)};
  }
};

/// Texel footprint of pixel (px, py) at a hit by ray differentials: the rays through
/// (px+1, py) and (px, py+1) meet the hit's tangent plane; their texture-coordinate offsets
/// (least squares on dpdu, dpdv) times the finest-level texture size give ‖∂Π/∂x‖, ‖∂Π/∂y‖
/// of eq. 1 in finest texels. distance = eye distance. noexcept.
inline LodInput surface_footprint(const Camera& cam, const SurfaceHit& h, float px, float py, uint32_t width_texels,
                                  uint32_t height_texels) noexcept {
  LodInput in;
  in.distance = h.t;
  const float a = glm::dot(h.dpdu, h.dpdu), b = glm::dot(h.dpdu, h.dpdv), c = glm::dot(h.dpdv, h.dpdv);
  const float det = a * c - b * b;
  const auto offset = [&](float dx, float dy) {
    const Ray r = cam.ray(px + dx, py + dy);
    const float denom = glm::dot(r.direction, h.normal);
    if (std::abs(denom) < 1e-8f || !(std::abs(det) > 0.0f)) return 1e30f;
    const float t = glm::dot(h.position - r.origin, h.normal) / denom;
    const glm::vec3 d = r.origin + t * r.direction - h.position;
    const float e = glm::dot(d, h.dpdu), f = glm::dot(d, h.dpdv);
    const float du = (c * e - b * f) / det, dv = (a * f - b * e) / det;
    const float sx = du * static_cast<float>(width_texels), sy = dv * static_cast<float>(height_texels);
    return std::sqrt(sx * sx + sy * sy);
  };
  in.footprint_x = offset(1.0f, 0.0f);
  in.footprint_y = offset(0.0f, 1.0f);
  return in;
}

/// The feedback word of one hit: material, requested level (selector + feedback_level, clamped
/// to kFeedbackMaxLevel) and tile (eq. 2). Returns kFeedbackNone for no hit or an unknown
/// material. noexcept.
template <LodSelector Selector>
uint32_t feedback_word(const Camera& cam, const SurfaceHit& h, float px, float py, const VtSet& set,
                       const Selector& selector) noexcept {
  if (!h.hit || h.material >= set.material_count()) return kFeedbackNone;
  const VtLevelTable& lv = set.material(h.material).levels;
  const VtGeometry& g = lv.geometry;
  const LodInput in = surface_footprint(cam, h, px, py, g.width, g.height);
  const uint32_t level =
      std::min(feedback_level(selector.level(in, g.finest_level), g.finest_level), kFeedbackMaxLevel);
  // Eq. 2 at this level: tile = ⌊s_l / T⌋ with s_l = texcoord · M / 2^(L−l).
  const float scale = static_cast<float>(g.tile_size << (g.finest_level - level));
  const uint32_t tx =
      std::min(static_cast<uint32_t>(h.texcoord.x * static_cast<float>(g.width) / scale), lv.tiles_x[level] - 1);
  const uint32_t ty =
      std::min(static_cast<uint32_t>(h.texcoord.y * static_cast<float>(g.height) / scale), lv.tiles_y[level] - 1);
  return pack_feedback({h.material, level, tx, ty});
}

/// Renders the feedback buffer at 1/decimation resolution: out has ⌈W/d⌉ × ⌈H/d⌉ words,
/// row-major; feedback pixel (x, y) samples screen pixel (x·d + dx, y·d + dy) with the rotating
/// offset of feedback_sample_offset(frame, d). Returns false (out untouched) when out is too
/// small. noexcept, no allocation.
template <LodSelector Selector>
bool render_feedback(const Scene& scene, const Camera& cam, const VtSet& set, const Selector& selector,
                     uint32_t decimation, uint64_t frame, std::span<uint32_t> out) noexcept {
  const uint32_t d = std::max(decimation, 1u);
  const uint32_t fw = (cam.width + d - 1) / d, fh = (cam.height + d - 1) / d;
  if (out.size() < static_cast<size_t>(fw) * fh) return false;
  uint32_t dx = 0, dy = 0;
  feedback_sample_offset(frame, d, dx, dy);
  for (uint32_t y = 0; y < fh; ++y)
    for (uint32_t x = 0; x < fw; ++x) {
      const float px = static_cast<float>(std::min(x * d + dx, cam.width - 1)) + 0.5f;
      const float py = static_cast<float>(std::min(y * d + dy, cam.height - 1)) + 0.5f;
      const SurfaceHit h = scene.intersect(cam.ray(px, py));
      out[static_cast<size_t>(y) * fw + x] = feedback_word(cam, h, px, py, set, selector);
    }
  return true;
}

/// CPU copy of the physical tile cache texture (slots_x·(T+2B) × slots_y·(T+2B) texels per
/// layer) in the cache's format (CacheConfig::format): RGBA16F, RGBA8 unorm with a map per
/// slot (runtime/vt/cache_format.hpp), or two BC5 planes with a map per slot (runtime/vt/cache_bc5.hpp:
/// the blocks are decoded by the reference decoder at upload, as the GPU decodes them before
/// filtering), filtered and mapped as the shaders do. Allocates at construction; upload() and
/// sample() are noexcept and allocation-free.
class CpuCacheTexture {
 public:
  CpuCacheTexture() = default;
  /// In the cache's format. Precondition: every material of the cache's set shares tile size
  /// and border.
  explicit CpuCacheTexture(const TileCache& cache) : CpuCacheTexture(cache, cache.config().format) {}
  /// In `format`, whatever the cache's (e.g. to compare the formats on one resident set).
  CpuCacheTexture(const TileCache& cache, CacheFormat format)
      : format_(format),
        stored_(cache.set().levels_of(0).geometry.stored_size()),
        width_(cache.config().slots_x * stored_),
        height_(cache.config().slots_y * stored_ * cache.config().cache_layers),
        texels_(format == CacheFormat::rgba16f ? static_cast<size_t>(width_) * height_ * 4 : 0, 0),
        unorm8_(format == CacheFormat::rgba8_affine ? static_cast<size_t>(width_) * height_ * 4 : 0, 0),
        bc5_(format == CacheFormat::bc5_affine ? static_cast<size_t>(width_) * height_ * 4 : 0, 0.0f),
        bc5_scratch_(format == CacheFormat::bc5_affine ? static_cast<size_t>(stored_) * stored_ * 4 : 0, 0.0f),
        maps_(cache_format_has_slot_map(format) ? cache.slot_count() : 0) {}

  /// Copies a stored tile ((T+2B)² RGBA half texels) into slot s (an rgba16f cache). Returns
  /// false on a size mismatch, a slot out of range or another cache format.
  bool upload(const TileCache& cache, uint32_t s, std::span<const uint16_t> tile) noexcept {
    if (format_ != CacheFormat::rgba16f || tile.size() != static_cast<size_t>(stored_) * stored_ * 4 ||
        s >= cache.slot_count())
      return false;
    copy_rows(cache, s, tile.data(), texels_.data());
    return true;
  }

  /// Copies a stored tile ((T+2B)² RGBA unorm8 texels) and its map into slot s (an
  /// rgba8_affine cache). Returns false on a size mismatch, a slot out of range or another format.
  bool upload(const TileCache& cache, uint32_t s, std::span<const uint8_t> tile, const CacheSlotMap& map) noexcept {
    if (format_ != CacheFormat::rgba8_affine || tile.size() != static_cast<size_t>(stored_) * stored_ * 4 ||
        s >= cache.slot_count())
      return false;
    copy_rows(cache, s, tile.data(), unorm8_.data());
    maps_[s] = map;
    return true;
  }

  /// Decodes a stored tile in the two-plane BC5 layout (cache_bc5_tile_bytes((T+2B)) bytes,
  /// runtime/vt/cache_bc5.hpp) with decode_cache_tile_bc5 and keeps it with its map in slot s (a
  /// bc5_affine cache). Returns false on a size mismatch, a slot out of range, a side that is not
  /// a multiple of 4 or another format.
  bool upload_bc5(const TileCache& cache, uint32_t s, std::span<const uint8_t> blocks,
                  const CacheSlotMap& map) noexcept {
    if (format_ != CacheFormat::bc5_affine || stored_ % 4 != 0 || blocks.size() != cache_bc5_tile_bytes(stored_) ||
        s >= cache.slot_count())
      return false;
    CacheSlotMap identity;  // the unorm values; the slot's map is applied after filtering
    for (float& scale : identity.scale) scale = 1.0f;
    decode_cache_tile_bc5(blocks, stored_, identity, bc5_scratch_);
    copy_rows(cache, s, bc5_scratch_.data(), bc5_.data());
    maps_[s] = map;
    return true;
  }

  /// Copies a Streamer's (or backend's) tile upload in any format. Returns false as upload().
  bool upload(const TileCache& cache, uint32_t s, std::span<const uint16_t> halves, std::span<const uint8_t> unorm8,
              const CacheSlotMap& map, std::span<const uint8_t> bc5 = {}) noexcept {
    if (format_ == CacheFormat::bc5_affine) return upload_bc5(cache, s, bc5, map);
    return format_ == CacheFormat::rgba8_affine ? upload(cache, s, unorm8, map) : upload(cache, s, halves);
  }

  /// Samples virtual texture `texture` at texture coordinates (u, v) ∈ [0, 1) through its page
  /// table: the entry of the finest tile names level l' and slot; paper 000 eq. 3 gives the texel
  /// in the cache (slot origin + border + the position inside the level-l' tile), then bilinear
  /// filtering inside the bordered tile, then (rgba8_affine, bc5_affine) the slot's map. Writes 4 floats;
  /// returns the level used. noexcept.
  uint32_t sample(const TileCache& cache, uint32_t texture, float u, float v, float* out) const noexcept {
    const VtLevelTable& lv = cache.set().levels_of(texture);
    const VtGeometry& g = lv.geometry;
    const uint32_t L = g.finest_level;
    const float s = u * static_cast<float>(g.width), t = v * static_cast<float>(g.height);
    const uint32_t fx = std::min(static_cast<uint32_t>(s / static_cast<float>(g.tile_size)), lv.tiles_x[L] - 1);
    const uint32_t fy = std::min(static_cast<uint32_t>(t / static_cast<float>(g.tile_size)), lv.tiles_y[L] - 1);
    const uint32_t entry = cache.page_table(texture)[static_cast<size_t>(fy) * lv.tiles_x[L] + fx];
    const uint32_t level = unpack_page_entry_level(entry), slot = unpack_page_entry_slot(entry);
    const uint32_t shift = L - level;
    const float inv = 1.0f / static_cast<float>(1u << shift);
    uint32_t ox, oy;
    cache.slot_origin(slot, ox, oy);
    oy += cache_slot_placement(cache.config(), slot).layer * cache.config().slots_y * stored_;
    // Eq. 3: x = i' + (2^{l'} s − M⌊2^{l'} s / M⌋) in texel units of level l' and tile-local.
    const float lx = s * inv - static_cast<float>((fx >> shift) * g.tile_size) + static_cast<float>(g.border);
    const float ly = t * inv - static_cast<float>((fy >> shift) * g.tile_size) + static_cast<float>(g.border);
    const float cx = static_cast<float>(ox) + lx - 0.5f, cy = static_cast<float>(oy) + ly - 0.5f;
    const float x0f = std::floor(cx), y0f = std::floor(cy);
    const float ax = cx - x0f, ay = cy - y0f;
    const size_t i00 = (static_cast<size_t>(y0f) * width_ + static_cast<size_t>(x0f)) * 4;
    const size_t i01 = i00 + static_cast<size_t>(width_) * 4;
    for (uint32_t c = 0; c < 4; ++c) {
      float a, b, d, e;  // texels (x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)
      if (format_ == CacheFormat::rgba8_affine) {
        a = unorm8_[i00 + c] * (1.0f / 255.0f), b = unorm8_[i00 + 4 + c] * (1.0f / 255.0f);
        d = unorm8_[i01 + c] * (1.0f / 255.0f), e = unorm8_[i01 + 4 + c] * (1.0f / 255.0f);
      } else if (format_ == CacheFormat::bc5_affine) {
        a = bc5_[i00 + c], b = bc5_[i00 + 4 + c], d = bc5_[i01 + c], e = bc5_[i01 + 4 + c];
      } else {
        a = half_bits_to_float(texels_[i00 + c]), b = half_bits_to_float(texels_[i00 + 4 + c]);
        d = half_bits_to_float(texels_[i01 + c]), e = half_bits_to_float(texels_[i01 + 4 + c]);
      }
      const float top = a + (b - a) * ax, bot = d + (e - d) * ax;
      out[c] = top + (bot - top) * ay;
      if (cache_format_has_slot_map(format_)) out[c] = maps_[slot].offset[c] + maps_[slot].scale[c] * out[c];
    }
    return level;
  }

  CacheFormat format() const noexcept { return format_; }
  uint32_t width() const noexcept { return width_; }
  uint32_t height() const noexcept { return height_; }

 private:
  template <class T>
  void copy_rows(const TileCache& cache, uint32_t s, const T* tile, T* texels) const noexcept {
    uint32_t ox, oy;
    cache.slot_origin(s, ox, oy);
    oy += cache_slot_placement(cache.config(), s).layer * cache.config().slots_y * stored_;  // layers stacked
    for (uint32_t y = 0; y < stored_; ++y)
      std::copy_n(tile + static_cast<size_t>(y) * stored_ * 4, stored_ * 4,
                  texels + (static_cast<size_t>(oy + y) * width_ + ox) * 4);
  }

  CacheFormat format_ = CacheFormat::rgba16f;
  uint32_t stored_ = 0;
  uint32_t width_ = 0;
  uint32_t height_ = 0;
  std::vector<uint16_t> texels_;
  std::vector<uint8_t> unorm8_;
  std::vector<float> bc5_;          // bc5_affine: the decoded unorm values in [0, 1], RGBA per texel
  std::vector<float> bc5_scratch_;  // bc5_affine: one decoded slot
  std::vector<CacheSlotMap> maps_;
};

/// FMF shading (paper 000 eq. 5) with the 9-tap light × view combination (§4): ρ = D(Σ over the
/// nine (light, view) taps of w_l·w_v · Σ_c U'(l, v, colour, c)·V'_c. `components` holds the
/// first components.size() eigen-texture values (components past it count as 0, e.g. U'
/// packets not yet streamed). Returns linear RGB. Precondition: indices < light/view counts.
inline glm::vec3 shade_fmf(const EigenTextures& fmf, const AngularSample& light, const AngularSample& view,
                           std::span<const float> components) noexcept {
  glm::vec3 rgb(0.0f);
  const uint32_t C = fmf.components();
  const uint32_t n = std::min<uint32_t>(C, static_cast<uint32_t>(components.size()));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const float w = light.weight[i] * view.weight[j];  // weights multiply
      if (w == 0.0f) continue;
      for (uint32_t colour = 0; colour < 3; ++colour) {
        const float* row = fmf.u_row(light.index[i], view.index[j], colour);  // either row order
        float sum = 0.0f;
        for (uint32_t c = 0; c < n; ++c) sum += row[c] * components[c];
        rgb[colour] += w * sum;
      }
    }
  // The sum is decoded after the angular interpolation, as the shaders' fmf_brdf does.
  if (!fmf.transform.is_linear()) fmf.transform.decode_rgb(&rgb.x);
  return rgb;
}

/// A direction in the hit's tangent frame (x along dpdu, y on dpdv's side, z = normal), as the
/// angular interpolators expect. The frame keeps the parameterisation's handedness, as the
/// shaders' tangent.w and TangentFrame do: where dpdu × dpdv points against the normal (the
/// tori seen from outside) the texture is mirrored on the surface and so are its directions,
/// so y = −(n × t) there. noexcept.
inline glm::vec3 to_local(const SurfaceHit& h, glm::vec3 world_dir) noexcept {
  const glm::vec3 t = glm::normalize(h.dpdu - h.normal * glm::dot(h.normal, h.dpdu));
  const glm::vec3 nxt = glm::cross(h.normal, t);
  const glm::vec3 b = glm::dot(nxt, h.dpdv) < 0.0f ? -nxt : nxt;
  return glm::vec3(glm::dot(world_dir, t), glm::dot(world_dir, b), glm::dot(world_dir, h.normal));
}

/// The render loop of every CPU image the samples and tests draw: calls
/// fn(x, y, px, py, const SurfaceHit&) once per pixel with the primary ray through its centre
/// (px, py) = (x + ½, y + ½), whether it hit or not. Rows go to `pool`'s workers when one is
/// given (fn must then be safe to call concurrently for distinct pixels), in order otherwise.
template <class PixelFn>
void for_each_pixel_hit(const Scene& scene, const Camera& cam, PixelFn&& fn, ThreadPool* pool = nullptr) {
  const auto rows = [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (uint32_t x = 0; x < cam.width; ++x) {
        const float px = static_cast<float>(x) + 0.5f, py = static_cast<float>(y) + 0.5f;
        fn(x, static_cast<uint32_t>(y), px, py, scene.intersect(cam.ray(px, py)));
      }
  };
  if (pool != nullptr)
    pool->parallel_for(0, cam.height, 4, rows);
  else
    rows(0, cam.height);
}

/// The first out.size() channels of `image` at texture coordinate uv as GL_LINEAR with
/// GL_REPEAT samples them (texel centres at half-integers, wrapped); channels past the
/// image's are 0. The FMF program's read of V' (eigen-textures). Precondition: a non-empty image.
inline void sample_repeat_bilinear(const Image<float>& image, glm::vec2 uv, std::span<float> out) noexcept {
  const int w = image.width(), h = image.height();
  const float fx = uv.x * static_cast<float>(w) - 0.5f, fy = uv.y * static_cast<float>(h) - 0.5f;
  const float x0f = std::floor(fx), y0f = std::floor(fy), ax = fx - x0f, ay = fy - y0f;
  const auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
  const int xa = wrap(static_cast<int>(x0f), w), xb = wrap(static_cast<int>(x0f) + 1, w);
  const int ya = wrap(static_cast<int>(y0f), h), yb = wrap(static_cast<int>(y0f) + 1, h);
  for (size_t c = 0; c < out.size(); ++c) {
    const int ci = static_cast<int>(c);
    if (ci >= image.channels()) {
      out[c] = 0.0f;
      continue;
    }
    const float top = image.at(xa, ya, ci) + (image.at(xb, ya, ci) - image.at(xa, ya, ci)) * ax;
    const float bottom = image.at(xa, yb, ci) + (image.at(xb, yb, ci) - image.at(xa, yb, ci)) * ax;
    out[c] = top + (bottom - top) * ay;
  }
}

/// Mean over the pixels showing a material of the ABRDF error E of paper 000 eq. 7,
/// Σ_c (V'_c − Ṽ'_c)² summed over every virtual texture of the pixel's material, where V' is the
/// finest level of the pyramid (bilinear; "everything resident") and Ṽ' comes from `approx`
/// (callable (material, k, const SurfaceHit&, float px, float py, float* out4) → void).
/// `pyramids[m]` is material m's pyramid. Returns 0 when no pixel shows a material.
template <class Approx>
double mean_abrdf_error(const Scene& scene, const Camera& cam, std::span<const TilePyramid* const> pyramids,
                        Approx&& approx) noexcept {
  double sum = 0.0;
  uint64_t pixels = 0;
  for_each_pixel_hit(scene, cam, [&](uint32_t, uint32_t, float px, float py, const SurfaceHit& h) {
    if (!h.hit || h.material >= pyramids.size() || pyramids[h.material] == nullptr) return;
    const TilePyramid& p = *pyramids[h.material];
    double e = 0.0;
    for (uint32_t k = 0; k < p.texture_count(); ++k) {
      float ref[4], got[4];
      p.sample(k, p.geometry().finest_level, h.texcoord.x, h.texcoord.y, ref);
      approx(h.material, k, h, px, py, got);
      for (int c = 0; c < 4; ++c) e += static_cast<double>(ref[c] - got[c]) * (ref[c] - got[c]);
    }
    sum += e;
    ++pixels;
  });
  return pixels == 0 ? 0.0 : sum / static_cast<double>(pixels);
}

}  // namespace btflod
