// btflod — the HLSL pieces and programs of runtime/shader/hlsl_generator.hpp (implementation section).
//
// One emitter per GlslPiece, each the HLSL spelling of the GLSL piece of the same name in
// runtime/shader/glsl_generator.hpp: the same functions, names, equations and comments (the paper
// references live with the GLSL templates). Change both when changing one; tests/test_shader_hlsl.cpp
// checks that every GLSL function of every piece has its HLSL twin.
#pragma once

#include "btflod/runtime/shader/hlsl_generator.hpp"

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include <string>
#include <string_view>
#include <vector>

namespace btflod {
namespace detail {

// Templates use the GLSL emitter's tokens: `@` = prefix, `$key$` = texture name or uniform
// expression; `$role_sampler$` = the sampler state of a filtered texture.
struct HlslEmitter {
  GlslEmitter g;

  std::string sampler_state(ShaderBinding b) const { return g.options.prefix + shader_binding_name(b) + "_sampler"; }

  void emit(std::string_view tmpl) {
    for (size_t i = 0; i < tmpl.size(); ++i) {
      if (tmpl[i] != '$') {
        if (tmpl[i] == '@')
          g.out += g.options.prefix;
        else
          g.out += tmpl[i];
        continue;
      }
      const size_t end = tmpl.find('$', i + 1);
      const std::string_view key = tmpl.substr(i + 1, end - i - 1);
      constexpr std::string_view suffix = "_sampler";
      if (key.size() > suffix.size() && key.substr(key.size() - suffix.size()) == suffix) {
        g.out += g.options.prefix;
        g.out += key;
      } else {
        g.out += g.value(key);
      }
      i = end;
    }
  }

  // Declares (unless the host does) texture `type` of role `b`, and its sampler state if `filtered`.
  void texture(const char* type, ShaderBinding b, bool filtered = false) {
    const GlslResource& r = g.options.resource(b);
    const std::string name = g.sampler_name(b);
    g.samplers.push_back(GlslSamplerUse{b, name, r.binding, r.set, r.declare});
    if (!r.declare) return;
    g.out += format_message("%s %s : register(t%u, space%u);\n", type, name.c_str(), r.binding, r.set);
    if (filtered)
      g.out +=
          format_message("SamplerState %s : register(s%u, space%u);\n", sampler_state(b).c_str(), r.binding, r.set);
  }

