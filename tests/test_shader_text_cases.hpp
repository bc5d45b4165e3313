// The configs, piece sets and engine shader body the shader-text tests share
// (test_shader_glsl.cpp, test_shader_hlsl.cpp, test_shader_filament.cpp): every generator is
// checked over the same configs, and an engine shader calls every generated entry point the same
// way whichever language it is written in.
#pragma once

#include <gtest/gtest.h>

#include <cctype>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod::shader_text {

/// The virtual-texture side of the varied config: a partial component group (C = 3), the
/// elevated concentric map, nearest lookup, 128-texel tiles with a 1-texel border, 8 × 4 slots in
/// 3 layers, 7 levels without trilinear blending and a moved feedback word.
inline ShaderConfig variant_vt_config() {
  ShaderConfig b;
  b.components = 3;  // a partial component group
  b.angular.parameterisation = DirectionParameterisation::elevated_concentric;
  b.angular.lookup = AngularLookup::nearest;
  b.vt.tile_size = 128;
  b.vt.border = 1;
  b.vt.slots_x = 8;
  b.vt.slots_y = 4;
  b.vt.cache_layers = 3;
  b.vt.finest_level = 7;
  b.vt.trilinear = false;
  b.vt.feedback = FeedbackWordLayout{16, 8, 24, 8, 0, 4, 4, 12, 0u};
  return b;
}

/// The configs every GLSL and HLSL program and piece is generated for: "default" (C = 8,
/// parabolic, barycentric, T = 64 + 4); "variant", variant_vt_config() with the compact cache
/// (the slot-map table and its fetches) and the smallest Laplacian, LPCA, PCA and SPMM settings;
/// "c16_l0", C = 16 at a single level with more SPMM slots and residual components than one RGBA
/// texel holds.
inline std::vector<std::pair<std::string, ShaderConfig>> generator_configs() {
  std::vector<std::pair<std::string, ShaderConfig>> out;
  out.emplace_back("default", ShaderConfig{});
  ShaderConfig b = variant_vt_config();
  b.vt.format = CacheFormat::rgba8_affine;
  b.laplacian.max_level = 0;
  b.laplacian.ycbcr_output = false;
  b.lpca.clusters = 1;
  b.lpca.grid_resolution = 2;
  b.pca.views_per_group = 151;
  b.pca.light_count = 151;
  b.spmm.slots = 1;  // one slot, mean-only residual (N_PCA = 0)
  b.spmm.residual_components = 0;
  out.emplace_back("variant", b);
  ShaderConfig c;
  c.components = 16;
  c.angular.parameterisation = DirectionParameterisation::elevated_concentric;
  c.vt.finest_level = 0;
  c.spmm.slots = 9;
  c.spmm.residual_components = 7;
  out.emplace_back("c16_l0", c);
  return out;
}

inline constexpr GlslPiece kAllPieces[] = {
    GlslPiece::direction_map, GlslPiece::local_frame, GlslPiece::angular,     GlslPiece::fmf_brdf,  GlslPiece::fmf,
    GlslPiece::page_table,    GlslPiece::bsvtf,       GlslPiece::feedback,    GlslPiece::laplacian, GlslPiece::lpca,
    GlslPiece::pca_views,     GlslPiece::spmm,        GlslPiece::ring_search, GlslPiece::pca_rings};

/// The glsl_pieces() set of every piece.
inline uint32_t all_pieces() {
  uint32_t all = 0;
  for (GlslPiece p : kAllPieces) all |= glsl_pieces({p});
  return all;
}

/// The (name, piece set) pairs an engine shader is compiled with for the config named
/// `config_name`: each piece alone (with what it calls) for "variant" only, which keeps the
/// number of compiler runs small, then all pieces together ("all") for every config.
inline std::vector<std::pair<std::string, uint32_t>> engine_piece_sets(const std::string& config_name) {
  std::vector<std::pair<std::string, uint32_t>> sets;
  if (config_name == "variant")
    for (GlslPiece p : kAllPieces) sets.emplace_back(glsl_piece_name(p), glsl_pieces({p}));
  sets.emplace_back("all", all_pieces());
  return sets;
}

/// An engine's choice on top of `o`: its own prefix "eng_btf_", bindings (registers) from 20 up
/// in sets (spaces) 1 and 2, the angular weights declared by the engine itself (binding 40, set
/// 3), and uniform sources in its own block: `material` names the block's members, e.g.
/// "material." for a GLSL block instance, "material_" for HLSL cbuffer members.
inline GlslFunctionOptions engine_options(GlslFunctionOptions o, const std::string& material) {
  o.prefix = "eng_btf_";
  for (uint32_t i = 1; i < kShaderBindingCount; ++i) {
    o.resources[i].binding = 20 + i;
    o.resources[i].set = 1 + i % 2;
  }
  o.resource(ShaderBinding::angular_weight) = GlslResource{"engine_angular_weights", 40, 3, false};
  o.uniforms.vt_extent = material + "extent";
  o.uniforms.lod_bias = material + "lod.x + frame_bias";
  o.uniforms.feedback_lod_offset = material + "lod.y";
  o.uniforms.range_lod_scale = material + "lod.z";
  o.uniforms.first_layer = material + "ids.x";
  o.uniforms.texture_id = material + "ids[1]";
  o.uniforms.spmm_mode = material + "ids.w";
  o.uniforms.component_count = material + "extent.w";
  return o;
}

