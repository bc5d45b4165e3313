// btflod — a procedural BTF synthesiser with the non-local effects measured BTFs have.
//
// A Mesostructure (offline/btf/heightfield.hpp: tileable height field + albedo/roughness/specular
// maps) is rendered for every (view, light) pair of two direction sets, as a BTF measurement
// setup would photograph it: an orthographic camera along the view direction, a distant point
// light of unit irradiance along the macro normal, images rectified onto the reference plane
// (height 0).
//
// For texel (x, y) and view ωv the camera ray through the reference-plane point
// (x + ½, y + ½, 0) is ray-marched through the height field (wrapping around, so the result
// tiles); its first hit q is what the texel shows — this gives parallax and masking. q is lit
// by the light ωl when the height field does not block the ray from q towards ωl
// (self-shadowing; visibility is ray-marched from every texel centre per light and
// interpolated bilinearly at q). Optionally one bounce of interreflection: from every texel,
// a fixed set of cosine-distributed rays finds the surface points it sees; their diffusely
// reflected direct light is gathered (Lambertian transport, Monte Carlo with cosine
// importance sampling).
//
// The base reflectance at q is either analytic — Lambert plus a GGX microfacet lobe
// (Trowbridge–Reitz D, height-correlated Smith visibility, Schlick Fresnel), with albedo,
// roughness and F0 from the maps — or a MeasuredBrdf (offline/btf/measured_brdf.hpp), modulated by the
// albedo map's luminance relative to its mean so the texture stays visible.
//
// Stored value (documented choice, SynthesisOptions::convention): by default the ABRDF value
// ρ·cosθ_l as Bonn BTFs hold it, i.e. the radiance towards ωv under the unit light —
// for a flat Lambertian surface exactly albedo·cosθ_l/π. BtfValueConvention::brdf divides by
// the macro cosθ_l instead.
//
// Deterministic: the output depends only on the inputs (no thread-order dependence), so any
// thread count gives the same bytes.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <type_traits>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/thread_pool.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/btf/heightfield.hpp"
#include "btflod/offline/btf/measured_brdf.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/math/math.hpp"

namespace btflod {

/// Settings of one synthesis run. Plain data; copyable.
struct SynthesisOptions {
  DirectionSet views = DirectionSet::ubo2003();
  DirectionSet lights = DirectionSet::ubo2003();
  /// Add one bounce of diffuse interreflection.
  bool interreflection = false;
  /// Rays per texel for the interreflection gather (1..256).
  int interreflection_rays = 16;
  /// When set, the base reflectance is this BRDF (not owned; must outlive the call).
  const MeasuredBrdf* measured_brdf = nullptr;
  BtfValueConvention convention = BtfValueConvention::abrdf_cos_light;
  /// Horizontal ray-march step, texels (0.05..2). Hits are refined by bisection.
  float march_step = 0.25f;
  /// Pool to run on; null means default_thread_pool().
  ThreadPool* pool = nullptr;
  /// Progress: stage "shadows" then "render", fraction in [0, 1]; return false to cancel.
  ProgressCallback progress;
};

/// Receives the synthesised samples of one view: n_light × height × width × 3 floats in the
/// TabulatedBtf layout (block[((l · H + y) · W + x) · 3 + c]). Called once per view, in
/// ascending view order, from the calling thread. Return false to cancel.
using SynthesisViewSink = std::function<bool(size_t view, std::span<const float> block)>;

namespace detail {

// Bilinear sample position over a wrapped W × H grid with values at texel centres.
struct Bilinear {
  size_t i00, i10, i01, i11;
  float w00, w10, w01, w11;
};
inline Bilinear bilinear_at(float col, float row, int w, int h) noexcept {
  const float fx = col - 0.5f, fy = row - 0.5f;
  const float x0f = std::floor(fx), y0f = std::floor(fy);
  const float tx = fx - x0f, ty = fy - y0f;
  const int x0 = wrap_index(static_cast<int>(x0f), w), y0 = wrap_index(static_cast<int>(y0f), h);
  const int x1 = x0 + 1 == w ? 0 : x0 + 1, y1 = y0 + 1 == h ? 0 : y0 + 1;
  const auto W = static_cast<size_t>(w);
  return {static_cast<size_t>(y0) * W + static_cast<size_t>(x0),
          static_cast<size_t>(y0) * W + static_cast<size_t>(x1),
          static_cast<size_t>(y1) * W + static_cast<size_t>(x0),
          static_cast<size_t>(y1) * W + static_cast<size_t>(x1),
          (1 - tx) * (1 - ty),
          tx * (1 - ty),
          (1 - tx) * ty,
          tx * ty};
}
inline float sample1(const float* data, const Bilinear& b) noexcept {
  return data[b.i00] * b.w00 + data[b.i10] * b.w10 + data[b.i01] * b.w01 + data[b.i11] * b.w11;
}
inline glm::vec3 sample3(const float* data, const Bilinear& b) noexcept {
  auto at = [data](size_t i) { return glm::vec3(data[3 * i], data[3 * i + 1], data[3 * i + 2]); };
  return at(b.i00) * b.w00 + at(b.i10) * b.w10 + at(b.i01) * b.w01 + at(b.i11) * b.w11;
}

// Read-only scene shared by all workers.
struct SynthScene {
  int w = 0, h = 0;
  const float* heights = nullptr;
  const float* albedo = nullptr;
  const float* roughness = nullptr;
  const float* specular = nullptr;
  std::vector<float> normals;  // 3 per texel, local frame
  float h_min = 0.0f, h_max = 0.0f;
  float step = 0.25f;
  float tint_norm = 1.0f;  // 1 / mean albedo luminance

