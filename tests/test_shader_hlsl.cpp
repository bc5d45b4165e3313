// HLSL generator: every program × config compiles (vertex and pixel shader) with glslang's HLSL
// front end (glslangValidator -D -V -S vert|frag -e main), the functions compile in an engine's
// HLSL with its own prefix, registers, spaces and uniform sources, every GLSL function has its
// HLSL twin of the same name, no GLSL spelling leaks, and the output is deterministic.
// btflod-link: btflod_shader_tools
#include <gtest/gtest.h>

#include <cctype>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/shader/hlsl_generator.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

using namespace btflod;

namespace {

std::vector<std::pair<std::string, ShaderConfig>> configs() {  // the configs of test_shader_glsl.cpp
  std::vector<std::pair<std::string, ShaderConfig>> out;
  out.emplace_back("default", ShaderConfig{});
  ShaderConfig b;
  b.components = 3;
  b.angular.parameterisation = DirectionParameterisation::elevated_concentric;
  b.angular.lookup = AngularLookup::nearest;
  b.vt.tile_size = 128;
  b.vt.border = 1;
  b.vt.slots_x = 8;
  b.vt.slots_y = 4;
  b.vt.cache_layers = 3;
  b.vt.finest_level = 7;
  b.vt.trilinear = false;
  b.vt.format = CacheFormat::rgba8_affine;  // the slot-map table and its loads
  b.vt.feedback = FeedbackWordLayout{16, 8, 24, 8, 0, 4, 4, 12, 0u};
  b.laplacian.max_level = 0;
  b.laplacian.ycbcr_output = false;
  b.lpca.clusters = 1;
  b.lpca.grid_resolution = 2;
  b.pca.views_per_group = 151;
  b.pca.light_count = 151;
  b.spmm.slots = 1;
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

constexpr GlslPiece kAllPieces[] = {
    GlslPiece::direction_map, GlslPiece::local_frame, GlslPiece::angular,     GlslPiece::fmf_brdf,  GlslPiece::fmf,
    GlslPiece::page_table,    GlslPiece::bsvtf,       GlslPiece::feedback,    GlslPiece::laplacian, GlslPiece::lpca,
    GlslPiece::pca_views,     GlslPiece::spmm,        GlslPiece::ring_search, GlslPiece::pca_rings};

// glslangValidator's HLSL front end on one file of stage "vert" or "frag"; "" on success, else the log.
std::string validate_hlsl(const std::string& source, const char* stage, const std::string& tag) {
  const std::string path = std::string(BTFLOD_TEST_TMP_DIR) + "/hlsl_" + tag + "." + stage + ".hlsl";
  std::ofstream(path, std::ios::binary) << source;
  const std::string log = path + ".log";
  const std::string cmd = std::string("\"") + BTFLOD_GLSLANG_VALIDATOR + "\" -D -V -S " + stage + " -e main -o \"" +
                          path + ".spv\" \"" + path + "\" > \"" + log + "\" 2>&1";
  if (std::system(cmd.c_str()) == 0) return {};
  std::ifstream in(log);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()) + "\n" + source;
}

// GLSL spellings that must not appear in HLSL output (as a call or type followed by '(' or ' ').
void expect_no_glsl(const std::string& hlsl, const std::string& what) {
  for (const char* word :
       {"vec2", "vec3", "vec4", "texelFetch", "textureSize", "textureLod", "texture(", "mix(", "fract(", "dFdx", "dFdy",
        "uintBitsToFloat", "atan(", "#version", "layout(", "sampler2D", "sampler3D"})
    EXPECT_EQ(hlsl.find(word), std::string::npos) << what << " contains GLSL " << word;
}

// Names `prefix...(` that are defined (followed by '(' after a type) in generated code.
std::set<std::string> called_names(const std::string& code, const std::string& prefix) {
  std::set<std::string> out;
  for (size_t at = code.find(prefix); at != std::string::npos; at = code.find(prefix, at + 1)) {
    size_t end = at + prefix.size();
    while (end < code.size() && (std::isalnum(static_cast<unsigned char>(code[end])) || code[end] == '_')) ++end;
    if (end < code.size() && code[end] == '(') out.insert(code.substr(at, end - at));
  }
  return out;
}

}  // namespace

TEST(ShaderHlsl, EveryProgramCompilesWithGlslangHlslFrontEnd) {
  if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) GTEST_SKIP() << "glslangValidator not found at configure time";
  int compiled = 0;
  for (const auto& [name, config] : configs()) {
    for (ShaderProgram p : kAllShaderPrograms) {
      Result<HlslProgramSource> src = generate_hlsl_program(p, config);
      ASSERT_TRUE(src.ok()) << src.message();
      const std::string tag = name + "_" + shader_program_name(p);
      expect_no_glsl(src->vertex, tag + " vertex");
      expect_no_glsl(src->fragment, tag + " fragment");
      EXPECT_EQ(validate_hlsl(src->vertex, "vert", tag), "") << tag;
      EXPECT_EQ(validate_hlsl(src->fragment, "frag", tag), "") << tag;
      compiled += 2;
    }
  }
  EXPECT_EQ(compiled, 3 * 9 * 2);
}

