// Shader generators: every program × target × a set of configs compiles with glslangValidator
// (run as a subprocess), the output is deterministic, bad configs are rejected, and the CPU
// twins of the shader encodings (feedback word, page entry, parameterisations) are right.
// btflod-link: btflod_shader_tools
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

// Cross-checks against angular/ and lod/ when their headers are present.
#if __has_include("btflod/offline/angular/parameterization.hpp")
#include "btflod/offline/angular/parameterization.hpp"
#define BTFLOD_TEST_HAS_ANGULAR 1
#endif
#if __has_include("btflod/runtime/lod/feedback.hpp")
#include "btflod/runtime/lod/feedback.hpp"
#define BTFLOD_TEST_HAS_LOD_FEEDBACK 1
#endif
#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/shader/shader_config.hpp"
#include "test_shader_text_cases.hpp"

using namespace btflod;
using namespace btflod::shader_text;

namespace {

// Runs glslangValidator on one stage; returns "" on success, else the tool output.
std::string validate_stage(const std::string& source, GlslTarget target, const char* stage, const std::string& tag) {
  const std::string dir = BTFLOD_TEST_TMP_DIR;
  const std::string path = dir + "/shader_" + tag + "." + stage;
  const std::string log = path + ".log";
  {
    std::ofstream f(path, std::ios::binary);
    f << source;
  }
  std::string cmd = std::string("\"") + BTFLOD_GLSLANG_VALIDATOR + "\" ";
  if (target == GlslTarget::vulkan450) cmd += "-V --target-env vulkan1.1 -o \"" + path + ".spv\" ";
  cmd += "\"" + path + "\" > \"" + log + "\" 2>&1";
  const int rc = std::system(cmd.c_str());
  if (rc == 0) return {};
  std::ifstream in(log);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return "exit " + std::to_string(rc) + ": " + text;
}

}  // namespace

// One glslangValidator run over all files of a GL or ES target (keeps the test fast, also under
// ASan on a loaded machine); Vulkan files one at a time (-V links its inputs into one module).
// When a batch fails, each file is validated alone to name the culprit.
std::string validate_batch(const std::vector<std::string>& paths, GlslTarget target, const std::string& tag) {
  const std::string dir = BTFLOD_TEST_TMP_DIR;
  const std::string log = dir + "/shader_batch_" + tag + ".log";
  std::string cmd = "cd \"" + dir + "\" && \"" + std::string(BTFLOD_GLSLANG_VALIDATOR) + "\" ";
  if (target == GlslTarget::vulkan450) cmd += "-V --target-env vulkan1.1 ";
  for (const std::string& p : paths) cmd += "\"" + p + "\" ";
  cmd += "> \"" + log + "\" 2>&1";
  if (std::system(cmd.c_str()) == 0) return {};
  std::ifstream in(log);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(ShaderGlsl, EveryProgramAndTargetCompilesWithGlslang) {
  if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) GTEST_SKIP() << "glslangValidator not found at configure time";
  int generated = 0;
  for (GlslTarget t : kAllGlslTargets) {
    std::vector<std::string> paths;
    std::vector<std::pair<std::string, std::string>> sources;  // (path, text) for the fallback
    for (const auto& [name, config] : generator_configs()) {
      for (ShaderProgram p : kAllShaderPrograms) {
        Result<GlslProgramSource> src = generate_program(p, t, config);
        ASSERT_TRUE(src.ok()) << src.message();
        const std::string tag = name + "_" + shader_program_name(p) + "_" + glsl_target_name(t);
        for (int stage = 0; stage < 2; ++stage) {
          if (stage == 0 && p != ShaderProgram::fmf) {  // the vertex shader is shared by every program
            EXPECT_EQ(src->vertex, generate_program(ShaderProgram::fmf, t, config)->vertex);
            continue;
          }
          const std::string path = std::string(BTFLOD_TEST_TMP_DIR) + "/shader_" + tag + (stage ? ".frag" : ".vert");
          std::ofstream(path, std::ios::binary) << (stage ? src->fragment : src->vertex);
          paths.push_back(path);
          sources.emplace_back(path, stage ? src->fragment : src->vertex);
        }
        generated += 2;
      }
    }
    std::string log;
    if (t == GlslTarget::vulkan450) {
      for (const std::string& path : paths) log += validate_batch({path}, t, "vk");
    } else {
      log = validate_batch(paths, t, glsl_target_name(t));
    }
    if (!log.empty()) {
      ADD_FAILURE() << glsl_target_name(t) << ": glslangValidator failed:\n" << log;
      for (const auto& [path, text] : sources)
        if (!validate_batch({path}, t, "single").empty()) ADD_FAILURE() << path << ":\n" << text;
    }
  }
  EXPECT_EQ(generated, 3 * 9 * 3 * 2);
}

