// Filament target (runtime/shader/filament_material.hpp): every material kind × config compiles with
// Filament's own material compiler for desktop GLSL 4.10 and mobile ESSL 3.00 (`matc -p all`;
// skipped with a message when matc is missing); the limits matc does not enforce hold (at most 8
// samplers, it only warns past them; no #version, textureQueryLevels, storage buffers or binding
// qualifiers in material code); every sampler the code reads is a declared parameter; the feedback
// bytes round-trip to the word (and a cleared texel is the empty word); bad options are refused;
// the output is deterministic. The sample (samples/filament, test filament_sample) renders with it.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/shader/filament_material.hpp"
#include "test_shader_text_cases.hpp"

using namespace btflod;

namespace {

std::vector<std::pair<std::string, ShaderConfig>> configs() {
  std::vector<std::pair<std::string, ShaderConfig>> out;
  out.emplace_back("default", ShaderConfig{});
  out.emplace_back("variant", shader_text::variant_vt_config());  // odd C, concentric, nearest, moved word
  ShaderConfig c;  // the compact cache: RGBA8 texels and the slot-map table
  c.vt.format = CacheFormat::rgba8_affine;
  out.emplace_back("rgba8", c);
  return out;
}

constexpr FilamentMaterialKind kKinds[] = {FilamentMaterialKind::bsvtf, FilamentMaterialKind::fmf,
                                           FilamentMaterialKind::feedback};

std::string matc_path() {
  if (const char* env = std::getenv("BTFLOD_MATC")) return env;
  std::FILE* p = popen("command -v matc 2>/dev/null", "r");
  if (!p) return {};
  char buf[512] = {};
  const bool got = std::fgets(buf, sizeof buf, p) != nullptr;
  pclose(p);
  std::string s = got ? buf : "";
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
  return s;
}

// Runs matc on `source`; returns its exit status and output (stdout + stderr).
int run_matc(const std::string& matc, const std::string& name, const std::string& source, std::string& output) {
  const std::string dir = ::testing::TempDir();
  const std::string in = dir + "/" + name + ".mat", out = dir + "/" + name + ".filamat",
                    log = dir + "/" + name + ".log";
  std::ofstream(in, std::ios::binary) << source;
  const int rc =
      std::system(("'" + matc + "' -p all -a opengl -o '" + out + "' '" + in + "' > '" + log + "' 2>&1").c_str());
  std::ifstream l(log);
  output.assign(std::istreambuf_iterator<char>(l), std::istreambuf_iterator<char>());
  return rc;
}

std::string fragment_block(const std::string& mat) { return mat.substr(mat.find("\nfragment {")); }

}  // namespace

TEST(ShaderFilament, EveryMaterialCompilesWithMatcForDesktopAndMobile) {
  const std::string matc = matc_path();
  if (matc.empty()) GTEST_SKIP() << "matc not found (Debian: libfilament-tools); set BTFLOD_MATC to its path";
  for (const auto& [config_name, config] : configs())
    for (FilamentMaterialKind kind : kKinds) {
      auto mat = generate_filament_material(kind, config);
      ASSERT_TRUE(mat.ok()) << mat.message();
      std::string output;
      const std::string name = config_name + "_" + filament_material_kind_name(kind);
      const int rc = run_matc(matc, name, *mat, output);
      EXPECT_EQ(rc, 0) << name << ":\n" << output << "\n" << *mat;
      EXPECT_EQ(output.find("ERROR"), std::string::npos) << name << ":\n" << output;
      EXPECT_EQ(output.find("arning"), std::string::npos) << name << ": matc warned:\n" << output;
    }
}

TEST(ShaderFilament, StaysWithinFilamentLimitsMatcDoesNotEnforce) {
  for (const auto& [config_name, config] : configs())
    for (FilamentMaterialKind kind : kKinds) {
      auto mat = generate_filament_material(kind, config);
      ASSERT_TRUE(mat.ok()) << mat.message();
      // At most 8 sampler parameters (matc only warns past them and the material then fails at run time).
      const std::regex sampler_param(R"(\{ type : sampler\w+, name : (\w+))");
      std::set<std::string> declared;
      for (auto it = std::sregex_iterator(mat->begin(), mat->end(), sampler_param); it != std::sregex_iterator(); ++it)
        declared.insert((*it)[1]);
      EXPECT_LE(declared.size(), 8u) << config_name;
      EXPECT_EQ(declared.size(), filament_material_samplers(kind, config.vt.format).size());
      for (ShaderBinding role : filament_material_samplers(kind, config.vt.format))
        EXPECT_TRUE(declared.count(filament_sampler_parameter(role))) << shader_binding_name(role);
      // Material code: GLSL 4.10 / ESSL 3.00, no declarations Filament makes itself.
      const std::string code = fragment_block(*mat);
      for (const char* banned :
           {"#version", "textureQueryLevels", "layout(", "\nbuffer ", "\nuniform ", "\nprecision "})
        EXPECT_EQ(code.find(banned), std::string::npos)
            << config_name << " " << filament_material_kind_name(kind) << " uses " << banned;
      // Every sampler the code reads is one of the declared parameters.
      const std::regex used(R"(materialParams_(\w+))");
      for (auto it = std::sregex_iterator(code.begin(), code.end(), used); it != std::sregex_iterator(); ++it)
        EXPECT_TRUE(declared.count((*it)[1])) << "reads undeclared sampler " << (*it)[1];
      EXPECT_NE(mat->find("flipUV : false"), std::string::npos) << "uv must reach the page table unflipped";
      EXPECT_NE(mat->find("shadingModel : unlit"), std::string::npos);
      // Deterministic.
      EXPECT_EQ(*mat, *generate_filament_material(kind, config));
    }
}