TEST(ShaderHlsl, ValidatorRejectsBrokenHlsl) {
  if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) GTEST_SKIP() << "glslangValidator not found at configure time";
  EXPECT_NE(validate_hlsl("float4 main() : SV_Target0 { return vec4(1.0); }\n", "frag", "broken"), "");
}

namespace {

// An engine's choice: its own prefix, registers from 20 up in spaces 1 and 2, one texture it
// declares itself, uniform sources in its own cbuffer.
GlslFunctionOptions engine_options() {
  HlslFunctionOptions o;
  o.prefix = "eng_btf_";
  for (uint32_t i = 1; i < kShaderBindingCount; ++i) {
    o.resources[i].binding = 20 + i;
    o.resources[i].set = 1 + i % 2;
  }
  o.resource(ShaderBinding::angular_weight) = GlslResource{"engine_angular_weights", 40, 3, false};
  o.uniforms.vt_extent = "material_extent";
  o.uniforms.lod_bias = "material_lod.x + frame_bias";
  o.uniforms.feedback_lod_offset = "material_lod.y";
  o.uniforms.range_lod_scale = "material_lod.z";
  o.uniforms.first_layer = "material_ids.x";
  o.uniforms.texture_id = "material_ids[1]";
  o.uniforms.spmm_mode = "material_ids.w";
  o.uniforms.component_count = "material_extent.w";
  return o;
}

std::string engine_shader(const std::string& functions, uint32_t pieces) {
  std::string s =
      "cbuffer EngineMaterial : register(b7, space0) {\n"
      "  float4 material_extent; float4 material_lod; uint4 material_ids;\n};\n"
      "Texture2DArray<float4> engine_angular_weights : register(t40, space3);\n"
      "static const float frame_bias = 0.25;\n";
  s += functions;
  auto has = [&](GlslPiece p) { return (pieces & glsl_pieces({p})) != 0; };
  s += "float4 main(float3 f_position : TEXCOORD0, float3 f_normal : TEXCOORD1, float4 f_tangent : TEXCOORD2,"
       " float2 f_uv : TEXCOORD3) : SV_Target0 {\n"
       "  float3 wl; float3 wv;\n  float3 rho = (float3)0.0;\n  uint word = 0u;\n";
  if (has(GlslPiece::local_frame))
    s += "  eng_btf_local_dirs(f_normal, f_tangent, float3(0.0, 0.0, 1.0), normalize(-f_position), wl, wv);\n";
  else
    s += "  wl = float3(0.0, 0.0, 1.0); wv = normalize(float3(0.2, 0.1, 1.0));\n";
  if (has(GlslPiece::direction_map)) s += "  rho.xy += eng_btf_direction_map(wl);\n";
  if (has(GlslPiece::angular))
    s += "  int3 idx; float3 w;\n  eng_btf_angular(0, wl, idx, w);\n"
         "  rho += w * float(idx.x + eng_btf_angular_nearest(1, wv));\n";
  if (has(GlslPiece::fmf_brdf))
    s += "  float4 v[eng_btf_kFmfGroups];\n  for (int g = 0; g < eng_btf_kFmfGroups; ++g) v[g] = (float4)0.5;\n"
         "  rho += eng_btf_fmf_brdf(v, wl, wv);\n";
  if (has(GlslPiece::fmf)) s += "  rho += eng_btf_fmf(f_uv, wl, wv) + eng_btf_fmf_raw(f_uv).rgb;\n";
  if (has(GlslPiece::page_table))
    s += "  int2 tile = eng_btf_tile_of(frac(f_uv), 1);\n"
         "  word += eng_btf_page_entry(0, tile, 1) + uint(eng_btf_vt_lambda(f_uv));\n";
  if (has(GlslPiece::bsvtf))
    s += "  float4 bv[eng_btf_kFmfGroups];\n  eng_btf_bsvtf_components(f_uv, bv);\n"
         "  rho += eng_btf_bsvtf(f_uv, wl, wv) + bv[0].rgb + eng_btf_bsvtf_raw(f_uv).rgb;\n";
  if (has(GlslPiece::feedback)) s += "  word += eng_btf_feedback_word(f_uv);\n";
  if (has(GlslPiece::laplacian))
    s += "  rho += eng_btf_laplacian(f_uv, wl, wv, eng_btf_laplacian_lambda(length(f_position)));\n";
  if (has(GlslPiece::lpca)) s += "  rho += eng_btf_lpca(f_uv, wl, wv);\n";
  if (has(GlslPiece::pca_views)) s += "  rho += eng_btf_pca_views(f_uv, wl, wv);\n";
  if (has(GlslPiece::ring_search))
    s += "  int3 ri; float3 rw;\n  eng_btf_ring_search(1, wv, ri, rw);\n  rho += rw * float(ri.y);\n";
  if (has(GlslPiece::pca_rings)) s += "  rho += eng_btf_pca_rings(f_uv, wl, wv);\n";
  if (has(GlslPiece::spmm)) s += "  rho += eng_btf_spmm(f_uv, wl, wv) + eng_btf_spmm_epsilon((int2)0, wl, wv, 2);\n";
  s += "  return float4(rho, float(word & 255u));\n}\n";
  return s;
}

}  // namespace

