// Shared test scene for the GPU backend tests (test_gl_*.cpp, test_vk_*.cpp): a quad in front of
// the camera, an FMF material with known U', V' and angular tables, a BSVTF tile pyramid, and a
// CPU evaluation of exactly the arithmetic the generated shaders perform (the oracle).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod::test_scene {

inline constexpr int kSize = 256;  // render target side

inline uint32_t lcg(uint32_t& s) {
  s = s * 1664525u + 1013904223u;
  return s >> 8;
}
inline float rnd01(uint32_t& s) { return static_cast<float>(lcg(s)) / 16777216.0f; }

/// A quad over NDC [x0,x1]×[-1,1] at z = 0 (identity model, MVP scales x), uv = ((x+1)/2, (y+1)/2).
inline std::vector<MeshVertex> quad_vertices() {
  std::vector<MeshVertex> v(4);
  const float p[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  for (int i = 0; i < 4; ++i) {
    v[i] = MeshVertex{{p[i][0], p[i][1], 0.0f}, {0, 0, 1}, {1, 0, 0, 1}, {(p[i][0] + 1) * 0.5f, (p[i][1] + 1) * 0.5f}};
  }
  return v;
}
inline std::vector<uint32_t> quad_indices() { return {0, 1, 2, 0, 2, 3}; }

/// Directions on the upper hemisphere: rings of θ, a few φ each.
inline std::vector<glm::vec3> direction_set(int rings, int per_ring, float phase) {
  std::vector<glm::vec3> d;
  d.push_back({0, 0, 1});
  for (int r = 1; r <= rings; ++r) {
    const float theta = 1.4f * static_cast<float>(r) / static_cast<float>(rings);
    for (int k = 0; k < per_ring; ++k) {
      const float phi = phase + 6.2831853f * static_cast<float>(k) / static_cast<float>(per_ring);
      d.push_back({std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
    }
  }
  return d;
}

/// A lookup table: for each texel centre, the 3 nearest directions with inverse-distance weights
/// (a stand-in for angular/'s rasterised Delaunay triangulation; the shader does not care).
inline void build_table(const std::vector<glm::vec3>& dirs, DirectionParameterisation p, uint32_t res,
                        std::vector<uint32_t>& index, std::vector<float>& weight) {
  index.assign(static_cast<size_t>(res) * res * 3, 0);
  weight.assign(static_cast<size_t>(res) * res * 3, 0.0f);
  std::vector<glm::vec2> pts;
  for (const glm::vec3& d : dirs) pts.push_back(shader_direction_to_unit_square(p, d));
  for (uint32_t y = 0; y < res; ++y)
    for (uint32_t x = 0; x < res; ++x) {
      const glm::vec2 c((static_cast<float>(x) + 0.5f) / static_cast<float>(res),
                        (static_cast<float>(y) + 0.5f) / static_cast<float>(res));
      uint32_t best[3] = {0, 0, 0};
      float dist[3] = {1e30f, 1e30f, 1e30f};
      for (uint32_t i = 0; i < pts.size(); ++i) {
        const float dd = glm::length(pts[i] - c);
        for (int k = 0; k < 3; ++k)
          if (dd < dist[k]) {
            for (int j = 2; j > k; --j) {
              dist[j] = dist[j - 1];
              best[j] = best[j - 1];
            }
            dist[k] = dd;
            best[k] = i;
            break;
          }
      }
      float w[3], sum = 0;
      for (int k = 0; k < 3; ++k) sum += (w[k] = 1.0f / (dist[k] + 0.02f));
      const size_t o = (static_cast<size_t>(y) * res + x) * 3;
      for (int k = 0; k < 3; ++k) {
        index[o + static_cast<size_t>(k)] = best[k];
        weight[o + static_cast<size_t>(k)] = w[k] / sum;
      }
    }
}

/// Everything a backend needs for the test material, plus the data to evaluate it on the CPU.
struct Material {
  ShaderConfig config;
  uint32_t lights = 0, views = 0;
  std::vector<float> u;  // E's layout: ((light·views + view)·3 + colour)·C + c
  Image<float> v;        // M × N × C
  std::vector<uint32_t> light_index, view_index;
  std::vector<float> light_weight, view_weight;

  FmfMaterialData data(bool with_textures) const {
    FmfMaterialData d;
    d.components = config.components;
    d.light_count = lights;
    d.view_count = views;
    d.eigen_abrdfs = u;
    if (with_textures) d.eigen_textures = v.view();
    d.mipmaps = true;
    d.angular = AngularTablesData{config.angular.resolution, light_index, light_weight, view_index, view_weight};
    return d;
  }
};

/// C = 5 (two component groups, the second partial), smooth random eigen-textures; `seed`
/// varies U′, the phases of V′ and its noise.
inline Material make_material(const ShaderConfig& config, int width, int height, uint32_t seed = 7u) {
  Material m;
  m.config = config;
  const std::vector<glm::vec3> ld = direction_set(2, 5, 0.3f);  // 11 lights
  const std::vector<glm::vec3> vd = direction_set(2, 4, 0.0f);  // 9 views
  m.lights = static_cast<uint32_t>(ld.size());
  m.views = static_cast<uint32_t>(vd.size());
  const uint32_t C = config.components;
  uint32_t s = seed;
  const float phase = 0.37f * static_cast<float>(static_cast<int>(seed) - 7);
  m.u.resize(static_cast<size_t>(m.lights) * m.views * 3 * C);
  for (float& x : m.u) x = rnd01(s) * (1.0f / static_cast<float>(C));
  m.v = Image<float>(width, height, static_cast<int>(C));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < static_cast<int>(C); ++c) {
        const float fx = static_cast<float>(x) / static_cast<float>(width),
                    fy = static_cast<float>(y) / static_cast<float>(height);
        m.v.at(x, y, c) =
            0.6f +
            0.4f * std::sin(6.2831853f * (fx * static_cast<float>(c + 1) + 2.0f * fy) + static_cast<float>(c) + phase) +
            0.1f * rnd01(s);
      }
  build_table(ld, config.angular.parameterisation, config.angular.resolution, m.light_index, m.light_weight);
  build_table(vd, config.angular.parameterisation, config.angular.resolution, m.view_index, m.view_weight);
  return m;
}

/// Shader parameters: camera above the quad, a point light; MVP scales x by `x_scale`.
inline ShaderParams make_params(float x_scale = 1.0f) {
  ShaderParams p;
  p.model_view_proj = glm::scale(glm::mat4(1.0f), glm::vec3(x_scale, 1.0f, 1.0f));
  p.model = glm::mat4(1.0f);
  p.camera_pos = glm::vec4(0.3f, -0.2f, 1.5f, 1.0f);
  p.light = glm::vec4(-0.6f, 0.5f, 0.8f, 1.0f);
  p.light_color = glm::vec4(1.5f, 1.0f, 0.8f, 1.0f);
  return p;
}

/// Pixel centre (x, y), row 0 = top, to world position on the quad and its uv.
inline void pixel_to_quad(int x, int y, int w, int h, float x_scale, glm::vec3& world, glm::vec2& uv) {
  const float ndc_x = (static_cast<float>(x) + 0.5f) / static_cast<float>(w) * 2.0f - 1.0f;
  const float ndc_y = 1.0f - (static_cast<float>(y) + 0.5f) / static_cast<float>(h) * 2.0f;
  world = glm::vec3(ndc_x / x_scale, ndc_y, 0.0f);
  uv = glm::vec2((world.x + 1.0f) * 0.5f, (world.y + 1.0f) * 0.5f);
}

/// The angular lookup of the shader (barycentric or nearest), on the CPU.
inline void lookup(const Material& m, const std::vector<uint32_t>& idx, const std::vector<float>& wt, glm::vec3 d,
                   uint32_t out_i[3], float out_w[3]) {
  const glm::ivec2 t = shader_table_texel(shader_direction_to_unit_square(m.config.angular.parameterisation, d),
                                          m.config.angular.resolution);
  const size_t o = (static_cast<size_t>(t.y) * m.config.angular.resolution + static_cast<size_t>(t.x)) * 3;
  for (int k = 0; k < 3; ++k) {
    out_i[k] = idx[o + static_cast<size_t>(k)];
    out_w[k] = wt[o + static_cast<size_t>(k)];
  }
  if (m.config.angular.lookup == AngularLookup::nearest) {
    int k = 0;
    if (out_w[1] > out_w[0]) k = 1;
    if (out_w[2] > out_w[k]) k = 2;
    out_i[0] = out_i[k];
    out_w[0] = 1.0f;
    out_w[1] = out_w[2] = 0.0f;
  }
}

/// Paper 000 eq. 5 at one pixel: ρ = Σ_c U_c(ωl, ωv) · V_c, U blended over 3 × 3 taps.
inline glm::vec3 eq5(const Material& m, glm::vec3 world, const ShaderParams& p, const float* v) {
  const glm::vec3 to_eye = glm::normalize(glm::vec3(p.camera_pos) - world);
  const glm::vec3 to_light =
      p.light.w > 0.5f ? glm::normalize(glm::vec3(p.light) - world) : glm::normalize(glm::vec3(p.light));
  uint32_t il[3], iv[3];
  float al[3], av[3];
  lookup(m, m.light_index, m.light_weight, to_light, il, al);  // quad frame: t = x, b = y, n = z
  lookup(m, m.view_index, m.view_weight, to_eye, iv, av);
  const uint32_t C = m.config.components;
  glm::vec3 rho(0.0f);
  for (uint32_t c = 0; c < C; ++c) {
    glm::vec3 u(0.0f);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const float w = al[i] * av[j];
        if (!(w > 0.0f)) continue;
        for (int k = 0; k < 3; ++k)
          u[k] += w * m.u[((static_cast<size_t>(il[i]) * m.views + iv[j]) * 3 + static_cast<size_t>(k)) * C + c];
      }
    rho += u * v[c];
  }
  return rho * glm::vec3(p.light_color);
}

/// Bilinear sample, texel centres at i + 0.5; wrap (repeat) or clamp-to-edge addressing.
inline void bilinear(const Image<float>& img, float s, float t, bool wrap, float* out) {
  const float fx = s - 0.5f, fy = t - 0.5f;
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const float ax = fx - static_cast<float>(x0), ay = fy - static_cast<float>(y0);
  auto ix = [&](int x, int n) { return wrap ? ((x % n) + n) % n : std::clamp(x, 0, n - 1); };
  const int xa = ix(x0, img.width()), xb = ix(x0 + 1, img.width());
  const int ya = ix(y0, img.height()), yb = ix(y0 + 1, img.height());
  for (int c = 0; c < img.channels(); ++c) {
    const float top = img.at(xa, ya, c) * (1 - ax) + img.at(xb, ya, c) * ax;
    const float bot = img.at(xa, yb, c) * (1 - ax) + img.at(xb, yb, c) * ax;
    out[c] = top * (1 - ay) + bot * ay;
  }
}

/// CPU reference of the fmf program over a full-screen quad (V' sampled bilinearly, repeat).
inline Image<float> reference_fmf(const Material& m, const ShaderParams& p) {
  Image<float> out(kSize, kSize, 4, 0.0f);
  std::vector<float> v(m.config.components);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      glm::vec3 world;
      glm::vec2 uv;
      pixel_to_quad(x, y, kSize, kSize, 1.0f, world, uv);
      // image row 0 = uv.y 0 (the texture's first row is uploaded at t = 0)
      bilinear(m.v, uv.x * static_cast<float>(m.v.width()), uv.y * static_cast<float>(m.v.height()), true, v.data());
      const glm::vec3 c = eq5(m, world, p, v.data());
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = c[k];
      out.at(x, y, 3) = 1.0f;
    }
  return out;
}