TEST(ShaderGlsl, ValidatorRejectsBrokenSource) {
  // Guards the harness itself: a broken shader must be reported, or the test above proves nothing.
  if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) GTEST_SKIP() << "glslangValidator not found at configure time";
  EXPECT_NE(validate_stage("#version 450 core\nvoid main() { undefined_call(); }\n", GlslTarget::gl450_core, "frag",
                           "broken"),
            "");
}

TEST(ShaderGlsl, OutputIsDeterministicAndConfigDriven) {
  ShaderConfig c;
  auto a = generate_program(ShaderProgram::bsvtf, GlslTarget::gl450_core, c);
  auto b = generate_program(ShaderProgram::bsvtf, GlslTarget::gl450_core, c);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->fragment, b->fragment);
  expect_contains(a->fragment, {"const int btflod_kFmfComponents = 8;", "const float btflod_kPaddedTile = 72.0;",
                                "layout(binding = 5) uniform sampler2DArray btflod_tile_cache;"});
  c.components = 5;
  auto d = generate_program(ShaderProgram::bsvtf, GlslTarget::gl450_core, c);
  ASSERT_TRUE(d.ok());
  EXPECT_NE(d->fragment.find("const int btflod_kFmfGroups = 2;"), std::string::npos);
  auto es = generate_program(ShaderProgram::fmf, GlslTarget::es300, c);
  ASSERT_TRUE(es.ok());
  EXPECT_EQ(es->fragment.find("binding"), std::string::npos) << "GLSL ES 3.00 has no binding qualifier";
  EXPECT_EQ(es->fragment.rfind("#version 300 es\n", 0), 0u);
  auto vk = generate_program(ShaderProgram::fmf, GlslTarget::vulkan450, c);
  ASSERT_TRUE(vk.ok());
  EXPECT_NE(vk->fragment.find("set = 0, binding = 1"), std::string::npos);
}

TEST(ShaderGlsl, InvalidConfigsAreRejectedWithAMessage) {
  ShaderConfig c;
  c.components = 0;
  auto r = generate_program(ShaderProgram::fmf, GlslTarget::gl450_core, c);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status(), Status::invalid_argument);
  EXPECT_NE(r.message().find("components"), std::string::npos);
  ShaderConfig o;
  o.vt.feedback.level_shift = 5;  // overlaps x (bits 0..8)
  EXPECT_FALSE(validate_shader_config(o).ok());
  ShaderConfig l;
  l.vt.finest_level = 16;  // beyond the tile-id budget
  EXPECT_FALSE(validate_shader_config(l).ok());
  ShaderConfig z;
  z.vt.border = 0;  // bilinear would bleed into the neighbouring slot
  EXPECT_FALSE(validate_shader_config(z).ok());
  EXPECT_TRUE(validate_shader_config(ShaderConfig{}).ok());
}

TEST(ShaderConfig, FeedbackWordRoundTripsAndMasks) {
  FeedbackWordLayout l;
  const FeedbackSample s{200, 9, 511, 317};
  const uint32_t w = pack_feedback_word(l, s);
  EXPECT_EQ(w, (200u << 22) | (9u << 18) | (317u << 9) | 511u);
  EXPECT_EQ(unpack_feedback_word(l, w), s);
  // out-of-range fields are masked, never spill into the neighbours
  EXPECT_EQ(unpack_feedback_word(l, pack_feedback_word(l, {1, 0, 512, 0})), (FeedbackSample{1, 0, 0, 0}));
  EXPECT_EQ(l.max_level(), 9u);
  EXPECT_EQ(l.empty_word, kFeedbackNone);
}