  void constant(const char* type, const char* name, const std::string& v) {
    g.out += format_message("static const %s %s%s = %s;\n", type, g.options.prefix.c_str(), name, v.c_str());
  }
  void constant_int(const char* name, uint32_t v) { constant("int", name, std::to_string(v)); }
  void constant_float(const char* name, uint32_t v) { constant("float", name, std::to_string(v) + ".0"); }
  void constant_uint(const char* name, uint32_t v) { constant("uint", name, std::to_string(v) + "u"); }
  void constant_bool(const char* name, bool v) { constant("bool", name, v ? "true" : "false"); }
  void constant_real(const char* name, float v) {
    constant("float", name, format_message("%.9e", static_cast<double>(v)));
  }
};

inline void hlsl_direction_map(HlslEmitter& e) {
  e.emit(
      "// Local direction (z = normal) -> unit square; directions below the horizon are clamped to it.\n"
      "float2 @direction_map(float3 d) {\n"
      "  d.z = max(d.z, 0.0);\n"
      "  float len = length(d);\n"
      "  if (!(len > 1e-20)) return float2(0.5, 0.5);\n"
      "  d /= len;\n");
  if (e.g.config.angular.parameterisation == DirectionParameterisation::parabolic) {
    e.emit("  return d.xy / (1.0 + d.z) * 0.5 + 0.5;  // parabolic map, paper 000 §4\n");
  } else {
    e.emit(
        "  // elevated concentric map (paper 002 §6.1): disk radius sqrt(1 - z), Shirley-Chiu inverse\n"
        "  float2 disk = d.xy / sqrt(1.0 + d.z);\n"
        "  float r = length(disk);\n"
        "  if (r < 1e-7) return float2(0.5, 0.5);\n"
        "  const float q = 0.78539816339744831;\n"
        "  float phi = atan2(disk.y, disk.x);\n"
        "  if (phi < -q) phi += 8.0 * q;\n"
        "  float a; float b;\n"
        "  if (phi < q) { a = r; b = phi * a / q; }\n"
        "  else if (phi < 3.0 * q) { b = r; a = -(phi - 2.0 * q) * b / q; }\n"
        "  else if (phi < 5.0 * q) { a = -r; b = (phi - 4.0 * q) * a / q; }\n"
        "  else { b = -r; a = -(phi - 6.0 * q) * b / q; }\n"
        "  return float2(a, b) * 0.5 + 0.5;\n");
  }
  e.emit("}\n");
}

inline void hlsl_local_frame(HlslEmitter& e) {
  e.emit(
      "// World-space normal, tangent (w = bitangent sign), unit vectors to the light and the eye\n"
      "// -> light and view directions in the local frame (t, b, n).\n"
      "void @local_dirs(float3 normal, float4 tangent, float3 to_light, float3 to_eye,\n"
      "                 out float3 wl, out float3 wv) {\n"
      "  float3 n = normalize(normal);\n"
      "  float3 t = normalize(tangent.xyz - n * dot(n, tangent.xyz));\n"
      "  float3 b = cross(n, t) * (tangent.w < 0.0 ? -1.0 : 1.0);\n"
      "  wl = float3(dot(to_light, t), dot(to_light, b), dot(to_light, n));\n"
      "  wv = float3(dot(to_eye, t), dot(to_eye, b), dot(to_eye, n));\n"
      "}\n");
}

inline void hlsl_angular(HlslEmitter& e) {
  e.texture("Texture2DArray<uint4>", ShaderBinding::angular_index);
  e.texture("Texture2DArray<float4>", ShaderBinding::angular_weight);
  e.constant_int("kAngularRes", e.g.config.angular.resolution);
  e.constant_int("kAngularTaps", static_cast<uint32_t>(angular_taps(e.g.config)));
  e.emit(
      "int2 @angular_texel(float3 d) {\n"
      "  return clamp(int2(floor(@direction_map(d) * float(@kAngularRes))), (int2)0, (int2)(@kAngularRes - 1));\n"
      "}\n"
      "// The table's 3 direction indices and barycentric weights for d (table 0 = light, 1 = view).\n"
      "void @angular(int table, float3 d, out int3 idx, out float3 w) {\n"
      "  int2 texel = @angular_texel(d);\n"
      "  idx = int3($angular_index$.Load(int4(texel, table, 0)).xyz);\n"
      "  w = $angular_weight$.Load(int4(texel, table, 0)).xyz;\n");
  if (e.g.config.angular.lookup == AngularLookup::nearest) {
    e.emit(
        "  // nearest: the first index with the largest weight\n"
        "  int k = 0;\n"
        "  if (w.y > w.x) k = 1;\n"
        "  if (w.z > w[k]) k = 2;\n"
        "  idx = (int3)idx[k];\n"
        "  w = float3(1.0, 0.0, 0.0);\n");
  }
  e.emit(
      "}\n"
      "// The first index with the largest weight (nearest measured direction).\n"
      "int @angular_nearest(int table, float3 d) {\n"
      "  int2 texel = @angular_texel(d);\n"
      "  int3 idx = int3($angular_index$.Load(int4(texel, table, 0)).xyz);\n"
      "  float3 w = $angular_weight$.Load(int4(texel, table, 0)).xyz;\n"
      "  int k = 0;\n"
      "  if (w.y > w.x) k = 1;\n"
      "  if (w.z > w[k]) k = 2;\n"
      "  return idx[k];\n"
      "}\n");
}

// D(s) of core/value_transform.hpp, applied to the sum of eq. 5 (the identity for linear).
inline void hlsl_decode_value(HlslEmitter& e) {
  const ValueTransform& t = e.g.config.value_transform;
  if (t.uses_log_offset()) e.constant_real("kLogOffset", t.log_offset);
  e.emit(t.encoding == ValueEncoding::sqrt ? "float3 @decode_value(float3 s) { return s * abs(s); }\n"
         : t.encoding == ValueEncoding::log
             ? "float3 @decode_value(float3 s) { return exp(s) - (float3)@kLogOffset; }\n"
         : t.encoding == ValueEncoding::log_ycbcr
             ? "// s = (ln(Y + eps), Cb / (Y + eps), Cr / (Y + eps)) summed; BT.601 YCbCr back to RGB.\n"
               "float3 @decode_value(float3 s) {\n"
               "  float w = exp(s.x);\n"
               "  float y = w - @kLogOffset, cb = s.y * w, cr = s.z * w;\n"
               "  return float3(y + 1.402 * cr, y - 0.344136 * cb - 0.714136 * cr, y + 1.772 * cb);\n"
               "}\n"
             : "float3 @decode_value(float3 s) { return s; }\n");
}

inline void hlsl_fmf_brdf(HlslEmitter& e) {
  e.texture("Texture2DArray<float4>", ShaderBinding::eigen_abrdfs);
  e.constant_int("kFmfComponents", e.g.config.components);
  e.constant_int("kFmfGroups", e.g.config.component_groups());
  hlsl_decode_value(e);
  e.emit(
      "// C_m of the drawn material ($component_count$; 0 or above kFmfComponents: kFmfComponents).\n"
      "int @component_count() {\n"
      "  int n = int($component_count$);\n"
      "  return (n <= 0 || n > @kFmfComponents) ? @kFmfComponents : n;\n"
      "}\n"
      "// Paper 000 eq. 5 for the component weights v (component c in v[c / 4][c % 4]), c < C_m.\n"
      "float3 @fmf_brdf(float4 v[@kFmfGroups], float3 wl, float3 wv) {\n"
      "  int3 il; float3 al; int3 iv; float3 av;\n"
      "  @angular(0, wl, il, al);\n"
      "  @angular(1, wv, iv, av);\n"
      "  float3 rho = (float3)0.0;\n"
      "  int count = @component_count();\n"
      "  for (int c = 0; c < @kFmfComponents; ++c) {\n"
      "    if (c >= count) break;  // a per-draw uniform: every invocation leaves together\n"
      "    float3 u = (float3)0.0;\n"
      "    for (int i = 0; i < @kAngularTaps; ++i) {\n"
      "      for (int j = 0; j < @kAngularTaps; ++j) {\n"
      "        float w = al[i] * av[j];\n"
      "        if (w > 0.0) u += w * $eigen_abrdfs$.Load(int4(il[i], iv[j], c, 0)).rgb;\n"
      "      }\n"
      "    }\n"
      "    rho += u * v[c / 4][c % 4];\n"
      "  }\n"
      "  return @decode_value(rho);\n"
      "}\n");
}

inline void hlsl_fmf(HlslEmitter& e) {
  e.texture("Texture2DArray<float4>", ShaderBinding::eigen_textures, true);
  e.emit(
      "// Groups past the material's ⌈C_m/4⌉ are not fetched (zero).\n"
      "void @fmf_components(float2 uv, out float4 v[@kFmfGroups]) {\n"
      "  int groups = (@component_count() + 3) / 4;\n"
      "  for (int g = 0; g < @kFmfGroups; ++g) {\n"
      "    v[g] = (float4)0.0;\n"
      "    if (g < groups) v[g] = $eigen_textures$.Sample($eigen_textures_sampler$, float3(uv, float(g)));\n"
      "  }\n"
      "}\n"
      "float4 @fmf_raw(float2 uv) { return $eigen_textures$.Sample($eigen_textures_sampler$, float3(uv, 0.0)); }\n"
      "float3 @fmf(float2 uv, float3 wl, float3 wv) {\n"
      "  float4 v[@kFmfGroups];\n"
      "  @fmf_components(uv, v);\n"
      "  return @fmf_brdf(v, wl, wv);\n"
      "}\n");
}

inline void hlsl_page_table(HlslEmitter& e) {
  const VirtualTextureConfig& v = e.g.config.vt;
  e.texture("Texture2DArray<uint>", ShaderBinding::page_table);
  e.constant_float("kTileSize", v.tile_size);
  e.constant_float("kBorder", v.border);
  e.constant_float("kPaddedTile", v.padded_tile_size());
  e.constant_uint("kSlotsX", v.slots_x);
  e.constant_uint("kSlotsPerLayer", v.slots_x * v.slots_y);
  e.constant("float2", "kCacheSize", format_message("float2(%u.0, %u.0)", v.cache_width(), v.cache_height()));
  e.emit(
      "int @vt_finest() { return int($vt_extent$.z); }\n"
      "// Desired continuous level, paper 000 eq. 1: l = L - log2 max(|dPi/dx|, |dPi/dy|), minus the LOD bias.\n"
      "// Uses derivatives: call in uniform control flow.\n"
      "float @vt_lambda(float2 uv) {\n"
      "  float2 tx = uv * $vt_extent$.xy;\n"
      "  float2 dx = ddx(tx);\n"
      "  float2 dy = ddy(tx);\n"
      "  float m = max(dot(dx, dx), dot(dy, dy));\n"
      "  return $vt_extent$.z - 0.5 * log2(max(m, 1e-20)) - $lod_bias$;\n"
      "}\n"
      "// Level-l texel coordinate of uv (uv in [0,1)), and the tile grid size at level l.\n"
      "float2 @level_texel(float2 uv, int level) { return uv * $vt_extent$.xy * exp2(float(level - @vt_finest())); }\n"
      "int2 @level_tiles(int level) { return max(int2(ceil($vt_extent$.xy * exp2(float(level - @vt_finest())) / "
      "@kTileSize)), (int2)1); }\n"
      "int2 @tile_of(float2 uv, int level) {  // paper 000 eq. 2\n"
      "  return clamp(int2(floor(@level_texel(uv, level) / @kTileSize)), (int2)0, @level_tiles(level) - 1);\n"
      "}\n"
      "// Tile (eq. 2) and in-tile offset at `level` of the finest-level texel coordinate `texel`.\n"
      "int2 @tile_at(float2 texel, int level, out float2 in_tile) {\n"
      "  float2 s = texel * exp2(float(level - @vt_finest()));\n"
      "  int2 t = clamp(int2(floor(s / @kTileSize)), (int2)0, @level_tiles(level) - 1);\n"
      "  in_tile = s - float2(t) * @kTileSize;\n"
      "  return t;\n"
      "}\n"
      "// Page-table entry (pack_page_entry) of tile `tile` at `level` in page-table layer `layer`.\n"
      "uint @page_entry(int layer, int2 tile, int level) {\n"
      "  return $page_table$.Load(int4(tile, layer, @vt_finest() - level));\n"
      "}\n");
}

inline void hlsl_bsvtf(HlslEmitter& e) {
  e.texture("Texture2DArray<float4>", ShaderBinding::tile_cache, true);
  const bool affine = cache_format_has_slot_map(e.g.config.vt.format);
  const bool bc5 = e.g.config.vt.format == CacheFormat::bc5_affine;
  if (affine) {
    e.texture("Texture2D<uint4>", ShaderBinding::slot_map);
    e.constant_uint("kSlotsY", e.g.config.vt.slots_y);
  }
  e.constant_bool("kTrilinear", e.g.config.vt.trilinear);
  e.emit(
      "// One fragment's virtual-texture address: finest-level texel coordinate, the two blend levels\n"
      "// (l0 = floor(lambda), l1 = l0 + 1 clamped), their tiles (eq. 2) and in-tile offsets, and the\n"
      "// mip-0 tile (runtime/vt/tile_cache.hpp's table, the deepest resident tile).\n"
      "struct @VtSite {\n"
      "  float2 texel; int finest; int l0; int l1; float w;\n"
      "  int2 tile0; int2 tile1; int2 tilef; float2 in0; float2 in1;\n"
      "};\n"
      "@VtSite @vt_site(float2 uv, float lambda) {\n"
      "  @VtSite a;\n"
      "  a.texel = uv * $vt_extent$.xy;\n"
      "  a.finest = @vt_finest();\n"
      "  float l = clamp(lambda, 0.0, float(a.finest));\n"
      "  a.l0 = int(floor(l));\n"
      "  a.l1 = min(a.l0 + 1, a.finest);\n"
      "  a.w = l - float(a.l0);\n"
      "  a.tile0 = @tile_at(a.texel, a.l0, a.in0);\n"
      "  a.tile1 = @tile_at(a.texel, a.l1, a.in1);\n"
      "  float2 unused;\n"
      "  a.tilef = @tile_at(a.texel, a.finest, unused);\n"
      "  return a;\n"
      "}\n"
      "// Paper 000 eq. 3: cache texel = slot origin + border + in-tile offset at the entry's level.\n"
      "float4 @cache_sample(uint entry, float2 in_tile) {\n"
      "  uint slot = entry & 0xFFFFFFu;\n"
      "  uint r = slot % @kSlotsPerLayer;\n"
      "  float2 origin = float2(float(r % @kSlotsX), float(r / @kSlotsX)) * @kPaddedTile + @kBorder;\n");
  if (bc5)  // runtime/vt/cache_bc5.hpp: plane p of cache layer L is array layer 2L + p (glsl_generator.hpp)
    e.emit(
        "  float2 c = (origin + in_tile) / @kCacheSize;\n"
        "  float l = float(slot / @kSlotsPerLayer) * 2.0;\n"
        "  float4 t = float4($tile_cache$.SampleLevel($tile_cache_sampler$, float3(c, l), 0.0).xy, "
        "$tile_cache$.SampleLevel($tile_cache_sampler$, float3(c, l + 1.0), 0.0).xy);\n");
  else
    e.emit(
        "  float4 t = $tile_cache$.SampleLevel($tile_cache_sampler$, float3((origin + in_tile) / @kCacheSize, "
        "float(slot / @kSlotsPerLayer)), 0.0);\n");
  if (affine)  // runtime/vt/cache_format.hpp: offset + scale · unorm, halves widened as glsl_generator.hpp does
    e.emit(
        "  uint4 m = $slot_map$.Load(int3(int(r % @kSlotsX), int((slot / @kSlotsPerLayer) * @kSlotsY + r / @kSlotsX), "
        "0));\n"
        "  uint4 a = uint4(m.x, m.x >> 16u, m.y, m.y >> 16u), b = uint4(m.z, m.z >> 16u, m.w, m.w >> 16u);\n"
        "  float4 o = asfloat(((a & 0x7FFFu) << 13u) | ((a & 0x8000u) << 16u)) * 5.192296858534828e33;\n"
        "  float4 s = asfloat(((b & 0x7FFFu) << 13u) | ((b & 0x8000u) << 16u)) * 5.192296858534828e33;\n"
        "  return o + s * t;\n");
  else
    e.emit("  return t;\n");
  e.emit(
      "}\n"
      "float4 @vt_fetch(int layer, @VtSite a) {\n"
      "  uint e1 = $page_table$.Load(int4(a.tile1, layer, a.finest - a.l1));\n"
      "  bool have1 = int(e1 >> 24u) == a.l1;\n"
      "  // One second page-table texel serves both exclusive cases (glsl_generator.hpp): tile l0\n"
      "  // (trilinear, tile l1 resident) or mip 0 (tile l1 missing); selects, not branches.\n"
      "  uint e2 = $page_table$.Load(int4(have1 ? a.tile0 : a.tilef, layer, have1 ? a.finest - a.l0 : 0));\n"
      "  bool tri = @kTrilinear && have1 && a.l1 != a.l0 && int(e2 >> 24u) == a.l0;\n"
      "  uint e = (tri || (!have1 && (e2 >> 24u) > (e1 >> 24u))) ? e2 : e1;  // the entry sampled first\n"
      "  float2 in_tile;\n"
      "  @tile_at(a.texel, int(e >> 24u), in_tile);\n"
      "  // Level l1 blended over it with weight w; w = 0 leaves the first sample exact (finite texels).\n"
      "  return lerp(@cache_sample(e, in_tile), @cache_sample(e1, a.in1), tri ? a.w : 0.0);\n"
      "}\n"
      "// Component groups of the material whose group 0 is page-table layer $first_layer$.\n"
      "// Uses derivatives (@vt_lambda): call in uniform control flow.\n"
      "void @bsvtf_components(float2 uv, out float4 v[@kFmfGroups]) {\n"
      "  @VtSite site = @vt_site(frac(uv), @vt_lambda(uv));\n"
      "  int groups = (@component_count() + 3) / 4;  // the material's layers; none of another's is read\n"
      "  for (int g = 0; g < @kFmfGroups; ++g) {\n"
      "    v[g] = (float4)0.0;\n"
      "    if (g < groups) v[g] = @vt_fetch(int($first_layer$) + g, site);\n"
      "  }\n"
      "}\n"
      "float4 @bsvtf_raw(float2 uv) { return @vt_fetch(int($first_layer$), @vt_site(frac(uv), @vt_lambda(uv))); }\n"
      "float3 @bsvtf(float2 uv, float3 wl, float3 wv) {\n"
      "  float4 v[@kFmfGroups];\n"
      "  @bsvtf_components(uv, v);\n"
      "  return @fmf_brdf(v, wl, wv);\n"
      "}\n");
}

inline void hlsl_feedback(HlslEmitter& e) {
  const FeedbackWordLayout& f = e.g.config.vt.feedback;
  e.emit(
      "// Packed feedback word (paper 000 eq. 1-2; FeedbackWordLayout, pack_feedback_word) of uv at\n"
      "// continuous level `lambda` (@vt_lambda at the resolution of the pass) for texture $texture_id$.\n"
      "uint @feedback_word_at(float2 uv, float lambda) {\n"
      "  // request the finest level the renderer blends in (ceil), tolerant of float noise\n");
  e.g.out += format_message("  int level = clamp(int(ceil(lambda - 1e-3)), 0, min(%svt_finest(), %u));\n",
                            e.g.options.prefix.c_str(), f.max_level());
  e.emit("  uint2 tile = uint2(@tile_of(frac(uv), level));  // paper 000 eq. 2\n");
  const std::string id = e.g.value("texture_id");
  e.g.out += format_message(
      "  return ((tile.x & %uu) << %uu) | ((tile.y & %uu) << %uu) | ((uint(level) & %uu) << %uu)"
      " | ((uint(%s) & %uu) << %uu);\n",
      detail::low_mask(f.x_bits), f.x_shift, detail::low_mask(f.y_bits), f.y_shift, detail::low_mask(f.level_bits),
      f.level_shift, id.c_str(), detail::low_mask(f.texture_bits), f.texture_shift);
  e.emit(
      "}\n"
      "// The word of a feedback pass: uses derivatives, call in uniform control flow.\n"
      "uint @feedback_word(float2 uv) {\n"
      "  // log2(screen / feedback size): derivatives in a smaller feedback pass are that much larger.\n"
      "  return @feedback_word_at(uv, @vt_lambda(uv) + $feedback_lod_offset$);\n"
      "}\n");
}

inline void hlsl_laplacian(HlslEmitter& e) {
  e.texture("Texture2DArray<float4>", ShaderBinding::laplacian_eigen);
  e.texture("Texture2DArray<float4>", ShaderBinding::laplacian_weights);
  e.texture("Texture2D<float4>", ShaderBinding::laplacian_mean);
  e.constant_int("kLaplacianComponents", e.g.config.components);
  e.constant_int("kLaplacianMaxLevel", e.g.config.laplacian.max_level);
  e.constant_bool("kLaplacianYCbCr", e.g.config.laplacian.ycbcr_output);
  e.emit(
      "// Range-based LOD (paper 001 §3.4 step 2): lambda = min(lambda_max, max(log2(d), 0)), d scaled.\n"
      "float @laplacian_lambda(float distance_to_eye) {\n"
      "  float d = distance_to_eye * $range_lod_scale$;\n"
      "  return clamp(log2(max(d, 1e-20)), 0.0, float(@kLaplacianMaxLevel));\n"
      "}\n"
      "float3 @laplacian(float2 uv, float3 wl, float3 wv, float lambda) {\n"
      "  // paper 001 §3.4 step 1: nearest light and view direction\n"
      "  int2 lv = int2(@angular_nearest(0, wl), @angular_nearest(1, wv));\n"
      "  float3 acc = $laplacian_mean$.Load(int3(lv, 0)).rgb;  // mu'_lambda_max\n"
      "  // D_k is stored per pyramid texel (paper 001 §3.3): level k's texel is the finest texel >> k\n"
      "  uint sw; uint sh; uint sl; uint sm;\n"
      "  $laplacian_weights$.GetDimensions(0u, sw, sh, sl, sm);\n"
      "  int2 size0 = int2(sw, sh);\n"
      "  int2 t0 = clamp(int2(frac(uv) * float2(size0)), (int2)0, size0 - 1);\n"
      "  for (int k = 0; k <= @kLaplacianMaxLevel; ++k) {\n"
      "    float wk = clamp(1.0 - lambda + float(k), 0.0, 1.0);  // paper 001 eq. 7 weight w_k\n"
      "    if (wk <= 0.0) continue;\n"
      "    $laplacian_weights$.GetDimensions(uint(k), sw, sh, sl, sm);\n"
      "    int2 tk = min(t0 >> k, int2(sw, sh) - 1);\n"
      "    for (int j = 0; j < @kLaplacianComponents; j += 4) {\n"
      "      float4 d = $laplacian_weights$.Load(int4(tk, j / 4, k));\n"
      "      for (int q = 0; q < 4 && j + q < @kLaplacianComponents; ++q)\n"
      "        acc += wk * d[q] * $laplacian_eigen$.Load(int4(lv, k * @kLaplacianComponents + j + q, 0)).rgb;\n"
      "    }\n"
      "  }\n"
      "  if (@kLaplacianYCbCr) acc = float3(acc.x + 1.402 * acc.z, acc.x - 0.344136 * acc.y - 0.714136 * acc.z,"
      " acc.x + 1.772 * acc.y);\n"
      "  return acc;\n"
      "}\n");
}

inline void hlsl_lpca(HlslEmitter& e) {
  e.texture("Texture2D<uint>", ShaderBinding::lpca_cluster);
  e.texture("Texture2DArray<float4>", ShaderBinding::lpca_weights);
  e.texture("Texture3D<float4>", ShaderBinding::lpca_volume, true);
  e.constant_int("kLpcaComponents", e.g.config.components);
  e.constant_float("kLpcaClusters", e.g.config.lpca.clusters);
  e.constant_float("kLpcaGrid", e.g.config.lpca.grid_resolution);
  e.emit(
      "// Grid coordinate s in [0,1] sampled at i/(R-1) -> texel centre inside a cell of R texels.\n"
      "float @lpca_cell(float s) { return (0.5 + clamp(s, 0.0, 1.0) * (@kLpcaGrid - 1.0)) / @kLpcaGrid; }\n"
      "float3 @lpca(float2 uv, float3 wl, float3 wv) {\n"
      "  float2 sv = @direction_map(wv);\n"
      "  float2 sl = @direction_map(wl);\n"
      "  uint sw; uint sh;\n"
      "  $lpca_cluster$.GetDimensions(sw, sh);\n"
      "  int2 size = int2(sw, sh);\n"
      "  int2 texel = clamp(int2(frac(uv) * float2(size)), (int2)0, size - 1);\n"
      "  float k = float($lpca_cluster$.Load(int3(texel, 0)));\n"
      "  // paper 002 §6.2: t_l discretised at i/(R-1); one manual lerp between slabs i and i+1\n"
      "  float tl = clamp(sl.y, 0.0, 1.0) * (@kLpcaGrid - 1.0);\n"
      "  float i0 = min(floor(tl), @kLpcaGrid - 1.0);\n"
      "  float i1 = min(i0 + 1.0, @kLpcaGrid - 1.0);\n"
      "  float w = tl - i0;\n"
      "  float y = (k + @lpca_cell(sv.y)) / @kLpcaClusters;\n"
      "  float z1 = (i0 + @lpca_cell(sl.x)) / @kLpcaGrid;\n"
      "  float z2 = (i1 + @lpca_cell(sl.x)) / @kLpcaGrid;\n"
      "  float3 acc = (float3)0.0;\n"
      "  for (int j = 0; j <= @kLpcaComponents; ++j) {\n"
      "    // j = 0 is the cluster mean; paper 002 §6.3: the 8-bit scales are folded into the weights\n"
      "    float alpha = $lpca_weights$.Load(int4(texel, j / 4, 0))[j % 4];\n"
      "    float x = (float(j) + @lpca_cell(sv.x)) / float(@kLpcaComponents + 1);\n"
      "    float3 e = lerp($lpca_volume$.Sample($lpca_volume_sampler$, float3(x, y, z1)).rgb,"
      " $lpca_volume$.Sample($lpca_volume_sampler$, float3(x, y, z2)).rgb, w);\n"
      "    acc += alpha * e;\n"
      "  }\n"
      "  return acc;\n"
      "}\n");
}

inline void hlsl_pca_views_declarations(HlslEmitter& e) {
  e.texture("Texture2DArray<float4>", ShaderBinding::pca_l);
  e.texture("Texture2D<float4>", ShaderBinding::pca_r);
  e.constant_int("kPcaComponents", e.g.config.components);
  e.constant_int("kPcaViewsPerGroup", e.g.config.pca.views_per_group);
  e.constant_int("kPcaLightCount", e.g.config.pca.light_count);
  e.constant_int("kPcaLayers", (e.g.config.components + 4) / 4);
}

// `float3 @<name>(uv, wl, wv)` with the direction lookup `lookup` and `taps` taps per direction.
inline void hlsl_pca_views_function(HlslEmitter& e, std::string_view name, std::string_view lookup,
                                    std::string_view taps) {
  std::string t =
      "// paper 004 §4.4: 3 closest directions with barycentric weights\n"
      "float3 @NAME(float2 uv, float3 wl, float3 wv) {\n"
      "  int3 il; float3 al; int3 iv; float3 av;\n"
      "  LOOKUP(0, wl, il, al);\n"
      "  LOOKUP(1, wv, iv, av);\n"
      "  uint sw; uint sh; uint sl; uint sm;\n"
      "  $pca_l$.GetDimensions(0u, sw, sh, sl, sm);\n"
      "  int2 size = int2(sw, sh);\n"
      "  int2 texel = clamp(int2(frac(uv) * float2(size)), (int2)0, size - 1);  // paper 004 §6.3: i = floor(u N)\n"
      "  float3 acc = (float3)0.0;\n"
      "  for (int j = 0; j < TAPS; ++j) {\n"
      "    int view = iv[j];\n"
      "    int base = (view / @kPcaViewsPerGroup) * @kPcaLayers;  // PCA group b of k views\n"
      "    float4 lc[@kPcaLayers];  // L = [m | U Sigma] of this texel, component c in lc[c / 4][c % 4]\n"
      "    for (int g = 0; g < @kPcaLayers; ++g) lc[g] = $pca_l$.Load(int4(texel, base + g, 0));\n"
      "    for (int i = 0; i < TAPS; ++i) {\n"
      "      float w = al[i] * av[j];\n"
      "      if (w <= 0.0) continue;\n"
      "      int row = il[i] + @kPcaLightCount * view;\n"
      "      float3 val = (float3)lc[0].x;  // R = [1; V^T]: the mean has weight 1\n"
      "      for (int c = 1; c <= @kPcaComponents; ++c)\n"
      "        val += lc[c / 4][c % 4] * $pca_r$.Load(int3(c - 1, row, 0)).rgb;  // paper 004 §4.3.2\n"
      "      acc += w * val;\n"
      "    }\n"
      "  }\n"
      "  return acc;\n"
      "}\n";
  const auto substitute = [&t](std::string_view token, std::string_view with) {
    for (size_t at = t.find(token); at != std::string::npos; at = t.find(token, at + with.size()))
      t.replace(at, token.size(), with);
  };
  substitute("NAME", name);
  substitute("LOOKUP", lookup);
  substitute("TAPS", taps);
  e.emit(t);
}

inline void hlsl_pca_views(HlslEmitter& e) {
  hlsl_pca_views_declarations(e);
  hlsl_pca_views_function(e, "pca_views", "@angular", "@kAngularTaps");
}

}  // namespace detail
}  // namespace btflod

#include "btflod/runtime/shader/hlsl_programs.hpp"
#endif  // BTFLOD_IMPLEMENTATION