/// PSNR over the rgb channels with the reference's maximum as the peak.
inline double psnr_rgb(const Image<float>& ref, const Image<float>& img) {
  double se = 0.0, peak = 1e-12;
  size_t n = 0;
  for (int y = 0; y < ref.height(); ++y)
    for (int x = 0; x < ref.width(); ++x)
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(ref.at(x, y, c)) - static_cast<double>(img.at(x, y, c));
        se += d * d;
        peak = std::max(peak, static_cast<double>(ref.at(x, y, c)));
        ++n;
      }
  const double mse = se / static_cast<double>(n);
  return mse <= 0.0 ? 200.0 : 10.0 * std::log10(peak * peak / mse);
}

// ---- BSVTF ----------------------------------------------------------------------------------

/// Level images (box filter, like offline/build/tile_pyramid.hpp) of component group g and padded tiles
/// (borders from the neighbouring texels, clamped at the texture edge), as half bits.
struct Pyramid {
  uint32_t finest = 0;
  std::vector<std::vector<Image<float>>> levels;  // [group][level], 4 channels, half-rounded
};

inline Pyramid build_pyramid(const Material& m, uint32_t finest) {
  Pyramid p;
  p.finest = finest;
  const int groups = static_cast<int>(m.config.component_groups());
  p.levels.resize(static_cast<size_t>(groups));
  for (int g = 0; g < groups; ++g) {
    auto& lv = p.levels[static_cast<size_t>(g)];
    lv.resize(finest + 1);
    Image<float>& top = lv[finest];
    top = Image<float>(m.v.width(), m.v.height(), 4, 0.0f);
    for (int y = 0; y < m.v.height(); ++y)
      for (int x = 0; x < m.v.width(); ++x)
        for (int k = 0; k < 4; ++k)
          if (4 * g + k < m.v.channels()) top.at(x, y, k) = m.v.at(x, y, 4 * g + k);
    for (uint32_t l = finest; l > 0; --l) {
      const Image<float>& src = lv[l];
      Image<float>& dst = lv[l - 1];
      dst = Image<float>((src.width() + 1) / 2, (src.height() + 1) / 2, 4);
      for (int y = 0; y < dst.height(); ++y)
        for (int x = 0; x < dst.width(); ++x)
          for (int k = 0; k < 4; ++k) {
            const int xa = std::min(2 * x, src.width() - 1), xb = std::min(2 * x + 1, src.width() - 1);
            const int ya = std::min(2 * y, src.height() - 1), yb = std::min(2 * y + 1, src.height() - 1);
            dst.at(x, y, k) = 0.25f * (src.at(xa, ya, k) + src.at(xb, ya, k) + src.at(xa, yb, k) + src.at(xb, yb, k));
          }
    }
    for (auto& img : lv)  // the cache holds half floats: make the reference see the same values
      for (float& f : img.elements()) f = half_bits_to_float(float_to_half_bits(f));
  }
  return p;
}