  float height_at(float col, float row) const noexcept { return sample1(heights, bilinear_at(col, row, w, h)); }

  // Column/row of the point at parameter s along frame direction d from (col0, row0);
  // frame +y is decreasing row.
  static void advance(float col0, float row0, glm::vec3 d, float s, float& col, float& row) noexcept {
    col = col0 + s * d.x;
    row = row0 - s * d.y;
  }

  // First hit of the camera ray through reference-plane point (col0, row0, 0) coming from
  // direction d (pointing away from the surface). Returns the hit column/row.
  void view_hit(float col0, float row0, glm::vec3 d, float& col, float& row) const noexcept {
    col = col0;
    row = row0;
    const float horiz = std::hypot(d.x, d.y);
    if (!(h_max > h_min) || horiz < 1e-6f) return;  // flat field or nadir view: no parallax
    const float dz = std::max(d.z, 1e-4f);
    float s_top = h_max / dz, s_bot = h_min / dz;  // s along d: z = s · d.z
    const float span = (s_top - s_bot) * horiz;    // horizontal distance covered
    int steps = static_cast<int>(std::ceil(span / step));
    steps = std::clamp(steps, 1, 16384);
    const float ds = (s_top - s_bot) / static_cast<float>(steps);
    float s_prev = s_top;
    for (int i = 1; i <= steps; ++i) {
      const float s = s_top - ds * static_cast<float>(i);
      float c, r;
      advance(col0, row0, d, s, c, r);
      if (s * dz <= height_at(c, r)) {
        // Bracket (s, s_prev]: refine the crossing by bisection.
        float lo = s, hi = s_prev;
        for (int k = 0; k < 8; ++k) {
          const float mid = 0.5f * (lo + hi);
          advance(col0, row0, d, mid, c, r);
          if (mid * dz <= height_at(c, r)) {
            lo = mid;
          } else {
            hi = mid;
          }
        }
        advance(col0, row0, d, 0.5f * (lo + hi), col, row);
        return;
      }
      s_prev = s;
    }
    advance(col0, row0, d, s_bot, col, row);
  }

  // True when the ray from texel centre (col0, row0) at its height towards d leaves the
  // height field's bounding slab without passing below the surface.
  bool unoccluded(float col0, float row0, float z0, glm::vec3 d) const noexcept {
    if (!(d.z > 0.0f)) return false;
    if (!(h_max > h_min)) return true;
    const float horiz = std::hypot(d.x, d.y);
    if (horiz < 1e-6f) return true;
    const float s_end = (h_max - z0) / d.z;
    const float ds = step / horiz;
    const float eps = 0.02f + 0.25f * step;  // keeps a lit slope from shadowing itself
    for (float s = ds; s < s_end; s += ds) {
      float c, r;
      advance(col0, row0, d, s, c, r);
      if (z0 + s * d.z + eps < height_at(c, r)) return false;
    }
    return true;
  }

