// Shader generators: every program × target × a set of configs compiles with glslangValidator
// (run as a subprocess), the output is deterministic, bad configs are rejected, and the CPU
// twins of the shader encodings (feedback word, page entry, parameterisations) are right.
// btflod-link: btflod_shader_tools
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>
#include <sys/wait.h>

// angular/ and lod/ are written in parallel by other engineers: cross-check when present.
#if __has_include("btflod/angular/parameterization.hpp")
#include "btflod/angular/parameterization.hpp"
#define BTFLOD_TEST_HAS_ANGULAR 1
#endif
#if __has_include("btflod/lod/feedback.hpp")
#include "btflod/lod/feedback.hpp"
#define BTFLOD_TEST_HAS_LOD_FEEDBACK 1
#endif
#include "btflod/shader/glsl_generator.hpp"
#include "btflod/shader/shader_config.hpp"

using namespace btflod;

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

std::vector<std::pair<std::string, ShaderConfig>> configs() {
  std::vector<std::pair<std::string, ShaderConfig>> out;
  ShaderConfig a;  // defaults: C = 8, parabolic, barycentric, T = 64 + 4
  out.emplace_back("default", a);
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
  b.laplacian.max_level = 0;
  b.laplacian.ycbcr_output = false;
  b.lpca.clusters = 1;
  b.lpca.grid_resolution = 2;
  b.pca.views_per_group = 151;
  b.pca.light_count = 151;
  out.emplace_back("variant", b);
  ShaderConfig c;
  c.components = 16;
  c.angular.parameterisation = DirectionParameterisation::elevated_concentric;
  c.vt.finest_level = 0;
  out.emplace_back("c16_l0", c);
  return out;
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
    for (const auto& [name, config] : configs()) {
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
  EXPECT_EQ(generated, 3 * 6 * 3 * 2);
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
  EXPECT_NE(a->fragment.find("const int kComponents = 8;"), std::string::npos);
  EXPECT_NE(a->fragment.find("const float kPaddedTile = 72.0;"), std::string::npos);
  EXPECT_NE(a->fragment.find("layout(binding = 5) uniform sampler2DArray btflod_tile_cache;"), std::string::npos);
  c.components = 5;
  auto d = generate_program(ShaderProgram::bsvtf, GlslTarget::gl450_core, c);
  ASSERT_TRUE(d.ok());
  EXPECT_NE(d->fragment.find("const int kGroups = 2;"), std::string::npos);
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
  // The shader's default word must be exactly lod/feedback.hpp's, or votes go to wrong tiles.
  const FeedbackWordLayout l;
  for (uint32_t m : {0u, 1u, 77u, 1022u})
    for (uint32_t level : {0u, 3u, 9u, 15u})
      for (uint32_t x : {0u, 5u, 511u})
        for (uint32_t y : {0u, 300u, 511u}) {
          const uint32_t ours = pack_feedback_word(l, {m, level, x, y});
#ifdef BTFLOD_TEST_HAS_LOD_FEEDBACK
          EXPECT_EQ(ours, pack_feedback(FeedbackTile{m, level, x, y}));
#endif
          // lod/feedback.hpp's documented layout: [31..22] material [21..18] level [17..9] y [8..0] x
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
