// btflod — GLSL generators for OpenGL 4.5 core, Vulkan GLSL 450 and GLSL ES 3.00.
//
// Two forms from one set of pieces:
//
// * generate_functions() emits FUNCTIONS to paste into an engine's own shader: BTF evaluation
//   per representation, page-table lookup, feedback word, angular lookup, local frame and the
//   direction maps, with names (a prefix), bindings, descriptor sets and uniform sources the
//   caller chooses (GlslFunctionOptions). No `#version`, no `main()`, no uniform block.
// * generate_program() assembles today's whole programs (one shared vertex shader, the uniform
//   block BtflodParams = ShaderParams, the binding table ShaderBinding) from the same pieces with
//   the default options; every program's main() is the same few lines around one call.
//
// Pieces (GlslPiece) and the functions they define, `P` standing for the prefix:
//
//   direction_map  vec2 P_direction_map(vec3 d)                  local direction → unit square
//   local_frame    void P_local_dirs(n, tangent, to_light, to_eye, out wl, out wv)
//   angular        void P_angular(int table, vec3 d, out ivec3 idx, out vec3 w)   paper 000 §4
//                  int  P_angular_nearest(int table, vec3 d)
//   fmf_brdf       vec3 P_fmf_brdf(vec4 v[P_kFmfGroups], vec3 wl, vec3 wv)      paper 000 eq. 5
//                  vec3 P_decode_value(vec3 s)   ShaderConfig::value_transform's D(s)
//   fmf            void P_fmf_components(vec2 uv, out vec4 v[P_kFmfGroups]); vec4 P_fmf_raw(vec2 uv);
//                  vec3 P_fmf(vec2 uv, vec3 wl, vec3 wv)
//   page_table     float P_vt_lambda(vec2 uv); ivec2 P_tile_of(vec2 uv, int level); …  eq. 1–2
//   bsvtf          P_VtSite P_vt_site(vec2 uv, float lambda); vec4 P_vt_fetch(int layer, P_VtSite);
//                  void P_bsvtf_components(uv, out v[]); vec4 P_bsvtf_raw(uv); vec3 P_bsvtf(uv, wl, wv)
//   feedback       uint P_feedback_word(vec2 uv); uint P_feedback_word_at(uv, lambda)   paper 000 eq. 1–2
//   laplacian      float P_laplacian_lambda(float distance); vec3 P_laplacian(uv, wl, wv, lambda)
//   lpca           vec3 P_lpca(vec2 uv, vec3 wl, vec3 wv)                         paper 002 §6.2
//   pca_views      vec3 P_pca_views(vec2 uv, vec3 wl, vec3 wv)                    paper 004 §6.3
//   ring_search    void P_ring_search(int table, vec3 d, out ivec3 idx, out vec3 w)   paper 004 §4.4
//                  reads the uniform block P_DirectionRings (offline/packing/ring_search_block.hpp)
//   pca_rings      vec3 P_pca_rings(vec2 uv, vec3 wl, vec3 wv)            paper 004 §6.3 with §4.4
//   spmm           float P_spmm_brdf(int model, vec3 kappa, vec3 wi, vec3 wo); float P_spmm_basis(int g, wl, wv);
//                  vec3 P_spmm_analytic(ivec2 texel, wl, wv); vec3 P_spmm_epsilon(ivec2 texel, wl, wv, int n_pca);
//                  vec3 P_spmm(vec2 uv, vec3 wl, vec3 wv)                         paper 003 eq. 1–3
//
// A requested piece brings the pieces it calls (each emitted once, in dependency order). The
// evaluation functions return ρ (rgb, before the light's colour); wl, wv are local directions
// (z = normal, pointing away from the surface). Adding a representation is one new piece: an
// enumerator, one emit function and one row in detail::kPieces (plus, for a whole program, a
// ShaderProgram and a row in detail::kProgramRecipes).
//
// runtime/shader/hlsl_generator.hpp emits the same pieces and programs in HLSL (one HLSL emitter per piece
// in runtime/shader/hlsl_pieces.hpp and hlsl_programs.hpp): a change to a piece's arithmetic here is made
// there too (tests/test_shader_hlsl.cpp checks the function names and textures agree).
//
// The generated text is deterministic (same inputs → same bytes). docs/shaders.md describes the
// texture layouts each piece expects and has an example of an engine shader.
//
// generate_functions() and generate_program() are set-up code: they and the pieces' emitters are
// defined in the implementation TU (BTFLOD_IMPLEMENTATION), so including this header instantiates
// none of their string building.
#pragma once

#include <array>
#include <cstdint>
#include <initializer_list>
#include <iterator>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod {

/// Whole programs of generate_program(). bsvtf_feedback is bsvtf that also writes every pixel's
/// feedback word (paper 000 eq. 1–2, at the colour pass's own derivatives) to a second render
/// target, fragment output 1 (uint): the backend subsamples it to the feedback target, so no
/// separate feedback pass draws the geometry again.
enum class ShaderProgram : unsigned char {
  fmf,
  bsvtf,
  feedback,
  laplacian,
  lpca,
  pca_views,
  spmm,
  pca_rings,
  bsvtf_feedback
};

inline constexpr ShaderProgram kAllShaderPrograms[] = {
    ShaderProgram::fmf,       ShaderProgram::bsvtf,     ShaderProgram::feedback,
    ShaderProgram::laplacian, ShaderProgram::lpca,      ShaderProgram::pca_views,
    ShaderProgram::spmm,      ShaderProgram::pca_rings, ShaderProgram::bsvtf_feedback};
/// Rings and directions per table (light, view) of the ring search's uniform block (UBO2014:
/// 10 rings, 151 directions). offline/packing/ring_search_block.hpp packs the block.
inline constexpr uint32_t kRingSearchMaxRings = 16;
inline constexpr uint32_t kRingSearchMaxSlots = 256;
inline constexpr GlslTarget kAllGlslTargets[] = {GlslTarget::gl450_core, GlslTarget::vulkan450, GlslTarget::es300};

/// Stable lower-case name, e.g. "bsvtf". Never null.
constexpr const char* shader_program_name(ShaderProgram p) noexcept {
  switch (p) {
    case ShaderProgram::fmf:
      return "fmf";
    case ShaderProgram::bsvtf:
      return "bsvtf";
    case ShaderProgram::feedback:
      return "feedback";
    case ShaderProgram::laplacian:
      return "laplacian";
    case ShaderProgram::lpca:
      return "lpca";
    case ShaderProgram::pca_views:
      return "pca_views";
    case ShaderProgram::pca_rings:
      return "pca_rings";
    case ShaderProgram::spmm:
      return "spmm";
    case ShaderProgram::bsvtf_feedback:
      return "bsvtf_feedback";
  }
  return "unknown";
}
/// Stable lower-case name, e.g. "es300". Never null.
constexpr const char* glsl_target_name(GlslTarget t) noexcept {
  switch (t) {
    case GlslTarget::gl450_core:
      return "gl450_core";
    case GlslTarget::vulkan450:
      return "vulkan450";
    case GlslTarget::es300:
      return "es300";
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

/// Every sampler any whole program declares, with its binding. Programs declare a subset.
/// The names are the default resource names of generate_functions() with the prefix "btflod_".
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
      {"btflod_spmm_texels", ShaderBinding::spmm_texels},
      {"btflod_spmm_dictionary", ShaderBinding::spmm_dictionary},
      {"btflod_spmm_residual", ShaderBinding::spmm_residual},
      {"btflod_slot_map", ShaderBinding::slot_map},
  };
  return kNames;
}

/// Number of ShaderBinding values (the block at 0 and every sampler role); sizes
/// GlslFunctionOptions::resources. Grows with ShaderBinding.
inline constexpr uint32_t kShaderBindingCount = static_cast<uint32_t>(ShaderBinding::slot_map) + 1;

/// Role name of a binding without prefix, e.g. "tile_cache" ("params" for the uniform block).
constexpr const char* shader_binding_name(ShaderBinding b) noexcept {
  switch (b) {
    case ShaderBinding::params:
      return "params";
    case ShaderBinding::eigen_abrdfs:
      return "eigen_abrdfs";
    case ShaderBinding::angular_index:
      return "angular_index";
    case ShaderBinding::angular_weight:
      return "angular_weight";
    case ShaderBinding::eigen_textures:
      return "eigen_textures";
    case ShaderBinding::tile_cache:
      return "tile_cache";
    case ShaderBinding::page_table:
      return "page_table";
    case ShaderBinding::laplacian_eigen:
      return "laplacian_eigen";
    case ShaderBinding::laplacian_weights:
      return "laplacian_weights";
    case ShaderBinding::laplacian_mean:
      return "laplacian_mean";
    case ShaderBinding::lpca_cluster:
      return "lpca_cluster";
    case ShaderBinding::lpca_weights:
      return "lpca_weights";
    case ShaderBinding::lpca_volume:
      return "lpca_volume";
    case ShaderBinding::pca_l:
      return "pca_l";
    case ShaderBinding::pca_r:
      return "pca_r";
    case ShaderBinding::direction_rings:
      return "direction_rings";
    case ShaderBinding::spmm_texels:
      return "spmm_texels";
    case ShaderBinding::spmm_dictionary:
      return "spmm_dictionary";
    case ShaderBinding::spmm_residual:
      return "spmm_residual";
    case ShaderBinding::slot_map:
      return "slot_map";
  }
  return "unknown";
}

/// One group of generated functions (see the table at the top of this file).
enum class GlslPiece : unsigned char {
  direction_map,
  local_frame,
  angular,
  fmf_brdf,
  fmf,
  page_table,
  bsvtf,
  feedback,
  laplacian,
  lpca,
  pca_views,
  spmm,
  ring_search,
  pca_rings,
};
inline constexpr uint32_t kGlslPieceCount = static_cast<uint32_t>(GlslPiece::pca_rings) + 1;

