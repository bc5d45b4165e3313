// btflod — GLSL source generators for OpenGL 4.5 core, Vulkan GLSL 450 and GLSL ES 3.00.
//
// generate_program() turns a plain ShaderConfig (shader/shader_config.hpp) into a vertex and a
// fragment shader. Every program shares one vertex shader, the uniform block BtflodParams
// (ShaderParams), the binding table ShaderBinding and the angular lookup code; the programs:
//
//   fmf          FMF rendering, paper 000 eq. 5, with 9-tap angular interpolation (§4)
//   bsvtf        the same through page table + tile cache (paper 000 eq. 3), bilinear inside
//                padded tiles, trilinear across levels when both are resident
//   feedback     paper 000 eq. 1–2, writes the packed word to an R32UI attachment
//   laplacian    Laplacian-pyramid PCA with continuous range-based LOD, paper 001 eq. 7
//   lpca         local PCA with the 3D-texture layout and one manual lerp, paper 002 §6.2
//   pca_views    PCA over groups of k views, L = [m | UΣ], R = [1; Vᵀ], paper 004 §6.3
//
// The generated text is deterministic (same config → same bytes). docs/shaders.md describes
// the texture layouts each program expects.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "btflod/core/result.hpp"
#include "btflod/shader/shader_config.hpp"