TEST(ShaderFilament, LitMaterialsTakeTheLightAndTheMeshFrameAsDocumented) {
  auto mat = generate_filament_material(FilamentMaterialKind::bsvtf, ShaderConfig{});
  ASSERT_TRUE(mat.ok());
  for (const char* p :
       {kFilamentParamVtExtent, kFilamentParamLod, kFilamentParamIds, kFilamentParamLight, kFilamentParamLightColor})
    EXPECT_NE(mat->find(std::string("name : ") + p), std::string::npos) << p;
  EXPECT_NE(mat->find("requires : [ uv0, tangents ]"), std::string::npos);
  EXPECT_NE(mat->find("toTangentFrame(mesh_tangents"), std::string::npos);
  EXPECT_NE(mat->find("btflod_bsvtf(uv, wl, wv)"), std::string::npos);
  auto fb = generate_filament_material(FilamentMaterialKind::feedback, ShaderConfig{});
  ASSERT_TRUE(fb.ok());
  EXPECT_EQ(fb->find(kFilamentParamLight), std::string::npos);
  EXPECT_NE(fb->find("btflod_feedback_word(uv) ^ 4294967295u"), std::string::npos);
}

TEST(ShaderFilament, FeedbackBytesRoundTripAndClearedTexelsAreEmpty) {
  // What the feedback material writes: byte k of (word ^ empty) in channel k.
  const uint32_t words[3] = {pack_feedback({5, 3, 7, 2}), pack_feedback({1022, 9, 511, 511}), kFeedbackNone};
  std::vector<uint8_t> rgba;
  for (uint32_t w : words)
    for (int k = 0; k < 4; ++k) rgba.push_back(static_cast<uint8_t>(((w ^ kFeedbackNone) >> (8 * k)) & 0xffu));
  for (int k = 0; k < 4; ++k) rgba.push_back(0);  // a texel the pass never wrote (cleared to 0)
  std::vector<uint32_t> out(4);
  ASSERT_EQ(feedback_words_from_rgba8(rgba, 2, 2, false, out), Status::success);
  EXPECT_EQ(out[0], words[0]);
  EXPECT_EQ(out[1], words[1]);
  EXPECT_EQ(out[2], kFeedbackNone);
  EXPECT_EQ(out[3], kFeedbackNone);
  // Bottom-up readback: rows swap.
  ASSERT_EQ(feedback_words_from_rgba8(rgba, 2, 2, true, out), Status::success);
  EXPECT_EQ(out[0], kFeedbackNone);
  EXPECT_EQ(out[2], words[0]);
  // Sizes that do not match are refused and nothing is written.
  std::vector<uint32_t> small(3, 7u);
  EXPECT_EQ(feedback_words_from_rgba8(rgba, 2, 2, false, small), Status::invalid_argument);
  EXPECT_EQ(small[0], 7u);
}

TEST(ShaderFilament, RefusesBadOptionsAndConfigs) {
  FilamentMaterialOptions o;
  o.name = "x, shadingModel : lit";
  EXPECT_FALSE(generate_filament_material(FilamentMaterialKind::bsvtf, ShaderConfig{}, o).ok());
  o.name = "ok_name";
  o.culling = "none }";
  EXPECT_FALSE(generate_filament_material(FilamentMaterialKind::bsvtf, ShaderConfig{}, o).ok());
  ShaderConfig bad;
  bad.components = 0;
  auto r = generate_filament_material(FilamentMaterialKind::fmf, bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("components"), std::string::npos);
  o.culling = "back";
  auto named = generate_filament_material(FilamentMaterialKind::fmf, ShaderConfig{}, o);
  ASSERT_TRUE(named.ok());
  EXPECT_NE(named->find("name : ok_name,"), std::string::npos);
  EXPECT_NE(named->find("culling : back,"), std::string::npos);
}

TEST(ShaderFilament, CompactCacheMaterialsDeclareTheSlotMapTable) {
  ShaderConfig config;
  config.vt.format = CacheFormat::rgba8_affine;
  auto bsvtf = generate_filament_material(FilamentMaterialKind::bsvtf, config);
  ASSERT_TRUE(bsvtf.ok()) << bsvtf.message();
  // The per-slot maps: a uint 2D sampler the cache sample reads after its fetch (unpackHalf2x16).
  EXPECT_NE(bsvtf->find("{ type : sampler2d, name : btflod_slot_map, format : uint, precision : high }"),
            std::string::npos)
      << *bsvtf;
  EXPECT_NE(fragment_block(*bsvtf).find("materialParams_btflod_slot_map"), std::string::npos);
  EXPECT_EQ(filament_material_samplers(FilamentMaterialKind::bsvtf, CacheFormat::rgba8_affine).size(),
            filament_material_samplers(FilamentMaterialKind::bsvtf).size() + 1);
  // The other materials read no cache texel: the same text as for an rgba16f cache.
  for (FilamentMaterialKind kind : {FilamentMaterialKind::fmf, FilamentMaterialKind::feedback})
    EXPECT_EQ(*generate_filament_material(kind, config), *generate_filament_material(kind, ShaderConfig{}));
  auto plain = generate_filament_material(FilamentMaterialKind::bsvtf, ShaderConfig{});
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->find("slot_map"), std::string::npos);
}