/// Stable lower-case name of a piece, e.g. "page_table". Never null.
constexpr const char* glsl_piece_name(GlslPiece p) noexcept {
  switch (p) {
    case GlslPiece::direction_map:
      return "direction_map";
    case GlslPiece::local_frame:
      return "local_frame";
    case GlslPiece::angular:
      return "angular";
    case GlslPiece::fmf_brdf:
      return "fmf_brdf";
    case GlslPiece::fmf:
      return "fmf";
    case GlslPiece::page_table:
      return "page_table";
    case GlslPiece::bsvtf:
      return "bsvtf";
    case GlslPiece::feedback:
      return "feedback";
    case GlslPiece::laplacian:
      return "laplacian";
    case GlslPiece::lpca:
      return "lpca";
    case GlslPiece::pca_views:
      return "pca_views";
    case GlslPiece::ring_search:
      return "ring_search";
    case GlslPiece::pca_rings:
      return "pca_rings";
    case GlslPiece::spmm:
      return "spmm";
  }
  return "unknown";
}

/// Where one sampler (or, for ShaderBinding::params, the whole programs' uniform block) comes
/// from in the host shader.
struct GlslResource {
  /// GLSL name the functions read. Empty: prefix + shader_binding_name() (e.g.
  /// "btflod_tile_cache"). With `declare` false it may be any expression of the sampler type
  /// the host shader declares (e.g. "u_materials[2]").
  std::string name;
  uint32_t binding = 0;  ///< GL binding / Vulkan binding; an ES host assigns this unit by name
  uint32_t set = 0;      ///< Vulkan descriptor set (ignored by the other targets)
  bool declare = true;   ///< false: the host shader declares the sampler itself
};

/// GLSL expressions the functions read for per-draw values. The defaults name the members of
/// the whole programs' uniform block BtflodParams (instance `btflod`); an engine points them at
/// its own uniforms, push constants or globals it sets before the call (e.g.
/// "u_material.vt_extent"). Each is evaluated inside the function, in parentheses.
struct GlslUniformSources {
  std::string vt_extent = "btflod.vt_extent";        ///< vec3/vec4: xy = M, N (finest-level texels), z = L_m
  std::string lod_bias = "btflod.lod.x";             ///< float: LOD bias in levels (page_table, bsvtf, feedback)
  std::string feedback_lod_offset = "btflod.lod.y";  ///< float: log2(screen / feedback size) (feedback)
  std::string range_lod_scale = "btflod.lod.z";      ///< float: laplacian λ = log2(distance · scale)
  std::string first_layer = "btflod.ids.x";          ///< uint: page-table layer of component group 0 (bsvtf)
  std::string texture_id = "btflod.ids.y";           ///< uint: texture id in the feedback word (feedback)
  std::string spmm_mode = "btflod.ids.w";            ///< uint: SPMM residual switch, spmm_residual_mode() (spmm)
  /// float/int/uint: the drawn material's component count C_m (fmf_brdf, fmf, bsvtf): eq. 5 sums
  /// components c < C_m and fetches ⌈C_m/4⌉ groups, so one program of C = max C_m draws
  /// materials of every rank. 0 (or above the program's C): the program's C. Empty: always
  /// the program's C (no per-draw value read).
  std::string component_count = "btflod.vt_extent.w";
};

/// Names, bindings, sets and uniform sources of generate_functions().
struct GlslFunctionOptions {
  /// Prefix of every function, struct and constant (and of default sampler names): a GLSL
  /// identifier start, no "gl_" and no "__". Two generations with different prefixes (e.g.
  /// two configs) can live in one shader.
  std::string prefix = "btflod_";
  /// Indexed by ShaderBinding: defaults are binding = the ShaderBinding value, set 0, declared.
  std::array<GlslResource, kShaderBindingCount> resources = default_resources();
  GlslUniformSources uniforms;

  GlslResource& resource(ShaderBinding b) noexcept { return resources[static_cast<uint32_t>(b)]; }
  const GlslResource& resource(ShaderBinding b) const noexcept { return resources[static_cast<uint32_t>(b)]; }

  /// The whole programs' table: binding = ShaderBinding value, set 0, name from the prefix.
  static std::array<GlslResource, kShaderBindingCount> default_resources() {
    std::array<GlslResource, kShaderBindingCount> r;
    for (uint32_t i = 0; i < kShaderBindingCount; ++i) r[i].binding = i;
    return r;
  }
};

/// A sampler the generated functions read, as resolved from the options.
struct GlslSamplerUse {
  ShaderBinding role = ShaderBinding::params;
  std::string name;
  uint32_t binding = 0;
  uint32_t set = 0;
  bool declared = true;  ///< declared by the generated text (false: the host declares it)
};

/// Output of generate_functions().
struct GlslFunctionSource {
  std::string code;                      ///< declarations and functions, no #version, no main()
  std::vector<GlslSamplerUse> samplers;  ///< every sampler `code` reads, in declaration order
};

namespace detail {
using GlslPieceSet = uint32_t;  ///< bits of GlslPiece values
constexpr GlslPieceSet piece_bit(GlslPiece p) noexcept { return 1u << static_cast<uint32_t>(p); }
}  // namespace detail

/// Set of pieces for generate_functions(), e.g. `glsl_pieces({GlslPiece::bsvtf, GlslPiece::feedback})`.
constexpr uint32_t glsl_pieces(std::initializer_list<GlslPiece> pieces) noexcept {
  uint32_t s = 0;
  for (GlslPiece p : pieces) s |= detail::piece_bit(p);
  return s;
}

/// Generates the functions of `pieces` (a glsl_pieces() set; the pieces they call are added) for
/// `target`, to paste into a host shader after its `#version` line (ES: after its precision
/// statements; every sampler is declared `highp`). The host declares nothing the functions
/// need except what it chose to declare itself (GlslResource::declare = false) and whatever the
/// uniform-source expressions name. `out.samplers` lists every sampler the code reads with its
/// binding and set (an ES host sets each unit by name). Functions using derivatives (the
/// page_table λ, bsvtf, feedback) must be called in uniform control flow of a fragment shader;
/// the others work in any stage.
/// Returns invalid_argument (naming the field) for a config failing validate_shader_config(), an
/// empty or unknown piece set, a prefix that is no GLSL identifier start, sampler names or
/// uniform sources that are no identifier / one-line expression, or two declared samplers on
/// one name or binding (set). Deterministic. Allocates (set-up time). Thread-safe. Options are
/// checked, so untrusted option text cannot inject statements, but the expressions are pasted
/// verbatim: a wrong expression fails in the host's GLSL compiler.
Result<GlslFunctionSource> generate_functions(uint32_t pieces, GlslTarget target, const ShaderConfig& config,
                                              const GlslFunctionOptions& options = {});

