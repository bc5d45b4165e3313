// Angular interpolation against real measurements: the car-paint BRDFs of
// ../shared/data/measured/ (skipped with a message when the folder is absent). Reconstruction
// is exact at the measured light × view pairs, linear interpolation beats the nearest
// direction, and the denser UBO2014 set beats UBO2003.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/nine_tap.hpp"
#include "btflod/offline/angular/ring_search.hpp"
#include "btflod/offline/btf/measured_brdf.hpp"

namespace btflod {
namespace {

std::string paint_path() { return std::string(BTFLOD_SHARED_DIR) + "/data/measured/carpaint_red.mbsdf"; }

std::vector<glm::vec3> tabulate(const MeasuredBrdf& b, const DirectionSet& set) {
  std::vector<glm::vec3> t(set.size() * set.size());
  for (size_t l = 0; l < set.size(); ++l)
    for (size_t v = 0; v < set.size(); ++v) t[l * set.size() + v] = b.evaluate(set[l].vector, set[v].vector);
  return t;
}

template <class I>
double held_out_error(const MeasuredBrdf& b, const DirectionSet& set, const I& interp, bool mae) {
  const auto table = tabulate(b, set);
  const size_t n = set.size();
  std::mt19937 rng(123);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float zmin = std::cos(degrees_to_radians(75.0f));
  auto dir = [&] {
    const float z = zmin + (1.0f - zmin) * u(rng), phi = kTwoPi * u(rng), r = std::sqrt(1.0f - z * z);
    return glm::vec3(r * std::cos(phi), r * std::sin(phi), z);
  };
  double acc = 0.0;
  const int samples = 4000;
  for (int i = 0; i < samples; ++i) {
    const glm::vec3 l = dir(), v = dir();
    const glm::vec3 got =
        interpolate_light_view(interp, interp, l, v, [&](uint32_t a, uint32_t c) noexcept { return table[a * n + c]; });
    const glm::vec3 e = got - b.evaluate(l, v);
    acc += mae ? (std::abs(e.x) + std::abs(e.y) + std::abs(e.z)) : glm::dot(e, e);
  }
  return mae ? acc / (3.0 * samples) : std::sqrt(acc / (3.0 * samples));
}

class AngularMeasured : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(paint_path())) GTEST_SKIP() << "measured data not found at " << paint_path();
    auto b = read_mbsdf(paint_path());
    ASSERT_TRUE(b.ok()) << b.message();
    brdf_ = std::move(b.value());
  }
  MeasuredBrdf brdf_;
};

TEST_F(AngularMeasured, ExactAtMeasuredPairs) {
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    const auto table = tabulate(brdf_, set);
    const size_t n = set.size();
    auto grid = ExactGridInterpolator<ElevatedConcentricMap>::build(set);
    auto ring = RingSearchInterpolator::build(set);
    ASSERT_TRUE(grid.ok() && ring.ok());
    auto fetch = [&](uint32_t a, uint32_t c) noexcept { return table[a * n + c]; };
    for (size_t l = 0; l < n; l += 3)
      for (size_t v = 0; v < n; v += 2) {
        const glm::vec3 truth = table[l * n + v];
        const float tol = 1e-4f * (1.0f + glm::length(truth));
        const glm::vec3 a = interpolate_light_view(*grid, *grid, set[l].vector, set[v].vector, fetch);
        const glm::vec3 b = interpolate_light_view(*ring, *ring, set[l].vector, set[v].vector, fetch);
        ASSERT_LT(glm::length(a - truth), tol) << set.name() << " pair " << l << "," << v;
        ASSERT_LT(glm::length(b - truth), tol) << set.name() << " pair " << l << "," << v;
      }
  }
}

TEST_F(AngularMeasured, LinearBeatsNearestAndDenserSetBeatsSparser) {
  const DirectionSet s03 = DirectionSet::ubo2003(), s14 = DirectionSet::ubo2014();
  auto exact03 = ExactGridInterpolator<ParabolicMap>::build(s03);
  auto near03 = NearestLookupInterpolator<ParabolicMap>::build(s03, 256);
  auto exact14 = ExactGridInterpolator<ParabolicMap>::build(s14);
  ASSERT_TRUE(exact03.ok() && near03.ok() && exact14.ok());
  const double e_lin = held_out_error(brdf_, s03, *exact03, false);
  const double e_near = held_out_error(brdf_, s03, *near03, false);
  EXPECT_LT(e_lin, 0.8 * e_near) << "linear " << e_lin << " nearest " << e_near;
  const double mae03 = held_out_error(brdf_, s03, *exact03, true);
  const double mae14 = held_out_error(brdf_, s14, *exact14, true);
  EXPECT_LT(mae14, 0.8 * mae03) << "UBO2014 " << mae14 << " UBO2003 " << mae03;
}

}  // namespace
}  // namespace btflod
