// btflod — Filament target of the shader generator: material sources (`.mat`) for Filament's
// material compiler `matc` (Filament 1.9, tested with 1.9.25), built from the same GLSL pieces
// as every other target (runtime/shader/glsl_generator.hpp's generate_functions()).
//
// A Filament material is a parameter list plus a fragment block; Filament writes the shader's
// `#version`, the uniform block and the sampler declarations itself. So the generated functions
// are pasted with every sampler declared by Filament (GlslResource::declare = false, named
// `materialParams_<parameter>`) and every per-draw value read from the material's uniform block
// (`materialParams.<parameter>`). Material code is compiled as GLSL 4.10 (desktop) and ESSL 3.00
// (mobile): the pieces used here (page table, tile cache, angular lookup, eq. 5) need neither
// textureQueryLevels nor storage buffers, and the mip count of the page table is a parameter
// (btflod_vt_extent.z = L_m), as on every target.
//
// Materials (FilamentMaterialKind):
//   bsvtf     the streamed virtual texture (paper 000): page table + tile cache + U′ (5 samplers)
//   fmf       the resident FMF (eigen-textures V′ as one filtered 2D array, ⌈C/4⌉ RGBA layers; 4 samplers)
//   feedback  the feedback pass: the packed word (paper 000 eq. 1–2) written as RGBA8, byte k
//             of (word XOR FeedbackWordLayout::empty_word) in channel k, so that a target
//             cleared to 0 reads back as the empty word (feedback_word_from_rgba8() undoes it);
//             reads no texture but declares the page table (the shared addressing piece names it)
// Filament allows 8 samplers per material; these use at most 5, so no table is packed.
//
// Shading model: `unlit`. A BTF is the whole reflectance ρ(x, ωl, ωv) of the surface (eq. 5
// returns radiance per unit light); Filament's lit models apply Filament's own BRDF to material
// outputs and have no hook for a tabulated one, and the light loop of lit materials is not
// visible to unlit ones. The light therefore comes in as parameters (btflod_light: xyz direction
// towards the light, w = 0, or position, w = 1; btflod_light_color), which the engine copies from
// its light each frame — the same values btflod's own programs read (ShaderParams::light). The
// result is written to baseColor (alpha 1): with post-processing off the target receives btflod's
// linear radiance (samples/filament measures it against the CPU reference); with it on, Filament's
// colour grading and tone mapping apply as to any unlit material.
//
// Filament details the generated material handles: unlit materials get no tangent frame from
// Filament (getWorldTangentFrame() is only set up for lit ones), so a vertex block decodes the
// mesh's tangent quaternion into two variables; `flipUV : false` keeps the mesh's uv (tile ids and
// page-table addresses depend on it).
//
// Everything here is set-up code (string building) and allocates. Thread-safe, no shared state.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "btflod/core/result.hpp"
#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/shader/shader_config.hpp"
#include "btflod/runtime/vt/cache_format.hpp"

