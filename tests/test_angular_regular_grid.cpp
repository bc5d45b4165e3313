// Tests for offline/angular/regular_grid.hpp (paper 002 §6.2): the volume holds the function at the
// grid nodes, "two trilinear fetches + one lerp" equals 4D multilinear interpolation, the
// shader texture coordinates address the right texels, and bad sizes are rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "btflod/offline/angular/regular_grid.hpp"

namespace btflod {
namespace {

// A function of the four square coordinates, evaluated through the directions the grid hands
// to the sampler (so the test sees exactly what resample() sees).
template <class P>
glm::vec4 coords(glm::vec3 light, glm::vec3 view) {
  const glm::vec2 l = P::to_square(light), v = P::to_square(view);
  return {v.x, v.y, l.x, l.y};
}

float multilinear(glm::vec4 c) {
  // Multilinear (degree ≤ 1 in each variable) so 4D linear interpolation reproduces it.
  return 0.2f + 0.7f * c.x - 0.4f * c.y + 0.9f * c.z * c.w + 0.3f * c.x * c.y * c.z - 0.5f * c.w;
}

float smooth(glm::vec4 c) { return std::sin(3.0f * c.x) * std::cos(2.0f * c.y) + c.z * c.z * c.w; }

// Reference 4D multilinear interpolation straight from the node values.
template <class F>
float quadrilinear_ref(F f, int nv, int nl, glm::vec4 c) {
  float u[4] = {c.x * (nv - 1), c.y * (nv - 1), c.z * (nl - 1), c.w * (nl - 1)};
  const int n[4] = {nv, nv, nl, nl};
  int i0[4];
  float fr[4];
  for (int a = 0; a < 4; ++a) {
    i0[a] = std::min(static_cast<int>(std::floor(u[a])), n[a] - 2);
    fr[a] = u[a] - i0[a];
  }
  float sum = 0.0f;
  for (int corner = 0; corner < 16; ++corner) {
    float w = 1.0f;
    glm::vec4 node;
    for (int a = 0; a < 4; ++a) {
      const int bit = (corner >> a) & 1;
      w *= bit ? fr[a] : 1.0f - fr[a];
      node[a] = static_cast<float>(i0[a] + bit) / static_cast<float>(n[a] - 1);
    }
    sum += w * f(node);
  }
  return sum;
}

TEST(AngularRegularGrid, NodesHoldTheFunctionAndLayoutIsSlabbed) {
  using P = ElevatedConcentricMap;
  const int nv = 5, nl = 4;
  auto g = RegularAngularGrid<P>::resample(nv, nl, 2, [](glm::vec3 l, glm::vec3 v, float* out) {
    const glm::vec4 c = coords<P>(l, v);
    out[0] = smooth(c);
    out[1] = 1.0f;
  });
  ASSERT_TRUE(g.ok()) << g.message();
  EXPECT_EQ(g->volume_depth(), nl * nl);
  EXPECT_EQ(g->data().size(), static_cast<size_t>(nv * nv * nl * nl * 2));
  // Texel (x, y, i·nl + k) is node (s_v, t_v, s_l, t_l) = (x, y, k, i)/(n − 1).
  for (int i = 0; i < nl; ++i)
    for (int k = 0; k < nl; ++k)
      for (int y = 0; y < nv; ++y)
        for (int x = 0; x < nv; ++x) {
          const glm::vec4 c(x / float(nv - 1), y / float(nv - 1), k / float(nl - 1), i / float(nl - 1));
          EXPECT_NEAR(g->texel(x, y, i * nl + k)[0], smooth(c), 2e-5f);
          float out[2];
          g->evaluate_square({c.z, c.w}, {c.x, c.y}, out);
          EXPECT_NEAR(out[0], smooth(c), 2e-5f);
          EXPECT_FLOAT_EQ(out[1], 1.0f);
        }
}

TEST(AngularRegularGrid, TrilinearPlusLerpEqualsQuadrilinear) {
  using P = ElevatedConcentricMap;
  const int nv = 9, nl = 7;
  auto g = RegularAngularGrid<P>::resample(
      nv, nl, 1, [](glm::vec3 l, glm::vec3 v, float* out) { out[0] = smooth(coords<P>(l, v)); });
  ASSERT_TRUE(g.ok());
  auto lin = RegularAngularGrid<P>::resample(
      nv, nl, 1, [](glm::vec3 l, glm::vec3 v, float* out) { out[0] = multilinear(coords<P>(l, v)); });
  ASSERT_TRUE(lin.ok());
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int it = 0; it < 5000; ++it) {
    const glm::vec4 c(u(rng), u(rng), u(rng), u(rng));
    float out;
    g->evaluate_square({c.z, c.w}, {c.x, c.y}, &out);
    ASSERT_NEAR(out, quadrilinear_ref(smooth, nv, nl, c), 5e-5f);
    lin->evaluate_square({c.z, c.w}, {c.x, c.y}, &out);
    ASSERT_NEAR(out, multilinear(c), 5e-5f);  // exact for multilinear functions
    // Through directions: the same as through their square coordinates.
    const glm::vec3 ld = P::from_square({c.z, c.w}), vd = P::from_square({c.x, c.y});
    float out2;
    lin->evaluate(ld, vd, &out2);
    ASSERT_NEAR(out2, multilinear(coords<P>(ld, vd)), 5e-5f);
  }
  // Slab edges: s_l = 1 must not bleed into the next slab (the half-texel terms).
  float edge;
  lin->evaluate_square({1.0f, 0.5f}, {0.3f, 0.6f}, &edge);
  EXPECT_NEAR(edge, multilinear({0.3f, 0.6f, 1.0f, 0.5f}), 5e-5f);
}

TEST(AngularRegularGrid, ShaderCoordinatesAddressTheSlabs) {
  auto g = RegularAngularGrid<ParabolicMap>::resample(4, 5, 1, [](glm::vec3, glm::vec3, float* out) { out[0] = 0; });
  ASSERT_TRUE(g.ok());
  // t_l = 0.6 → u = 0.6·4 = 2.4: slabs 2 and 3, w = 0.4; s_l = 0.25 → in-slab texel 1.0,
  // depth texel centres 2·5 + 1 and 3·5 + 1 → z = (11 + 0.5)/25 and (16 + 0.5)/25.
  const LightSlabCoordinates c = g->light_slabs({0.25f, 0.6f});
  EXPECT_EQ(c.slab0, 2);
  EXPECT_EQ(c.slab1, 3);
  EXPECT_NEAR(c.w, 0.4f, 1e-6f);
  EXPECT_NEAR(c.z0, 11.5f / 25.0f, 1e-6f);
  EXPECT_NEAR(c.z1, 16.5f / 25.0f, 1e-6f);
  const LightSlabCoordinates top = g->light_slabs({0.0f, 1.0f});
  EXPECT_EQ(top.slab0, 4);
  EXPECT_EQ(top.slab1, 4);
}

TEST(AngularRegularGrid, RejectsBadSizes) {
  auto f = [](glm::vec3, glm::vec3, float* out) { out[0] = 0; };
  EXPECT_EQ(RegularAngularGrid<>::resample(1, 4, 1, f).status(), Status::invalid_argument);
  EXPECT_EQ(RegularAngularGrid<>::resample(4, 300, 1, f).status(), Status::invalid_argument);
  EXPECT_EQ(RegularAngularGrid<>::resample(4, 4, 0, f).status(), Status::invalid_argument);
  EXPECT_EQ(RegularAngularGrid<>::resample(4, 4, 17, f).status(), Status::invalid_argument);
  EXPECT_EQ(RegularAngularGrid<>::resample(256, 256, 16, f).status(), Status::invalid_argument);
}

}  // namespace
}  // namespace btflod
