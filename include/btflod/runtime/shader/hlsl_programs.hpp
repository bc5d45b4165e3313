// btflod — the HLSL SPMM and ring-search pieces, the piece table and the whole HLSL programs of
// runtime/shader/hlsl_generator.hpp (implementation section; the other pieces: runtime/shader/hlsl_pieces.hpp).
#pragma once

#include "btflod/runtime/shader/hlsl_pieces.hpp"

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include <string>
#include <utility>

namespace btflod {
namespace detail {

inline void hlsl_spmm(HlslEmitter& e) {
  e.texture("Texture2DArray<uint4>", ShaderBinding::spmm_texels);
  e.texture("Texture2D<float4>", ShaderBinding::spmm_dictionary);
  e.texture("Texture2DArray<float4>", ShaderBinding::spmm_residual);
  e.constant_int("kSpmmSlots", e.g.config.spmm.slots);
  e.constant_int("kSpmmResidualComponents", e.g.config.spmm.residual_components);
  e.constant_int("kSpmmBasesPerRow", kSpmmBasesPerRow);
  e.emit(
      "// f_j(kappa, wi, wo) of offline/factor/analytic_brdf.hpp, both directions in the basis frame (paper 003 §3).\n"
      "float @spmm_brdf(int model, float3 kappa, float3 wi, float3 wo) {\n"
      "  const float inv_pi = 0.318309886;\n"
      "  if (wi.z <= 0.0 || wo.z <= 0.0) return 0.0;\n"
      "  if (model == 0) return inv_pi;  // Lambert\n"
      "  if (model == 1) {  // Oren-Nayar, qualitative model\n"
      "    float s2 = kappa.x * kappa.x;\n"
      "    float a = 1.0 - 0.5 * s2 / (s2 + 0.33);\n"
      "    float bb = 0.45 * s2 / (s2 + 0.09);\n"
      "    float pi_ = sqrt(max(0.0, wi.x * wi.x + wi.y * wi.y));\n"
      "    float po = sqrt(max(0.0, wo.x * wo.x + wo.y * wo.y));\n"
      "    float cos_phi = 0.0;\n"
      "    if (pi_ > 1e-6 && po > 1e-6) cos_phi = max(0.0, (wi.x * wo.x + wi.y * wo.y) / (pi_ * po));\n"
      "    float cos_a = min(wi.z, wo.z);\n"
      "    float cos_b = max(wi.z, wo.z);\n"
      "    float sin_a = sqrt(max(0.0, 1.0 - cos_a * cos_a));\n"
      "    float tan_b = sqrt(max(0.0, 1.0 - cos_b * cos_b)) / cos_b;\n"
      "    return inv_pi * (a + bb * cos_phi * sin_a * tan_b);\n"
      "  }\n"
      "  if (model == 2) {  // normalised Blinn-Phong (e + 8)/(8 pi) (n.h)^e\n"
      "    float3 h = wi + wo;\n"
      "    float len = length(h);\n"
      "    if (len <= 0.0) return 0.0;\n"
      "    return (kappa.x + 8.0) * (inv_pi / 8.0) * pow(max(h.z / len, 0.0), kappa.x);\n"
      "  }\n"
      "  if (model == 3) {  // Ward, anisotropic Gaussian\n"
      "    float3 h = wi + wo;\n"
      "    float ex = (h.x * h.x / (kappa.x * kappa.x) + h.y * h.y / (kappa.y * kappa.y)) / (h.z * h.z);\n"
      "    return exp(-ex) / (4.0 * 3.14159265 * kappa.x * kappa.y * sqrt(wi.z * wo.z));\n"
      "  }\n"
      "  if (model == 4) {  // Cook-Torrance: Beckmann D, Schlick F, V-cavity G\n"
      "    float3 h = normalize(wi + wo);\n"
      "    float m2 = kappa.x * kappa.x;\n"
      "    float c2 = h.z * h.z;\n"
      "    float d = exp(-((1.0 - c2) / c2) / m2) / (3.14159265 * m2 * c2 * c2);\n"
      "    float vh = max(dot(wo, h), 1e-6);\n"
      "    float q = 1.0 - min(vh, 1.0);\n"
      "    float f = kappa.y + (1.0 - kappa.y) * (q * q * q * q * q);\n"
      "    float g = min(1.0, min(2.0 * h.z * wo.z / vh, 2.0 * h.z * wi.z / vh));\n"
      "    return d * f * g / (4.0 * wi.z * wo.z);\n"
      "  }\n"
      "  if (model == 5) {  // Lafortune, one generalised cosine lobe\n"
      "    float s = kappa.x * (wi.x * wo.x + wi.y * wo.y) + kappa.y * wi.z * wo.z;\n"
      "    if (s <= 0.0) return 0.0;\n"
      "    return (kappa.z + 2.0) * (inv_pi / 2.0) * pow(s, kappa.z);\n"
      "  }\n"
      "  if (model == 6) {  // Ashikhmin-Shirley, anisotropic specular term\n"
      "    float3 h = normalize(wi + wo);\n"
      "    float sin2 = h.x * h.x + h.y * h.y;\n"
      "    float expo = sin2 > 1e-12 ? (kappa.x * h.x * h.x + kappa.y * h.y * h.y) / sin2 : 0.5 * (kappa.x + "
      "kappa.y);\n"
      "    float hk = max(dot(h, wi), 1e-6);\n"
      "    float q = 1.0 - min(hk, 1.0);\n"
      "    float f = kappa.z + (1.0 - kappa.z) * (q * q * q * q * q);\n"
      "    return sqrt((kappa.x + 1.0) * (kappa.y + 1.0)) * (inv_pi / 8.0) * pow(max(h.z, 0.0), expo) /\n"
      "           (hk * max(wi.z, wo.z)) * f;\n"
      "  }\n"
      "  return 0.0;\n"
      "}\n"
      "// rho_g(wl, wv) of paper 003 eq. 2 for global dictionary entry g: f_j in the frame of n_j (the\n"
      "// minimal rotation taking +z to n_j) times max(n_j . wl, 0).\n"
      "float @spmm_basis(int g, float3 wl, float3 wv) {\n"
      "  int2 at = int2(2 * (g % @kSpmmBasesPerRow), g / @kSpmmBasesPerRow);\n"
      "  float4 p = $spmm_dictionary$.Load(int3(at, 0));  // model id, kappa_j\n"
      "  float3 n = $spmm_dictionary$.Load(int3(at + int2(1, 0), 0)).xyz;  // n_j\n"
      "  float k = 1.0 / (1.0 + n.z);\n"
      "  float3 t = float3(1.0 - n.x * n.x * k, -n.x * n.y * k, -n.x);\n"
      "  float3 b = float3(-n.x * n.y * k, 1.0 - n.y * n.y * k, -n.y);\n"
      "  float3 li = float3(dot(wl, t), dot(wl, b), dot(wl, n));\n"
      "  float3 lo = float3(dot(wv, t), dot(wv, b), dot(wv, n));\n"
      "  return @spmm_brdf(int(p.x), p.yzw, li, lo) * max(li.z, 0.0);\n"
      "}\n"
      "// Paper 003 eq. 1 without the residual: sum over the texel's occupied slots of alpha_j rho_j.\n"
      "float3 @spmm_analytic(int2 texel, float3 wl, float3 wv) {\n"
      "  float3 acc = (float3)0.0;\n"
      "  for (int k = 0; k < @kSpmmSlots; ++k) {\n"
      "    uint4 s = $spmm_texels$.Load(int4(texel, k, 0));  // x = basis, yzw = alpha (float bits)\n"
      "    if (s.x == 0xFFFFFFFFu) break;  // occupied slots come first\n"
      "    acc += @spmm_basis(int(s.x), wl, wv) * asfloat(s.yzw);\n"
      "  }\n"
      "  return acc;\n"
      "}\n"
      "// Paper 003 eq. 3: eps = mean + sum_{i < n_pca} coef_i(t) b_i(c), each read at the 3 x 3 measured\n"
      "// direction pairs of the angular tables and blended with their barycentric weights.\n"
      "float3 @spmm_epsilon(int2 texel, float3 wl, float3 wv, int n_pca) {\n"
      "  int n = clamp(n_pca, 0, @kSpmmResidualComponents);\n"
      "  uint4 cf[(@kSpmmResidualComponents + 4) / 4];  // [cluster, coef_0 bits, coef_1 bits, ...]\n"
      "  for (int g = 0; g <= n / 4; ++g) cf[g] = $spmm_texels$.Load(int4(texel, @kSpmmSlots + g, 0));\n"
      "  int base = int(cf[0].x) * (@kSpmmResidualComponents + 1);\n"
      "  int3 il; float3 al; int3 iv; float3 av;\n"
      "  @angular(0, wl, il, al);\n"
      "  @angular(1, wv, iv, av);\n"
      "  float3 acc = (float3)0.0;\n"
      "  for (int j = 0; j < @kAngularTaps; ++j) {\n"
      "    for (int i = 0; i < @kAngularTaps; ++i) {\n"
      "      float w = al[i] * av[j];\n"
      "      if (w <= 0.0) continue;\n"
      "      int2 lv = int2(il[i], iv[j]);\n"
      "      float3 e = $spmm_residual$.Load(int4(lv, base, 0)).rgb;  // mean of cluster c\n"
      "      for (int q = 1; q <= n; ++q)\n"
      "        e += asfloat(cf[q / 4][q % 4]) * $spmm_residual$.Load(int4(lv, base + q, 0)).rgb;\n"
      "      acc += w * e;\n"
      "    }\n"
      "  }\n"
      "  return acc;\n"
      "}\n"
      "// Paper 003 eq. 1 at texel floor(frac(uv) (W, H)); $spmm_mode$ = spmm_residual_mode(): 0 = every\n"
      "// stored component, 1 = no residual (paper 003 §5.2), 2 + n = n components.\n"
      "float3 @spmm(float2 uv, float3 wl, float3 wv) {\n"
      "  uint sw; uint sh; uint sl; uint sm;\n"
      "  $spmm_texels$.GetDimensions(0u, sw, sh, sl, sm);\n"
      "  int2 size = int2(sw, sh);\n"
      "  int2 texel = clamp(int2(frac(uv) * float2(size)), (int2)0, size - 1);\n"
      "  float3 rho = @spmm_analytic(texel, wl, wv);\n"
      "  uint mode = uint($spmm_mode$);\n"
      "  if (mode == 1u) return rho;\n"
      "  return rho + @spmm_epsilon(texel, wl, wv, mode == 0u ? @kSpmmResidualComponents : int(mode) - 2);\n"
      "}\n");
}

// Ring search of glsl_generator.hpp's piece_ring_search (paper 004 §4.4), the block a cbuffer.
inline void hlsl_ring_search(HlslEmitter& e) {
  e.constant_int("kRingMax", kRingSearchMaxRings);
  e.constant_int("kRingSlots", kRingSearchMaxSlots);
  const GlslResource& r = e.g.options.resource(ShaderBinding::direction_rings);
  if (r.declare) {  // declare = false: the host declares the same cbuffer (same member names)
    e.g.out += format_message("cbuffer %sDirectionRings : register(b%u, space%u) {\n", e.g.options.prefix.c_str(),
                              r.binding, r.set);
    e.emit(
        "  float4 @rings[2 * @kRingMax];          // table t, ring r at t * kRingMax + r: theta, phi0, n, slot 0\n"
        "  uint4 @ring_slots[@kRingSlots / 2];    // table t, slot s at t * kRingSlots + s: direction index\n"
        "  int4 @ring_counts;                     // x: light rings, y: view rings\n"
        "};\n");
  }
  e.emit(
      "uint @ring_slot(int table, float slot) {\n"
      "  int i = table * @kRingSlots + int(slot);\n"
      "  return @ring_slots[i / 4][i % 4];\n"
      "}\n"
      "float3 @ring_dir(float4 ring, float k) {\n"
      "  float phi = ring.y + k * 6.28318530718 / max(ring.z, 1.0);\n"
      "  return float3(sin(ring.x) * cos(phi), sin(ring.x) * sin(phi), cos(ring.x));\n"
      "}\n"
      "// Azimuth neighbours k, k + 1 (mod count) of phi on a ring (paper 004: f^l, f^u) and the fraction.\n"
      "void @ring_neighbours(float4 ring, float phi, out float lo, out float hi, out float fraction) {\n"
      "  if (ring.z <= 1.0) { lo = 0.0; hi = 0.0; fraction = 0.0; return; }\n"
      "  float dphi = 6.28318530718 / ring.z;\n"
      "  float rel = phi - ring.y;\n"
      "  rel = (rel - 6.28318530718 * floor(rel / 6.28318530718)) / dphi;\n"
      "  lo = min(floor(rel), ring.z - 1.0);\n"
      "  fraction = clamp(rel - lo, 0.0, 1.0);\n"
      "  hi = lo + 1.0 >= ring.z ? 0.0 : lo + 1.0;\n"
      "}\n"
      "void @ring_search(int table, float3 d, out int3 idx, out float3 w) {\n"
      "  float len = length(d);\n"
      "  float3 p = len > 0.0 ? d / len : float3(0.0, 0.0, 1.0);\n"
      "  if (p.z < 0.0) p = length(p.xy) > 0.0 ? float3(normalize(p.xy), 0.0) : float3(0.0, 0.0, 1.0);\n"
      "  float theta = acos(clamp(p.z, -1.0, 1.0));\n"
      "  float phi = (p.x == 0.0 && p.y == 0.0) ? 0.0 : atan2(p.y, p.x);\n"
      "  int n = table == 0 ? @ring_counts.x : @ring_counts.y;\n"
      "  int base = table * @kRingMax;\n"
      "  int upper = 0;  // first ring above theta (rings sorted by theta)\n"
      "  for (int r = 0; r < @kRingMax; ++r)\n"
      "    if (r < n && @rings[base + r].x <= theta) upper = r + 1;\n"
      "  float a; float b; float c; float dd; float f;\n"
      "  if (upper == n || upper == 0) {  // beyond the last ring (or below the first): linear in phi\n"
      "    float4 ring = @rings[base + (upper == 0 ? 0 : n - 1)];\n"
      "    @ring_neighbours(ring, phi, a, b, f);\n"
      "    int ia = int(@ring_slot(table, ring.w + a));\n"
      "    idx = int3(ia, int(@ring_slot(table, ring.w + b)), ia);\n"
      "    w = float3(1.0 - f, f, 0.0);\n"
      "    return;\n"
      "  }\n"
      "  float4 rl = @rings[base + upper - 1];\n"
      "  float4 ru = @rings[base + upper];\n"
      "  @ring_neighbours(rl, phi, a, b, f);\n"
      "  @ring_neighbours(ru, phi, c, dd, f);\n"
      "  float3 pa = @ring_dir(rl, a); float3 pb = @ring_dir(rl, b);\n"
      "  float3 pc = @ring_dir(ru, c); float3 pd = @ring_dir(ru, dd);\n"
      "  uint sa = @ring_slot(table, rl.w + a); uint sb = @ring_slot(table, rl.w + b);\n"
      "  uint sc = @ring_slot(table, ru.w + c); uint sd = @ring_slot(table, ru.w + dd);\n"
      "  float3 p1; float3 p2; float3 p3;\n"
      "  if (rl.z <= 1.0) { p1 = pa; p2 = pc; p3 = pd; idx = int3(uint3(sa, sc, sd)); }  // pole-C-D\n"
      "  else if (dot(p, pa) >= dot(p, pd)) { p1 = pa; p2 = pb; p3 = pc; idx = int3(uint3(sa, sb, sc)); }  // d'\n"
      "  else { p1 = pb; p2 = pc; p3 = pd; idx = int3(uint3(sb, sc, sd)); }\n"
      "  // paper 004 §4.4.2: |det(P, P_j, P_k)| (the 4 x 4 determinant with O is a triple product)\n"
      "  float3 v = float3(abs(dot(p, cross(p2, p3))), abs(dot(p, cross(p3, p1))), abs(dot(p, cross(p1, p2))));\n"
      "  float sum = v.x + v.y + v.z;\n"
      "  w = sum > 0.0 ? v / sum : float3(1.0, 0.0, 0.0);\n"
      "}\n");
}

inline void hlsl_pca_rings(HlslEmitter& e) {
  bool declared = false;  // pca_views in the same generation already declared L, R and the constants
  for (const GlslSamplerUse& u : e.g.samplers) declared = declared || u.role == ShaderBinding::pca_l;
  if (!declared) hlsl_pca_views_declarations(e);
  hlsl_pca_views_function(e, "pca_rings", "@ring_search", "3");
}

/// HLSL emitter per GlslPiece, in enum order (the needs are kPieces' of glsl_generator.hpp).
inline constexpr void (*kHlslPieces[])(HlslEmitter&) = {
    hlsl_direction_map, hlsl_local_frame, hlsl_angular, hlsl_fmf_brdf,  hlsl_fmf,  hlsl_page_table,  hlsl_bsvtf,
    hlsl_feedback,      hlsl_laplacian,   hlsl_lpca,    hlsl_pca_views, hlsl_spmm, hlsl_ring_search, hlsl_pca_rings,
};
static_assert(std::size(kHlslPieces) == kGlslPieceCount, "one HLSL emitter per GlslPiece, in enum order");

inline void hlsl_params_block(std::string& s) {
  s += "cbuffer BtflodParams : register(b0, space0) {  // ShaderParams (std140 and cbuffer packing agree)\n"
       "  column_major float4x4 btflod_model_view_proj;\n  column_major float4x4 btflod_model;\n"
       "  float4 btflod_camera_pos;\n  float4 btflod_light;\n  float4 btflod_light_color;\n  float4 btflod_lod;\n"
       "  float4 btflod_vt_extent;\n  uint4 btflod_ids;\n};\n"
       "struct BtflodVaryings {\n"
       "  float3 world_pos : TEXCOORD0;\n  float3 normal : TEXCOORD1;\n  float4 tangent : TEXCOORD2;\n"
       "  float2 uv : TEXCOORD3;\n  float4 position : SV_Position;\n};\n";
}

inline std::string hlsl_vertex() {
  std::string s;
  hlsl_params_block(s);
  s += "struct BtflodVertex {  // VertexAttribute order: position 0, normal 1, tangent 2, uv 3\n"
       "  float3 position : POSITION;\n  float3 normal : NORMAL;\n  float4 tangent : TANGENT;\n"
       "  float2 uv : TEXCOORD0;\n};\n"
       "BtflodVaryings main(BtflodVertex i) {\n"
       "  BtflodVaryings o;\n"
       "  o.world_pos = mul(btflod_model, float4(i.position, 1.0)).xyz;\n"
       "  o.normal = mul((float3x3)btflod_model, i.normal);\n"
       "  o.tangent = float4(mul((float3x3)btflod_model, i.tangent.xyz), i.tangent.w);\n"
       "  o.uv = i.uv;\n"
       "  o.position = mul(btflod_model_view_proj, float4(i.position, 1.0));\n"
       "  // one set of (OpenGL-convention) matrices for every API: z from [-w, w] to [0, w]\n"
       "  o.position.z = 0.5 * (o.position.z + o.position.w);\n"
       "  return o;\n"
       "}\n";
  return s;
}

inline Result<std::string> hlsl_program_fragment(const GlslProgramRecipe& r, const ShaderConfig& c) {
  const bool feedback = r.program == ShaderProgram::feedback;
  const bool stores_feedback = r.program == ShaderProgram::bsvtf_feedback;
  uint32_t pieces = feedback ? piece_bit(r.piece) : piece_bit(r.piece) | piece_bit(GlslPiece::local_frame);
  if (stores_feedback) pieces |= piece_bit(GlslPiece::feedback);
  Result<GlslFunctionSource> fn = generate_hlsl_functions(pieces, c);
  if (!fn) return fn.error();
  std::string s;
  hlsl_params_block(s);
  s += fn->code;
  if (feedback) {
    s += "uint main(BtflodVaryings i) : SV_Target0 { return btflod_feedback_word(i.uv); }\n";
    return s;
  }
  const char* name = glsl_piece_name(r.piece);
  if (stores_feedback)  // a second render target: no side effects, so early depth tests stay on
    s += "struct BtflodTargets {\n  float4 color : SV_Target0;\n  uint feedback : SV_Target1;\n};\n"
         "BtflodTargets main(BtflodVaryings i) {\n  BtflodTargets o;\n";
  else
    s += "float4 main(BtflodVaryings i) : SV_Target0 {\n";
  const char* ret = stores_feedback ? "o.color = " : "return ";
  if (r.raw_view)  // the components once: the raw view is group 0 of what eq. 5 reads
    s += format_message("  float4 v[btflod_kFmfGroups]; btflod_%s_components(i.uv, v);\n", name);
  if (stores_feedback)  // the colour pass's derivatives: no LOD offset (that is for a smaller feedback pass)
    s += "  o.feedback = btflod_feedback_word_at(i.uv, btflod_vt_lambda(i.uv));\n";
  if (r.raw_view)
    s += format_message("  if (btflod_ids.z == 1u) { %sv[0];%s }\n", ret, stores_feedback ? " return o;" : "");
  s += "  float3 to_eye = normalize(btflod_camera_pos.xyz - i.world_pos);\n"
       "  float3 to_light = btflod_light.w > 0.5 ? normalize(btflod_light.xyz - i.world_pos)"
       " : normalize(btflod_light.xyz);\n"
       "  float3 wl; float3 wv;\n"
       "  btflod_local_dirs(i.normal, i.tangent, to_light, to_eye, wl, wv);\n";
  if (r.raw_view) {
    s += format_message("  %sfloat4(btflod_fmf_brdf(v, wl, wv) * btflod_light_color.rgb, 1.0);\n", ret);
  } else {
    const bool laplacian = r.program == ShaderProgram::laplacian;
    s += format_message("  %sfloat4(btflod_%s(i.uv, wl, wv%s) * btflod_light_color.rgb, 1.0);\n", ret, name,
                        laplacian ? ", btflod_laplacian_lambda(distance(btflod_camera_pos.xyz, i.world_pos))" : "");
  }
  if (stores_feedback) s += "  return o;\n";
  s += "}\n";
  return s;
}

}  // namespace detail

Result<HlslFunctionSource> generate_hlsl_functions(uint32_t pieces, const ShaderConfig& config,
                                                   const GlslFunctionOptions& options) {
  if (VoidResult v = validate_shader_config(config); !v) return v.error();
  if (pieces == 0 || (pieces >> kGlslPieceCount) != 0)
    return make_error(Status::invalid_argument,
                      "generate_hlsl_functions: piece set 0x%x, expected a non-empty glsl_pieces() set", pieces);
  const detail::GlslPieceSet all = detail::close_pieces(pieces);
  if (VoidResult v = detail::validate_function_options(all, options); !v) return v.error();
  HlslFunctionSource out;
  detail::HlslEmitter e{detail::GlslEmitter{GlslTarget::vulkan450, config, options, out.code, out.samplers}};
  for (uint32_t i = 0; i < kGlslPieceCount; ++i)
    if (all & detail::piece_bit(static_cast<GlslPiece>(i))) detail::kHlslPieces[i](e);
  // Register spaces play the part of Vulkan descriptor sets in the uniqueness check.
  if (VoidResult v = detail::check_sampler_uses(GlslTarget::vulkan450, out.samplers); !v) return v.error();
  return out;
}

Result<HlslProgramSource> generate_hlsl_program(ShaderProgram program, const ShaderConfig& config) {
  if (VoidResult v = validate_shader_config(config); !v) return v.error();
  for (const detail::GlslProgramRecipe& r : detail::kProgramRecipes) {
    if (r.program != program) continue;
    Result<std::string> fragment = detail::hlsl_program_fragment(r, config);
    if (!fragment) return fragment.error();
    HlslProgramSource out;
    out.vertex = detail::hlsl_vertex();
    out.fragment = std::move(*fragment);
    return out;
  }
  return make_error(Status::invalid_argument, "generate_hlsl_program: unknown program %d", static_cast<int>(program));
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