inline std::vector<uint16_t> tile_texels(const Pyramid& p, int group, uint32_t level, uint32_t tx, uint32_t ty,
                                         uint32_t tile, uint32_t border) {
  const Image<float>& img = p.levels[static_cast<size_t>(group)][level];
  const uint32_t padded = tile + 2 * border;
  std::vector<uint16_t> out(static_cast<size_t>(padded) * padded * 4);
  for (uint32_t y = 0; y < padded; ++y)
    for (uint32_t x = 0; x < padded; ++x) {
      const int gx = std::clamp(static_cast<int>(tx * tile + x) - static_cast<int>(border), 0, img.width() - 1);
      const int gy = std::clamp(static_cast<int>(ty * tile + y) - static_cast<int>(border), 0, img.height() - 1);
      for (int k = 0; k < 4; ++k)
        out[(static_cast<size_t>(y) * padded + x) * 4 + static_cast<size_t>(k)] = float_to_half_bits(img.at(gx, gy, k));
    }
  return out;
}

/// A partially filled cache: for each group, every tile of levels < finest, and at the finest
/// level only the tiles with x < tiles/2 (the left half). resident(g, l, x, y) says which.
struct CacheFill {
  std::vector<std::vector<uint16_t>> texels;
  std::vector<TileUpload> uploads;
  std::vector<PageTableWrite> deltas;
  std::vector<std::vector<int>> slot_of;  // [group][flat (level, y, x)] → slot or −1
};