TEST(ShaderConfig, DefaultFeedbackLayoutIsTheLodFeedbackWord) {
  // The shader's default word must be exactly runtime/lod/feedback.hpp's, or votes go to wrong tiles.
  const FeedbackWordLayout l;
  for (uint32_t m : {0u, 1u, 77u, 1022u})
    for (uint32_t level : {0u, 3u, 9u, 15u})
      for (uint32_t x : {0u, 5u, 511u})
        for (uint32_t y : {0u, 300u, 511u}) {
          const uint32_t ours = pack_feedback_word(l, {m, level, x, y});
#ifdef BTFLOD_TEST_HAS_LOD_FEEDBACK
          EXPECT_EQ(ours, pack_feedback(FeedbackTile{m, level, x, y}));
#endif
          // runtime/lod/feedback.hpp's documented layout: [31..22] material [21..18] level [17..9] y [8..0] x
          EXPECT_EQ(ours, (m << 22) | (level << 18) | (y << 9) | x);
          EXPECT_EQ(unpack_feedback_word(l, ours), (FeedbackSample{m, level, x, y}));
        }
}

#ifdef BTFLOD_TEST_HAS_ANGULAR
TEST(ShaderConfig, ParameterisationTwinsMatchAngularMaps) {
  // shader_direction_to_unit_square is the CPU twin of the GLSL; angular/ builds the tables.
  // They must agree or table lookups in the shader land on the wrong texel.
  uint32_t state = 12345u;
  auto rnd = [&state] {
    state = state * 1664525u + 1013904223u;
    return static_cast<float>(state >> 8) / 16777216.0f;
  };
  for (int i = 0; i < 2000; ++i) {
    const glm::vec3 d(rnd() * 2.0f - 1.0f, rnd() * 2.0f - 1.0f, rnd() * 1.2f - 0.2f);
    const glm::vec2 a = shader_direction_to_unit_square(DirectionParameterisation::parabolic, d);
    const glm::vec2 b = ParabolicMap::to_square(d);
    EXPECT_NEAR(a.x, b.x, 2e-6f);
    EXPECT_NEAR(a.y, b.y, 2e-6f);
    const glm::vec2 c = shader_direction_to_unit_square(DirectionParameterisation::elevated_concentric, d);
    const glm::vec2 e = ElevatedConcentricMap::to_square(d);
    EXPECT_NEAR(c.x, e.x, 2e-6f);
    EXPECT_NEAR(c.y, e.y, 2e-6f);
  }
}
#endif

TEST(ShaderConfig, PageEntryAndSlotPlacement) {
  EXPECT_EQ(unpack_page_entry_slot(pack_page_entry(123456, 7)), 123456u);
  EXPECT_EQ(unpack_page_entry_level(pack_page_entry(123456, 7)), 7u);
  VirtualTextureConfig v;
  v.slots_x = 4;
  v.slots_y = 2;
  v.cache_layers = 2;
  const SlotPlacement p = slot_placement(v, 13);  // layer 1, slot 5 of the layer = row 1, column 1
  EXPECT_EQ(p.layer, 1u);
  EXPECT_EQ(p.x, 72u);
  EXPECT_EQ(p.y, 72u);
  EXPECT_EQ(v.cache_width(), 288u);
}

TEST(ShaderConfig, ParameterisationsMapKnownDirections) {
  using P = DirectionParameterisation;
  for (P p : {P::parabolic, P::elevated_concentric}) {
    const glm::vec2 n = shader_direction_to_unit_square(p, {0, 0, 1});
    EXPECT_NEAR(n.x, 0.5f, 1e-6f);
    EXPECT_NEAR(n.y, 0.5f, 1e-6f);
    const glm::vec2 e = shader_direction_to_unit_square(p, {1, 0, 0});  // horizon, φ = 0
    EXPECT_NEAR(e.x, 1.0f, 1e-6f);
    EXPECT_NEAR(e.y, 0.5f, 1e-6f);
    const glm::vec2 below = shader_direction_to_unit_square(p, {0, -1, -0.5f});  // clamped to the horizon
    EXPECT_NEAR(below.y, 0.0f, 1e-6f);
  }
  // concentric: the horizon at φ = 45° is the corner of the square; parabolic: the inscribed circle
  const glm::vec3 d45(std::sqrt(0.5f), std::sqrt(0.5f), 0.0f);
  const glm::vec2 c = shader_direction_to_unit_square(P::elevated_concentric, d45);
  EXPECT_NEAR(c.x, 1.0f, 1e-5f);
  EXPECT_NEAR(c.y, 1.0f, 1e-5f);
  const glm::vec2 q = shader_direction_to_unit_square(P::parabolic, d45);
  EXPECT_NEAR(q.x, 0.5f + 0.5f * std::sqrt(0.5f), 1e-6f);
  // elevated concentric: z = 1 − r², so θ = 60° (z = 0.5) lies at disk radius sqrt(0.5)
  const glm::vec2 m = shader_direction_to_unit_square(P::elevated_concentric, {std::sqrt(0.75f), 0.0f, 0.5f});
  EXPECT_NEAR(m.x, 0.5f + 0.5f * std::sqrt(0.5f), 1e-6f);
  EXPECT_NEAR(m.y, 0.5f, 1e-6f);
  EXPECT_EQ(shader_table_texel({1.0f, -0.2f}, 64), glm::ivec2(63, 0));
}