  // First surface point hit by a ray from (col0, row0, z0) towards d; false when it escapes.
  bool trace(float col0, float row0, float z0, glm::vec3 d, float& col, float& row) const noexcept {
    if (!(h_max > h_min) || !(d.z > 0.0f)) return false;
    const float horiz = std::hypot(d.x, d.y);
    if (horiz < 1e-6f) return false;
    const float s_end = (h_max - z0) / d.z;
    const float ds = step / horiz;
    const float eps = 0.02f + 0.25f * step;
    for (float s = ds; s < s_end; s += ds) {
      advance(col0, row0, d, s, col, row);
      if (z0 + s * d.z + eps < height_at(col, row)) return true;
    }
    return false;
  }
};

// Trowbridge–Reitz (GGX) specular + Schlick-weighted Lambert; returns ρ (not times cosine).
// n·l and n·v must be positive. Symmetric in (l, v), so reciprocal.
inline glm::vec3 analytic_brdf(glm::vec3 n, glm::vec3 l, glm::vec3 v, glm::vec3 albedo, float roughness,
                               float f0) noexcept {
  const float nl = glm::dot(n, l), nv = glm::dot(n, v);
  const glm::vec3 hv = glm::normalize(l + v);
  const float nh = std::max(glm::dot(n, hv), 0.0f), vh = std::max(glm::dot(v, hv), 0.0f);
  const float a = roughness * roughness, a2 = a * a;
  const float dd = nh * nh * (a2 - 1.0f) + 1.0f;
  const float D = a2 / (kPi * dd * dd);
  const float vis = 0.5f / (nl * std::sqrt(nv * nv * (1.0f - a2) + a2) + nv * std::sqrt(nl * nl * (1.0f - a2) + a2));
  // Schlick with f90 = min(1, 25·F0) (as Filament does): F0 = 0 means no specular
  // interface at all, so the analytic model reduces exactly to Lambert.
  const float f90 = std::min(1.0f, 25.0f * f0);
  auto schlick = [f0, f90](float c) {
    const float m = 1.0f - std::clamp(c, 0.0f, 1.0f);
    const float m2 = m * m;
    return f0 + (f90 - f0) * m2 * m2 * m;
  };
  const float spec = D * vis * schlick(vh);
  // The diffuse part only receives what the specular interface transmits on both ways, so
  // albedo + specular directional albedo stays below 1 (energy bound).
  const float diffuse = (1.0f - schlick(nl)) * (1.0f - schlick(nv)) / kPi;
  return albedo * diffuse + glm::vec3(spec);
}

// An orthonormal basis with n as z (Duff et al. 2017, "Building an orthonormal basis, revisited").
inline void orthonormal_basis(glm::vec3 n, glm::vec3& t, glm::vec3& b) noexcept {
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float c = n.x * n.y * a;
  t = glm::vec3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
  b = glm::vec3(c, sign + n.y * n.y * a, -n.y);
}

inline float luminance(glm::vec3 c) noexcept { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

}  // namespace detail

/// Synthesises the BTF of `meso` view by view and hands each view's block to `sink` (see
/// SynthesisViewSink), so callers can stream very large materials (a 256×256 UBO2003
/// material is 5 GB as float) to disk or a checksum without holding them.
/// Returns invalid_argument (mesostructure fails validate(), empty direction sets,
/// interreflection_rays or march_step out of range), or cancelled when the progress callback
/// or the sink returned false. Work runs on options.pool (default_thread_pool() when null); the
/// result does not depend on the thread count. Not reentrant on the same sink.
inline VoidResult synthesize_btf_views(const Mesostructure& meso, const SynthesisOptions& options,
                                       const SynthesisViewSink& sink) {
  if (auto ok = meso.validate(); !ok) return ok.error();
  if (options.views.empty() || options.lights.empty())
    return make_error(Status::invalid_argument, "synthesis: %zu views and %zu lights, expected both non-empty",
                      options.views.size(), options.lights.size());
  if (options.interreflection && (options.interreflection_rays < 1 || options.interreflection_rays > 256))
    return make_error(Status::invalid_argument, "synthesis: %d interreflection rays, expected 1..256",
                      options.interreflection_rays);
  if (!(options.march_step >= 0.05f && options.march_step <= 2.0f))
    return make_error(Status::invalid_argument, "synthesis: march step %g texels, expected 0.05..2",
                      static_cast<double>(options.march_step));
  if (options.measured_brdf != nullptr && options.measured_brdf->empty())
    return make_error(Status::invalid_argument, "synthesis: the measured BRDF is empty");

  using namespace detail;
  ThreadPool& pool = options.pool ? *options.pool : default_thread_pool();
  const int W = meso.width(), H = meso.height();
  const size_t n_texels = static_cast<size_t>(W) * static_cast<size_t>(H);
  const size_t n_views = options.views.size(), n_lights = options.lights.size();

  SynthScene scene;
  scene.w = W;
  scene.h = H;
  scene.heights = meso.height_map.data();
  scene.albedo = meso.albedo_map.data();
  scene.roughness = meso.roughness_map.data();
  scene.specular = meso.specular_map.data();
  scene.step = options.march_step;
  const auto [lo, hi] = std::minmax_element(meso.height_map.elements().begin(), meso.height_map.elements().end());
  scene.h_min = *lo;
  scene.h_max = *hi;
  // Normals by central differences with wrap-around; frame y = −row, so ∂h/∂y = −∂h/∂row.
  scene.normals.resize(3 * n_texels);
  double lum_sum = 0.0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float dx =
          0.5f * (meso.height_map.at(wrap_index(x + 1, W), y) - meso.height_map.at(wrap_index(x - 1, W), y));
      const float drow =
          0.5f * (meso.height_map.at(x, wrap_index(y + 1, H)) - meso.height_map.at(x, wrap_index(y - 1, H)));
      const glm::vec3 n = glm::normalize(glm::vec3(-dx, drow, 1.0f));
      const size_t t = static_cast<size_t>(y) * static_cast<size_t>(W) + static_cast<size_t>(x);
      scene.normals[3 * t] = n.x;
      scene.normals[3 * t + 1] = n.y;
      scene.normals[3 * t + 2] = n.z;
      lum_sum +=
          luminance(glm::vec3(meso.albedo_map.at(x, y, 0), meso.albedo_map.at(x, y, 1), meso.albedo_map.at(x, y, 2)));
    }
  const double lum_mean = lum_sum / static_cast<double>(n_texels);
  scene.tint_norm = lum_mean > 1e-6 ? static_cast<float>(1.0 / lum_mean) : 1.0f;