TEST(ShaderHlsl, FunctionsInAnEngineShaderCompile) {
  if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) GTEST_SKIP() << "glslangValidator not found at configure time";
  const GlslFunctionOptions options = engine_options();
  int compiled = 0;
  for (const auto& [name, config] : configs()) {
    std::vector<std::pair<std::string, uint32_t>> sets;
    if (name == "variant")
      for (GlslPiece p : kAllPieces) sets.emplace_back(glsl_piece_name(p), glsl_pieces({p}));
    uint32_t all = 0;
    for (GlslPiece p : kAllPieces) all |= glsl_pieces({p});
    sets.emplace_back("all", all);
    for (const auto& [piece, set] : sets) {
      Result<HlslFunctionSource> fn = generate_hlsl_functions(set, config, options);
      ASSERT_TRUE(fn.ok()) << fn.message();
      EXPECT_EQ(fn->code.find("main("), std::string::npos);
      EXPECT_EQ(fn->code.find("btflod"), std::string::npos) << "default names leak: " << piece;
      expect_no_glsl(fn->code, piece);
      EXPECT_EQ(validate_hlsl(engine_shader(fn->code, set), "frag", "engine_" + name + "_" + piece), "");
      ++compiled;
    }
  }
  EXPECT_EQ(compiled, 3 + 14);
}

TEST(ShaderHlsl, EveryGlslFunctionHasItsHlslTwin) {
  for (const auto& [name, config] : configs()) {
    for (GlslPiece p : kAllPieces) {
      Result<GlslFunctionSource> glsl = generate_functions(glsl_pieces({p}), GlslTarget::vulkan450, config);
      Result<HlslFunctionSource> hlsl = generate_hlsl_functions(glsl_pieces({p}), config);
      ASSERT_TRUE(glsl.ok() && hlsl.ok());
      EXPECT_EQ(called_names(glsl->code, "btflod_"), called_names(hlsl->code, "btflod_"))
          << name << " " << glsl_piece_name(p);
      ASSERT_EQ(glsl->samplers.size(), hlsl->samplers.size());
      for (size_t i = 0; i < glsl->samplers.size(); ++i) {
        EXPECT_EQ(glsl->samplers[i].name, hlsl->samplers[i].name);
        EXPECT_EQ(glsl->samplers[i].binding, hlsl->samplers[i].binding);
      }
    }
  }
}

TEST(ShaderHlsl, OutputIsDeterministicAndRegistersFollowTheOptions) {
  const ShaderConfig c;
  for (ShaderProgram p : kAllShaderPrograms) {
    Result<HlslProgramSource> a = generate_hlsl_program(p, c);
    Result<HlslProgramSource> b = generate_hlsl_program(p, c);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->fragment, b->fragment);
    EXPECT_EQ(a->vertex, b->vertex);
  }
  HlslFunctionOptions o;
  o.resource(ShaderBinding::tile_cache).binding = 3;
  o.resource(ShaderBinding::tile_cache).set = 2;
  Result<HlslFunctionSource> fn = generate_hlsl_functions(glsl_pieces({GlslPiece::bsvtf}), c, o);
  ASSERT_TRUE(fn.ok()) << fn.message();
  EXPECT_NE(fn->code.find("Texture2DArray<float4> btflod_tile_cache : register(t3, space2);"), std::string::npos);
  EXPECT_NE(fn->code.find("SamplerState btflod_tile_cache_sampler : register(s3, space2);"), std::string::npos);
  EXPECT_NE(fn->code.find("Texture2DArray<uint> btflod_page_table : register(t6, space0);"), std::string::npos);
  EXPECT_NE(fn->code.find("(btflod_ids.x)"), std::string::npos);
  // Two declared textures on one register and space are rejected, as for Vulkan bindings and sets.
  o.resource(ShaderBinding::page_table).binding = 3;
  o.resource(ShaderBinding::page_table).set = 2;
  EXPECT_FALSE(generate_hlsl_functions(glsl_pieces({GlslPiece::bsvtf}), c, o).ok());
  ShaderConfig bad;
  bad.components = 0;
  EXPECT_FALSE(generate_hlsl_program(ShaderProgram::fmf, bad).ok());
  EXPECT_FALSE(generate_hlsl_functions(0, c).ok());
}