// ---- Functions for an engine's own shader -----------------------------------------------------

namespace {

// An engine fragment shader around `functions`: its own block, varyings and main(), which calls
// the entry points of `pieces` (engine_main_body()).
std::string engine_shader(GlslTarget t, const std::string& functions, uint32_t pieces) {
  std::string s;
  const bool es = t == GlslTarget::es300;
  s += es ? "#version 300 es\nprecision highp float;\nprecision highp int;\n"
          : (t == GlslTarget::vulkan450 ? "#version 450\n" : "#version 450 core\n");
  const char* block_layout = t == GlslTarget::vulkan450    ? "layout(std140, set = 0, binding = 7)"
                             : t == GlslTarget::gl450_core ? "layout(std140, binding = 7)"
                                                           : "layout(std140)";
  s += std::string(block_layout) + " uniform EngineMaterial { vec4 extent; vec4 lod; uvec4 ids; } material;\n";
  s += std::string(t == GlslTarget::vulkan450    ? "layout(set = 3, binding = 40) "
                   : t == GlslTarget::gl450_core ? "layout(binding = 40) "
                                                 : "") +
       "uniform " + (es ? "highp " : "") + "sampler2DArray engine_angular_weights;\n";
  const char* loc[5] = {"", "", "", "", ""};
  if (!es) {
    loc[0] = "layout(location = 0) ";
    loc[1] = "layout(location = 1) ";
    loc[2] = "layout(location = 2) ";
    loc[3] = "layout(location = 3) ";
    loc[4] = "layout(location = 0) ";
  }
  s += std::string(loc[0]) + "in vec3 f_position;\n" + loc[1] + "in vec3 f_normal;\n" + loc[2] +
       "in vec4 f_tangent;\n" + loc[3] + "in vec2 f_uv;\n" + loc[4] + "out vec4 f_color;\n";
  s += "float frame_bias = 0.25;\n";
  s += functions;
  s += "void main() {\n" + engine_main_body(pieces, false);
  s += "  f_color = vec4(rho, float(word & 255u));\n}\n";
  return s;
}

}  // namespace

TEST(ShaderGlsl, FunctionsInAnEngineShaderCompileForEveryTarget) {
  // Each piece on its own (with what it calls; one config) and all pieces together (every
  // config), for every target, embedded in an engine shader with its own block, varyings, bindings and main().
  if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) GTEST_SKIP() << "glslangValidator not found at configure time";
  const GlslFunctionOptions options = engine_options({}, "material.");
  int generated = 0;
  for (GlslTarget t : kAllGlslTargets) {
    std::vector<std::string> paths;
    std::vector<std::pair<std::string, std::string>> sources;
    for (const auto& [name, config] : generator_configs()) {
      for (const auto& [piece, set] : engine_piece_sets(name)) {
        Result<GlslFunctionSource> fn = generate_functions(set, t, config, options);
        ASSERT_TRUE(fn.ok()) << fn.message();
        EXPECT_EQ(fn->code.find("#version"), std::string::npos);
        EXPECT_EQ(fn->code.find("main("), std::string::npos);
        EXPECT_EQ(fn->code.find("btflod"), std::string::npos) << "default names leak: " << piece;
        if (t == GlslTarget::es300) {
          EXPECT_EQ(fn->code.find("binding"), std::string::npos);
        }
        const std::string text = engine_shader(t, fn->code, set);
        const std::string path =
            std::string(BTFLOD_TEST_TMP_DIR) + "/engine_" + name + "_" + piece + "_" + glsl_target_name(t) + ".frag";
        std::ofstream(path, std::ios::binary) << text;
        paths.push_back(path);
        sources.emplace_back(path, text);
        ++generated;
      }
    }
    std::string log;
    if (t == GlslTarget::vulkan450) {
      for (const std::string& path : paths) log += validate_batch({path}, t, "vk_engine");
    } else {
      log = validate_batch(paths, t, std::string("engine_") + glsl_target_name(t));
    }
    if (!log.empty()) {
      ADD_FAILURE() << glsl_target_name(t) << ": glslangValidator failed:\n" << log;
      for (const auto& [path, text] : sources)
        if (!validate_batch({path}, t, "single").empty()) ADD_FAILURE() << path << ":\n" << text;
    }
  }
  EXPECT_EQ(generated, 3 * (3 + 14));
}

