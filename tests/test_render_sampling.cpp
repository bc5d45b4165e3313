// Tests for offline/render/sampling.hpp: the per-pixel generator is a pure function of its key and
// uniform; cosine hemisphere samples have the cos/π density (E[cos θ] = 2/3); the spherical
// rectangle's solid angle matches the closed form and its samples lie on the rectangle,
// uniformly in solid angle (the solid-angle and area estimators of the same integral agree).
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "btflod/offline/render/sampling.hpp"

namespace btflod {
namespace {

TEST(RenderSampling, PixelRngIsAPureFunctionOfItsKey) {
  PixelRng a = PixelRng::for_pixel(7, 3, 4, 5, 1), b = PixelRng::for_pixel(7, 3, 4, 5, 1);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(a.next_u64(), b.next_u64());
  // Any component of the key changes the stream.
  std::set<uint64_t> firsts;
  firsts.insert(PixelRng::for_pixel(7, 3, 4, 5, 1).next_u64());
  firsts.insert(PixelRng::for_pixel(8, 3, 4, 5, 1).next_u64());
  firsts.insert(PixelRng::for_pixel(7, 4, 3, 5, 1).next_u64());
  firsts.insert(PixelRng::for_pixel(7, 3, 4, 6, 1).next_u64());
  firsts.insert(PixelRng::for_pixel(7, 3, 4, 5, 2).next_u64());
  EXPECT_EQ(firsts.size(), 5u);
}

TEST(RenderSampling, PixelRngFloatsAreUniformInUnitInterval) {
  double sum = 0, sum2 = 0;
  const int n = 200000;
  int bins[10] = {};
  for (int i = 0; i < n; ++i) {
    PixelRng r = PixelRng::for_pixel(1, static_cast<uint32_t>(i % 512), static_cast<uint32_t>(i / 512), 0);
    const float f = r.next_float();
    ASSERT_GE(f, 0.0f);
    ASSERT_LT(f, 1.0f);
    sum += f, sum2 += f * f;
    ++bins[static_cast<int>(f * 10)];
  }
  EXPECT_NEAR(sum / n, 0.5, 0.005);
  EXPECT_NEAR(sum2 / n - (sum / n) * (sum / n), 1.0 / 12.0, 0.002);
  for (int b : bins) EXPECT_NEAR(b, n / 10, n / 100);
}

TEST(RenderSampling, CosineHemisphereHasCosineDensity) {
  PixelRng r(42);
  double mean_z = 0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 d = sample_cosine_hemisphere(r.next_vec2());
    ASSERT_GE(d.z, 0.0f);
    ASSERT_NEAR(glm::length(d), 1.0f, 1e-5f);
    mean_z += d.z;
  }
  // ∫ cos · (cos/π) dω = 2/3 (a uniform hemisphere would give 1/2).
  EXPECT_NEAR(mean_z / n, 2.0 / 3.0, 0.005);
  EXPECT_FLOAT_EQ(cosine_hemisphere_pdf({0, 0, 1}), 1.0f / kPi);
  EXPECT_EQ(cosine_hemisphere_pdf({0, 0, -1}), 0.0f);
}

TEST(RenderSampling, SphericalRectangleSolidAngleMatchesClosedForm) {
  // A centred a × b rectangle at distance d: Ω = 4·asin(a·b / sqrt((a² + 4d²)(b² + 4d²))).
  const float a = 2.0f, b = 1.0f, d = 1.5f;
  const glm::vec3 p(0.0f);
  const auto rect = SphericalRectangle::build(p, {-a / 2, -b / 2, d}, {a, 0, 0}, {0, b, 0});
  ASSERT_TRUE(rect.valid());
  const double exact = 4.0 * std::asin(a * b / std::sqrt((a * a + 4 * d * d) * (b * b + 4 * d * d)));
  EXPECT_NEAR(rect.solid_angle(), exact, 1e-4);
  // Same from the other side (the frame flips), and 0 in the plane.
  const auto back = SphericalRectangle::build({0, 0, 2 * d}, {-a / 2, -b / 2, d}, {a, 0, 0}, {0, b, 0});
  EXPECT_NEAR(back.solid_angle(), exact, 1e-4);
  EXPECT_FALSE(SphericalRectangle::build({5, 0, d}, {-a / 2, -b / 2, d}, {a, 0, 0}, {0, b, 0}).valid());
}

TEST(RenderSampling, SphericalRectangleSamplesAreUniformInSolidAngle) {
  // Off-centre, tilted view: compare Ω·mean(cos θ_p) (solid-angle sampling) with the area
  // estimator A·mean(cos θ_p·cos θ_l / r²) of the same integral ∫ cos θ_p dω.
  const glm::vec3 p(0.3f, -0.2f, 0.0f), corner(0.5f, 0.4f, 1.0f), eu(1.2f, 0, 0), ev(0, 0.8f, 0.4f);
  const auto rect = SphericalRectangle::build(p, corner, eu, ev);
  ASSERT_TRUE(rect.valid());
  const glm::vec3 n_l = glm::normalize(glm::cross(eu, ev));
  PixelRng r(9);
  double sum_solid = 0, sum_area = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 y = rect.sample(r.next_vec2());
    // On the rectangle: within its plane and its extent.
    const glm::vec3 q = y - corner;
    ASSERT_NEAR(glm::dot(q, n_l), 0.0f, 1e-4f);
    ASSERT_GE(glm::dot(q, eu) / glm::dot(eu, eu), -1e-4f);
    ASSERT_LE(glm::dot(q, eu) / glm::dot(eu, eu), 1.0f + 1e-4f);
    ASSERT_GE(glm::dot(q, ev) / glm::dot(ev, ev), -1e-4f);
    ASSERT_LE(glm::dot(q, ev) / glm::dot(ev, ev), 1.0f + 1e-4f);
    sum_solid += glm::normalize(y - p).z;
    const glm::vec3 ya = corner + r.next_float() * eu + r.next_float() * ev;
    const glm::vec3 w = ya - p;
    const float r2 = glm::dot(w, w);
    sum_area += (w.z / std::sqrt(r2)) * std::abs(glm::dot(n_l, w)) / std::sqrt(r2) / r2;
  }
  const double by_solid = rect.solid_angle() * sum_solid / n;
  const double by_area = glm::length(eu) * glm::length(ev) * sum_area / n;
  EXPECT_NEAR(by_solid, by_area, 0.01 * by_area);
}

}  // namespace
}  // namespace btflod
