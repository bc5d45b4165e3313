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
#include "test_shader_text_cases.hpp"

using namespace btflod;
using namespace btflod::shader_text;

namespace {

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
  for (const auto& [name, config] : generator_configs()) {
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

// An engine pixel shader around `functions`: its own cbuffer, the texture it declares itself and
// main(), which calls the entry points of `pieces` (engine_main_body()).
std::string engine_shader(const std::string& functions, uint32_t pieces) {
  std::string s =
      "cbuffer EngineMaterial : register(b7, space0) {\n"
      "  float4 material_extent; float4 material_lod; uint4 material_ids;\n};\n"
      "Texture2DArray<float4> engine_angular_weights : register(t40, space3);\n"
      "static const float frame_bias = 0.25;\n";
  s += functions;
  s += "float4 main(float3 f_position : TEXCOORD0, float3 f_normal : TEXCOORD1, float4 f_tangent : TEXCOORD2,"
       " float2 f_uv : TEXCOORD3) : SV_Target0 {\n" +
       engine_main_body(pieces, true);
  s += "  return float4(rho, float(word & 255u));\n}\n";
  return s;
}

}  // namespace

TEST(ShaderHlsl, FunctionsInAnEngineShaderCompile) {
  if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) GTEST_SKIP() << "glslangValidator not found at configure time";
  const GlslFunctionOptions options = engine_options(HlslFunctionOptions{}, "material_");
  int compiled = 0;
  for (const auto& [name, config] : generator_configs()) {
    for (const auto& [piece, set] : engine_piece_sets(name)) {
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
  for (const auto& [name, config] : generator_configs()) {
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

// A bc5_affine cache: the bsvtf programs compile and read both planes (array layers 2L, 2L + 1).
TEST(ShaderHlsl, Bc5CacheProgramsCompile) {
  ShaderConfig bc5;
  bc5.vt.format = CacheFormat::bc5_affine;
  for (ShaderProgram p : {ShaderProgram::bsvtf, ShaderProgram::bsvtf_feedback}) {
    Result<HlslProgramSource> src = generate_hlsl_program(p, bc5);
    ASSERT_TRUE(src.ok()) << src.message();
    EXPECT_NE(src->fragment.find("float3(c, l + 1.0)"), std::string::npos);
    EXPECT_NE(src->fragment.find("return o + s * t;"), std::string::npos);
    if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) continue;
    const std::string tag = std::string("bc5_") + shader_program_name(p);
    EXPECT_EQ(validate_hlsl(src->fragment, "frag", tag), "") << tag;
  }
}