TEST(ShaderGlsl, FunctionsFollowTheCallersNamesBindingsSetsAndSources) {
  const GlslFunctionOptions o = engine_options({}, "material.");
  const ShaderConfig c;
  const uint32_t set = glsl_pieces({GlslPiece::bsvtf, GlslPiece::feedback});
  auto vk = generate_functions(set, GlslTarget::vulkan450, c, o);
  ASSERT_TRUE(vk.ok()) << vk.message();
  const std::string& s = vk->code;
  // bindings and sets as chosen (tile_cache = 5 → binding 25, set 2; page_table = 6 → 26, set 1)
  expect_contains(s, {"layout(set = 2, binding = 25) uniform sampler2DArray eng_btf_tile_cache;",
                      "layout(set = 1, binding = 26) uniform usampler2DArray eng_btf_page_table;"});
  // the engine declares the weights table itself: read under its name, not declared here
  EXPECT_NE(s.find("texelFetch(engine_angular_weights"), std::string::npos);
  EXPECT_EQ(s.find("uniform sampler2DArray engine_angular_weights"), std::string::npos);
  // uniform sources: the engine's expressions, parenthesised
  expect_contains(s, {"(material.extent).xy", "- (material.lod.x + frame_bias)", "int((material.ids.x))",
                      "uint((material.ids[1]))"});
  // every function carries the prefix; the shared pieces appear once
  expect_contains(s, {"vec3 eng_btf_bsvtf(vec2 uv, vec3 wl, vec3 wv)", "uint eng_btf_feedback_word(vec2 uv)"});
  for (const char* def : {"float eng_btf_vt_lambda(", "vec3 eng_btf_fmf_brdf(", "void eng_btf_angular(",
                          "vec2 eng_btf_direction_map(", "struct eng_btf_VtSite"}) {
    EXPECT_NE(s.find(def), std::string::npos) << def;
    EXPECT_EQ(s.find(def), s.rfind(def)) << def << " emitted twice";
  }
  // the sampler list tells the host where each sampler is
  ASSERT_EQ(vk->samplers.size(), 5u);  // page table, angular index + weight, eigen abrdfs, tile cache
  for (const GlslSamplerUse& u : vk->samplers) {
    EXPECT_EQ(u.binding, o.resource(u.role).binding);
    EXPECT_EQ(u.set, o.resource(u.role).set);
    EXPECT_EQ(u.declared, u.role != ShaderBinding::angular_weight);
  }
  // ES: no binding qualifiers; the host sets units by the listed names
  auto es = generate_functions(set, GlslTarget::es300, c, o);
  ASSERT_TRUE(es.ok());
  EXPECT_EQ(es->code.find("binding"), std::string::npos);
  EXPECT_NE(es->code.find("uniform highp sampler2DArray eng_btf_tile_cache;"), std::string::npos);
  // without pieces that need them, other uniform sources are not checked nor used
  GlslFunctionOptions lp = o;
  lp.uniforms.vt_extent = "";
  EXPECT_TRUE(generate_functions(glsl_pieces({GlslPiece::lpca}), GlslTarget::gl450_core, c, lp).ok());
}

