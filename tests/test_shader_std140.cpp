// runtime/shader/std140.hpp and ShaderParams: the plain std140 types hold exactly the bytes GLM's types
// held (the backends memcpy ShaderParams into a uniform buffer), convert both ways with GLM, and
// the CPU twin of the shaders' direction map agrees with the angular module's maps and hand values.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <type_traits>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "btflod/offline/angular/parameterization.hpp"
#include "btflod/runtime/shader/shader_config.hpp"
#include "btflod/runtime/shader/std140.hpp"

using namespace btflod;

TEST(ShaderStd140, MatrixHoldsGlmBytesColumnMajorAndRoundTrips) {
  const glm::mat4 m = glm::perspective(0.9f, 1.5f, 0.1f, 50.0f) *
                      glm::lookAt(glm::vec3(1, 2, 3), glm::vec3(0, 0, 0), glm::vec3(0, 1, 0));
  const Float4x4 f = m;
  static_assert(sizeof(Float4x4) == sizeof(glm::mat4));
  EXPECT_EQ(std::memcmp(&f, &m, sizeof m), 0) << "the uniform buffer bytes changed";
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_EQ(f(c, r), m[c][r]);
  const glm::mat4 back = f;
  EXPECT_EQ(back, m);
  EXPECT_EQ(glm::mat4(Float4x4{}), glm::mat4(1.0f)) << "default is the identity";
}

TEST(ShaderStd140, VectorsRoundTripWithGlm) {
  const Float4 v = glm::vec4(1.5f, -2.0f, 3.25f, 4.0f);
  EXPECT_EQ(v, Float4(1.5f, -2.0f, 3.25f, 4.0f));
  EXPECT_EQ(glm::vec4(v), glm::vec4(1.5f, -2.0f, 3.25f, 4.0f));
  EXPECT_EQ(glm::vec3(v), glm::vec3(1.5f, -2.0f, 3.25f)) << "explicit xyz, as glm::vec3(vec4)";
  const UInt4 u = glm::uvec4(1u, 2u, 0xffffffffu, 7u);
  EXPECT_EQ(glm::uvec4(u), glm::uvec4(1u, 2u, 0xffffffffu, 7u));
  const Float2 p = glm::vec2(0.25f, 0.75f);
  EXPECT_EQ(glm::vec2(p), glm::vec2(0.25f, 0.75f));
  const Int2 i = glm::ivec2(-3, 9);
  EXPECT_EQ(glm::ivec2(i), glm::ivec2(-3, 9));
  const Float3 d = glm::vec3(0.0f, 0.6f, 0.8f);
  EXPECT_EQ(glm::vec3(d), glm::vec3(0.0f, 0.6f, 0.8f));
  // No silent conversion between the block types themselves, nor vec4 → vec3 without a cast.
  static_assert(!std::is_convertible_v<Float4, UInt4> && !std::is_convertible_v<UInt4, Float4>);
  static_assert(!std::is_convertible_v<Float2, Int2> && !std::is_convertible_v<Int2, Float2>);
  static_assert(!std::is_convertible_v<Float4, glm::vec3>);
}

TEST(ShaderStd140, ShaderParamsKeepsTheLayoutAndDefaultsOfTheGlmBlock) {
  // The block as it was declared with GLM members (the shaders' BtflodParams, std140).
  struct GlmParams {
    glm::mat4 model_view_proj{1.0f};
    glm::mat4 model{1.0f};
    glm::vec4 camera_pos{0.0f, 0.0f, 1.0f, 1.0f};
    glm::vec4 light{0.0f, 0.0f, 1.0f, 0.0f};
    glm::vec4 light_color{1.0f, 1.0f, 1.0f, 1.0f};
    glm::vec4 lod{0.0f, 0.0f, 1.0f, 0.0f};
    glm::vec4 vt_extent{256.0f, 256.0f, 2.0f, 0.0f};
    glm::uvec4 ids{0u, 0u, 0u, 0u};
  };
  static_assert(sizeof(GlmParams) == sizeof(ShaderParams));
  GlmParams g;
  ShaderParams s;
  EXPECT_EQ(std::memcmp(&g, &s, sizeof s), 0) << "default values";
  g.model_view_proj = glm::translate(glm::mat4(1.0f), glm::vec3(1, 2, 3));
  g.light = glm::vec4(0.3f, 0.4f, 0.5f, 1.0f);
  g.ids = glm::uvec4(4u, 5u, 1u, 2u);
  s.model_view_proj = g.model_view_proj;
  s.light = g.light;
  s.ids = g.ids;
  EXPECT_EQ(std::memcmp(&g, &s, sizeof s), 0) << "assigned from GLM";
}