namespace btflod {

/// Which material generate_filament_material() writes.
enum class FilamentMaterialKind : unsigned char { bsvtf, fmf, feedback };

/// Stable lower-case name ("bsvtf", "fmf", "feedback"). Never null.
constexpr const char* filament_material_kind_name(FilamentMaterialKind k) noexcept {
  return k == FilamentMaterialKind::bsvtf ? "bsvtf" : k == FilamentMaterialKind::fmf ? "fmf" : "feedback";
}

/// Options of generate_filament_material().
struct FilamentMaterialOptions {
  /// Filament material name (`name :` in the material block); empty: "btflod_" + kind name.
  std::string name;
  /// Face culling of the material: "none" shows both sides (btflod's planes are two-sided).
  std::string culling = "none";
};

/// The uniform parameters every generated Filament material declares (set them with
/// MaterialInstance::setParameter). Same meaning as ShaderParams' members of the same name.
inline constexpr const char* kFilamentParamVtExtent =
    "btflod_vt_extent";                                             ///< float4: M, N, L_m, C_m (0: the program's C)
inline constexpr const char* kFilamentParamLod = "btflod_lod";      ///< float4: bias, feedback offset, 0, 0
inline constexpr const char* kFilamentParamIds = "btflod_ids";      ///< uint4: first layer, texture id, 0, 0
inline constexpr const char* kFilamentParamLight = "btflod_light";  ///< float4 (not in feedback)
inline constexpr const char* kFilamentParamLightColor = "btflod_light_color";  ///< float4 (not in feedback)

/// The Filament parameter name of a sampler role: "btflod_" + shader_binding_name(role), e.g.
/// "btflod_tile_cache" (the generated GLSL reads materialParams_btflod_tile_cache).
inline std::string filament_sampler_parameter(ShaderBinding role) {
  return std::string("btflod_") + shader_binding_name(role);
}

namespace detail {

// A Filament material name or culling mode: letters, digits, '_' only (no injection into the
// material block).
inline bool filament_word(const std::string& s) noexcept {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

}  // namespace detail

/// The Filament sampler parameters a material of `kind` declares for a tile cache of `format`, in
/// declaration order (each is set with MaterialInstance::setParameter(filament_sampler_parameter(role),
/// texture, sampler)). All are 2D arrays (sampler2dArray) but the slot-map table (sampler2d, the
/// bsvtf material of an rgba8_affine or bc5_affine cache only: runtime/vt/cache_format.hpp); angular_index,
/// page_table and slot_map hold uint texels (RGBA32UI, R32UI: `format : uint`), the others float.
/// precision is high for all: the page-table entry and the cache coordinates need 32-bit integers
/// and floats.
inline std::span<const ShaderBinding> filament_material_samplers(FilamentMaterialKind kind,
                                                                 CacheFormat format = CacheFormat::rgba16f) noexcept {
  static constexpr ShaderBinding kBsvtfRgba8[] = {ShaderBinding::eigen_abrdfs,   ShaderBinding::angular_index,
                                                  ShaderBinding::angular_weight, ShaderBinding::tile_cache,
                                                  ShaderBinding::page_table,     ShaderBinding::slot_map};
  if (kind == FilamentMaterialKind::bsvtf && cache_format_has_slot_map(format)) return kBsvtfRgba8;
  static constexpr ShaderBinding kBsvtf[] = {ShaderBinding::eigen_abrdfs, ShaderBinding::angular_index,
                                             ShaderBinding::angular_weight, ShaderBinding::tile_cache,
                                             ShaderBinding::page_table};
  static constexpr ShaderBinding kFmf[] = {ShaderBinding::eigen_abrdfs, ShaderBinding::angular_index,
                                           ShaderBinding::angular_weight, ShaderBinding::eigen_textures};
  static constexpr ShaderBinding kFeedback[] = {ShaderBinding::page_table};
  switch (kind) {
    case FilamentMaterialKind::bsvtf:
      return kBsvtf;
    case FilamentMaterialKind::fmf:
      return kFmf;
    case FilamentMaterialKind::feedback:
      return kFeedback;
  }
  return {};
}

/// Generates the `.mat` source of a Filament material of `kind` for `config` (C, angular
/// tables, cache shape, feedback word layout: the values the Streamer and the textures use),
/// for `matc` (e.g. `matc -p desktop -a opengl -o out.filamat in.mat`). The material requires
/// uv0 (uv = (0,0) at the texture's first texel; `flipUV : false`, so Filament passes the mesh's
/// uv unchanged, as btflod's page table and feedback words expect) and, except feedback,
/// tangents (Filament's tangent frame: t = ∂p/∂u, n, b = n × t · handedness); its samplers and
/// uniforms are listed at filament_material_samplers() and kFilamentParam*. Each material
/// instance draws one btflod material: btflod_vt_extent, btflod_ids (first page-table layer,
/// texture id) per instance.
/// Returns invalid_argument for a config failing validate_shader_config() or a name/culling
/// that is not a plain word. Deterministic. Allocates (set-up time).
/// Thread-safe.
inline Result<std::string> generate_filament_material(FilamentMaterialKind kind, const ShaderConfig& config,
                                                      const FilamentMaterialOptions& options = {}) {
  const std::string name =
      options.name.empty() ? std::string("btflod_") + filament_material_kind_name(kind) : options.name;
  if (!detail::filament_word(name) || !detail::filament_word(options.culling))
    return make_error(Status::invalid_argument,
                      "generate_filament_material: name \"%.80s\" or culling \"%.80s\" "
                      "is not a word of letters, digits and '_'",
                      name.c_str(), options.culling.c_str());
  GlslFunctionOptions fo;
  fo.prefix = "btflod_";
  for (uint32_t i = 1; i < kShaderBindingCount; ++i) {
    GlslResource& r = fo.resources[i];
    r.name = "materialParams_" + filament_sampler_parameter(static_cast<ShaderBinding>(i));
    r.declare = false;  // Filament declares every sampler parameter
  }
  fo.uniforms.vt_extent = std::string("materialParams.") + kFilamentParamVtExtent;
  fo.uniforms.lod_bias = std::string("materialParams.") + kFilamentParamLod + ".x";
  fo.uniforms.feedback_lod_offset = std::string("materialParams.") + kFilamentParamLod + ".y";
  fo.uniforms.range_lod_scale = std::string("materialParams.") + kFilamentParamLod + ".z";
  fo.uniforms.first_layer = std::string("materialParams.") + kFilamentParamIds + ".x";
  fo.uniforms.texture_id = std::string("materialParams.") + kFilamentParamIds + ".y";
  fo.uniforms.spmm_mode = std::string("materialParams.") + kFilamentParamIds + ".w";
  fo.uniforms.component_count = std::string("materialParams.") + kFilamentParamVtExtent + ".w";
  const uint32_t pieces = kind == FilamentMaterialKind::bsvtf ? glsl_pieces({GlslPiece::bsvtf, GlslPiece::local_frame})
                          : kind == FilamentMaterialKind::fmf ? glsl_pieces({GlslPiece::fmf, GlslPiece::local_frame})
                                                              : glsl_pieces({GlslPiece::feedback});
  // gl450_core and es300 emit the same function text when no sampler is declared by it; es300
  // is the conservative choice (its subset compiles as GLSL 4.10 and ESSL 3.00).
  Result<GlslFunctionSource> fn = generate_functions(pieces, GlslTarget::es300, config, fo);
  if (!fn) return fn.error();

  std::string s;
  s += "// Generated by btflod (runtime/shader/filament_material.hpp) for matc, Filament 1.9. Do not edit:\n"
       "// regenerate from the ShaderConfig the Streamer and the textures use.\n"
       "material {\n"
       "    name : " +
       name +
       ",\n"
       "    shadingModel : unlit,\n"
       "    flipUV : false,\n"
       "    culling : " +
       options.culling + ",\n";
  s += kind == FilamentMaterialKind::feedback ? "    requires : [ uv0 ],\n" : "    requires : [ uv0, tangents ],\n";
  s += "    parameters : [\n";
  for (ShaderBinding role : filament_material_samplers(kind, config.vt.format)) {
    const bool uint_texels =
        role == ShaderBinding::angular_index || role == ShaderBinding::page_table || role == ShaderBinding::slot_map;
    s += std::string("        { type : ") + (role == ShaderBinding::slot_map ? "sampler2d" : "sampler2dArray") +
         ", name : " + filament_sampler_parameter(role);
    s += uint_texels ? ", format : uint, precision : high },\n" : ", precision : high },\n";
  }
  s += std::string("        { type : float4, name : ") + kFilamentParamVtExtent + " },\n";
  s += std::string("        { type : float4, name : ") + kFilamentParamLod + " },\n";
  s += std::string("        { type : uint4, name : ") + kFilamentParamIds + " }";
  if (kind != FilamentMaterialKind::feedback) {
    s += std::string(",\n        { type : float4, name : ") + kFilamentParamLight + " },\n";
    s += std::string("        { type : float4, name : ") + kFilamentParamLightColor + " }";
  }
  s += "\n    ]";
  if (kind == FilamentMaterialKind::feedback) {
    s += "\n}\n\nfragment {\n";
  } else {
    // Unlit materials get no tangent frame from Filament (getWorldTangentFrame() is only set up
    // for lit ones), so the vertex block passes the mesh's own: normal and tangent in world
    // space, the quaternion's handedness in tangent.w.
    s += ",\n    variables : [ btflod_world_normal, btflod_world_tangent ]\n}\n\n"
         "vertex {\n"
         "    void materialVertex(inout MaterialVertexInputs material) {\n"
         "        vec3 n; vec3 t;\n"
         "        toTangentFrame(mesh_tangents, n, t);\n"
         "        material.btflod_world_normal = vec4(getWorldFromModelNormalMatrix() * n, 0.0);\n"
         "        material.btflod_world_tangent = vec4(mat3(getWorldFromModelMatrix()) * t,\n"
         "                                             mesh_tangents.w < 0.0 ? -1.0 : 1.0);\n"
         "    }\n"
         "}\n\nfragment {\n";
  }
  s += fn->code;
  s += "void material(inout MaterialInputs material) {\n"
       "    prepareMaterial(material);\n"
       "    vec2 uv = getUV0();\n";
  if (kind == FilamentMaterialKind::feedback) {
    // Byte k of (word ^ empty word) in channel k: k / 255 is exact in UNORM8, so the bytes read
    // back are the word's, and a pixel nothing covers (cleared to 0) is the empty word.
    s += "    uint w = btflod_feedback_word(uv) ^ " + std::to_string(config.vt.feedback.empty_word) +
         "u;\n"
         "    material.baseColor = vec4(float(w & 255u), float((w >> 8u) & 255u), float((w >> 16u) & 255u),\n"
         "                              float(w >> 24u)) / 255.0;\n"
         "}\n}\n";
    return s;
  }
  const char* fn_name = kind == FilamentMaterialKind::bsvtf ? "btflod_bsvtf" : "btflod_fmf";
  s += std::string(
           "    // The mesh's frame (vertex block), the eye and the light in world space → local directions.\n"
           "    vec3 pos = getWorldPosition();\n"
           "    vec3 to_eye = normalize(getWorldCameraPosition() - pos);\n"
           "    vec4 light = materialParams.") +
       kFilamentParamLight + ";\n" +
       "    vec3 to_light = light.w > 0.5 ? normalize(light.xyz - pos) : normalize(light.xyz);\n"
       "    vec3 wl; vec3 wv;\n"
       "    btflod_local_dirs(variable_btflod_world_normal.xyz, variable_btflod_world_tangent, to_light, to_eye, wl, "
       "wv);\n"
       "    vec3 rho = " +
       fn_name +
       "(uv, wl, wv);\n"
       "    material.baseColor = vec4(rho * materialParams." +
       kFilamentParamLightColor +
       ".rgb, 1.0);\n"
       "}\n}\n";
  return s;
}

/// The feedback word of one RGBA8 texel written by the feedback material (byte k of word XOR
/// `empty_word` in channel k; a texel cleared to 0 gives `empty_word`). noexcept.
constexpr uint32_t feedback_word_from_rgba8(const uint8_t* texel, uint32_t empty_word = 0xffffffffu) noexcept {
  return (uint32_t{texel[0]} | (uint32_t{texel[1]} << 8) | (uint32_t{texel[2]} << 16) | (uint32_t{texel[3]} << 24)) ^
         empty_word;
}

/// Turns a read-back RGBA8 feedback image (width × height texels, 4 bytes each, row 0 = the
/// bottom row when `bottom_up`, as OpenGL and Filament's readPixels return it) into words, row
/// 0 = top row (the Streamer's votes do not depend on the order; a comparison does). `empty_word`
/// is the config's FeedbackWordLayout::empty_word. Returns invalid_argument (out untouched) when
/// a size does not match. noexcept, no allocation; safe for any bytes.
inline Status feedback_words_from_rgba8(std::span<const uint8_t> rgba, uint32_t width, uint32_t height, bool bottom_up,
                                        std::span<uint32_t> out, uint32_t empty_word = 0xffffffffu) noexcept {
  const size_t n = static_cast<size_t>(width) * height;
  if (rgba.size() != n * 4 || out.size() != n) return Status::invalid_argument;
  for (uint32_t y = 0; y < height; ++y) {
    const uint32_t src_row = bottom_up ? height - 1 - y : y;
    for (uint32_t x = 0; x < width; ++x)
      out[static_cast<size_t>(y) * width + x] =
          feedback_word_from_rgba8(&rgba[(static_cast<size_t>(src_row) * width + x) * 4], empty_word);
  }
  return Status::success;
}

}  // namespace btflod