TEST(ShaderGlsl, WholeProgramsAreAssembledFromTheFunctions) {
  // The fragment shader of each program contains the functions of its piece verbatim (one copy
  // of each piece) and a main() of a few lines.
  const ShaderConfig c;
  const struct {
    ShaderProgram program;
    uint32_t pieces;
  } cases[] = {
      {ShaderProgram::fmf, glsl_pieces({GlslPiece::fmf, GlslPiece::local_frame})},
      {ShaderProgram::bsvtf, glsl_pieces({GlslPiece::bsvtf, GlslPiece::local_frame})},
      {ShaderProgram::feedback, glsl_pieces({GlslPiece::feedback})},
      {ShaderProgram::laplacian, glsl_pieces({GlslPiece::laplacian, GlslPiece::local_frame})},
      {ShaderProgram::lpca, glsl_pieces({GlslPiece::lpca, GlslPiece::local_frame})},
      {ShaderProgram::pca_views, glsl_pieces({GlslPiece::pca_views, GlslPiece::local_frame})},
      {ShaderProgram::spmm, glsl_pieces({GlslPiece::spmm, GlslPiece::local_frame})},
      {ShaderProgram::bsvtf_feedback, glsl_pieces({GlslPiece::bsvtf, GlslPiece::feedback, GlslPiece::local_frame})},
  };
  for (GlslTarget t : kAllGlslTargets)
    for (const auto& k : cases) {
      auto prog = generate_program(k.program, t, c);
      auto fn = generate_functions(k.pieces, t, c);
      ASSERT_TRUE(prog.ok() && fn.ok());
      const size_t at = prog->fragment.find(fn->code);
      EXPECT_NE(at, std::string::npos) << shader_program_name(k.program);
      const std::string tail = prog->fragment.substr(at + fn->code.size());
      EXPECT_EQ(tail.rfind("void main()", 0), 0u) << shader_program_name(k.program);
      EXPECT_LE(std::count(tail.begin(), tail.end(), '\n'), 10) << "main() is a few lines around one call";
    }
}

TEST(ShaderGlsl, BadFunctionOptionsAreRejectedWithAMessage) {
  const ShaderConfig c;
  const uint32_t bsvtf = glsl_pieces({GlslPiece::bsvtf, GlslPiece::feedback});
  auto rejects = [&](const GlslFunctionOptions& o, const char* word, uint32_t pieces) {
    auto r = generate_functions(pieces, GlslTarget::vulkan450, c, o);
    ASSERT_FALSE(r.ok()) << word;
    EXPECT_EQ(r.status(), Status::invalid_argument);
    EXPECT_NE(r.message().find(word), std::string::npos) << r.message();
  };
  GlslFunctionOptions o;
  for (const char* bad : {"", "1abc", "gl_x", "a__b", "a-b", "a b", "x;", "$", "@"}) {
    o.prefix = bad;
    rejects(o, "prefix", bsvtf);
  }
  o = {};
  o.prefix = std::string(65, 'a');
  rejects(o, "prefix", bsvtf);
  // statements, blocks, preprocessor and unbalanced brackets cannot enter through a source
  for (const char* bad : {"", "x; discard", "x }", "{", "#define a", "f(x", "a)", "a\nb", "a[1", "\"s\"", "a@b"}) {
    o = {};
    o.uniforms.lod_bias = bad;
    rejects(o, "lod_bias", bsvtf);
  }
  o = {};
  o.uniforms.texture_id = "ids.y; x = 1";
  rejects(o, "texture_id", bsvtf);
  o = {};
  o.resource(ShaderBinding::tile_cache).name = "cache[2]";  // an expression needs declare = false
  rejects(o, "tile_cache", bsvtf);
  o.resource(ShaderBinding::tile_cache).declare = false;
  EXPECT_TRUE(generate_functions(bsvtf, GlslTarget::vulkan450, c, o).ok());
  o = {};
  o.resource(ShaderBinding::tile_cache).binding = 6;  // = page_table's
  rejects(o, "binding 6", bsvtf);
  o.resource(ShaderBinding::tile_cache).set = 1;  // another set: fine for Vulkan
  EXPECT_TRUE(generate_functions(bsvtf, GlslTarget::vulkan450, c, o).ok());
  EXPECT_FALSE(generate_functions(bsvtf, GlslTarget::gl450_core, c, o).ok()) << "GL has no sets";
  o = {};
  o.resource(ShaderBinding::tile_cache).name = "btflod_page_table";  // same name as another sampler
  rejects(o, "share the name", bsvtf);
  o = {};
  o.resource(ShaderBinding::pca_r).set = 32;
  rejects(o, "pca_r", glsl_pieces({GlslPiece::pca_views}));
  rejects(GlslFunctionOptions{}, "piece set", 0);
  rejects(GlslFunctionOptions{}, "piece set", 1u << kGlslPieceCount);
  ShaderConfig bad;
  bad.components = 0;
  EXPECT_FALSE(generate_functions(bsvtf, GlslTarget::gl450_core, bad).ok());
}

