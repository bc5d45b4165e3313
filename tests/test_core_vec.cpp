// core/vec.hpp: the GLM-free vectors of the runtime's angular tables compute exactly what GLM
// computes (the tables must stay bit-identical to the GLM code they replaced), and convert to and
// from GLM's types without loss.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <type_traits>

#include <glm/glm.hpp>

#include "btflod/core/vec.hpp"
#include "btflod/offline/math/math.hpp"

namespace {

using namespace btflod;

// Deterministic values over many binades, signs included, so rounding differences would show.
template <class T>
T value(uint64_t i) {
  const uint64_t h = mix_bits64(i);
  const double mantissa = static_cast<double>(h & 0xfffff) / 1048576.0 - 0.5;
  const int exponent = static_cast<int>((h >> 20) % 24) - 12;
  return static_cast<T>(std::ldexp(mantissa, exponent));
}

template <class T>
void expect_ops_match_glm() {
  using G2 = glm::vec<2, T>;
  using G3 = glm::vec<3, T>;
  for (uint64_t i = 0; i < 20000; i += 8) {
    const G2 a2(value<T>(i), value<T>(i + 1)), b2(value<T>(i + 2), value<T>(i + 3));
    const G3 a3(value<T>(i), value<T>(i + 4), value<T>(i + 5)), b3(value<T>(i + 6), value<T>(i + 7), value<T>(i + 1));
    const T s = value<T>(i + 3);
    const Vector2<T> c2(a2), d2(b2);
    const Vector3<T> c3(a3), d3(b3);
    // Exact equality on purpose: these must be the same roundings, not close values.
    EXPECT_EQ(dot(c2, d2), glm::dot(a2, b2));
    EXPECT_EQ(dot(c3, d3), glm::dot(a3, b3));
    EXPECT_EQ(length(c2 - d2), glm::length(a2 - b2));
    EXPECT_EQ(length(c3 + d3), glm::length(a3 + b3));
    EXPECT_EQ(G2(min(c2, d2)), glm::min(a2, b2));
    EXPECT_EQ(G2(max(c2, d2)), glm::max(a2, b2));
    EXPECT_EQ(G3(max(c3, d3)), glm::max(a3, b3));
    EXPECT_EQ(G2(c2 + s), a2 + s);
    EXPECT_EQ(G2(s * c2 - d2), s * a2 - b2);
    EXPECT_EQ(G3(c3 * s / s), a3 * s / s);
    Vector3<T> q = c3;
    G3 g = a3;
    q /= s;
    g /= s;
    EXPECT_EQ(G3(q), g);
  }
}

TEST(CoreVec, FloatOperationsAreGlmsBitForBit) { expect_ops_match_glm<float>(); }

TEST(CoreVec, DoubleOperationsAreGlmsBitForBit) { expect_ops_match_glm<double>(); }

TEST(CoreVec, ConvertsToAndFromGlmAndBetweenPrecisions) {
  const glm::dvec2 g(0.1, -2.5e-300);
  const Vector2d v = g;  // implicit from a type with members x, y of type double
  const glm::dvec2 back = v;
  EXPECT_EQ(back, g);
  // The precisions convert explicitly, each component static_cast as GLM does.
  const Vector2f f(v);
  EXPECT_EQ(glm::vec2(f), glm::vec2(g));
  const Vector3d d(Vector3f(1.0f / 3.0f, 2.0f, -0.1f));
  EXPECT_EQ(glm::dvec3(d), glm::dvec3(glm::vec3(1.0f / 3.0f, 2.0f, -0.1f)));
  // A glm::vec2 never becomes a Vector2d silently (members of exactly the component type).
  static_assert(!std::is_convertible_v<glm::vec2, Vector2d>);
  static_assert(!std::is_convertible_v<Vector2f, Vector2d>);
  static_assert(std::is_convertible_v<glm::vec3, Vector3f>);
}

TEST(CoreVec, SphericalUnitVectorIsTheOfflineDirection) {
  for (int i = 0; i < 400; ++i) {
    const float theta = 0.004f * static_cast<float>(i), phi = -3.1f + 0.0155f * static_cast<float>(i);
    EXPECT_EQ(glm::vec3(unit_vector_from_spherical(theta, phi)), direction_from_spherical(theta, phi));
    const glm::vec3 d = unit_vector_from_spherical(theta, phi);
    EXPECT_NEAR(glm::length(d), 1.0f, 1e-6f);
    EXPECT_NEAR(std::acos(d.z), theta, 2e-3f);
  }
}

}  // namespace
