// btflod — procedural mesostructure for the BTF synthesiser: a tileable height field with
// per-texel reflectance maps, and generators for woven cloth, rough stone/gravel, embossed
// leather and tiles with grout.
//
// Texel space: texel (x, y) is the unit square [x, x+1) × [y, y+1) with its centre at
// (x + ½, y + ½); row 0 is the top row (core/image.hpp). Heights are in texel widths. All maps
// wrap around (the pattern tiles), and every generator is periodic over the texture, so the
// synthesised BTF tiles seamlessly. Local frame (DESIGN.md: z = normal): +x points along
// increasing column, +y along DECREASING row (up in the image), so (x, y, z) is right-handed
// with z towards a viewer looking at the image.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string_view>

#include <glm/glm.hpp>

#include "btflod/core/enum_names.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/math/math.hpp"

namespace btflod {

/// A height field with reflectance maps, all width × height and wrapping around.
struct Mesostructure {
  Image<float> height_map;     ///< 1 channel, texel widths (any offset)
  Image<float> albedo_map;     ///< 3 channels, linear RGB diffuse albedo in [0, 1]
  Image<float> roughness_map;  ///< 1 channel, GGX perceptual roughness in [0.02, 1] (α = r²)
  Image<float> specular_map;   ///< 1 channel, Fresnel reflectance at normal incidence F0 in [0, 1]

  int width() const noexcept { return height_map.width(); }
  int height() const noexcept { return height_map.height(); }

  /// Checks the shapes and ranges above. Returns invalid_argument naming the first offending
  /// map and texel. Thread-safe.
  VoidResult validate() const {
    const int w = width(), h = height();
    if (w <= 0 || h <= 0 || height_map.channels() != 1)
      return make_error(Status::invalid_argument,
                        "mesostructure: height map is %dx%d with %d channels, expected a "
                        "non-empty 1-channel image",
                        w, h, height_map.channels());
    struct Check {
      const Image<float>* img;
      const char* name;
      int channels;
      float lo, hi;
    };
    const Check checks[] = {{&height_map, "height", 1, -1e6f, 1e6f},
                            {&albedo_map, "albedo", 3, 0.0f, 1.0f},
                            {&roughness_map, "roughness", 1, 0.02f, 1.0f},
                            {&specular_map, "specular", 1, 0.0f, 1.0f}};
    for (const auto& c : checks) {
      if (c.img->width() != w || c.img->height() != h || c.img->channels() != c.channels)
        return make_error(Status::invalid_argument, "mesostructure: %s map is %dx%dx%d, expected %dx%dx%d", c.name,
                          c.img->width(), c.img->height(), c.img->channels(), w, h, c.channels);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int ch = 0; ch < c.channels; ++ch) {
            const float v = c.img->at(x, y, ch);
            if (!(v >= c.lo && v <= c.hi))
              return make_error(Status::invalid_argument,
                                "mesostructure: %s map texel (%d, %d) channel %d is %g, "
                                "expected in [%g, %g]",
                                c.name, x, y, ch, static_cast<double>(v), static_cast<double>(c.lo),
                                static_cast<double>(c.hi));
          }
    }
    return {};
  }
};

/// A flat mesostructure (height 0) with uniform reflectance; the analytic reference case.
/// Precondition: width, height ≥ 1. Thread-safe.
inline Mesostructure make_flat_mesostructure(int width, int height, glm::vec3 albedo, float roughness = 0.5f,
                                             float specular = 0.0f) {
  Mesostructure m;
  m.height_map = Image<float>(width, height, 1, 0.0f);
  m.albedo_map = Image<float>(width, height, 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) m.albedo_map.at(x, y, c) = albedo[c];
  m.roughness_map = Image<float>(width, height, 1, roughness);
  m.specular_map = Image<float>(width, height, 1, specular);
  return m;
}

/// The procedural materials.
enum class SynthMaterial : unsigned char { cloth, stone, leather, tiles };

namespace detail {
/// material_name()'s table: one name per SynthMaterial, in value order.
inline constexpr const char* kSynthMaterialNames[] = {"cloth", "stone", "leather", "tiles"};
}  // namespace detail

/// Lower-case name of a material ("cloth", "stone", "leather", "tiles").
constexpr const char* material_name(SynthMaterial m) noexcept {
  return enum_value_name<SynthMaterial::tiles>(m, detail::kSynthMaterialNames);
}

/// Parses a material name (as material_name() spells it); nullopt when unknown.
inline std::optional<SynthMaterial> material_from_name(std::string_view name) noexcept {
  for (auto m : {SynthMaterial::cloth, SynthMaterial::stone, SynthMaterial::leather, SynthMaterial::tiles})
    if (name == material_name(m)) return m;
  return std::nullopt;
}