// The CPU twin of the shaders' direction map against values computed independently of it: the
// angular module's maps in double precision (offline/angular/parameterization.hpp, written for the
// triangulation), the inverse maps (from_square: the forward Shirley–Chiu map and the elevation,
// a different formula) bringing the direction back, and values worked out by hand.
TEST(ShaderStd140, DirectionMapTwinMatchesTheAngularMapsAndHandValues) {
  using P = DirectionParameterisation;
  const auto twin = [](P p, glm::vec3 d) { return glm::vec2(shader_direction_to_unit_square(p, d)); };
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (P p : {P::parabolic, P::elevated_concentric}) {
    for (int i = 0; i < 20000; ++i) {
      const glm::vec3 d(u(rng), u(rng), u(rng));
      const glm::vec2 got = twin(p, d);
      const glm::dvec2 want = p == P::parabolic ? ParabolicMap::to_square_precise(glm::dvec3(d))
                                                : ElevatedConcentricMap::to_square_precise(glm::dvec3(d));
      ASSERT_NEAR(got.x, want.x, 2e-6) << d.x << " " << d.y << " " << d.z;
      ASSERT_NEAR(got.y, want.y, 2e-6) << d.x << " " << d.y << " " << d.z;
      // The inverse map returns the direction clamped onto the hemisphere.
      glm::vec3 h(d.x, d.y, std::max(d.z, 0.0f));
      if (glm::length(h) < 1e-3f) continue;
      h = glm::normalize(h);
      const glm::vec3 back =
          p == P::parabolic ? ParabolicMap::from_square(got) : ElevatedConcentricMap::from_square(got);
      ASSERT_LT(glm::length(back - h), 1e-5f) << d.x << " " << d.y << " " << d.z;
      const glm::ivec2 t = shader_table_texel(got, 33);
      ASSERT_GE(t.x, 0);
      ASSERT_LT(t.x, 33);
      ASSERT_GE(t.y, 0);
      ASSERT_LT(t.y, 33);
    }
    // By hand: the pole is the centre, the horizon's axis points are the edges' midpoints,
    // a zero vector (and straight down, clamped to zero) maps to the centre.
    for (glm::vec3 d : {glm::vec3(0, 0, 1), glm::vec3(0, 0, 0), glm::vec3(0, 0, -1)})
      EXPECT_EQ(twin(p, d), glm::vec2(0.5f)) << d.x << " " << d.y << " " << d.z;
    EXPECT_EQ(twin(p, {1, 0, 0}), glm::vec2(1.0f, 0.5f));
    EXPECT_EQ(twin(p, {0, 1, 0}), glm::vec2(0.5f, 1.0f));
    EXPECT_EQ(twin(p, {-1, 0, 0}), glm::vec2(0.0f, 0.5f));
    EXPECT_EQ(twin(p, {0, -1, 0}), glm::vec2(0.5f, 0.0f));
  }
  // θ = 60° towards +x (z = 1/2): parabolic x/(1 + z) = tan 30°; elevated concentric ρ = √(1 − z).
  const glm::vec3 d60(std::sqrt(3.0f) / 2, 0, 0.5f);
  EXPECT_NEAR(twin(P::parabolic, d60).x, 0.5 + 0.5 / std::sqrt(3.0), 1e-6);
  EXPECT_NEAR(twin(P::elevated_concentric, d60).x, 0.5 + 0.5 * std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(twin(P::elevated_concentric, d60).y, 0.5, 1e-6);
  // The horizon's diagonal: the parabolic disk's rim at 45°, the concentric square's corner.
  const glm::vec3 diagonal(std::sqrt(0.5f), std::sqrt(0.5f), 0);
  EXPECT_NEAR(twin(P::parabolic, diagonal).x, 0.5 + 0.5 * std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(twin(P::elevated_concentric, diagonal).x, 1.0, 1e-6);
  EXPECT_NEAR(twin(P::elevated_concentric, diagonal).y, 1.0, 1e-6);
}

TEST(ShaderStd140, NoTruncatingConversionFromOtherComponentTypes) {
  static_assert(std::is_convertible_v<glm::ivec2, Int2> && !std::is_convertible_v<glm::vec2, Int2>);
  static_assert(std::is_convertible_v<glm::uvec4, UInt4> && !std::is_convertible_v<glm::vec4, UInt4>);
  static_assert(!std::is_convertible_v<glm::ivec4, Float4>);
  SUCCEED();
}