/// Generates the vertex and fragment shader of `program` for `target`: the shared vertex
/// shader, and a fragment shader of the BtflodParams block, the varyings, the functions of
/// generate_functions() with the default options and a main() calling them.
/// Returns invalid_argument when the config fails validate_shader_config(). The source is
/// deterministic. Allocates (set-up time only). Thread-safe (no shared state).
Result<GlslProgramSource> generate_program(ShaderProgram program, GlslTarget target, const ShaderConfig& config);

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
// The generator: string building at set-up time, compiled once in the implementation TU.
namespace btflod {

namespace detail {

inline void glsl_version(std::string& s, GlslTarget t) {
  switch (t) {
    case GlslTarget::gl450_core:
      s += "#version 450 core\n";
      break;
    case GlslTarget::vulkan450:
      s += "#version 450\n";
      break;
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
    case GlslTarget::gl450_core:
      s += "layout(std140, binding = 0) uniform BtflodParams {\n";
      break;
    case GlslTarget::vulkan450:
      s += "layout(std140, set = 0, binding = 0) uniform BtflodParams {\n";
      break;
    case GlslTarget::es300:
      s += "layout(std140) uniform BtflodParams {\n";
      break;
  }
  s += "  mat4 model_view_proj;\n  mat4 model;\n  vec4 camera_pos;\n  vec4 light;\n  vec4 light_color;\n"
       "  vec4 lod;\n  vec4 vt_extent;\n  uvec4 ids;\n} btflod;\n";
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

// ---- Piece emission ------------------------------------------------------------------------
//
// Templates are GLSL with two kinds of tokens: `@` is replaced by the prefix, `$key$` by the
// resolved sampler name or the parenthesised uniform expression of that key.

struct GlslEmitter {
  GlslTarget target;
  const ShaderConfig& config;
  const GlslFunctionOptions& options;
  std::string& out;
  std::vector<GlslSamplerUse>& samplers;

  std::string sampler_name(ShaderBinding b) const {
    const GlslResource& r = options.resource(b);
    return r.name.empty() ? options.prefix + shader_binding_name(b) : r.name;
  }

  std::string value(std::string_view key) const {
    const GlslUniformSources& u = options.uniforms;
    const std::string* src = key == "vt_extent"             ? &u.vt_extent
                             : key == "lod_bias"            ? &u.lod_bias
                             : key == "feedback_lod_offset" ? &u.feedback_lod_offset
                             : key == "range_lod_scale"     ? &u.range_lod_scale
                             : key == "first_layer"         ? &u.first_layer
                             : key == "texture_id"          ? &u.texture_id
                             : key == "spmm_mode"           ? &u.spmm_mode
                             : key == "component_count"     ? &u.component_count
                                                            : nullptr;
    if (src == &u.component_count && src->empty()) return "(0)";  // the program's C
    if (src) return "(" + *src + ")";
    for (uint32_t i = 1; i < kShaderBindingCount; ++i)
      if (key == shader_binding_name(static_cast<ShaderBinding>(i))) return sampler_name(static_cast<ShaderBinding>(i));
    return "<unknown key " + std::string(key) + ">";  // a template bug; glslang tests catch it
  }

  // Appends `tmpl` with the tokens replaced.
  void emit(std::string_view tmpl) {
    for (size_t i = 0; i < tmpl.size(); ++i) {
      const char ch = tmpl[i];
      if (ch == '@') {
        out += options.prefix;
      } else if (ch == '$') {
        const size_t end = tmpl.find('$', i + 1);
        out += value(tmpl.substr(i + 1, end - i - 1));
        i = end;
      } else {
        out += ch;
      }
    }
  }

  // Declares (unless the host does) the sampler of role `b` with GLSL type `type`.
  void sampler(const char* type, ShaderBinding b) {
    const GlslResource& r = options.resource(b);
    const std::string name = sampler_name(b);
    samplers.push_back(GlslSamplerUse{b, name, r.binding, r.set, r.declare});
    if (!r.declare) return;
    switch (target) {
      case GlslTarget::gl450_core:
        out += format_message("layout(binding = %u) uniform %s ", r.binding, type);
        break;
      case GlslTarget::vulkan450:
        out += format_message("layout(set = %u, binding = %u) uniform %s ", r.set, r.binding, type);
        break;
      case GlslTarget::es300:
        out += format_message("uniform highp %s ", type);
        break;  // no binding in ES
    }
    out += name + ";\n";
  }

  // `const <type> @<name> = <value>;`
  void constant(const char* type, const char* name, const std::string& v) {
    out += format_message("const %s %s%s = %s;\n", type, options.prefix.c_str(), name, v.c_str());
  }
  void constant_int(const char* name, uint32_t v) { constant("int", name, std::to_string(v)); }
  void constant_float(const char* name, uint32_t v) { constant("float", name, std::to_string(v) + ".0"); }
  void constant_uint(const char* name, uint32_t v) { constant("uint", name, std::to_string(v) + "u"); }
  void constant_bool(const char* name, bool v) { constant("bool", name, v ? "true" : "false"); }
  void constant_real(const char* name, float v) {
    constant("float", name, format_message("%.9e", static_cast<double>(v)));
  }
};

inline int angular_taps(const ShaderConfig& c) { return c.angular.lookup == AngularLookup::nearest ? 1 : 3; }

// Direction → unit square, twins of shader_direction_to_unit_square().
inline void piece_direction_map(GlslEmitter& e) {
  e.emit(
      "// Local direction (z = normal) -> unit square; directions below the horizon are clamped to it.\n"
      "vec2 @direction_map(vec3 d) {\n"
      "  d.z = max(d.z, 0.0);\n"
      "  float len = length(d);\n"
      "  if (!(len > 1e-20)) return vec2(0.5);\n"
      "  d /= len;\n");
  if (e.config.angular.parameterisation == DirectionParameterisation::parabolic) {
    e.emit("  return d.xy / (1.0 + d.z) * 0.5 + 0.5;  // parabolic map, paper 000 §4\n");
  } else {
    e.emit(
        "  // elevated concentric map (paper 002 §6.1): disk radius sqrt(1 - z), Shirley-Chiu inverse\n"
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
        "  return vec2(a, b) * 0.5 + 0.5;\n");
  }
  e.emit("}\n");
}

// Local frame (z = normal, both directions away from the surface; DESIGN.md).
inline void piece_local_frame(GlslEmitter& e) {
  e.emit(
      "// World-space normal, tangent (w = bitangent sign), unit vectors to the light and the eye\n"
      "// -> light and view directions in the local frame (t, b, n).\n"
      "void @local_dirs(vec3 normal, vec4 tangent, vec3 to_light, vec3 to_eye, out vec3 wl, out vec3 wv) {\n"
      "  vec3 n = normalize(normal);\n"
      "  vec3 t = normalize(tangent.xyz - n * dot(n, tangent.xyz));\n"
      "  vec3 b = cross(n, t) * (tangent.w < 0.0 ? -1.0 : 1.0);\n"
      "  wl = vec3(dot(to_light, t), dot(to_light, b), dot(to_light, n));\n"
      "  wv = vec3(dot(to_eye, t), dot(to_eye, b), dot(to_eye, n));\n"
      "}\n");
}

// Angular lookup: index + barycentric weight tables (paper 000 §4). table 0 = light, 1 = view.
inline void piece_angular(GlslEmitter& e) {
  e.sampler("usampler2DArray", ShaderBinding::angular_index);
  e.sampler("sampler2DArray", ShaderBinding::angular_weight);
  e.constant_int("kAngularRes", e.config.angular.resolution);
  e.constant_int("kAngularTaps", static_cast<uint32_t>(angular_taps(e.config)));
  e.emit(
      "ivec2 @angular_texel(vec3 d) {\n"
      "  return clamp(ivec2(floor(@direction_map(d) * float(@kAngularRes))), ivec2(0), ivec2(@kAngularRes - 1));\n"
      "}\n"
      "// The table's 3 direction indices and barycentric weights for d (table 0 = light, 1 = view).\n"
      "void @angular(int table, vec3 d, out ivec3 idx, out vec3 w) {\n"
      "  ivec2 texel = @angular_texel(d);\n"
      "  idx = ivec3(texelFetch($angular_index$, ivec3(texel, table), 0).xyz);\n"
      "  w = texelFetch($angular_weight$, ivec3(texel, table), 0).xyz;\n");
  if (e.config.angular.lookup == AngularLookup::nearest) {
    e.emit(
        "  // nearest: the first index with the largest weight\n"
        "  int k = 0;\n"
        "  if (w.y > w.x) k = 1;\n"
        "  if (w.z > w[k]) k = 2;\n"
        "  idx = ivec3(idx[k]);\n"
        "  w = vec3(1.0, 0.0, 0.0);\n");
  }
  e.emit(
      "}\n"
      "// The first index with the largest weight (nearest measured direction).\n"
      "int @angular_nearest(int table, vec3 d) {\n"
      "  ivec2 texel = @angular_texel(d);\n"
      "  ivec3 idx = ivec3(texelFetch($angular_index$, ivec3(texel, table), 0).xyz);\n"
      "  vec3 w = texelFetch($angular_weight$, ivec3(texel, table), 0).xyz;\n"
      "  int k = 0;\n"
      "  if (w.y > w.x) k = 1;\n"
      "  if (w.z > w[k]) k = 2;\n"
      "  return idx[k];\n"
      "}\n");
}

// D(s) of core/value_transform.hpp, applied to the sum of eq. 5 (the identity for linear).
inline void glsl_decode_value(GlslEmitter& e) {
  const ValueTransform& t = e.config.value_transform;
  if (t.uses_log_offset()) e.constant_real("kLogOffset", t.log_offset);
  e.emit(t.encoding == ValueEncoding::sqrt  ? "vec3 @decode_value(vec3 s) { return s * abs(s); }\n"
         : t.encoding == ValueEncoding::log ? "vec3 @decode_value(vec3 s) { return exp(s) - vec3(@kLogOffset); }\n"
         : t.encoding == ValueEncoding::log_ycbcr
             ? "// s = (ln(Y + eps), Cb / (Y + eps), Cr / (Y + eps)) summed; BT.601 YCbCr back to RGB.\n"
               "vec3 @decode_value(vec3 s) {\n"
               "  float w = exp(s.x);\n"
               "  float y = w - @kLogOffset, cb = s.y * w, cr = s.z * w;\n"
               "  return vec3(y + 1.402 * cr, y - 0.344136 * cb - 0.714136 * cr, y + 1.772 * cb);\n"
               "}\n"
             : "vec3 @decode_value(vec3 s) { return s; }\n");
}

// Σ_c U_c(ωl, ωv) · V_c(x), paper 000 eq. 5; U interpolated over 3 × 3 direction pairs (§4).
inline void piece_fmf_brdf(GlslEmitter& e) {
  e.sampler("sampler2DArray", ShaderBinding::eigen_abrdfs);
  e.constant_int("kFmfComponents", e.config.components);
  e.constant_int("kFmfGroups", e.config.component_groups());
  glsl_decode_value(e);
  e.emit(
      "// C_m of the drawn material ($component_count$; 0 or above kFmfComponents: kFmfComponents).\n"
      "int @component_count() {\n"
      "  int n = int($component_count$);\n"
      "  return (n <= 0 || n > @kFmfComponents) ? @kFmfComponents : n;\n"
      "}\n"
      "// Paper 000 eq. 5 for the component weights v (component c in v[c / 4][c % 4]), c < C_m.\n"
      "vec3 @fmf_brdf(vec4 v[@kFmfGroups], vec3 wl, vec3 wv) {\n"
      "  ivec3 il; vec3 al; ivec3 iv; vec3 av;\n"
      "  @angular(0, wl, il, al);\n"
      "  @angular(1, wv, iv, av);\n"
      "  vec3 rho = vec3(0.0);\n"
      "  int count = @component_count();\n"
      "  for (int c = 0; c < @kFmfComponents; ++c) {\n"
      "    if (c >= count) break;  // a per-draw uniform: every invocation leaves together\n"
      "    vec3 u = vec3(0.0);\n"
      "    for (int i = 0; i < @kAngularTaps; ++i) {\n"
      "      for (int j = 0; j < @kAngularTaps; ++j) {\n"
      "        float w = al[i] * av[j];\n"
      "        if (w > 0.0) u += w * texelFetch($eigen_abrdfs$, ivec3(il[i], iv[j], c), 0).rgb;\n"
      "      }\n"
      "    }\n"
      "    rho += u * v[c / 4][c % 4];\n"
      "  }\n"
      "  return @decode_value(rho);\n"
      "}\n");
}

// FMF: V from a hardware-filtered 2D array, 4 components per texel.
inline void piece_fmf(GlslEmitter& e) {
  e.sampler("sampler2DArray", ShaderBinding::eigen_textures);
  e.emit(
      "// Groups past the material's ⌈C_m/4⌉ are not fetched (zero).\n"
      "void @fmf_components(vec2 uv, out vec4 v[@kFmfGroups]) {\n"
      "  int groups = (@component_count() + 3) / 4;\n"
      "  for (int g = 0; g < @kFmfGroups; ++g) v[g] = g < groups ? texture($eigen_textures$, vec3(uv, float(g))) : "
      "vec4(0.0);\n"
      "}\n"
      "vec4 @fmf_raw(vec2 uv) { return texture($eigen_textures$, vec3(uv, 0.0)); }\n"
      "vec3 @fmf(vec2 uv, vec3 wl, vec3 wv) {\n"
      "  vec4 v[@kFmfGroups];\n"
      "  @fmf_components(uv, v);\n"
      "  return @fmf_brdf(v, wl, wv);\n"
      "}\n");
}

// Page-table addressing shared by the BSVTF lookup and the feedback word (paper 000 eq. 1–2).
inline void piece_page_table(GlslEmitter& e) {
  const VirtualTextureConfig& v = e.config.vt;
  e.sampler("usampler2DArray", ShaderBinding::page_table);
  e.constant_float("kTileSize", v.tile_size);
  e.constant_float("kBorder", v.border);
  e.constant_float("kPaddedTile", v.padded_tile_size());
  e.constant_uint("kSlotsX", v.slots_x);
  e.constant_uint("kSlotsPerLayer", v.slots_x * v.slots_y);
  e.constant("vec2", "kCacheSize", format_message("vec2(%u.0, %u.0)", v.cache_width(), v.cache_height()));
  e.emit(
      "int @vt_finest() { return int($vt_extent$.z); }\n"
      "// Desired continuous level, paper 000 eq. 1: l = L - log2 max(|dPi/dx|, |dPi/dy|), minus the LOD bias.\n"
      "// Uses derivatives: call in uniform control flow.\n"
      "float @vt_lambda(vec2 uv) {\n"
      "  vec2 tx = uv * $vt_extent$.xy;\n"
      "  vec2 dx = dFdx(tx);\n"
      "  vec2 dy = dFdy(tx);\n"
      "  float m = max(dot(dx, dx), dot(dy, dy));\n"
      "  return $vt_extent$.z - 0.5 * log2(max(m, 1e-20)) - $lod_bias$;\n"
      "}\n"
      "// Level-l texel coordinate of uv (uv in [0,1)), and the tile grid size at level l.\n"
      "vec2 @level_texel(vec2 uv, int level) { return uv * $vt_extent$.xy * exp2(float(level - @vt_finest())); }\n"
      "ivec2 @level_tiles(int level) { return max(ivec2(ceil($vt_extent$.xy * exp2(float(level - @vt_finest())) / "
      "@kTileSize)), ivec2(1)); }\n"
      "ivec2 @tile_of(vec2 uv, int level) {  // paper 000 eq. 2\n"
      "  return clamp(ivec2(floor(@level_texel(uv, level) / @kTileSize)), ivec2(0), @level_tiles(level) - 1);\n"
      "}\n"
      "// Tile (eq. 2) and in-tile offset at `level` of the finest-level texel coordinate `texel`.\n"
      "ivec2 @tile_at(vec2 texel, int level, out vec2 in_tile) {\n"
      "  vec2 s = texel * exp2(float(level - @vt_finest()));\n"
      "  ivec2 t = clamp(ivec2(floor(s / @kTileSize)), ivec2(0), @level_tiles(level) - 1);\n"
      "  in_tile = s - vec2(t) * @kTileSize;\n"
      "  return t;\n"
      "}\n"
      "// Page-table entry (pack_page_entry) of tile `tile` at `level` in page-table layer `layer`.\n"
      "uint @page_entry(int layer, ivec2 tile, int level) {\n"
      "  return texelFetch($page_table$, ivec3(tile, layer), @vt_finest() - level).x;\n"
      "}\n");
}

// BSVTF: V through page table and tile cache (paper 000 eq. 3).
inline void piece_bsvtf(GlslEmitter& e) {
  e.sampler("sampler2DArray", ShaderBinding::tile_cache);
  const bool affine = cache_format_has_slot_map(e.config.vt.format);
  const bool bc5 = e.config.vt.format == CacheFormat::bc5_affine;
  if (affine) {
    e.sampler("usampler2D", ShaderBinding::slot_map);
    e.constant_uint("kSlotsY", e.config.vt.slots_y);
  }
  e.constant_bool("kTrilinear", e.config.vt.trilinear);
  // Addressing (paper 000 eq. 2-3) is done once per fragment for the levels the blend can use
  // and shared by every RGBA group; per group: two page-table texels (level l1, and level l0 or
  // mip 0 — exclusive cases, one fetch with a selected address) and two cache fetches blended
  // with weight 0 when only one level applies. No branches: llvmpipe/lavapipe run both sides of
  // a branch under an execution mask, and a real GPU gains little from skipping one fetch
  // (docs/shaders.md, "BSVTF fragment cost").
  e.emit(
      "// One fragment's virtual-texture address: finest-level texel coordinate, the two blend levels\n"
      "// (l0 = floor(lambda), l1 = l0 + 1 clamped), their tiles (eq. 2) and in-tile offsets, and the\n"
      "// mip-0 tile (runtime/vt/tile_cache.hpp's table, the deepest resident tile).\n"
      "struct @VtSite {\n"
      "  vec2 texel; int finest; int l0; int l1; float w;\n"
      "  ivec2 tile0; ivec2 tile1; ivec2 tilef; vec2 in0; vec2 in1;\n"
      "};\n"
      "@VtSite @vt_site(vec2 uv, float lambda) {\n"
      "  @VtSite a;\n"
      "  a.texel = uv * $vt_extent$.xy;\n"
      "  a.finest = @vt_finest();\n"
      "  float l = clamp(lambda, 0.0, float(a.finest));\n"
      "  a.l0 = int(floor(l));\n"
      "  a.l1 = min(a.l0 + 1, a.finest);\n"
      "  a.w = l - float(a.l0);\n"
      "  a.tile0 = @tile_at(a.texel, a.l0, a.in0);\n"
      "  a.tile1 = @tile_at(a.texel, a.l1, a.in1);\n"
      "  vec2 unused;\n"
      "  a.tilef = @tile_at(a.texel, a.finest, unused);\n"
      "  return a;\n"
      "}\n"
      "// Paper 000 eq. 3: cache texel = slot origin + border + in-tile offset at the entry's level.\n"
      "vec4 @cache_sample(uint entry, vec2 in_tile) {\n"
      "  uint slot = entry & 0xFFFFFFu;\n"
      "  uint r = slot % @kSlotsPerLayer;\n"
      "  vec2 origin = vec2(float(r % @kSlotsX), float(r / @kSlotsX)) * @kPaddedTile + @kBorder;\n");
  if (bc5)  // runtime/vt/cache_bc5.hpp: plane p of cache layer L is array layer 2L + p, both at one coordinate
    e.emit(
        "  vec2 c = (origin + in_tile) / @kCacheSize;\n"
        "  float l = float(slot / @kSlotsPerLayer) * 2.0;\n"
        "  vec4 t = vec4(textureLod($tile_cache$, vec3(c, l), 0.0).xy, textureLod($tile_cache$, vec3(c, l + 1.0), "
        "0.0).xy);\n");
  else
    e.emit(
        "  vec4 t = textureLod($tile_cache$, vec3((origin + in_tile) / @kCacheSize, float(slot / @kSlotsPerLayer)), "
        "0.0);\n");
  // runtime/vt/cache_format.hpp: value = offset + scale · unorm, one map per slot (exact after filtering).
  // Its eight halves (0 or normal) are widened with integer operations and a multiply by 2^112
  // (the exponent rebias): on llvmpipe 2 % of the frame cheaper than unpackHalf2x16.
  if (affine)
    e.emit(
        "  uvec4 m = texelFetch($slot_map$, ivec2(int(r % @kSlotsX), int((slot / @kSlotsPerLayer) * @kSlotsY + "
        "r / @kSlotsX)), 0);\n"
        "  uvec4 a = uvec4(m.x, m.x >> 16u, m.y, m.y >> 16u), b = uvec4(m.z, m.z >> 16u, m.w, m.w >> 16u);\n"
        "  vec4 o = uintBitsToFloat(((a & 0x7FFFu) << 13u) | ((a & 0x8000u) << 16u)) * 5.192296858534828e33;\n"
        "  vec4 s = uintBitsToFloat(((b & 0x7FFFu) << 13u) | ((b & 0x8000u) << 16u)) * 5.192296858534828e33;\n"
        "  return o + s * t;\n");
  else
    e.emit("  return t;\n");
  e.emit(
      "}\n"
      "vec4 @vt_fetch(int layer, @VtSite a) {\n"
      "  uint e1 = texelFetch($page_table$, ivec3(a.tile1, layer), a.finest - a.l1).x;\n"
      "  bool have1 = int(e1 >> 24u) == a.l1;\n"
      "  // One second page-table texel serves both exclusive cases: tile l0 (trilinear, when tile l1\n"
      "  // is resident) or mip 0 (tile l1 missing). Fetched unconditionally: SIMD rasterisers such as\n"
      "  // llvmpipe run both sides of a branch under a mask, so two fetches in two branches cost two.\n"
      "  uint e2 = texelFetch($page_table$, ivec3(have1 ? a.tile0 : a.tilef, layer), have1 ? a.finest - a.l0 : 0).x;\n"
      "  // Selects, not branches (the same masking reason). Trilinear across levels when tile l0 is\n"
      "  // resident too (weight 0: level l0 alone). Tile l1 missing: mip 0 holds the deepest resident\n"
      "  // tile (runtime/vt/tile_cache.hpp's table); it is finer than l1 when the cache dropped ancestors hidden\n"
      "  // by resident children. Either way the first sample is at the level of its entry.\n"
      "  bool tri = @kTrilinear && have1 && a.l1 != a.l0 && int(e2 >> 24u) == a.l0;\n"
      "  uint e = (tri || (!have1 && (e2 >> 24u) > (e1 >> 24u))) ? e2 : e1;  // the entry sampled first\n"
      "  vec2 in_tile;\n"
      "  @tile_at(a.texel, int(e >> 24u), in_tile);\n"
      "  // Level l1 blended over it with weight w; w = 0 leaves the first sample exact (finite texels).\n"
      "  return mix(@cache_sample(e, in_tile), @cache_sample(e1, a.in1), tri ? a.w : 0.0);\n"
      "}\n"
      "// Component groups of the material whose group 0 is page-table layer $first_layer$.\n"
      "// Uses derivatives (@vt_lambda): call in uniform control flow.\n"
      "void @bsvtf_components(vec2 uv, out vec4 v[@kFmfGroups]) {\n"
      "  @VtSite site = @vt_site(fract(uv), @vt_lambda(uv));\n"
      "  int groups = (@component_count() + 3) / 4;  // the material's layers; none of another's is read\n"
      "  for (int g = 0; g < @kFmfGroups; ++g) v[g] = g < groups ? @vt_fetch(int($first_layer$) + g, site) : "
      "vec4(0.0);\n"
      "}\n"
      "vec4 @bsvtf_raw(vec2 uv) { return @vt_fetch(int($first_layer$), @vt_site(fract(uv), @vt_lambda(uv))); }\n"
      "vec3 @bsvtf(vec2 uv, vec3 wl, vec3 wv) {\n"
      "  vec4 v[@kFmfGroups];\n"
      "  @bsvtf_components(uv, v);\n"
      "  return @fmf_brdf(v, wl, wv);\n"
      "}\n");
}

inline void piece_feedback(GlslEmitter& e) {
  const FeedbackWordLayout& f = e.config.vt.feedback;
  e.emit(
      "// Packed feedback word (paper 000 eq. 1-2; FeedbackWordLayout, pack_feedback_word) of uv at\n"
      "// continuous level `lambda` (@vt_lambda at the resolution of the pass) for texture $texture_id$.\n"
      "uint @feedback_word_at(vec2 uv, float lambda) {\n"
      "  // request the finest level the renderer blends in (ceil), tolerant of float noise\n");
  e.out += format_message("  int level = clamp(int(ceil(lambda - 1e-3)), 0, min(%svt_finest(), %u));\n",
                          e.options.prefix.c_str(), f.max_level());
  e.emit("  uvec2 tile = uvec2(@tile_of(fract(uv), level));  // paper 000 eq. 2\n");
  const std::string id = e.value("texture_id");
  e.out += format_message(
      "  return ((tile.x & %uu) << %uu) | ((tile.y & %uu) << %uu) | ((uint(level) & %uu) << %uu)"
      " | ((uint(%s) & %uu) << %uu);\n",
      detail::low_mask(f.x_bits), f.x_shift, detail::low_mask(f.y_bits), f.y_shift, detail::low_mask(f.level_bits),
      f.level_shift, id.c_str(), detail::low_mask(f.texture_bits), f.texture_shift);
  e.emit(
      "}\n"
      "// The word of a feedback pass: uses derivatives, call in uniform control flow.\n"
      "uint @feedback_word(vec2 uv) {\n"
      "  // log2(screen / feedback size): derivatives in a smaller feedback pass are that much larger.\n"
      "  return @feedback_word_at(uv, @vt_lambda(uv) + $feedback_lod_offset$);\n"
      "}\n");
}

// Laplacian-pyramid PCA with continuous range-based LOD, paper 001 eq. 7.
inline void piece_laplacian(GlslEmitter& e) {
  e.sampler("sampler2DArray", ShaderBinding::laplacian_eigen);
  e.sampler("sampler2DArray", ShaderBinding::laplacian_weights);
  e.sampler("sampler2D", ShaderBinding::laplacian_mean);
  e.constant_int("kLaplacianComponents", e.config.components);
  e.constant_int("kLaplacianMaxLevel", e.config.laplacian.max_level);
  e.constant_bool("kLaplacianYCbCr", e.config.laplacian.ycbcr_output);
  e.emit(
      "// Range-based LOD (paper 001 §3.4 step 2): lambda = min(lambda_max, max(log2(d), 0)), d scaled.\n"
      "float @laplacian_lambda(float distance_to_eye) {\n"
      "  float d = distance_to_eye * $range_lod_scale$;\n"
      "  return clamp(log2(max(d, 1e-20)), 0.0, float(@kLaplacianMaxLevel));\n"
      "}\n"
      "vec3 @laplacian(vec2 uv, vec3 wl, vec3 wv, float lambda) {\n"
      "  // paper 001 §3.4 step 1: nearest light and view direction\n"
      "  ivec2 lv = ivec2(@angular_nearest(0, wl), @angular_nearest(1, wv));\n"
      "  vec3 acc = texelFetch($laplacian_mean$, lv, 0).rgb;  // mu'_lambda_max\n"
      "  // D_k is stored per pyramid texel (paper 001 §3.3): level k's texel is the finest texel >> k\n"
      "  ivec2 size0 = textureSize($laplacian_weights$, 0).xy;\n"
      "  ivec2 t0 = clamp(ivec2(fract(uv) * vec2(size0)), ivec2(0), size0 - 1);\n"
      "  for (int k = 0; k <= @kLaplacianMaxLevel; ++k) {\n"
      "    float wk = clamp(1.0 - lambda + float(k), 0.0, 1.0);  // paper 001 eq. 7 weight w_k\n"
      "    if (wk <= 0.0) continue;\n"
      "    ivec2 tk = min(t0 >> k, textureSize($laplacian_weights$, k).xy - 1);\n"
      "    for (int j = 0; j < @kLaplacianComponents; j += 4) {\n"
      "      vec4 d = texelFetch($laplacian_weights$, ivec3(tk, j / 4), k);\n"
      "      for (int q = 0; q < 4 && j + q < @kLaplacianComponents; ++q)\n"
      "        acc += wk * d[q] * texelFetch($laplacian_eigen$, ivec3(lv, k * @kLaplacianComponents + j + q), 0).rgb;\n"
      "    }\n"
      "  }\n"
      "  if (@kLaplacianYCbCr) acc = vec3(acc.x + 1.402 * acc.z, acc.x - 0.344136 * acc.y - 0.714136 * acc.z,"
      " acc.x + 1.772 * acc.y);\n"
      "  return acc;\n"
      "}\n");
}

// Local PCA with the 3D-texture layout and one manual lerp, paper 002 §6.2.
inline void piece_lpca(GlslEmitter& e) {
  e.sampler("usampler2D", ShaderBinding::lpca_cluster);
  e.sampler("sampler2DArray", ShaderBinding::lpca_weights);
  e.sampler("sampler3D", ShaderBinding::lpca_volume);
  e.constant_int("kLpcaComponents", e.config.components);
  e.constant_float("kLpcaClusters", e.config.lpca.clusters);
  e.constant_float("kLpcaGrid", e.config.lpca.grid_resolution);
  e.emit(
      "// Grid coordinate s in [0,1] sampled at i/(R-1) -> texel centre inside a cell of R texels.\n"
      "float @lpca_cell(float s) { return (0.5 + clamp(s, 0.0, 1.0) * (@kLpcaGrid - 1.0)) / @kLpcaGrid; }\n"
      "vec3 @lpca(vec2 uv, vec3 wl, vec3 wv) {\n"
      "  vec2 sv = @direction_map(wv);\n"
      "  vec2 sl = @direction_map(wl);\n"
      "  ivec2 size = textureSize($lpca_cluster$, 0);\n"
      "  ivec2 texel = clamp(ivec2(fract(uv) * vec2(size)), ivec2(0), size - 1);\n"
      "  float k = float(texelFetch($lpca_cluster$, texel, 0).x);\n"
      "  // paper 002 §6.2: t_l discretised at i/(R-1); one manual lerp between slabs i and i+1\n"
      "  float tl = clamp(sl.y, 0.0, 1.0) * (@kLpcaGrid - 1.0);\n"
      "  float i0 = min(floor(tl), @kLpcaGrid - 1.0);\n"
      "  float i1 = min(i0 + 1.0, @kLpcaGrid - 1.0);\n"
      "  float w = tl - i0;\n"
      "  float y = (k + @lpca_cell(sv.y)) / @kLpcaClusters;\n"
      "  float z1 = (i0 + @lpca_cell(sl.x)) / @kLpcaGrid;\n"
      "  float z2 = (i1 + @lpca_cell(sl.x)) / @kLpcaGrid;\n"
      "  vec3 acc = vec3(0.0);\n"
      "  for (int j = 0; j <= @kLpcaComponents; ++j) {\n"
      "    // j = 0 is the cluster mean; paper 002 §6.3: the 8-bit scales are folded into the weights\n"
      "    float alpha = texelFetch($lpca_weights$, ivec3(texel, j / 4), 0)[j % 4];\n"
      "    float x = (float(j) + @lpca_cell(sv.x)) / float(@kLpcaComponents + 1);\n"
      "    vec3 e = mix(texture($lpca_volume$, vec3(x, y, z1)).rgb, texture($lpca_volume$, vec3(x, y, z2)).rgb, w);\n"
      "    acc += alpha * e;\n"
      "  }\n"
      "  return acc;\n"
      "}\n");
}

// PCA over groups of k views, L = [m | UΣ], R = [1; Vᵀ], paper 004 §6.3: samplers and constants.
inline void pca_views_declarations(GlslEmitter& e) {
  e.sampler("sampler2DArray", ShaderBinding::pca_l);
  e.sampler("sampler2D", ShaderBinding::pca_r);
  // L = [m | UΣ] holds one scalar per texel and component (paper 004 §4.3.2: red(x, y) =
  // Σ_k L_{xy,k} R_{k,3i}); the colour lives in R. 4 components of L per RGBA texel.
  e.constant_int("kPcaComponents", e.config.components);
  e.constant_int("kPcaViewsPerGroup", e.config.pca.views_per_group);
  e.constant_int("kPcaLightCount", e.config.pca.light_count);
  e.constant_int("kPcaLayers", (e.config.components + 4) / 4);
}

// The PCA-k evaluation `vec3 @<name>(uv, wl, wv)` with the direction lookup `lookup` (a function
// (int table, vec3 d, out ivec3 idx, out vec3 w)) and `taps` (GLSL expression) taps per direction.
inline void pca_views_function(GlslEmitter& e, std::string_view name, std::string_view lookup, std::string_view taps) {
  std::string t =
      "// paper 004 §4.4: 3 closest directions with barycentric weights\n"
      "vec3 @NAME(vec2 uv, vec3 wl, vec3 wv) {\n"
      "  ivec3 il; vec3 al; ivec3 iv; vec3 av;\n"
      "  LOOKUP(0, wl, il, al);\n"
      "  LOOKUP(1, wv, iv, av);\n"
      "  ivec2 size = textureSize($pca_l$, 0).xy;\n"
      "  ivec2 texel = clamp(ivec2(fract(uv) * vec2(size)), ivec2(0), size - 1);  // paper 004 §6.3: i = floor(u N)\n"
      "  vec3 acc = vec3(0.0);\n"
      "  for (int j = 0; j < TAPS; ++j) {\n"
      "    int view = iv[j];\n"
      "    int base = (view / @kPcaViewsPerGroup) * @kPcaLayers;  // PCA group b of k views\n"
      "    vec4 lc[@kPcaLayers];  // L = [m | U Sigma] of this texel, component c in lc[c / 4][c % 4]\n"
      "    for (int g = 0; g < @kPcaLayers; ++g) lc[g] = texelFetch($pca_l$, ivec3(texel, base + g), 0);\n"
      "    for (int i = 0; i < TAPS; ++i) {\n"
      "      float w = al[i] * av[j];\n"
      "      if (w <= 0.0) continue;\n"
      "      int row = il[i] + @kPcaLightCount * view;\n"
      "      vec3 val = vec3(lc[0].x);  // R = [1; V^T]: the mean has weight 1\n"
      "      for (int c = 1; c <= @kPcaComponents; ++c)\n"
      "        val += lc[c / 4][c % 4] * texelFetch($pca_r$, ivec2(c - 1, row), 0).rgb;  // paper 004 §4.3.2\n"
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

inline void piece_pca_views(GlslEmitter& e) {
  pca_views_declarations(e);
  pca_views_function(e, "pca_views", "@angular", "@kAngularTaps");
}

// SPMM: sparse mixture of analytic basis functions plus a clustered-PCA residual, paper 003
// eq. 1–3. Per fragment: the texel's slots (one RGBA32UI texel each, adjacent fragments read
// adjacent texels of one layer), two dictionary texels per occupied slot (scattered: the index
// is data), the residual layer(s) of the texel and 3 × 3 × (1 + n) residual-table texels.
inline void piece_spmm(GlslEmitter& e) {
  e.sampler("usampler2DArray", ShaderBinding::spmm_texels);
  e.sampler("sampler2D", ShaderBinding::spmm_dictionary);
  e.sampler("sampler2DArray", ShaderBinding::spmm_residual);
  e.constant_int("kSpmmSlots", e.config.spmm.slots);
  e.constant_int("kSpmmResidualComponents", e.config.spmm.residual_components);
  e.constant_int("kSpmmBasesPerRow", kSpmmBasesPerRow);
  e.emit(
      "// f_j(kappa, wi, wo) of offline/factor/analytic_brdf.hpp, both directions in the basis frame (paper 003 §3).\n"
      "float @spmm_brdf(int model, vec3 kappa, vec3 wi, vec3 wo) {\n"
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
      "    vec3 h = wi + wo;\n"
      "    float len = length(h);\n"
      "    if (len <= 0.0) return 0.0;\n"
      "    return (kappa.x + 8.0) * (inv_pi / 8.0) * pow(max(h.z / len, 0.0), kappa.x);\n"
      "  }\n"
      "  if (model == 3) {  // Ward, anisotropic Gaussian\n"
      "    vec3 h = wi + wo;\n"
      "    float ex = (h.x * h.x / (kappa.x * kappa.x) + h.y * h.y / (kappa.y * kappa.y)) / (h.z * h.z);\n"
      "    return exp(-ex) / (4.0 * 3.14159265 * kappa.x * kappa.y * sqrt(wi.z * wo.z));\n"
      "  }\n"
      "  if (model == 4) {  // Cook-Torrance: Beckmann D, Schlick F, V-cavity G\n"
      "    vec3 h = normalize(wi + wo);\n"
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
      "    vec3 h = normalize(wi + wo);\n"
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
      "float @spmm_basis(int g, vec3 wl, vec3 wv) {\n"
      "  ivec2 at = ivec2(2 * (g % @kSpmmBasesPerRow), g / @kSpmmBasesPerRow);\n"
      "  vec4 p = texelFetch($spmm_dictionary$, at, 0);  // model id, kappa_j\n"
      "  vec3 n = texelFetch($spmm_dictionary$, at + ivec2(1, 0), 0).xyz;  // n_j\n"
      "  float k = 1.0 / (1.0 + n.z);\n"
      "  vec3 t = vec3(1.0 - n.x * n.x * k, -n.x * n.y * k, -n.x);\n"
      "  vec3 b = vec3(-n.x * n.y * k, 1.0 - n.y * n.y * k, -n.y);\n"
      "  vec3 li = vec3(dot(wl, t), dot(wl, b), dot(wl, n));\n"
      "  vec3 lo = vec3(dot(wv, t), dot(wv, b), dot(wv, n));\n"
      "  return @spmm_brdf(int(p.x), p.yzw, li, lo) * max(li.z, 0.0);\n"
      "}\n"
      "// Paper 003 eq. 1 without the residual: sum over the texel's occupied slots of alpha_j rho_j.\n"
      "vec3 @spmm_analytic(ivec2 texel, vec3 wl, vec3 wv) {\n"
      "  vec3 acc = vec3(0.0);\n"
      "  for (int k = 0; k < @kSpmmSlots; ++k) {\n"
      "    uvec4 s = texelFetch($spmm_texels$, ivec3(texel, k), 0);  // x = basis, yzw = alpha (float bits)\n"
      "    if (s.x == 0xFFFFFFFFu) break;  // occupied slots come first\n"
      "    acc += @spmm_basis(int(s.x), wl, wv) * uintBitsToFloat(s.yzw);\n"
      "  }\n"
      "  return acc;\n"
      "}\n"
      "// Paper 003 eq. 3: eps = mean + sum_{i < n_pca} coef_i(t) b_i(c), each read at the 3 x 3 measured\n"
      "// direction pairs of the angular tables and blended with their barycentric weights.\n"
      "vec3 @spmm_epsilon(ivec2 texel, vec3 wl, vec3 wv, int n_pca) {\n"
      "  int n = clamp(n_pca, 0, @kSpmmResidualComponents);\n"
      "  uvec4 cf[(@kSpmmResidualComponents + 4) / 4];  // [cluster, coef_0 bits, coef_1 bits, ...]\n"
      "  for (int g = 0; g <= n / 4; ++g) cf[g] = texelFetch($spmm_texels$, ivec3(texel, @kSpmmSlots + g), 0);\n"
      "  int base = int(cf[0].x) * (@kSpmmResidualComponents + 1);\n"
      "  ivec3 il; vec3 al; ivec3 iv; vec3 av;\n"
      "  @angular(0, wl, il, al);\n"
      "  @angular(1, wv, iv, av);\n"
      "  vec3 acc = vec3(0.0);\n"
      "  for (int j = 0; j < @kAngularTaps; ++j) {\n"
      "    for (int i = 0; i < @kAngularTaps; ++i) {\n"
      "      float w = al[i] * av[j];\n"
      "      if (w <= 0.0) continue;\n"
      "      ivec2 lv = ivec2(il[i], iv[j]);\n"
      "      vec3 e = texelFetch($spmm_residual$, ivec3(lv, base), 0).rgb;  // mean of cluster c\n"
      "      for (int q = 1; q <= n; ++q)\n"
      "        e += uintBitsToFloat(cf[q / 4][q % 4]) * texelFetch($spmm_residual$, ivec3(lv, base + q), 0).rgb;\n"
      "      acc += w * e;\n"
      "    }\n"
      "  }\n"
      "  return acc;\n"
      "}\n"
      "// Paper 003 eq. 1 at texel floor(fract(uv) (W, H)); $spmm_mode$ = spmm_residual_mode(): 0 = every\n"
      "// stored component, 1 = no residual (paper 003 §5.2), 2 + n = n components.\n"
      "vec3 @spmm(vec2 uv, vec3 wl, vec3 wv) {\n"
      "  ivec2 size = textureSize($spmm_texels$, 0).xy;\n"
      "  ivec2 texel = clamp(ivec2(fract(uv) * vec2(size)), ivec2(0), size - 1);\n"
      "  vec3 rho = @spmm_analytic(texel, wl, wv);\n"
      "  uint mode = uint($spmm_mode$);\n"
      "  if (mode == 1u) return rho;\n"
      "  return rho + @spmm_epsilon(texel, wl, wv, mode == 0u ? @kSpmmResidualComponents : int(mode) - 2);\n"
      "}\n");
}

// Ring search over ring-sampled direction sets held in a uniform block, paper 004 §4.4: the
// bracketing rings and, on each, the azimuth neighbours A, B (lower) and C, D (upper); triangle
// ABC when P is closer to A than to D (§4.4.1's d′), else BCD, pole-C-D above the pole; weights
// are the tetrahedron volumes |det(P, P_j, P_k)| normalised (§4.4.2); beyond the last ring (or
// below the first of a set without pole) linear in φ on that ring. Same arithmetic as
// RingSearchInterpolator::query (offline/angular/ring_search.hpp); table 0 = light, 1 = view.
inline void piece_ring_search(GlslEmitter& e) {
  e.constant_int("kRingMax", kRingSearchMaxRings);
  e.constant_int("kRingSlots", kRingSearchMaxSlots);
  const GlslResource& r = e.options.resource(ShaderBinding::direction_rings);
  // With declare = false the host declares the same block itself (same member names).
  if (r.declare) {
    switch (e.target) {
      case GlslTarget::gl450_core:
        e.out += format_message("layout(std140, binding = %u) uniform ", r.binding);
        break;
      case GlslTarget::vulkan450:
        e.out += format_message("layout(std140, set = %u, binding = %u) uniform ", r.set, r.binding);
        break;
      case GlslTarget::es300:
        e.out += "layout(std140) uniform ";
        break;
    }
    e.emit(
        "@DirectionRings {\n"
        "  vec4 @rings[2 * @kRingMax];          // table t, ring r at t * kRingMax + r: theta, phi0, n, slot 0\n"
        "  uvec4 @ring_slots[@kRingSlots / 2];  // table t, slot s at t * kRingSlots + s: direction index\n"
        "  ivec4 @ring_counts;                  // x: light rings, y: view rings\n"
        "};\n");
  }
  e.emit(
      "uint @ring_slot(int table, float slot) {\n"
      "  int i = table * @kRingSlots + int(slot);\n"
      "  return @ring_slots[i / 4][i % 4];\n"
      "}\n"
      "vec3 @ring_dir(vec4 ring, float k) {\n"
      "  float phi = ring.y + k * 6.28318530718 / max(ring.z, 1.0);\n"
      "  return vec3(sin(ring.x) * cos(phi), sin(ring.x) * sin(phi), cos(ring.x));\n"
      "}\n"
      "// Azimuth neighbours k, k + 1 (mod count) of phi on a ring (paper 004: f^l, f^u) and the fraction.\n"
      "void @ring_neighbours(vec4 ring, float phi, out float lo, out float hi, out float frac) {\n"
      "  if (ring.z <= 1.0) { lo = 0.0; hi = 0.0; frac = 0.0; return; }\n"
      "  float dphi = 6.28318530718 / ring.z;\n"
      "  float rel = phi - ring.y;\n"
      "  rel = (rel - 6.28318530718 * floor(rel / 6.28318530718)) / dphi;\n"
      "  lo = min(floor(rel), ring.z - 1.0);\n"
      "  frac = clamp(rel - lo, 0.0, 1.0);\n"
      "  hi = lo + 1.0 >= ring.z ? 0.0 : lo + 1.0;\n"
      "}\n"
      "void @ring_search(int table, vec3 d, out ivec3 idx, out vec3 w) {\n"
      "  float len = length(d);\n"
      "  vec3 p = len > 0.0 ? d / len : vec3(0.0, 0.0, 1.0);\n"
      "  if (p.z < 0.0) p = length(p.xy) > 0.0 ? vec3(normalize(p.xy), 0.0) : vec3(0.0, 0.0, 1.0);\n"
      "  float theta = acos(clamp(p.z, -1.0, 1.0));\n"
      "  float phi = (p.x == 0.0 && p.y == 0.0) ? 0.0 : atan(p.y, p.x);\n"
      "  int n = table == 0 ? @ring_counts.x : @ring_counts.y;\n"
      "  int base = table * @kRingMax;\n"
      "  int upper = 0;  // first ring above theta (rings sorted by theta)\n"
      "  for (int r = 0; r < @kRingMax; ++r)\n"
      "    if (r < n && @rings[base + r].x <= theta) upper = r + 1;\n"
      "  float a; float b; float c; float dd; float f;\n"
      "  if (upper == n || upper == 0) {  // beyond the last ring (or below the first): linear in phi\n"
      "    vec4 ring = @rings[base + (upper == 0 ? 0 : n - 1)];\n"
      "    @ring_neighbours(ring, phi, a, b, f);\n"
      "    int ia = int(@ring_slot(table, ring.w + a));\n"
      "    idx = ivec3(ia, int(@ring_slot(table, ring.w + b)), ia);\n"
      "    w = vec3(1.0 - f, f, 0.0);\n"
      "    return;\n"
      "  }\n"
      "  vec4 rl = @rings[base + upper - 1];\n"
      "  vec4 ru = @rings[base + upper];\n"
      "  @ring_neighbours(rl, phi, a, b, f);\n"
      "  @ring_neighbours(ru, phi, c, dd, f);\n"
      "  vec3 pa = @ring_dir(rl, a); vec3 pb = @ring_dir(rl, b);\n"
      "  vec3 pc = @ring_dir(ru, c); vec3 pd = @ring_dir(ru, dd);\n"
      "  uint sa = @ring_slot(table, rl.w + a); uint sb = @ring_slot(table, rl.w + b);\n"
      "  uint sc = @ring_slot(table, ru.w + c); uint sd = @ring_slot(table, ru.w + dd);\n"
      "  vec3 p1; vec3 p2; vec3 p3;\n"
      "  if (rl.z <= 1.0) { p1 = pa; p2 = pc; p3 = pd; idx = ivec3(uvec3(sa, sc, sd)); }  // pole-C-D\n"
      "  else if (dot(p, pa) >= dot(p, pd)) { p1 = pa; p2 = pb; p3 = pc; idx = ivec3(uvec3(sa, sb, sc)); }  // d'\n"
      "  else { p1 = pb; p2 = pc; p3 = pd; idx = ivec3(uvec3(sb, sc, sd)); }\n"
      "  // paper 004 §4.4.2: |det(P, P_j, P_k)| (the 4 x 4 determinant with O is a triple product)\n"
      "  vec3 v = vec3(abs(dot(p, cross(p2, p3))), abs(dot(p, cross(p3, p1))), abs(dot(p, cross(p1, p2))));\n"
      "  float sum = v.x + v.y + v.z;\n"
      "  w = sum > 0.0 ? v / sum : vec3(1.0, 0.0, 0.0);\n"
      "}\n");
}

// PCA over groups of k views (pca_views' layout and arithmetic) with the ring search of the
// uniform block instead of the angular tables, paper 004 §6.3 with §4.4.
inline void piece_pca_rings(GlslEmitter& e) {
  bool declared = false;  // pca_views in the same generation already declared L, R and the constants
  for (const GlslSamplerUse& u : e.samplers) declared = declared || u.role == ShaderBinding::pca_l;
  if (!declared) pca_views_declarations(e);
  pca_views_function(e, "pca_rings", "@ring_search", "3");
}

/// One row per piece: the pieces it calls (emitted before it) and its emitter.
struct GlslPieceRecipe {
  GlslPiece piece;
  GlslPieceSet needs;
  void (*emit)(GlslEmitter&);
};

inline constexpr GlslPieceRecipe kPieces[] = {
    {GlslPiece::direction_map, 0, piece_direction_map},
    {GlslPiece::local_frame, 0, piece_local_frame},
    {GlslPiece::angular, piece_bit(GlslPiece::direction_map), piece_angular},
    {GlslPiece::fmf_brdf, piece_bit(GlslPiece::angular), piece_fmf_brdf},
    {GlslPiece::fmf, piece_bit(GlslPiece::fmf_brdf), piece_fmf},
    {GlslPiece::page_table, 0, piece_page_table},
    {GlslPiece::bsvtf, piece_bit(GlslPiece::page_table) | piece_bit(GlslPiece::fmf_brdf), piece_bsvtf},
    {GlslPiece::feedback, piece_bit(GlslPiece::page_table), piece_feedback},
    {GlslPiece::laplacian, piece_bit(GlslPiece::angular), piece_laplacian},
    {GlslPiece::lpca, piece_bit(GlslPiece::direction_map), piece_lpca},
    {GlslPiece::pca_views, piece_bit(GlslPiece::angular), piece_pca_views},
    {GlslPiece::spmm, piece_bit(GlslPiece::angular), piece_spmm},
    {GlslPiece::ring_search, 0, piece_ring_search},
    {GlslPiece::pca_rings, piece_bit(GlslPiece::ring_search), piece_pca_rings},
};
static_assert(std::size(kPieces) == kGlslPieceCount, "one recipe per GlslPiece, in enum order");

/// `wanted` closed under `needs`.
inline GlslPieceSet close_pieces(GlslPieceSet wanted) {
  for (bool changed = true; changed;) {
    changed = false;
    for (const GlslPieceRecipe& r : kPieces)
      if ((wanted & piece_bit(r.piece)) && (wanted | r.needs) != wanted) {
        wanted |= r.needs;
        changed = true;
      }
  }
  return wanted;
}

inline bool glsl_identifier(std::string_view s) {
  if (s.empty() || s.size() > 64) return false;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    const bool alpha = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
    if (!alpha && !(i > 0 && c >= '0' && c <= '9')) return false;
  }
  return s.substr(0, 3) != "gl_" && s.find("__") == std::string_view::npos;
}

// An expression pasted into the functions: one line, no statement or block separators, no
// preprocessor, balanced parentheses/brackets, bounded length.
inline bool glsl_expression(std::string_view s) {
  if (s.empty() || s.size() > 256) return false;
  int depth = 0;
  for (char c : s) {
    if (c == ';' || c == '{' || c == '}' || c == '#' || c == '\n' || c == '\r' || c == '@' || c == '$' || c == '\\' ||
        c == '"' || static_cast<unsigned char>(c) < 0x20)
      return false;
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if (depth < 0) return false;
  }
  return depth == 0;
}

// Which uniform sources and samplers each piece reads (for validation of what is used).
inline VoidResult validate_function_options(GlslPieceSet pieces, const GlslFunctionOptions& o) {
  if (!glsl_identifier(o.prefix))
    return make_error(
        Status::invalid_argument,
        "generate_functions: prefix \"%s\" is not a GLSL identifier start (letters, digits, _; not gl_, no "
        "__, at most 64 characters)",
        o.prefix.c_str());
  const struct {
    const std::string* expr;
    const char* what;
    GlslPieceSet used_by;
    bool may_be_empty = false;  // empty: the generator's own value (component_count: the program's C)
  } sources[] = {
      {&o.uniforms.vt_extent, "vt_extent", piece_bit(GlslPiece::page_table)},
      {&o.uniforms.lod_bias, "lod_bias", piece_bit(GlslPiece::page_table)},
      {&o.uniforms.feedback_lod_offset, "feedback_lod_offset", piece_bit(GlslPiece::feedback)},
      {&o.uniforms.range_lod_scale, "range_lod_scale", piece_bit(GlslPiece::laplacian)},
      {&o.uniforms.first_layer, "first_layer", piece_bit(GlslPiece::bsvtf)},
      {&o.uniforms.texture_id, "texture_id", piece_bit(GlslPiece::feedback)},
      {&o.uniforms.spmm_mode, "spmm_mode", piece_bit(GlslPiece::spmm)},
      {&o.uniforms.component_count, "component_count", piece_bit(GlslPiece::fmf_brdf), true},
  };
  for (const auto& s : sources)
    if ((pieces & s.used_by) && !glsl_expression(*s.expr) && !(s.may_be_empty && s.expr->empty()))
      return make_error(Status::invalid_argument,
                        "generate_functions: uniform source %s = \"%.80s\" is not a one-line GLSL expression "
                        "(non-empty, at most 256 characters, balanced brackets, none of ; { } # @ $ \\ \")",
                        s.what, s.expr->c_str());
  for (uint32_t i = 1; i < kShaderBindingCount; ++i) {
    const GlslResource& r = o.resources[i];
    if (!r.name.empty() && (r.declare ? !glsl_identifier(r.name) : !glsl_expression(r.name)))
      return make_error(Status::invalid_argument, "generate_functions: %s name \"%.80s\" is not a %s",
                        shader_binding_name(static_cast<ShaderBinding>(i)), r.name.c_str(),
                        r.declare ? "GLSL identifier" : "GLSL expression");
    if (r.binding > 65535 || r.set > 31)
      return make_error(Status::invalid_argument, "generate_functions: %s binding %u set %u, expected ≤ 65535, ≤ 31",
                        shader_binding_name(static_cast<ShaderBinding>(i)), r.binding, r.set);
  }
  return {};
}

inline VoidResult check_sampler_uses(GlslTarget target, const std::vector<GlslSamplerUse>& used) {
  for (size_t i = 0; i < used.size(); ++i)
    for (size_t j = 0; j < i; ++j) {
      const GlslSamplerUse& a = used[i];
      const GlslSamplerUse& b = used[j];
      if (a.declared && b.declared && a.name == b.name)
        return make_error(Status::invalid_argument, "generate_functions: samplers %s and %s share the name %s",
                          shader_binding_name(a.role), shader_binding_name(b.role), a.name.c_str());
      const bool same_point = a.binding == b.binding && (target != GlslTarget::vulkan450 || a.set == b.set);
      if (a.declared && b.declared && same_point)
        return make_error(Status::invalid_argument, "generate_functions: samplers %s and %s share binding %u (set %u)",
                          shader_binding_name(a.role), shader_binding_name(b.role), a.binding, a.set);
    }
  return {};
}

}  // namespace detail

Result<GlslFunctionSource> generate_functions(uint32_t pieces, GlslTarget target, const ShaderConfig& config,
                                              const GlslFunctionOptions& options) {
  if (VoidResult v = validate_shader_config(config); !v) return v.error();
  if (pieces == 0 || (pieces >> kGlslPieceCount) != 0)
    return make_error(Status::invalid_argument,
                      "generate_functions: piece set 0x%x, expected a non-empty glsl_pieces() set", pieces);
  const detail::GlslPieceSet all = detail::close_pieces(pieces);
  if (VoidResult v = detail::validate_function_options(all, options); !v) return v.error();
  GlslFunctionSource out;
  detail::GlslEmitter e{target, config, options, out.code, out.samplers};
  for (const detail::GlslPieceRecipe& r : detail::kPieces)
    if (all & detail::piece_bit(r.piece)) r.emit(e);
  if (VoidResult v = detail::check_sampler_uses(target, out.samplers); !v) return v.error();
  return out;
}

namespace detail {

/// How a whole program is assembled: the piece whose function main() calls, whether it has the
/// raw-component debug view (ids.z == 1), and extra arguments after (uv, wl, wv).
struct GlslProgramRecipe {
  ShaderProgram program;
  GlslPiece piece;
  bool raw_view;
  const char* extra_args;
};

inline constexpr GlslProgramRecipe kProgramRecipes[] = {
    {ShaderProgram::fmf, GlslPiece::fmf, true, ""},
    {ShaderProgram::bsvtf, GlslPiece::bsvtf, true, ""},
    {ShaderProgram::feedback, GlslPiece::feedback, false, ""},
    {ShaderProgram::laplacian, GlslPiece::laplacian, false,
     ", btflod_laplacian_lambda(distance(btflod.camera_pos.xyz, v_world_pos))"},
    {ShaderProgram::lpca, GlslPiece::lpca, false, ""},
    {ShaderProgram::pca_views, GlslPiece::pca_views, false, ""},
    {ShaderProgram::spmm, GlslPiece::spmm, false, ""},
    {ShaderProgram::pca_rings, GlslPiece::pca_rings, false, ""},
    {ShaderProgram::bsvtf_feedback, GlslPiece::bsvtf, true, ""},
};

inline Result<std::string> glsl_program_fragment(const GlslProgramRecipe& r, GlslTarget t, const ShaderConfig& c) {
  const bool feedback = r.program == ShaderProgram::feedback;
  const bool stores_feedback = r.program == ShaderProgram::bsvtf_feedback;
  uint32_t pieces = feedback ? piece_bit(r.piece) : piece_bit(r.piece) | piece_bit(GlslPiece::local_frame);
  if (stores_feedback) pieces |= piece_bit(GlslPiece::feedback);
  Result<GlslFunctionSource> fn = generate_functions(pieces, t, c);
  if (!fn) return fn.error();
  std::string s;
  glsl_version(s, t);
  glsl_params_block(s, t);
  glsl_varyings(s, t, "in");
  s += feedback ? "layout(location = 0) out uint btflod_feedback;\n" : "layout(location = 0) out vec4 btflod_color;\n";
  if (stores_feedback)  // a second render target: no side effects, so early depth tests stay on
    s += t == GlslTarget::es300 ? "layout(location = 1) out highp uint btflod_feedback;\n"
                                : "layout(location = 1) out uint btflod_feedback;\n";
  s += fn->code;
  if (feedback) {
    s += "void main() { btflod_feedback = btflod_feedback_word(v_uv); }\n";
    return s;
  }
  const char* name = glsl_piece_name(r.piece);
  s += "void main() {\n";
  if (r.raw_view)  // the components once: the raw view is group 0 of what eq. 5 reads (a
                   // separate _raw() call would fetch group 0 twice on SIMD rasterisers)
    s += format_message("  vec4 v[btflod_kFmfGroups]; btflod_%s_components(v_uv, v);\n", name);
  if (stores_feedback)  // the colour pass's derivatives: no LOD offset (that is for a smaller feedback pass)
    s += "  btflod_feedback = btflod_feedback_word_at(v_uv, btflod_vt_lambda(v_uv));\n";
  if (r.raw_view) s += "  if (btflod.ids.z == 1u) { btflod_color = v[0]; return; }\n";
  s += "  vec3 to_eye = normalize(btflod.camera_pos.xyz - v_world_pos);\n"
       "  vec3 to_light = btflod.light.w > 0.5 ? normalize(btflod.light.xyz - v_world_pos)"
       " : normalize(btflod.light.xyz);\n"
       "  vec3 wl; vec3 wv;\n"
       "  btflod_local_dirs(v_normal, v_tangent, to_light, to_eye, wl, wv);\n";
  if (r.raw_view)
    s += "  btflod_color = vec4(btflod_fmf_brdf(v, wl, wv) * btflod.light_color.rgb, 1.0);\n";
  else
    s += format_message("  btflod_color = vec4(btflod_%s(v_uv, wl, wv%s) * btflod.light_color.rgb, 1.0);\n", name,
                        r.extra_args);
  s += "}\n";
  return s;
}

}  // namespace detail

Result<GlslProgramSource> generate_program(ShaderProgram program, GlslTarget target, const ShaderConfig& config) {
  if (VoidResult v = validate_shader_config(config); !v) return v.error();
  for (const detail::GlslProgramRecipe& r : detail::kProgramRecipes) {
    if (r.program != program) continue;
    Result<std::string> fragment = detail::glsl_program_fragment(r, target, config);
    if (!fragment) return fragment.error();
    GlslProgramSource out;
    out.vertex = detail::glsl_vertex(target);
    out.fragment = std::move(*fragment);
    return out;
  }
  return make_error(Status::invalid_argument, "generate_program: unknown program %d", static_cast<int>(program));
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