  std::mutex progress_mutex;
  std::atomic<bool> cancelled{false};
  auto report = [&](const char* stage, double fraction) {
    std::lock_guard lock(progress_mutex);
    if (!report_progress(options.progress, stage, fraction)) cancelled = true;
  };

  // Pass 1: light visibility from every texel centre, per light (self-shadowing).
  std::vector<float> visibility(n_lights * n_texels);
  std::atomic<size_t> lights_done{0};
  report("shadows", 0.0);
  pool.parallel_for(0, n_lights, 1, [&](size_t b, size_t e) {
    for (size_t l = b; l < e && !cancelled; ++l) {
      const glm::vec3 d = options.lights[l].vector;
      float* vis = visibility.data() + l * n_texels;
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const size_t t = static_cast<size_t>(y) * static_cast<size_t>(W) + static_cast<size_t>(x);
          vis[t] = scene.unoccluded(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, scene.heights[t], d)
                       ? 1.0f
                       : 0.0f;
        }
      const size_t done = lights_done.fetch_add(1) + 1;
      report("shadows", static_cast<double>(done) / static_cast<double>(n_lights));
    }
  });
  if (cancelled) return make_error(Status::cancelled, "synthesis cancelled while computing shadows");

  // Pass 2 (optional): one diffuse bounce. indirect[l][texel] = albedo · mean over rays of the
  // direct diffuse radiance at the hit point (cosine-weighted gather: L = albedo/π · π/K · ΣLi).
  std::vector<float> indirect;
  if (options.interreflection) {
    const int K = options.interreflection_rays;
    std::vector<float> hits(2 * static_cast<size_t>(K) * n_texels, -1.0f);  // (col, row) or −1
    pool.parallel_for(0, static_cast<size_t>(H), 1, [&](size_t b, size_t e) {
      for (size_t y = b; y < e; ++y)
        for (int x = 0; x < W; ++x) {
          const size_t t = y * static_cast<size_t>(W) + static_cast<size_t>(x);
          const glm::vec3 n(scene.normals[3 * t], scene.normals[3 * t + 1], scene.normals[3 * t + 2]);
          glm::vec3 tx, ty;
          orthonormal_basis(n, tx, ty);
          // Stratified cosine-weighted directions (concentric rings × golden-angle azimuths),
          // rotated per texel by a hash so the pattern does not alias; fixed per texel.
          const float rot = kTwoPi * hash_unit(0x5eedull, 77, static_cast<int64_t>(t));
          for (int k = 0; k < K; ++k) {
            const float u1 = (static_cast<float>(k) + 0.5f) / static_cast<float>(K);
            const float r = std::sqrt(u1);
            const float phi = rot + static_cast<float>(k) * 2.39996323f;
            const glm::vec3 d =
                glm::normalize(tx * (r * std::cos(phi)) + ty * (r * std::sin(phi)) + n * std::sqrt(1.0f - u1));
            float c, rr;
            if (scene.trace(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, scene.heights[t], d, c, rr)) {
              hits[2 * (t * static_cast<size_t>(K) + static_cast<size_t>(k))] = c;
              hits[2 * (t * static_cast<size_t>(K) + static_cast<size_t>(k)) + 1] = rr;
            }
          }
        }
    });
    indirect.assign(3 * n_lights * n_texels, 0.0f);
    pool.parallel_for(0, n_lights, 1, [&](size_t b, size_t e) {
      for (size_t l = b; l < e && !cancelled; ++l) {
        const glm::vec3 ld = options.lights[l].vector;
        const float* vis = visibility.data() + l * n_texels;
        float* out = indirect.data() + 3 * l * n_texels;
        for (size_t t = 0; t < n_texels; ++t) {
          glm::vec3 sum(0.0f);
          for (int k = 0; k < K; ++k) {
            const float c = hits[2 * (t * static_cast<size_t>(K) + static_cast<size_t>(k))];
            if (c < 0.0f) continue;
            const float r = hits[2 * (t * static_cast<size_t>(K) + static_cast<size_t>(k)) + 1];
            const Bilinear bq = bilinear_at(c, r, W, H);
            const glm::vec3 nq = glm::normalize(sample3(scene.normals.data(), bq));
            const float cos_l = glm::dot(nq, ld);
            if (cos_l <= 0.0f) continue;
            sum += sample3(scene.albedo, bq) * (cos_l * sample1(vis, bq) / kPi);
          }
          const glm::vec3 a(scene.albedo[3 * t], scene.albedo[3 * t + 1], scene.albedo[3 * t + 2]);
          const glm::vec3 value = a * sum / static_cast<float>(K);
          out[3 * t] = value.r;
          out[3 * t + 1] = value.g;
          out[3 * t + 2] = value.b;
        }
      }
    });
    if (cancelled) return make_error(Status::cancelled, "synthesis cancelled during interreflection");
  }