inline bool in_fill(uint32_t level, uint32_t finest, uint32_t x, uint32_t tiles) {
  return level < finest || x < tiles / 2;
}

inline CacheFill fill_cache(const Pyramid& p, const VirtualTextureConfig& vt, int width, int height) {
  CacheFill f;
  const int groups = static_cast<int>(p.levels.size());
  uint32_t slot = 0;
  auto tiles_at = [&](uint32_t l, int n) {
    const uint32_t s = p.finest - l;
    return static_cast<uint32_t>((((n + (1 << s) - 1) >> s) + static_cast<int>(vt.tile_size) - 1) /
                                 static_cast<int>(vt.tile_size));
  };
  // Slots in reverse order so that slot ≠ tile index (catches a page table that is ignored).
  std::vector<std::tuple<int, uint32_t, uint32_t, uint32_t>> order;
  for (int g = 0; g < groups; ++g)
    for (uint32_t l = 0; l <= p.finest; ++l)
      for (uint32_t y = 0; y < tiles_at(l, height); ++y)
        for (uint32_t x = 0; x < tiles_at(l, width); ++x)
          if (in_fill(l, p.finest, x, tiles_at(l, width))) order.emplace_back(g, l, x, y);
  const uint32_t total = static_cast<uint32_t>(order.size());
  f.texels.reserve(total);
  std::vector<std::vector<std::vector<uint32_t>>> resident(static_cast<size_t>(groups));
  for (int g = 0; g < groups; ++g) resident[static_cast<size_t>(g)].resize(p.finest + 1);
  std::vector<std::vector<std::vector<int>>> slots(static_cast<size_t>(groups));
  for (int g = 0; g < groups; ++g) {
    slots[static_cast<size_t>(g)].resize(p.finest + 1);
    for (uint32_t l = 0; l <= p.finest; ++l)
      slots[static_cast<size_t>(g)][l].assign(tiles_at(l, width) * tiles_at(l, height), -1);
  }
  for (auto [g, l, x, y] : order) {
    slot = total - 1 - static_cast<uint32_t>(f.texels.size());
    f.texels.push_back(tile_texels(p, g, l, x, y, vt.tile_size, vt.border));
    slots[static_cast<size_t>(g)][l][y * tiles_at(l, width) + x] = static_cast<int>(slot);
  }
  for (size_t i = 0; i < f.texels.size(); ++i)
    f.uploads.push_back(TileUpload{total - 1 - static_cast<uint32_t>(i), f.texels[i], {}, {}});
  // Page table: every tile of every level points at itself or its nearest resident ancestor.
  for (int g = 0; g < groups; ++g)
    for (uint32_t l = 0; l <= p.finest; ++l)
      for (uint32_t y = 0; y < tiles_at(l, height); ++y)
        for (uint32_t x = 0; x < tiles_at(l, width); ++x) {
          uint32_t rl = l, rx = x, ry = y;
          while (slots[static_cast<size_t>(g)][rl][ry * tiles_at(rl, width) + rx] < 0) {
            --rl;
            rx >>= 1;
            ry >>= 1;
          }
          const uint32_t s = static_cast<uint32_t>(slots[static_cast<size_t>(g)][rl][ry * tiles_at(rl, width) + rx]);
          f.deltas.push_back(make_page_table_write(TileId{static_cast<uint32_t>(g), l, x, y}, p.finest, s, rl));
        }
  return f;
}

