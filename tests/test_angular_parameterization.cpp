// Tests for offline/angular/parameterization.hpp: map ∘ inverse = identity over the hemisphere, the
// papers' closed forms, area preservation of the elevated concentric map, clamping.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "btflod/offline/angular/parameterization.hpp"

namespace btflod {
namespace {

template <class P>
void expect_round_trip(float max_theta_deg, float tol) {
  // Dense (θ, φ) sweep including the pole, the horizon and the map's region boundaries.
  double worst = 0.0;
  for (int it = 0; it <= 180; ++it) {
    const float theta = degrees_to_radians(max_theta_deg * static_cast<float>(it) / 180.0f);
    for (int ip = 0; ip < 360; ++ip) {
      const float phi = degrees_to_radians(static_cast<float>(ip));
      const glm::vec3 d = direction_from_spherical(theta, phi);
      const glm::vec2 st = P::to_square(d);
      ASSERT_GE(st.x, 0.0f);
      ASSERT_LE(st.x, 1.0f);
      ASSERT_GE(st.y, 0.0f);
      ASSERT_LE(st.y, 1.0f);
      const glm::vec3 back = P::from_square(st);
      worst = std::max(worst, static_cast<double>(glm::length(back - d)));
      ASSERT_NEAR(glm::length(back), 1.0f, 1e-6f);
    }
  }
  EXPECT_LE(worst, tol) << P::kName;
}

TEST(AngularParameterization, ParabolicRoundTripOverHemisphere) { expect_round_trip<ParabolicMap>(90.0f, 1e-6f); }
TEST(AngularParameterization, ConcentricRoundTripOverHemisphere) {
  expect_round_trip<ElevatedConcentricMap>(90.0f, 1e-6f);
}
TEST(AngularParameterization, OrthographicRoundTripAwayFromHorizon) {
  // The orthographic inverse loses precision at grazing angles (dz/dr → ∞): documented.
  expect_round_trip<OrthographicMap>(80.0f, 1e-6f);
}

template <class P>
void expect_square_round_trip() {
  // square → direction → square over the whole square (parabolic: inside the inscribed disk).
  for (int y = 0; y <= 200; ++y)
    for (int x = 0; x <= 200; ++x) {
      const glm::vec2 st(x / 200.0f, y / 200.0f);
      const glm::vec2 c = 2.0f * st - 1.0f;
      if (P::kName != std::string("concentric") && glm::dot(c, c) > 0.98f) continue;
      const glm::vec2 back = P::to_square(P::from_square(st));
      ASSERT_NEAR(back.x, st.x, 2e-6f) << P::kName << " at " << st.x << "," << st.y;
      ASSERT_NEAR(back.y, st.y, 2e-6f) << P::kName << " at " << st.x << "," << st.y;
    }
}

TEST(AngularParameterization, SquareRoundTrip) {
  expect_square_round_trip<ParabolicMap>();
  expect_square_round_trip<ElevatedConcentricMap>();
}

TEST(AngularParameterization, ParabolicMatchesPaperFormula) {
  // paper 000: p = (x, y) / (1 + z); the horizon maps onto the unit circle, the pole to 0.
  const glm::vec3 d = glm::normalize(glm::vec3(0.3f, -0.4f, 0.5f));
  const glm::vec2 st = ParabolicMap::to_square(d);
  EXPECT_NEAR(2.0f * st.x - 1.0f, d.x / (1.0f + d.z), 1e-6f);
  EXPECT_NEAR(2.0f * st.y - 1.0f, d.y / (1.0f + d.z), 1e-6f);
  const glm::vec2 pole = ParabolicMap::to_square({0, 0, 1});
  EXPECT_FLOAT_EQ(pole.x, 0.5f);
  EXPECT_FLOAT_EQ(pole.y, 0.5f);
  const glm::vec2 h = ParabolicMap::to_square({0, 1, 0});
  EXPECT_NEAR(h.y, 1.0f, 1e-7f);
}

TEST(AngularParameterization, ConcentricMatchesPaperFormula) {
  // paper 002 §6.1, first region: ρ = s, φ = (π/4)·t/s; elevation z = 1 − ρ².
  const float a = 0.6f, b = 0.2f;
  const glm::vec3 d = ElevatedConcentricMap::from_square({0.5f * (a + 1.0f), 0.5f * (b + 1.0f)});
  const float rho = a, phi = 0.25f * kPi * b / a;
  EXPECT_NEAR(d.z, 1.0f - rho * rho, 1e-6f);
  EXPECT_NEAR(d.x, rho * std::sqrt(2.0f - rho * rho) * std::cos(phi), 1e-6f);
  EXPECT_NEAR(d.y, rho * std::sqrt(2.0f - rho * rho) * std::sin(phi), 1e-6f);
  // Concentric squares map to rings of equal θ: |a| = const on the square boundary of a
  // centred square gives z = 1 − a² everywhere.
  for (float t = -0.5f; t <= 0.5f; t += 0.125f) {
    EXPECT_NEAR(ElevatedConcentricMap::from_square({0.5f * (0.5f + 1.0f), 0.5f * (t + 1.0f)}).z, 0.75f, 1e-6f);
    EXPECT_NEAR(ElevatedConcentricMap::from_square({0.5f * (t + 1.0f), 0.5f * (-0.5f + 1.0f)}).z, 0.75f, 1e-6f);
  }
  // Square corners reach the horizon; the centre is the normal.
  EXPECT_NEAR(ElevatedConcentricMap::from_square({1, 1}).z, 0.0f, 1e-6f);
  EXPECT_NEAR(ElevatedConcentricMap::from_square({0.5f, 0.5f}).z, 1.0f, 1e-7f);
}

TEST(AngularParameterization, ConcentricIsAreaPreserving) {
  // Uniform points on the square must be uniform on the hemisphere: z is uniform on [0, 1],
  // so the fraction with z > 0.5 is 1/2 and the mean of z is 1/2 (paper 002 §6.1).
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const int n = 200000;
  int above = 0;
  double mean = 0.0;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 d = ElevatedConcentricMap::from_square({u(rng), u(rng)});
    above += d.z > 0.5f;
    mean += d.z;
  }
  EXPECT_NEAR(static_cast<double>(above) / n, 0.5, 0.005);
  EXPECT_NEAR(mean / n, 0.5, 0.005);
  // The parabolic map is not area preserving: the same test must fail for it, by a lot.
  above = 0;
  for (int i = 0; i < n; ++i) above += ParabolicMap::from_square({u(rng), u(rng)}).z > 0.5f;
  EXPECT_GT(std::abs(static_cast<double>(above) / n - 0.5), 0.05);
}

TEST(AngularParameterization, ClampsHostileInput) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (glm::vec3 d : {glm::vec3(0.0f), glm::vec3(nan, 0, 1), glm::vec3(0, 0, -1), glm::vec3(1, 0, -1),
                      glm::vec3(1e30f, 1e30f, 1e30f)}) {
    const glm::vec3 c = clamp_to_hemisphere(d);
    EXPECT_GE(c.z, 0.0f);
    EXPECT_NEAR(glm::length(c), 1.0f, 1e-6f);
    for (glm::vec2 st :
         {ParabolicMap::to_square(d), ElevatedConcentricMap::to_square(d), OrthographicMap::to_square(d)}) {
      EXPECT_TRUE(st.x >= 0.0f && st.x <= 1.0f && st.y >= 0.0f && st.y <= 1.0f);
    }
  }
  // Below the horizon projects onto it.
  const glm::vec3 c = clamp_to_hemisphere({1, 0, -1});
  EXPECT_NEAR(c.x, 1.0f, 1e-7f);
  EXPECT_EQ(c.z, 0.0f);
  // Square points outside [0, 1]² or NaN still give unit upper directions.
  for (glm::vec2 st : {glm::vec2(-3, 4), glm::vec2(nan, 0.5f), glm::vec2(1, 1)}) {
    for (glm::vec3 d :
         {ParabolicMap::from_square(st), ElevatedConcentricMap::from_square(st), OrthographicMap::from_square(st)}) {
      EXPECT_NEAR(glm::length(d), 1.0f, 1e-6f);
      EXPECT_GE(d.z, 0.0f);
    }
  }
}

}  // namespace
}  // namespace btflod