  // Pass 3: per view, march the camera rays and shade every light.
  std::vector<float> block(n_lights * n_texels * 3);
  const MeasuredBrdf* measured = options.measured_brdf;
  for (size_t v = 0; v < n_views; ++v) {
    const glm::vec3 vd = options.views[v].vector;
    pool.parallel_for(0, static_cast<size_t>(H), 1, [&](size_t b, size_t e) {
      for (size_t y = b; y < e && !cancelled; ++y)
        for (int x = 0; x < W; ++x) {
          float qc, qr;
          scene.view_hit(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, vd, qc, qr);
          const Bilinear bq = bilinear_at(qc, qr, W, H);
          const glm::vec3 n = glm::normalize(sample3(scene.normals.data(), bq));
          const glm::vec3 albedo = sample3(scene.albedo, bq);
          const float rough = sample1(scene.roughness, bq);
          const float f0 = sample1(scene.specular, bq);
          const float nv = glm::dot(n, vd);
          glm::vec3 tx, ty;
          orthonormal_basis(n, tx, ty);
          const glm::vec3 v_local(glm::dot(vd, tx), glm::dot(vd, ty), nv);
          const float tint = luminance(albedo) * scene.tint_norm;
          const size_t t_out = y * static_cast<size_t>(W) + static_cast<size_t>(x);
          for (size_t l = 0; l < n_lights; ++l) {
            const glm::vec3 ld = options.lights[l].vector;
            glm::vec3 value(0.0f);
            const float nl = glm::dot(n, ld);
            if (nv > 0.0f && nl > 0.0f && ld.z > 0.0f) {
              const float vis = sample1(visibility.data() + l * n_texels, bq);
              if (vis > 0.0f) {
                glm::vec3 rho;
                if (measured) {
                  const glm::vec3 l_local(glm::dot(ld, tx), glm::dot(ld, ty), nl);
                  rho = measured->evaluate(l_local, v_local) * tint;
                } else {
                  rho = analytic_brdf(n, ld, vd, albedo, rough, f0);
                }
                value = rho * (nl * vis);
              }
            }
            if (!indirect.empty() && nv > 0.0f) value += sample3(indirect.data() + 3 * l * n_texels, bq);
            if (options.convention == BtfValueConvention::brdf) value = ld.z > 1e-6f ? value / ld.z : glm::vec3(0.0f);
            float* dst = block.data() + 3 * (l * n_texels + t_out);
            dst[0] = value.r;
            dst[1] = value.g;
            dst[2] = value.b;
          }
        }
    });
    if (cancelled) return make_error(Status::cancelled, "synthesis cancelled at view %zu of %zu", v, n_views);
    if (sink && !sink(v, block)) return make_error(Status::cancelled, "synthesis sink stopped at view %zu", v);
    report("render", static_cast<double>(v + 1) / static_cast<double>(n_views));
    if (cancelled) return make_error(Status::cancelled, "synthesis cancelled after view %zu of %zu", v + 1, n_views);
  }
  return {};
}