/// Which level the reference uses at uv for a desired λ (mirrors btflod_vt_fetch), and the
/// blended sample of component group g.
inline void reference_vt_sample(const Pyramid& p, const VirtualTextureConfig& vt, int width, int height, int g,
                                glm::vec2 uv, float lambda, float* out) {
  const float L = static_cast<float>(p.finest);
  const float l = std::clamp(lambda, 0.0f, L);
  const uint32_t l0 = static_cast<uint32_t>(std::floor(l));
  const uint32_t l1 = std::min(l0 + 1, p.finest);
  auto resident_level = [&](uint32_t level) {
    const float scale = std::ldexp(1.0f, static_cast<int>(level) - static_cast<int>(p.finest));
    const uint32_t tiles =
        static_cast<uint32_t>(std::ceil(static_cast<float>(width) * scale / static_cast<float>(vt.tile_size)));
    const uint32_t tx = std::min(
        static_cast<uint32_t>(std::floor(uv.x * static_cast<float>(width) * scale / static_cast<float>(vt.tile_size))),
        tiles - 1);
    uint32_t r = level;
    uint32_t x = tx;
    while (!in_fill(r, p.finest, x,
                    static_cast<uint32_t>(std::ceil(static_cast<float>(width) *
                                                    std::ldexp(1.0f, static_cast<int>(r) - static_cast<int>(p.finest)) /
                                                    static_cast<float>(vt.tile_size))))) {
      --r;
      x >>= 1;
    }
    return r;
  };
  auto sample = [&](uint32_t level, float* o) {
    const float scale = std::ldexp(1.0f, static_cast<int>(level) - static_cast<int>(p.finest));
    bilinear(p.levels[static_cast<size_t>(g)][level], uv.x * static_cast<float>(width) * scale,
             uv.y * static_cast<float>(height) * scale, false, o);
  };
  const uint32_t r1 = resident_level(l1);
  sample(r1, out);
  if (!vt.trilinear || l1 == l0 || r1 != l1) return;
  if (resident_level(l0) != l0) return;
  float s0[4];
  sample(l0, s0);
  const float f = l - static_cast<float>(l0);
  for (int k = 0; k < 4; ++k) out[k] = s0[k] + (out[k] - s0[k]) * f;
}

}  // namespace btflod::test_scene