namespace btflod {

enum class ShaderProgram : unsigned char { fmf, bsvtf, feedback, laplacian, lpca, pca_views };

inline constexpr ShaderProgram kAllShaderPrograms[] = {ShaderProgram::fmf,       ShaderProgram::bsvtf,
                                                       ShaderProgram::feedback,  ShaderProgram::laplacian,
                                                       ShaderProgram::lpca,      ShaderProgram::pca_views};
inline constexpr GlslTarget kAllGlslTargets[] = {GlslTarget::gl450_core, GlslTarget::vulkan450, GlslTarget::es300};

/// Stable lower-case name, e.g. "bsvtf". Never null.
constexpr const char* shader_program_name(ShaderProgram p) noexcept {
  switch (p) {
    case ShaderProgram::fmf: return "fmf";
    case ShaderProgram::bsvtf: return "bsvtf";
    case ShaderProgram::feedback: return "feedback";
    case ShaderProgram::laplacian: return "laplacian";
    case ShaderProgram::lpca: return "lpca";
    case ShaderProgram::pca_views: return "pca_views";
  }
  return "unknown";
}
/// Stable lower-case name, e.g. "es300". Never null.
constexpr const char* glsl_target_name(GlslTarget t) noexcept {
  switch (t) {
    case GlslTarget::gl450_core: return "gl450_core";
    case GlslTarget::vulkan450: return "vulkan450";
    case GlslTarget::es300: return "es300";
  }
  return "unknown";
}

/// Generated source of one program.
struct GlslProgramSource {
  std::string vertex;
  std::string fragment;
};

/// A sampler's GLSL name and its binding point. GLSL ES 3.00 has no binding qualifier, so an ES
/// host sets each sampler uniform to its unit by name (glUniform1i(location, binding)); the
/// uniform block BtflodParams must be bound to point 0 with glUniformBlockBinding.
struct SamplerName {
  const char* name;
  ShaderBinding binding;
};

/// Every sampler any program declares, with its binding. Programs declare a subset.
inline std::span<const SamplerName> shader_sampler_names() noexcept {
  static constexpr SamplerName kNames[] = {
      {"btflod_eigen_abrdfs", ShaderBinding::eigen_abrdfs},
      {"btflod_angular_index", ShaderBinding::angular_index},
      {"btflod_angular_weight", ShaderBinding::angular_weight},
      {"btflod_eigen_textures", ShaderBinding::eigen_textures},
      {"btflod_tile_cache", ShaderBinding::tile_cache},
      {"btflod_page_table", ShaderBinding::page_table},
      {"btflod_laplacian_eigen", ShaderBinding::laplacian_eigen},
      {"btflod_laplacian_weights", ShaderBinding::laplacian_weights},
      {"btflod_laplacian_mean", ShaderBinding::laplacian_mean},
      {"btflod_lpca_cluster", ShaderBinding::lpca_cluster},
      {"btflod_lpca_weights", ShaderBinding::lpca_weights},
      {"btflod_lpca_volume", ShaderBinding::lpca_volume},
      {"btflod_pca_l", ShaderBinding::pca_l},
      {"btflod_pca_r", ShaderBinding::pca_r},
  };
  return kNames;
}

namespace detail {

inline void glsl_version(std::string& s, GlslTarget t) {
  switch (t) {
    case GlslTarget::gl450_core: s += "#version 450 core\n"; break;
    case GlslTarget::vulkan450: s += "#version 450\n"; break;
    case GlslTarget::es300:
      s += "#version 300 es\n"
           "precision highp float;\nprecision highp int;\n"
           "precision highp sampler2D;\nprecision highp sampler2DArray;\nprecision highp sampler3D;\n"
           "precision highp usampler2D;\nprecision highp usampler2DArray;\n";
      break;
  }
}

inline void glsl_params_block(std::string& s, GlslTarget t) {
  switch (t) {
    case GlslTarget::gl450_core: s += "layout(std140, binding = 0) uniform BtflodParams {\n"; break;
    case GlslTarget::vulkan450: s += "layout(std140, set = 0, binding = 0) uniform BtflodParams {\n"; break;
    case GlslTarget::es300: s += "layout(std140) uniform BtflodParams {\n"; break;
  }
  s += "  mat4 model_view_proj;\n  mat4 model;\n  vec4 camera_pos;\n  vec4 light;\n  vec4 light_color;\n"
       "  vec4 lod;\n  vec4 vt_extent;\n  uvec4 ids;\n} btflod;\n";
}

inline void glsl_sampler(std::string& s, GlslTarget t, const char* type, const char* name, ShaderBinding b) {
  const unsigned binding = static_cast<unsigned>(b);
  switch (t) {
    case GlslTarget::gl450_core: s += format_message("layout(binding = %u) uniform %s %s;\n", binding, type, name); break;
    case GlslTarget::vulkan450:
      s += format_message("layout(set = 0, binding = %u) uniform %s %s;\n", binding, type, name);
      break;
    case GlslTarget::es300: s += format_message("uniform %s %s;\n", type, name); break;
  }
}

// Varying declaration: GLSL ES 3.00 has no location qualifier on varyings; Vulkan requires it.
inline void glsl_varying(std::string& s, GlslTarget t, unsigned loc, const char* dir, const char* decl) {
  if (t == GlslTarget::es300)
    s += format_message("%s %s;\n", dir, decl);
  else
    s += format_message("layout(location = %u) %s %s;\n", loc, dir, decl);
}

inline void glsl_varyings(std::string& s, GlslTarget t, const char* dir) {
  glsl_varying(s, t, 0, dir, "vec3 v_world_pos");
  glsl_varying(s, t, 1, dir, "vec3 v_normal");
  glsl_varying(s, t, 2, dir, "vec4 v_tangent");
  glsl_varying(s, t, 3, dir, "vec2 v_uv");
}

inline std::string glsl_vertex(GlslTarget t) {
  std::string s;
  glsl_version(s, t);
  glsl_params_block(s, t);
  s += "layout(location = 0) in vec3 btflod_position;\n"
       "layout(location = 1) in vec3 btflod_normal;\n"
       "layout(location = 2) in vec4 btflod_tangent;\n"
       "layout(location = 3) in vec2 btflod_uv;\n";
  glsl_varyings(s, t, "out");
  s += "void main() {\n"
       "  v_world_pos = (btflod.model * vec4(btflod_position, 1.0)).xyz;\n"
       "  v_normal = mat3(btflod.model) * btflod_normal;\n"
       "  v_tangent = vec4(mat3(btflod.model) * btflod_tangent.xyz, btflod_tangent.w);\n"
       "  v_uv = btflod_uv;\n"
       "  gl_Position = btflod.model_view_proj * vec4(btflod_position, 1.0);\n";
  if (t == GlslTarget::vulkan450)  // one set of (OpenGL-convention) matrices for every API: z from [-w, w] to [0, w]
    s += "  gl_Position.z = 0.5 * (gl_Position.z + gl_Position.w);\n";
  s += "}\n";
  return s;
}

// Local frame (z = normal, both directions away from the surface; DESIGN.md) and the
// direction → unit-square maps, twins of shader_direction_to_unit_square().
inline void glsl_frame_and_param(std::string& s, const ShaderConfig& c) {
  s += "void btflod_local_dirs(out vec3 wl, out vec3 wv) {\n"
       "  vec3 n = normalize(v_normal);\n"
       "  vec3 t = normalize(v_tangent.xyz - n * dot(n, v_tangent.xyz));\n"
       "  vec3 b = cross(n, t) * (v_tangent.w < 0.0 ? -1.0 : 1.0);\n"
       "  vec3 to_eye = normalize(btflod.camera_pos.xyz - v_world_pos);\n"
       "  vec3 to_light = btflod.light.w > 0.5 ? normalize(btflod.light.xyz - v_world_pos)"
       " : normalize(btflod.light.xyz);\n"
       "  wl = vec3(dot(to_light, t), dot(to_light, b), dot(to_light, n));\n"
       "  wv = vec3(dot(to_eye, t), dot(to_eye, b), dot(to_eye, n));\n"
       "}\n";
  s += "vec2 btflod_param(vec3 d) {\n"
       "  d.z = max(d.z, 0.0);\n"
       "  float len = length(d);\n"
       "  if (!(len > 1e-20)) return vec2(0.5);\n"
       "  d /= len;\n";
  if (c.angular.parameterisation == DirectionParameterisation::parabolic) {
    s += "  return d.xy / (1.0 + d.z) * 0.5 + 0.5;  // parabolic map, paper 000 §4\n";
  } else {
    s += "  // elevated concentric map (paper 002 §6.1): disk radius sqrt(1 - z), Shirley-Chiu inverse\n"
         "  vec2 disk = d.xy / sqrt(1.0 + d.z);\n"
         "  float r = length(disk);\n"
         "  if (r < 1e-7) return vec2(0.5);\n"
         "  const float q = 0.78539816339744831;\n"
         "  float phi = atan(disk.y, disk.x);\n"
         "  if (phi < -q) phi += 8.0 * q;\n"
         "  float a; float b;\n"
         "  if (phi < q) { a = r; b = phi * a / q; }\n"
         "  else if (phi < 3.0 * q) { b = r; a = -(phi - 2.0 * q) * b / q; }\n"
         "  else if (phi < 5.0 * q) { a = -r; b = (phi - 4.0 * q) * a / q; }\n"
         "  else { b = -r; a = -(phi - 6.0 * q) * b / q; }\n"
         "  return vec2(a, b) * 0.5 + 0.5;\n";
  }
  s += "}\n";
}

// Angular lookup: index + barycentric weight tables (paper 000 §4). layer 0 = light, 1 = view.
inline void glsl_angular(std::string& s, GlslTarget t, const ShaderConfig& c, bool force_nearest) {
  glsl_sampler(s, t, "usampler2DArray", "btflod_angular_index", ShaderBinding::angular_index);
  glsl_sampler(s, t, "sampler2DArray", "btflod_angular_weight", ShaderBinding::angular_weight);
  s += format_message("const int kAngularRes = %u;\n", c.angular.resolution);
  s += "void btflod_angular(int layer, vec3 d, out ivec3 idx, out vec3 w) {\n"
       "  ivec2 texel = clamp(ivec2(floor(btflod_param(d) * float(kAngularRes))), ivec2(0), ivec2(kAngularRes - 1));\n"
       "  idx = ivec3(texelFetch(btflod_angular_index, ivec3(texel, layer), 0).xyz);\n"
       "  w = texelFetch(btflod_angular_weight, ivec3(texel, layer), 0).xyz;\n";
  if (force_nearest || c.angular.lookup == AngularLookup::nearest) {
    s += "  // nearest: the first index with the largest weight\n"
         "  int k = 0;\n"
         "  if (w.y > w.x) k = 1;\n"
         "  if (w.z > w[k]) k = 2;\n"
         "  idx = ivec3(idx[k]);\n"
         "  w = vec3(1.0, 0.0, 0.0);\n";
  }
  s += "}\n";
}

inline int angular_taps(const ShaderConfig& c) { return c.angular.lookup == AngularLookup::nearest ? 1 : 3; }

// Σ_c U_c(ωl, ωv) · V_c(x), paper 000 eq. 5; U interpolated over 3 × 3 direction pairs (§4).
inline void glsl_fmf_sum(std::string& s, GlslTarget t, const ShaderConfig& c) {
  glsl_sampler(s, t, "sampler2DArray", "btflod_eigen_abrdfs", ShaderBinding::eigen_abrdfs);
  s += format_message("const int kComponents = %u;\nconst int kGroups = %u;\nconst int kTaps = %d;\n", c.components,
                      c.component_groups(), angular_taps(c));
  s += "vec3 btflod_eq5(vec4 v[kGroups], vec3 wl, vec3 wv) {\n"
       "  ivec3 il; vec3 al; ivec3 iv; vec3 av;\n"
       "  btflod_angular(0, wl, il, al);\n"
       "  btflod_angular(1, wv, iv, av);\n"
       "  vec3 rho = vec3(0.0);\n"
       "  for (int c = 0; c < kComponents; ++c) {\n"
       "    vec3 u = vec3(0.0);\n"
       "    for (int i = 0; i < kTaps; ++i) {\n"
       "      for (int j = 0; j < kTaps; ++j) {\n"
       "        float w = al[i] * av[j];\n"
       "        if (w > 0.0) u += w * texelFetch(btflod_eigen_abrdfs, ivec3(il[i], iv[j], c), 0).rgb;\n"
       "      }\n"
       "    }\n"
       "    rho += u * v[c / 4][c % 4];\n"
       "  }\n"
       "  return rho;\n"
       "}\n";
}

inline void glsl_color_output(std::string& s) { s += "layout(location = 0) out vec4 btflod_color;\n"; }

inline void glsl_vt_common(std::string& s, GlslTarget t, const ShaderConfig& c) {
  const VirtualTextureConfig& v = c.vt;
  glsl_sampler(s, t, "usampler2DArray", "btflod_page_table", ShaderBinding::page_table);
  s += format_message(
      "const float kTileSize = %u.0;\nconst float kBorder = %u.0;\n"
      "const float kPaddedTile = %u.0;\nconst uint kSlotsX = %uu;\nconst uint kSlotsPerLayer = %uu;\n"
      "const vec2 kCacheSize = vec2(%u.0, %u.0);\n",
      v.tile_size, v.border, v.padded_tile_size(), v.slots_x, v.slots_x * v.slots_y, v.cache_width(),
      v.cache_height());
  s += "int btflod_vt_finest() { return int(btflod.vt_extent.z); }\n"
       "// Desired continuous level, paper 000 eq. 1: l = L - log2 max(|dPi/dx|, |dPi/dy|), minus the LOD bias.\n"
       "float btflod_vt_lambda(vec2 uv) {\n"
       "  vec2 tx = uv * btflod.vt_extent.xy;\n"
       "  vec2 dx = dFdx(tx);\n"
       "  vec2 dy = dFdy(tx);\n"
       "  float m = max(dot(dx, dx), dot(dy, dy));\n"
       "  return btflod.vt_extent.z - 0.5 * log2(max(m, 1e-20)) - btflod.lod.x;\n"
       "}\n"
       "// Level-l texel coordinate of uv (uv in [0,1)), and the tile grid size at level l.\n"
       "vec2 btflod_level_texel(vec2 uv, int level) { return uv * btflod.vt_extent.xy * exp2(float(level - btflod_vt_finest())); }\n"
       "ivec2 btflod_level_tiles(int level) { return max(ivec2(ceil(btflod.vt_extent.xy * exp2(float(level - btflod_vt_finest())) / kTileSize)), ivec2(1)); }\n"
       "ivec2 btflod_tile_of(vec2 uv, int level) {  // paper 000 eq. 2\n"
       "  return clamp(ivec2(floor(btflod_level_texel(uv, level) / kTileSize)), ivec2(0), btflod_level_tiles(level) - 1);\n"
       "}\n";
}

// What every shading fragment program (all but the feedback pass) starts with: version,
// uniform block, varyings, colour output, local frame and direction maps.
inline void glsl_shading_fragment_prelude(std::string& s, GlslTarget t, const ShaderConfig& c) {
  glsl_version(s, t);
  glsl_params_block(s, t);
  glsl_varyings(s, t, "in");
  glsl_color_output(s);
  glsl_frame_and_param(s, c);
}

inline std::string glsl_fmf_fragment(GlslTarget t, const ShaderConfig& c) {
  std::string s;
  glsl_shading_fragment_prelude(s, t, c);
  glsl_angular(s, t, c, false);
  glsl_fmf_sum(s, t, c);
  glsl_sampler(s, t, "sampler2DArray", "btflod_eigen_textures", ShaderBinding::eigen_textures);
  s += "void main() {\n"
       "  vec4 v[kGroups];\n"
       "  for (int g = 0; g < kGroups; ++g) v[g] = texture(btflod_eigen_textures, vec3(v_uv, float(g)));\n"
       "  if (btflod.ids.z == 1u) { btflod_color = v[0]; return; }\n"
       "  vec3 wl; vec3 wv;\n"
       "  btflod_local_dirs(wl, wv);\n"
       "  btflod_color = vec4(btflod_eq5(v, wl, wv) * btflod.light_color.rgb, 1.0);\n"
       "}\n";
  return s;
}

inline std::string glsl_bsvtf_fragment(GlslTarget t, const ShaderConfig& c) {
  std::string s;
  glsl_shading_fragment_prelude(s, t, c);
  glsl_angular(s, t, c, false);
  glsl_fmf_sum(s, t, c);
  glsl_vt_common(s, t, c);
  glsl_sampler(s, t, "sampler2DArray", "btflod_tile_cache", ShaderBinding::tile_cache);
  s += format_message("const bool kTrilinear = %s;\n", c.vt.trilinear ? "true" : "false");
  // Addressing (paper 000 eq. 2-3) is done once per fragment for the levels the blend can use
  // and shared by every RGBA group; per group: the page-table texel of level l1 (and of l0 or
  // mip 0 only when that case arises) and one cache fetch per blended level: the second fetch
  // is skipped when the blend weight is 0 (l0 == l1, lambda clamped, or an integer lambda).
  // The l0 and mip-0 page-table texels are one fetch with a selected address (exclusive cases).
  s += "// One fragment's virtual-texture address: finest-level texel coordinate, the two blend levels\n"
       "// (l0 = floor(lambda), l1 = l0 + 1 clamped), their tiles (eq. 2) and in-tile offsets, and the\n"
       "// mip-0 tile (vt/tile_cache.hpp's table, the deepest resident tile).\n"
       "struct BtflodVtSite {\n"
       "  vec2 texel; int finest; int l0; int l1; float w;\n"
       "  ivec2 tile0; ivec2 tile1; ivec2 tilef; vec2 in0; vec2 in1;\n"
       "};\n"
       "// Tile (eq. 2) and in-tile offset at `level` of the finest-level texel coordinate `texel`.\n"
       "ivec2 btflod_tile_at(vec2 texel, int level, out vec2 in_tile) {\n"
       "  vec2 s = texel * exp2(float(level - btflod_vt_finest()));\n"
       "  ivec2 t = clamp(ivec2(floor(s / kTileSize)), ivec2(0), btflod_level_tiles(level) - 1);\n"
       "  in_tile = s - vec2(t) * kTileSize;\n"
       "  return t;\n"
       "}\n"
       "BtflodVtSite btflod_vt_site(vec2 uv, float lambda) {\n"
       "  BtflodVtSite a;\n"
       "  a.texel = uv * btflod.vt_extent.xy;\n"
       "  a.finest = btflod_vt_finest();\n"
       "  float l = clamp(lambda, 0.0, float(a.finest));\n"
       "  a.l0 = int(floor(l));\n"
       "  a.l1 = min(a.l0 + 1, a.finest);\n"
       "  a.w = l - float(a.l0);\n"
       "  a.tile0 = btflod_tile_at(a.texel, a.l0, a.in0);\n"
       "  a.tile1 = btflod_tile_at(a.texel, a.l1, a.in1);\n"
       "  vec2 unused;\n"
       "  a.tilef = btflod_tile_at(a.texel, a.finest, unused);\n"
       "  return a;\n"
       "}\n"
       "// Paper 000 eq. 3: cache texel = slot origin + border + in-tile offset at the entry's level.\n"
       "vec4 btflod_cache_sample(uint entry, vec2 in_tile) {\n"
       "  uint slot = entry & 0xFFFFFFu;\n"
       "  uint r = slot % kSlotsPerLayer;\n"
       "  vec2 origin = vec2(float(r % kSlotsX), float(r / kSlotsX)) * kPaddedTile + kBorder;\n"
       "  return textureLod(btflod_tile_cache, vec3((origin + in_tile) / kCacheSize, float(slot / kSlotsPerLayer)), 0.0);\n"
       "}\n"
       "vec4 btflod_vt_fetch(int layer, BtflodVtSite a) {\n"
       "  uint e1 = texelFetch(btflod_page_table, ivec3(a.tile1, layer), a.finest - a.l1).x;\n"
       "  bool have1 = int(e1 >> 24u) == a.l1;\n"
       "  // One second page-table texel serves both exclusive cases: tile l0 (trilinear, when tile l1\n"
       "  // is resident) or mip 0 (tile l1 missing). Fetched unconditionally: SIMD rasterisers such as\n"
       "  // llvmpipe run both sides of a branch under a mask, so two fetches in two branches cost two.\n"
       "  uint e2 = texelFetch(btflod_page_table, ivec3(have1 ? a.tile0 : a.tilef, layer), have1 ? a.finest - a.l0 : 0).x;\n"
       "  uint e = e1;  // the entry sampled first\n"
       "  vec2 in_tile = a.in1;\n"
       "  float w = 0.0;  // weight of level l1 blended over it\n"
       "  if (!have1) {\n"
       "    // tile l1 missing: mip 0 holds the deepest resident tile (vt/tile_cache.hpp's table); it is\n"
       "    // finer than l1 when the cache dropped ancestors hidden by resident children\n"
       "    if ((e2 >> 24u) > (e1 >> 24u)) e = e2;\n"
       "    btflod_tile_at(a.texel, int(e >> 24u), in_tile);\n"
       "  } else if (kTrilinear && a.l1 != a.l0 && int(e2 >> 24u) == a.l0) {\n"
       "    // trilinear across levels when tile l0 is resident too (weight 0: level l0 alone)\n"
       "    e = e2;\n"
       "    in_tile = a.in0;\n"
       "    w = a.w;\n"
       "  }\n"
       "  vec4 s = btflod_cache_sample(e, in_tile);\n"
       "  return w > 0.0 ? mix(s, btflod_cache_sample(e1, a.in1), w) : s;\n"
       "}\n"
       "void main() {\n"
       "  BtflodVtSite site = btflod_vt_site(fract(v_uv), btflod_vt_lambda(v_uv));\n"
       "  vec4 v[kGroups];\n"
       "  for (int g = 0; g < kGroups; ++g) v[g] = btflod_vt_fetch(int(btflod.ids.x) + g, site);\n"
       "  if (btflod.ids.z == 1u) { btflod_color = v[0]; return; }\n"
       "  vec3 wl; vec3 wv;\n"
       "  btflod_local_dirs(wl, wv);\n"
       "  btflod_color = vec4(btflod_eq5(v, wl, wv) * btflod.light_color.rgb, 1.0);\n"
       "}\n";
  return s;
}

inline std::string glsl_feedback_fragment(GlslTarget t, const ShaderConfig& c) {
  const FeedbackWordLayout& f = c.vt.feedback;
  std::string s;
  glsl_version(s, t);
  glsl_params_block(s, t);
  glsl_varyings(s, t, "in");
  s += "layout(location = 0) out uint btflod_feedback;\n";
  glsl_vt_common(s, t, c);
  auto mask = [](uint32_t bits) { return bits >= 32 ? 0xffffffffu : ((1u << bits) - 1u); };
  s += "void main() {\n"
       "  // lod.y = log2(screen / feedback size): derivatives here are that much larger.\n"
       "  float lambda = btflod_vt_lambda(v_uv) + btflod.lod.y;\n"
       "  // request the finest level the renderer blends in (ceil), tolerant of float noise\n";
  s += format_message("  int level = clamp(int(ceil(lambda - 1e-3)), 0, min(btflod_vt_finest(), %u));\n", f.max_level());
  s += "  uvec2 tile = uvec2(btflod_tile_of(fract(v_uv), level));  // paper 000 eq. 2\n";
  s += format_message(
      "  btflod_feedback = ((tile.x & %uu) << %uu) | ((tile.y & %uu) << %uu) | ((uint(level) & %uu) << %uu)"
      " | ((btflod.ids.y & %uu) << %uu);\n",
      mask(f.x_bits), f.x_shift, mask(f.y_bits), f.y_shift, mask(f.level_bits), f.level_shift, mask(f.texture_bits),
      f.texture_shift);
  s += "}\n";
  return s;
}

inline std::string glsl_laplacian_fragment(GlslTarget t, const ShaderConfig& c) {
  std::string s;
  glsl_shading_fragment_prelude(s, t, c);
  glsl_angular(s, t, c, true);  // paper 001 §3.4 step 1: nearest light and view direction
  glsl_sampler(s, t, "sampler2DArray", "btflod_laplacian_eigen", ShaderBinding::laplacian_eigen);
  glsl_sampler(s, t, "sampler2DArray", "btflod_laplacian_weights", ShaderBinding::laplacian_weights);
  glsl_sampler(s, t, "sampler2D", "btflod_laplacian_mean", ShaderBinding::laplacian_mean);
  s += format_message("const int kComponents = %u;\nconst int kMaxLevel = %u;\nconst bool kYCbCr = %s;\n", c.components,
                      c.laplacian.max_level, c.laplacian.ycbcr_output ? "true" : "false");
  s += "void main() {\n"
       "  vec3 wl; vec3 wv;\n"
       "  btflod_local_dirs(wl, wv);\n"
       "  ivec3 il; vec3 al; ivec3 iv; vec3 av;\n"
       "  btflod_angular(0, wl, il, al);\n"
       "  btflod_angular(1, wv, iv, av);\n"
       "  ivec2 lv = ivec2(il.x, iv.x);\n"
       "  // range-based LOD (paper 001 §3.4 step 2): lambda = min(lambda_max, max(log2(d), 0))\n"
       "  float d = distance(btflod.camera_pos.xyz, v_world_pos) * btflod.lod.z;\n"
       "  float lambda = clamp(log2(max(d, 1e-20)), 0.0, float(kMaxLevel));\n"
       "  vec3 acc = texelFetch(btflod_laplacian_mean, lv, 0).rgb;  // mu'_lambda_max\n"
       "  // D_k is stored per pyramid texel (paper 001 §3.3): level k's texel is the finest texel >> k\n"
       "  ivec2 size0 = textureSize(btflod_laplacian_weights, 0).xy;\n"
       "  ivec2 t0 = clamp(ivec2(fract(v_uv) * vec2(size0)), ivec2(0), size0 - 1);\n"
       "  for (int k = 0; k <= kMaxLevel; ++k) {\n"
       "    float wk = clamp(1.0 - lambda + float(k), 0.0, 1.0);  // paper 001 eq. 7 weight w_k\n"
       "    if (wk <= 0.0) continue;\n"
       "    ivec2 tk = min(t0 >> k, textureSize(btflod_laplacian_weights, k).xy - 1);\n"
       "    for (int j = 0; j < kComponents; j += 4) {\n"
       "      vec4 d = texelFetch(btflod_laplacian_weights, ivec3(tk, j / 4), k);\n"
       "      for (int q = 0; q < 4 && j + q < kComponents; ++q)\n"
       "        acc += wk * d[q] * texelFetch(btflod_laplacian_eigen, ivec3(lv, k * kComponents + j + q), 0).rgb;\n"
       "    }\n"
       "  }\n"
       "  if (kYCbCr) acc = vec3(acc.x + 1.402 * acc.z, acc.x - 0.344136 * acc.y - 0.714136 * acc.z,"
       " acc.x + 1.772 * acc.y);\n"
       "  btflod_color = vec4(acc * btflod.light_color.rgb, 1.0);\n"
       "}\n";
  return s;
}

inline std::string glsl_lpca_fragment(GlslTarget t, const ShaderConfig& c) {
  std::string s;
  glsl_shading_fragment_prelude(s, t, c);
  glsl_sampler(s, t, "usampler2D", "btflod_lpca_cluster", ShaderBinding::lpca_cluster);
  glsl_sampler(s, t, "sampler2DArray", "btflod_lpca_weights", ShaderBinding::lpca_weights);
  glsl_sampler(s, t, "sampler3D", "btflod_lpca_volume", ShaderBinding::lpca_volume);
  s += format_message("const int kComponents = %u;\nconst float kClusters = %u.0;\nconst float kGrid = %u.0;\n",
                      c.components, c.lpca.clusters, c.lpca.grid_resolution);
  s += "// Grid coordinate s in [0,1] sampled at i/(R-1) -> texel centre inside a cell of R texels.\n"
       "float btflod_cell(float s) { return (0.5 + clamp(s, 0.0, 1.0) * (kGrid - 1.0)) / kGrid; }\n"
       "void main() {\n"
       "  vec3 wl; vec3 wv;\n"
       "  btflod_local_dirs(wl, wv);\n"
       "  vec2 sv = btflod_param(wv);\n"
       "  vec2 sl = btflod_param(wl);\n"
       "  ivec2 size = textureSize(btflod_lpca_cluster, 0);\n"
       "  ivec2 texel = clamp(ivec2(fract(v_uv) * vec2(size)), ivec2(0), size - 1);\n"
       "  float k = float(texelFetch(btflod_lpca_cluster, texel, 0).x);\n"
       "  // paper 002 §6.2: t_l discretised at i/(R-1); one manual lerp between slabs i and i+1\n"
       "  float tl = clamp(sl.y, 0.0, 1.0) * (kGrid - 1.0);\n"
       "  float i0 = min(floor(tl), kGrid - 1.0);\n"
       "  float i1 = min(i0 + 1.0, kGrid - 1.0);\n"
       "  float w = tl - i0;\n"
       "  float y = (k + btflod_cell(sv.y)) / kClusters;\n"
       "  float z1 = (i0 + btflod_cell(sl.x)) / kGrid;\n"
       "  float z2 = (i1 + btflod_cell(sl.x)) / kGrid;\n"
       "  vec3 acc = vec3(0.0);\n"
       "  for (int j = 0; j <= kComponents; ++j) {\n"
       "    // j = 0 is the cluster mean; paper 002 §6.3: the 8-bit scales are folded into the weights\n"
       "    float alpha = texelFetch(btflod_lpca_weights, ivec3(texel, j / 4), 0)[j % 4];\n"
       "    float x = (float(j) + btflod_cell(sv.x)) / float(kComponents + 1);\n"
       "    vec3 e = mix(texture(btflod_lpca_volume, vec3(x, y, z1)).rgb, texture(btflod_lpca_volume, vec3(x, y, z2)).rgb, w);\n"
       "    acc += alpha * e;\n"
       "  }\n"
       "  btflod_color = vec4(acc * btflod.light_color.rgb, 1.0);\n"
       "}\n";
  return s;
}

inline std::string glsl_pca_views_fragment(GlslTarget t, const ShaderConfig& c) {
  std::string s;
  glsl_shading_fragment_prelude(s, t, c);
  glsl_angular(s, t, c, false);  // paper 004 §4.4: 3 closest directions with barycentric weights
  glsl_sampler(s, t, "sampler2DArray", "btflod_pca_l", ShaderBinding::pca_l);
  glsl_sampler(s, t, "sampler2D", "btflod_pca_r", ShaderBinding::pca_r);
  // L = [m | UΣ] holds one scalar per texel and component (paper 004 §4.3.2: red(x, y) =
  // Σ_k L_{xy,k} R_{k,3i}); the colour lives in R. 4 components of L per RGBA texel.
  s += format_message("const int kComponents = %u;\nconst int kViewsPerGroup = %u;\nconst int kLightCount = %u;\n"
                      "const int kTaps = %d;\nconst int kLLayers = %u;\n",
                      c.components, c.pca.views_per_group, c.pca.light_count, angular_taps(c), (c.components + 4) / 4);
  s += "void main() {\n"
       "  vec3 wl; vec3 wv;\n"
       "  btflod_local_dirs(wl, wv);\n"
       "  ivec3 il; vec3 al; ivec3 iv; vec3 av;\n"
       "  btflod_angular(0, wl, il, al);\n"
       "  btflod_angular(1, wv, iv, av);\n"
       "  ivec2 size = textureSize(btflod_pca_l, 0).xy;\n"
       "  ivec2 texel = clamp(ivec2(fract(v_uv) * vec2(size)), ivec2(0), size - 1);  // paper 004 §6.3: i = floor(u N)\n"
       "  vec3 acc = vec3(0.0);\n"
       "  for (int j = 0; j < kTaps; ++j) {\n"
       "    int view = iv[j];\n"
       "    int base = (view / kViewsPerGroup) * kLLayers;  // PCA group b of k views\n"
       "    vec4 lc[kLLayers];  // L = [m | U Sigma] of this texel, component c in lc[c / 4][c % 4]\n"
       "    for (int g = 0; g < kLLayers; ++g) lc[g] = texelFetch(btflod_pca_l, ivec3(texel, base + g), 0);\n"
       "    for (int i = 0; i < kTaps; ++i) {\n"
       "      float w = al[i] * av[j];\n"
       "      if (w <= 0.0) continue;\n"
       "      int row = il[i] + kLightCount * view;\n"
       "      vec3 val = vec3(lc[0].x);  // R = [1; V^T]: the mean has weight 1\n"
       "      for (int c = 1; c <= kComponents; ++c)\n"
       "        val += lc[c / 4][c % 4] * texelFetch(btflod_pca_r, ivec2(c - 1, row), 0).rgb;  // paper 004 §4.3.2\n"
       "      acc += w * val;\n"
       "    }\n"
       "  }\n"
       "  btflod_color = vec4(acc * btflod.light_color.rgb, 1.0);\n"
       "}\n";
  return s;
}

}  // namespace detail

/// Generates the vertex and fragment shader of `program` for `target`.
/// Returns invalid_argument when the config fails validate_shader_config(). The source is
/// deterministic. Allocates (set-up time only). Thread-safe (no shared state).
inline Result<GlslProgramSource> generate_program(ShaderProgram program, GlslTarget target, const ShaderConfig& config) {
  if (VoidResult v = validate_shader_config(config); !v) return v.error();
  GlslProgramSource out;
  out.vertex = detail::glsl_vertex(target);
  switch (program) {
    case ShaderProgram::fmf: out.fragment = detail::glsl_fmf_fragment(target, config); break;
    case ShaderProgram::bsvtf: out.fragment = detail::glsl_bsvtf_fragment(target, config); break;
    case ShaderProgram::feedback: out.fragment = detail::glsl_feedback_fragment(target, config); break;
    case ShaderProgram::laplacian: out.fragment = detail::glsl_laplacian_fragment(target, config); break;
    case ShaderProgram::lpca: out.fragment = detail::glsl_lpca_fragment(target, config); break;
    case ShaderProgram::pca_views: out.fragment = detail::glsl_pca_views_fragment(target, config); break;
    default: return make_error(Status::invalid_argument, "generate_program: unknown program %d", static_cast<int>(program));
  }
  return out;
}

}  // namespace btflod