/// Synthesises the whole BTF of `meso` into a table (float or Half storage; Half rounds to
/// nearest even). Shape: meso's size, options.views × options.lights. Errors as
/// synthesize_btf_views(), plus insufficient_space when the table would exceed 2³³ samples.
/// Thread-safe for distinct calls; the result does not depend on the thread count.
template <class T = float>
Result<TabulatedBtf<T>> synthesize_btf(const Mesostructure& meso, const SynthesisOptions& options) {
  if (options.views.empty() || options.lights.empty())
    return make_error(Status::invalid_argument, "synthesis: %zu views and %zu lights, expected both non-empty",
                      options.views.size(), options.lights.size());
  auto count = TabulatedBtf<T>::checked_sample_count(static_cast<uint64_t>(std::max(meso.width(), 0)),
                                                     static_cast<uint64_t>(std::max(meso.height(), 0)),
                                                     options.views.size(), options.lights.size());
  if (!count) return count.error();
  TabulatedBtf<T> out(meso.width(), meso.height(), options.views, options.lights);
  const size_t per_view = out.texel_count() * out.light_count() * 3;
  auto samples = out.samples();
  auto done = synthesize_btf_views(meso, options, [&](size_t v, std::span<const float> block) {
    if constexpr (std::is_same_v<T, float>) {
      std::copy(block.begin(), block.end(), samples.begin() + static_cast<ptrdiff_t>(v * per_view));
    } else {
      float_to_half(block, std::span<uint16_t>(reinterpret_cast<uint16_t*>(samples.data() + v * per_view), per_view));
    }
    return true;
  });
  if (!done) return done.error();
  return out;
}

/// Convenience: generates the procedural material (make_mesostructure) of the given size and
/// seed and synthesises its BTF. Errors as make_mesostructure() and synthesize_btf().
template <class T = float>
Result<TabulatedBtf<T>> synthesize_material(SynthMaterial material, int width, int height, uint64_t seed,
                                            const SynthesisOptions& options) {
  auto meso = make_mesostructure(material, width, height, seed);
  if (!meso) return meso.error();
  return synthesize_btf<T>(*meso, options);
}

}  // namespace btflod
