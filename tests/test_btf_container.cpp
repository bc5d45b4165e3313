// Tests for offline/angular/directions.hpp and offline/btf/tabulated_btf.hpp.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"

namespace {

using namespace btflod;

int count_ring(const DirectionSet& s, float theta_deg) {
  int n = 0;
  for (const auto& d : s) n += std::abs(radians_to_degrees(d.theta) - theta_deg) < 1e-3f;
  return n;
}

TEST(DirectionSet, Ubo2003HasTheDocumentedRings) {
  const DirectionSet s = DirectionSet::ubo2003();
  ASSERT_EQ(s.size(), 81u);
  const int expected[] = {1, 6, 12, 18, 20, 24};
  for (int r = 0; r < 6; ++r) EXPECT_EQ(count_ring(s, 15.0f * r), expected[r]) << "ring " << r;
  // θ = 60°: 20 directions 18° apart starting at 0.
  const size_t i = s.find_degrees(60.0f, 18.0f);
  ASSERT_LT(i, s.size());
  EXPECT_NEAR(radians_to_degrees(s[i].phi), 18.0f, 1e-4f);
  EXPECT_EQ(s.find_degrees(60.0f, 9.0f), s.size());  // between two samples: no match
  EXPECT_LT(s.find_degrees(75.0f, 345.0f), s.size());
  EXPECT_LT(s.find_degrees(75.0f, -15.0f), s.size());  // same direction, other spelling
  for (const auto& d : s) EXPECT_NEAR(glm::length(d.vector), 1.0f, 1e-6f);
}

TEST(DirectionSet, Ubo2014HasTheDocumentedRingsOffsetsAndWrapping) {
  const DirectionSet s = DirectionSet::ubo2014();
  ASSERT_EQ(s.size(), 151u);
  const float thetas[] = {0, 11, 23.5f, 30, 37.5f, 45, 52.5f, 60, 67.5f, 75};
  const int counts[] = {1, 6, 12, 12, 12, 18, 18, 24, 24, 24};
  for (int r = 0; r < 10; ++r) EXPECT_EQ(count_ring(s, thetas[r]), counts[r]) << "ring " << r;
  for (const auto& d : s) {
    const float p = radians_to_degrees(d.phi);
    EXPECT_GE(p, -180.0f - 1e-3f);
    EXPECT_LT(p, 180.0f);
  }
  // Ring θ = 11°: offset 15°, 60° apart → 15, 75, 135, −165, −105, −45.
  EXPECT_LT(s.find_degrees(11.0f, 15.0f, 0.01f), s.size());
  EXPECT_LT(s.find_degrees(11.0f, -165.0f, 0.01f), s.size());
  EXPECT_EQ(s.find_degrees(11.0f, 0.0f, 0.01f), s.size());
  // Ring θ = 52.5°: 18 directions, offset 7.5° → 7.5, 27.5, ...
  EXPECT_LT(s.find_degrees(52.5f, 27.5f, 0.01f), s.size());
  std::set<std::pair<int, int>> unique;
  for (const auto& d : s) unique.insert({int(std::lround(d.vector.x * 1e5)), int(std::lround(d.vector.y * 1e5))});
  EXPECT_EQ(unique.size(), 151u) << "directions must be distinct";
}

TEST(DirectionSet, NearestFindsTheClosestDirection) {
  const DirectionSet s = DirectionSet::ubo2003();
  for (size_t i = 0; i < s.size(); ++i) {
    const glm::vec3 v = s[i].vector * 3.0f + glm::vec3(0.001f, -0.001f, 0.0f);
    EXPECT_EQ(s.nearest(v), i);
  }
  EXPECT_EQ(s.nearest(glm::vec3(0.0f)), s.size());
}

TEST(TabulatedBtf, LayoutIsImageMajorAsDocumented) {
  BtfFloat btf(5, 3, DirectionSet::ubo2003(), DirectionSet::ubo2014());
  EXPECT_EQ(btf.samples().size(), 5u * 3u * 81u * 151u * 3u);
  // index(x, y, v, l, c) = ((((v·nL + l)·H + y)·W + x)·3 + c
  EXPECT_EQ(btf.index(2, 1, 4, 7, 2), ((((4u * 151u + 7u) * 3u + 1u) * 5u + 2u) * 3u + 2u));
  btf.at(2, 1, 4, 7, 2) = 0.25f;
  EXPECT_EQ(btf.image(4, 7).at(2, 1, 2), 0.25f);
  EXPECT_TRUE(btf.image(4, 7).is_dense());
  EXPECT_EQ(btf.abrdf(2, 1).at(4, 7, 2), 0.25f);
  EXPECT_EQ(btf.abrdf(2, 1).view_count(), 81u);
}

TEST(TabulatedBtf, HalfConversionRoundsAndRoundTrips) {
  BtfFloat btf(2, 2, DirectionSet::ubo2003(), DirectionSet::ubo2003());
  float v = 0.0f;
  for (float& s : btf.samples()) s = (v += 0.001f);
  const BtfHalf h = btf.convert<Half>();
  EXPECT_EQ(h.size_bytes() * 2, btf.size_bytes());
  const BtfFloat back = h.convert<float>();
  double max_rel = 0.0;
  for (size_t i = 0; i < btf.samples().size(); ++i)
    max_rel = std::max(max_rel, std::abs(double(back.samples()[i]) - btf.samples()[i]) / btf.samples()[i]);
  EXPECT_LE(max_rel, 1.0 / 2048.0 + 1e-9);  // half has 11 significant bits
  EXPECT_EQ(h.value(1, 1, 3, 4, 1), back.value(1, 1, 3, 4, 1));
}

TEST(TabulatedBtf, CheckedSampleCountRejectsEmptyOverflowingAndHugeShapes) {
  EXPECT_TRUE(BtfFloat::checked_sample_count(64, 64, 81, 81).ok());
  EXPECT_EQ(BtfFloat::checked_sample_count(0, 64, 81, 81).status(), Status::bad_data);
  EXPECT_EQ(BtfFloat::checked_sample_count(1u << 31, 1u << 31, 1u << 31, 1u << 31).status(),
            Status::insufficient_space);
  EXPECT_EQ(BtfFloat::checked_sample_count(65536, 65536, 151, 151).status(), Status::insufficient_space);
}

}  // namespace
