// runtime/angular/bsvtf_angular_tables.hpp: a streamed material's angular lookup tables built from
// its container's directions by the runtime (no GLM) are the offline interpolator's tables, bit for
// bit, for both of the shaders' parameterisations; bad metadata gives an error, never a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/parameterization.hpp"
#include "btflod/runtime/angular/bsvtf_angular_tables.hpp"

namespace {

using namespace btflod;

std::vector<float> xyz_of(const DirectionSet& set) {
  std::vector<float> xyz;
  for (const Direction& d : set) xyz.insert(xyz.end(), {d.vector.x, d.vector.y, d.vector.z});
  return xyz;
}

// The set the runtime sees: (θ, φ) recovered from each xyz exactly as the table builder does.
DirectionSet set_from_xyz(const std::vector<float>& xyz) {
  std::vector<std::pair<float, float>> tp;
  for (size_t i = 0; i < xyz.size(); i += 3) {
    const float x = xyz[i], y = xyz[i + 1], z = xyz[i + 2];
    const float len = std::sqrt(x * x + y * y + z * z);
    tp.emplace_back(std::acos(std::fmin(1.0f, std::fmax(-1.0f, z / len))), std::atan2(y, x));
  }
  return DirectionSet::from_radians("from xyz", tp);
}

template <class Map>
void expect_same_tables(const std::vector<float>& xyz, const std::vector<uint32_t>& index,
                        const std::vector<float>& weight, int resolution) {
  auto offline = LookupTableInterpolator<Map>::build(set_from_xyz(xyz), resolution);
  ASSERT_TRUE(offline.ok()) << offline.message();
  const auto& oi = offline->index_table().elements();
  const auto& ow = offline->weight_table().elements();
  ASSERT_EQ(index.size(), oi.size());
  ASSERT_EQ(weight.size(), ow.size());
  EXPECT_EQ(std::memcmp(index.data(), oi.data(), index.size() * sizeof(uint32_t)), 0) << Map::kName;
  EXPECT_EQ(std::memcmp(weight.data(), ow.data(), weight.size() * sizeof(float)), 0) << Map::kName;
}

TEST(AngularRuntimeTables, AreTheOfflineLookupTablesBitForBit) {
  BsvtfMetadata md;
  md.light_directions = xyz_of(DirectionSet::ubo2003());
  md.view_directions = xyz_of(DirectionSet::ubo2014());
  for (const uint32_t res : {7u, 32u, 64u}) {
    for (const auto p : {DirectionParameterisation::parabolic, DirectionParameterisation::elevated_concentric}) {
      auto t = build_bsvtf_angular_tables(md, AngularTableConfig{p, AngularLookup::barycentric, res});
      ASSERT_TRUE(t.ok()) << t.message();
      EXPECT_EQ(t->light_count, 81u);
      EXPECT_EQ(t->view_count, 151u);
      const int r = static_cast<int>(res);
      if (p == DirectionParameterisation::parabolic) {
        expect_same_tables<ParabolicMap>(md.light_directions, t->light_index, t->light_weight, r);
        expect_same_tables<ParabolicMap>(md.view_directions, t->view_index, t->view_weight, r);
      } else {
        expect_same_tables<ElevatedConcentricMap>(md.light_directions, t->light_index, t->light_weight, r);
        expect_same_tables<ElevatedConcentricMap>(md.view_directions, t->view_index, t->view_weight, r);
      }
      // The shader's RGBA textures: layer 0 light, layer 1 view, .w = 0.
      ASSERT_EQ(t->index_rgba.size(), size_t{2} * res * res * 4);
      EXPECT_EQ(t->index_rgba[4 * (res * res + 1) + 2], t->view_index[3 + 2]);
      EXPECT_EQ(t->weight_rgba[4 * 1 + 1], t->light_weight[3 + 1]);
      EXPECT_EQ(t->weight_rgba[3], 0.0f);
    }
  }
}

TEST(AngularRuntimeTables, BadMetadataIsAnError) {
  const AngularTableConfig config{};
  BsvtfMetadata md;
  md.light_directions = xyz_of(DirectionSet::ubo2003());
  md.view_directions = md.light_directions;
  ASSERT_TRUE(build_bsvtf_angular_tables(md, config).ok());
  BsvtfMetadata bad = md;
  bad.view_directions.clear();  // no directions
  EXPECT_EQ(build_bsvtf_angular_tables(bad, config).status(), Status::invalid_argument);
  bad = md;
  bad.light_directions.pop_back();  // not a multiple of 3
  EXPECT_EQ(build_bsvtf_angular_tables(bad, config).status(), Status::invalid_argument);
  bad = md;
  bad.light_directions[4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(build_bsvtf_angular_tables(bad, config).status(), Status::invalid_argument);
  bad = md;
  bad.view_directions = {0, 0, 1, 0, 0, 2, 0.5f, 0, 0.5f};  // two distinct points only
  EXPECT_EQ(build_bsvtf_angular_tables(bad, config).status(), Status::invalid_argument);
  for (const uint32_t res : {0u, 8193u, 0x80000000u}) {
    const AngularTableConfig c{DirectionParameterisation::parabolic, AngularLookup::barycentric, res};
    EXPECT_EQ(build_bsvtf_angular_tables(md, c).status(), Status::invalid_argument) << res;
  }
}

}  // namespace