TEST(ShaderGlsl, DefaultFunctionNamesAreTheWholeProgramSamplerNames) {
  // An ES host sets the whole programs' samplers by the names of shader_sampler_names(); the
  // default options must produce exactly those names and bindings, or such a host binds nothing.
  const GlslFunctionOptions o;
  const uint32_t all = all_pieces();
  ShaderConfig config;
  config.vt.format = CacheFormat::rgba8_affine;  // every sampler, the slot map too
  auto fn = generate_functions(all, GlslTarget::es300, config, o);
  ASSERT_TRUE(fn.ok()) << fn.message();
  ASSERT_EQ(fn->samplers.size(), shader_sampler_names().size());
  for (const SamplerName& n : shader_sampler_names()) {
    EXPECT_EQ(std::string(n.name), std::string("btflod_") + shader_binding_name(n.binding));
    bool found = false;
    for (const GlslSamplerUse& u : fn->samplers)
      if (u.role == n.binding) {
        found = true;
        EXPECT_EQ(u.name, n.name);
        EXPECT_EQ(u.binding, static_cast<uint32_t>(n.binding));
        EXPECT_TRUE(u.declared);
      }
    EXPECT_TRUE(found) << n.name;
  }
  // same inputs, same bytes
  EXPECT_EQ(fn->code, generate_functions(all, GlslTarget::es300, config, o)->code);
  // An rgba16f cache declares no slot map.
  auto wide = generate_functions(all, GlslTarget::es300, ShaderConfig{}, o);
  ASSERT_TRUE(wide.ok()) << wide.message();
  EXPECT_EQ(wide->samplers.size(), shader_sampler_names().size() - 1);
  EXPECT_EQ(wide->code.find("slot_map"), std::string::npos);
}

// A bc5_affine cache: the bsvtf programs of every target compile; the cache is read as two
// planes (array layers 2L and 2L + 1) at one coordinate, then the slot map is applied as for
// rgba8_affine, whose text is otherwise the same.
TEST(ShaderGlsl, Bc5CacheProgramsCompileAndReadBothPlanes) {
  ShaderConfig bc5;
  bc5.vt.format = CacheFormat::bc5_affine;  // T + 2B = 72: whole 4 × 4 blocks
  ShaderConfig rgba8 = bc5;
  rgba8.vt.format = CacheFormat::rgba8_affine;
  for (GlslTarget t : kAllGlslTargets)
    for (ShaderProgram p : {ShaderProgram::bsvtf, ShaderProgram::bsvtf_feedback}) {
      Result<GlslProgramSource> src = generate_program(p, t, bc5);
      ASSERT_TRUE(src.ok()) << src.message();
      const std::string& f = src->fragment;
      expect_contains(f, {"float l = float(slot / btflod_kSlotsPerLayer) * 2.0;", "vec3(c, l + 1.0)", "btflod_slot_map",
                          "return o + s * t;"});
      // Everything but the cache fetch is rgba8_affine's text.
      const std::string other = generate_program(p, t, rgba8)->fragment;
      const size_t a = f.find("  vec2 c = "), b = f.find("  uvec4 m = texelFetch(");
      const size_t a8 = other.find("  vec4 t = textureLod("), b8 = other.find("  uvec4 m = texelFetch(");
      ASSERT_TRUE(a != std::string::npos && b != std::string::npos && a8 != std::string::npos &&
                  b8 != std::string::npos);
      EXPECT_EQ(f.substr(0, a) + f.substr(b), other.substr(0, a8) + other.substr(b8));
      if (std::string(BTFLOD_GLSLANG_VALIDATOR).empty()) continue;
      const std::string tag = std::string("bc5_") + shader_program_name(p) + "_" + glsl_target_name(t);
      EXPECT_EQ(validate_stage(f, t, "frag", tag), "") << tag;
    }
  // A slot side that is not whole blocks is refused.
  bc5.vt.border = 3;
  Result<GlslProgramSource> bad = generate_program(ShaderProgram::bsvtf, GlslTarget::gl450_core, bc5);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("multiple of 4"), std::string::npos) << bad.message();
}