namespace detail {

// The SplitMix64 finaliser (mix_bits64) is the only source of randomness, so every texel's
// value depends on (seed, salt, lattice coordinates) alone — never on thread order.
constexpr uint64_t hash_ints(uint64_t seed, uint64_t salt, int64_t a, int64_t b = 0) noexcept {
  return mix_bits64(mix_bits64(mix_bits64(seed ^ (salt * 0x2545f4914f6cdd1dull)) + static_cast<uint64_t>(a)) +
                    static_cast<uint64_t>(b));
}
// Uniform in [0, 1).
constexpr float hash_unit(uint64_t seed, uint64_t salt, int64_t a, int64_t b = 0) noexcept {
  return static_cast<float>(hash_ints(seed, salt, a, b) >> 40) * (1.0f / 16777216.0f);
}
inline int wrap_index(int i, int n) noexcept {
  const int r = i % n;
  return r < 0 ? r + n : r;
}
inline float smoothstep01(float e0, float e1, float x) noexcept {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

// Periodic value noise in [0, 1) on an fx × fy lattice over the unit square (u, v in [0, 1)):
// tileable because lattice indices wrap.
inline float periodic_value_noise(float u, float v, int fx, int fy, uint64_t seed, uint64_t salt) noexcept {
  const float x = u * static_cast<float>(fx), y = v * static_cast<float>(fy);
  const float x0f = std::floor(x), y0f = std::floor(y);
  const int x0 = static_cast<int>(x0f), y0 = static_cast<int>(y0f);
  float tx = x - x0f, ty = y - y0f;
  tx = tx * tx * (3.0f - 2.0f * tx);
  ty = ty * ty * (3.0f - 2.0f * ty);
  auto at = [&](int i, int j) { return hash_unit(seed, salt, wrap_index(i, fx), wrap_index(j, fy)); };
  const float a = at(x0, y0), b = at(x0 + 1, y0), c = at(x0, y0 + 1), d = at(x0 + 1, y0 + 1);
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

// Periodic fBm in about [−1, 1]: octaves of value noise doubling the lattice frequency.
inline float periodic_fbm(float u, float v, int f, int octaves, uint64_t seed, uint64_t salt) noexcept {
  float sum = 0.0f, amp = 0.5f, norm = 0.0f;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * (2.0f * periodic_value_noise(u, v, f << o, f << o, seed, salt + static_cast<uint64_t>(o)) - 1.0f);
    norm += amp;
    amp *= 0.5f;
  }
  return sum / norm;
}

// Periodic Worley (cellular) noise: one jittered feature point per cell of an n × n grid over
// the unit square. Distances in cell units; id is the nearest point's (wrapped) cell.
struct Worley {
  float f1 = 1e9f, f2 = 1e9f;
  int cell_x = 0, cell_y = 0;
  float dx = 0.0f, dy = 0.0f;  // offset from the nearest feature point, cell units
};
inline Worley periodic_worley(float u, float v, int n, uint64_t seed, uint64_t salt, float jitter = 0.8f) noexcept {
  const float x = u * static_cast<float>(n), y = v * static_cast<float>(n);
  const int cx = static_cast<int>(std::floor(x)), cy = static_cast<int>(std::floor(y));
  Worley w;
  for (int j = -1; j <= 1; ++j)
    for (int i = -1; i <= 1; ++i) {
      const int gx = cx + i, gy = cy + j;
      const int wx = wrap_index(gx, n), wy = wrap_index(gy, n);
      const float px = static_cast<float>(gx) + 0.5f + jitter * (hash_unit(seed, salt, wx, wy) - 0.5f);
      const float py = static_cast<float>(gy) + 0.5f + jitter * (hash_unit(seed, salt + 1, wx, wy) - 0.5f);
      const float d = std::hypot(x - px, y - py);
      if (d < w.f1) {
        w.f2 = w.f1;
        w.f1 = d;
        w.cell_x = wx;
        w.cell_y = wy;
        w.dx = x - px;
        w.dy = y - py;
      } else if (d < w.f2) {
        w.f2 = d;
      }
    }
  return w;
}

// Count of pattern repeats across `size` texels for features about `feature` texels wide.
inline int repeats(int size, float feature, int minimum, bool even) noexcept {
  int n = std::max(minimum, static_cast<int>(std::lround(static_cast<float>(size) / feature)));
  if (even && (n & 1)) ++n;
  return n;
}

inline glm::vec3 clamp01(glm::vec3 c) noexcept { return glm::clamp(c, glm::vec3(0.0f), glm::vec3(1.0f)); }

}  // namespace detail

/// Generates a tileable procedural mesostructure, deterministic in (material, size, seed,
/// depth_scale). Pattern repeats scale with the texture size so features keep about the same
/// size in texels (cloth: 8-texel threads, stone: 12-texel pebbles, leather: 10-texel grains,
/// tiles: 16-texel tiles); non-square sizes stretch the pattern. Heights are multiplied by
/// depth_scale (0 gives a flat field with the material's textures).
/// Returns invalid_argument when width or height is outside [1, 16384] or depth_scale is not
/// finite or negative. Thread-safe.
inline Result<Mesostructure> make_mesostructure(SynthMaterial material, int width, int height, uint64_t seed,
                                                float depth_scale = 1.0f) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    return make_error(Status::invalid_argument, "mesostructure size %dx%d outside [1, 16384]", width, height);
  if (!(depth_scale >= 0.0f) || !std::isfinite(depth_scale))
    return make_error(Status::invalid_argument, "mesostructure depth scale %g, expected finite and >= 0",
                      static_cast<double>(depth_scale));
  using namespace detail;
  Mesostructure m = make_flat_mesostructure(width, height, glm::vec3(0.5f));
  const float fw = static_cast<float>(width), fh = static_cast<float>(height);
  const uint64_t salt = static_cast<uint64_t>(material) * 1000;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float u = (static_cast<float>(x) + 0.5f) / fw, v = (static_cast<float>(y) + 0.5f) / fh;
      float h = 0.0f, rough = 0.5f, spec = 0.04f;
      glm::vec3 albedo(0.5f);
      switch (material) {
        case SynthMaterial::cloth: {
          // Plain weave: warp threads run along y (one per column band), weft along x; at
          // crossing (i, j) the warp is on top when i + j is even (the sin() undulations below
          // are +1/−1 at crossing centres with opposite signs for warp and weft).
          const int nx = repeats(width, 8.0f, 2, true), ny = repeats(height, 8.0f, 2, true);
          const float s = fw / static_cast<float>(nx);  // thread spacing, texels
          const float tu = u * static_cast<float>(nx), tv = v * static_cast<float>(ny);
          const int i = static_cast<int>(std::floor(tu)), j = static_cast<int>(std::floor(tv));
          const float du = tu - std::floor(tu) - 0.5f, dv = tv - std::floor(tv) - 0.5f;
          const float profile_warp = std::sqrt(std::max(0.0f, 1.0f - (du / 0.46f) * (du / 0.46f)));
          const float profile_weft = std::sqrt(std::max(0.0f, 1.0f - (dv / 0.46f) * (dv / 0.46f)));
          const float und_warp = std::sin(kPi * (tv + static_cast<float>(i)));
          const float und_weft = -std::sin(kPi * (tu + static_cast<float>(j)));
          // Fibres: fast noise across each thread, slow along it.
          const float fib_warp = periodic_value_noise(u, v, nx * 6, ny, seed, salt + 1) - 0.5f;
          const float fib_weft = periodic_value_noise(u, v, nx, ny * 6, seed, salt + 2) - 0.5f;
          const float hw =
              profile_warp > 0.0f ? s * (0.3f * profile_warp + 0.18f * und_warp + 0.04f * fib_warp) : -1e9f;
          const float hf =
              profile_weft > 0.0f ? s * (0.3f * profile_weft + 0.18f * und_weft + 0.04f * fib_weft) : -1e9f;
          const float base = -0.25f * s;
          const float tint = 0.85f + 0.3f * periodic_value_noise(u, v, nx, ny, seed, salt + 3);
          if (hw >= hf && hw > base) {
            h = hw;
            albedo = glm::vec3(0.62f, 0.14f, 0.11f) * (tint * (0.75f + 0.25f * profile_warp));
          } else if (hf > base) {
            h = hf;
            albedo = glm::vec3(0.78f, 0.72f, 0.58f) * (tint * (0.75f + 0.25f * profile_weft));
          } else {
            h = base;
            albedo = glm::vec3(0.12f, 0.08f, 0.06f);
          }
          rough = 0.75f;
          spec = 0.03f;
          break;
        }
        case SynthMaterial::stone: {
          // Gravel: one dome-shaped pebble per Worley cell over a sandy bed.
          const int n = repeats(std::min(width, height), 12.0f, 2, false);
          const float cell = fw / static_cast<float>(n);
          const Worley w = periodic_worley(u, v, n, seed, salt + 10);
          const float radius = 0.38f + 0.14f * hash_unit(seed, salt + 12, w.cell_x, w.cell_y);  // cell units
          const float bump = periodic_fbm(u, v, n * 2, 3, seed, salt + 13);
          const float bed = 0.6f * periodic_fbm(u, v, n * 4, 2, seed, salt + 14);
          const float d = w.f1 / radius;
          const float dome = d < 1.0f ? std::sqrt(1.0f - d * d) * radius * cell * 0.75f + 0.4f * bump : -1e9f;
          const float pebble_tone = hash_unit(seed, salt + 15, w.cell_x, w.cell_y);
          if (dome > bed) {
            h = dome;
            const glm::vec3 dark(0.28f, 0.26f, 0.24f), light(0.62f, 0.57f, 0.5f);
            albedo = (dark + (light - dark) * pebble_tone) * (0.9f + 0.2f * bump);
            rough = 0.45f + 0.3f * hash_unit(seed, salt + 16, w.cell_x, w.cell_y);
            spec = 0.04f;
          } else {
            h = bed;
            albedo = glm::vec3(0.46f, 0.4f, 0.31f) *
                     (0.85f + 0.3f * periodic_value_noise(u, v, n * 8, n * 8, seed, salt + 17));
            rough = 0.9f;
            spec = 0.02f;
          }
          break;
        }
        case SynthMaterial::leather: {
          // Embossed grain: plateaus (Worley cells) separated by creases along cell borders.
          const int n = repeats(std::min(width, height), 10.0f, 2, false);
          const Worley w = periodic_worley(u, v, n, seed, salt + 20, 0.9f);
          const float border = w.f2 - w.f1;  // 0 on the crease
          const float plateau = smoothstep01(0.0f, 0.3f, border);
          const float pores = periodic_fbm(u, v, n * 6, 2, seed, salt + 21);
          h = 1.6f * plateau + 0.12f * pores + 0.25f * hash_unit(seed, salt + 22, w.cell_x, w.cell_y);
          const float tone = 0.85f + 0.3f * periodic_value_noise(u, v, n * 2, n * 2, seed, salt + 23);
          albedo = glm::vec3(0.36f, 0.2f, 0.1f) * (tone * (0.55f + 0.45f * plateau));
          rough = 0.7f - 0.3f * plateau;
          spec = 0.05f;
          break;
        }
        case SynthMaterial::tiles: {
          // Square tiles with bevelled edges, recessed grout between them.
          const int nx = repeats(width, 16.0f, 2, false), ny = repeats(height, 16.0f, 2, false);
          const float sx = fw / static_cast<float>(nx), sy = fh / static_cast<float>(ny);
          const float px = u * fw, py = v * fh;
          const int ti = static_cast<int>(std::floor(px / sx)), tj = static_cast<int>(std::floor(py / sy));
          const float lx = px - static_cast<float>(ti) * sx, ly = py - static_cast<float>(tj) * sy;
          const float edge = std::min(std::min(lx, sx - lx), std::min(ly, sy - ly));  // texels to tile border
          const float grout_half = std::max(1.0f, 0.08f * std::min(sx, sy));
          const float top = smoothstep01(grout_half, grout_half + 1.5f, edge);
          const float grit = periodic_fbm(u, v, std::max(nx, ny) * 8, 2, seed, salt + 31);
          const float wobble = 0.15f * (hash_unit(seed, salt + 32, ti, tj) - 0.5f);
          h = top * (2.0f + wobble) + (1.0f - top) * 0.15f * grit;
          const float pick = hash_unit(seed, salt + 33, ti, tj);
          const glm::vec3 tile_colour = pick < 0.4f   ? glm::vec3(0.62f, 0.28f, 0.16f)
                                        : pick < 0.7f ? glm::vec3(0.18f, 0.3f, 0.55f)
                                                      : glm::vec3(0.8f, 0.78f, 0.72f);
          const glm::vec3 tile =
              tile_colour * (0.9f + 0.15f * periodic_value_noise(u, v, nx * 4, ny * 4, seed, salt + 34));
          const glm::vec3 grout = glm::vec3(0.55f, 0.54f, 0.5f) * (0.85f + 0.2f * grit);
          albedo = grout + (tile - grout) * top;
          rough = 0.85f + (0.22f - 0.85f) * top;
          spec = 0.03f + 0.02f * top;
          break;
        }
      }
      m.height_map.at(x, y) = h * depth_scale;
      const glm::vec3 a = clamp01(albedo);
      for (int c = 0; c < 3; ++c) m.albedo_map.at(x, y, c) = a[c];
      m.roughness_map.at(x, y) = std::clamp(rough, 0.02f, 1.0f);
      m.specular_map.at(x, y) = std::clamp(spec, 0.0f, 1.0f);
    }
  }
  // Zero mean height: the reference plane (height 0, where the synthesiser's camera rays are
  // anchored) cuts through the middle of the relief, as a measurement's marker plane would.
  double sum = 0.0;
  for (float h : m.height_map.elements()) sum += h;
  const auto mean = static_cast<float>(sum / static_cast<double>(m.height_map.size()));
  for (float& h : m.height_map.elements()) h -= mean;
  return m;
}

}  // namespace btflod