/// `glsl` with GLSL's vector types and fract() spelled as HLSL's (the words the engine shader
/// body uses; every vector constructor there has all its components, valid in both languages).
inline std::string hlsl_spelling(std::string_view glsl) {
  static constexpr std::pair<std::string_view, std::string_view> kWords[] = {{"vec2", "float2"}, {"vec3", "float3"},
                                                                             {"vec4", "float4"}, {"ivec2", "int2"},
                                                                             {"ivec3", "int3"},  {"fract", "frac"}};
  const auto word_char = [&](size_t k) {
    return std::isalnum(static_cast<unsigned char>(glsl[k])) != 0 || glsl[k] == '_';
  };
  std::string out;
  for (size_t i = 0; i < glsl.size();) {
    if (!word_char(i)) {
      out += glsl[i++];
      continue;
    }
    size_t end = i;
    while (end < glsl.size() && word_char(end)) ++end;
    std::string_view word = glsl.substr(i, end - i);
    for (const auto& [from, to] : kWords)
      if (word == from) word = to;
    out += word;
    i = end;
  }
  return out;
}

/// Expects each of `needles` in `text`; a missing one fails naming it.
inline void expect_contains(const std::string& text, std::initializer_list<std::string_view> needles) {
  for (std::string_view needle : needles) EXPECT_NE(text.find(needle), std::string::npos) << "missing: " << needle;
}

/// The body of an engine shader's main() (without its braces and output): directions wl, wv
/// (from local_frame when present), then a call of every entry point of `pieces`, adding into
/// `vec3 rho` and `uint word`. Written in GLSL; `hlsl` spells it with hlsl_spelling().
inline std::string engine_main_body(uint32_t pieces, bool hlsl) {
  static constexpr std::pair<GlslPiece, const char*> kCalls[] = {
      {GlslPiece::direction_map, "  rho.xy += eng_btf_direction_map(wl);\n"},
      {GlslPiece::angular,
       "  ivec3 idx; vec3 w;\n  eng_btf_angular(0, wl, idx, w);\n"
       "  rho += w * float(idx.x + eng_btf_angular_nearest(1, wv));\n"},
      {GlslPiece::fmf_brdf,
       "  vec4 v[eng_btf_kFmfGroups];\n"
       "  for (int g = 0; g < eng_btf_kFmfGroups; ++g) v[g] = vec4(0.5, 0.5, 0.5, 0.5);\n"
       "  rho += eng_btf_fmf_brdf(v, wl, wv);\n"},
      {GlslPiece::fmf, "  rho += eng_btf_fmf(f_uv, wl, wv) + eng_btf_fmf_raw(f_uv).rgb;\n"},
      {GlslPiece::page_table,
       "  ivec2 tile = eng_btf_tile_of(fract(f_uv), 1);\n"
       "  word += eng_btf_page_entry(0, tile, 1) + uint(eng_btf_vt_lambda(f_uv));\n"},
      {GlslPiece::bsvtf,
       "  vec4 bv[eng_btf_kFmfGroups];\n  eng_btf_bsvtf_components(f_uv, bv);\n"
       "  rho += eng_btf_bsvtf(f_uv, wl, wv) + bv[0].rgb + eng_btf_bsvtf_raw(f_uv).rgb;\n"},
      {GlslPiece::feedback, "  word += eng_btf_feedback_word(f_uv);\n"},
      {GlslPiece::laplacian,
       "  rho += eng_btf_laplacian(f_uv, wl, wv, eng_btf_laplacian_lambda(length(f_position)));\n"},
      {GlslPiece::lpca, "  rho += eng_btf_lpca(f_uv, wl, wv);\n"},
      {GlslPiece::pca_views, "  rho += eng_btf_pca_views(f_uv, wl, wv);\n"},
      {GlslPiece::ring_search,
       "  ivec3 ri; vec3 rw;\n  eng_btf_ring_search(1, wv, ri, rw);\n  rho += rw * float(ri.y);\n"},
      {GlslPiece::pca_rings, "  rho += eng_btf_pca_rings(f_uv, wl, wv);\n"},
      {GlslPiece::spmm, "  rho += eng_btf_spmm(f_uv, wl, wv) + eng_btf_spmm_epsilon(ivec2(0, 0), wl, wv, 2);\n"},
  };
  std::string s = "  vec3 wl; vec3 wv;\n  vec3 rho = vec3(0.0, 0.0, 0.0);\n  uint word = 0u;\n";
  if (pieces & glsl_pieces({GlslPiece::local_frame}))
    s += "  eng_btf_local_dirs(f_normal, f_tangent, vec3(0.0, 0.0, 1.0), normalize(-f_position), wl, wv);\n";
  else
    s += "  wl = vec3(0.0, 0.0, 1.0); wv = normalize(vec3(0.2, 0.1, 1.0));\n";
  for (const auto& [piece, call] : kCalls)
    if (pieces & glsl_pieces({piece})) s += call;
  return hlsl ? hlsl_spelling(s) : s;
}

}  // namespace btflod::shader_text
