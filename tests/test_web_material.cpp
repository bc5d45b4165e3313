// The web client's directory-side helpers (samples/web/client/web_material.hpp), natively: U'
// packets land in the texel the shaders read for both row orders, angular tables are valid
// barycentric tables, bad metadata and bad containers are refused with an error.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "../samples/web/client/web_material.hpp"

namespace {

using namespace btflod;

BsvtfMetadata small_metadata(uint32_t lights, uint32_t views, uint32_t components) {
  BsvtfMetadata md;
  md.material_name = "test";
  md.component_count = components;
  md.color_channels = 3;
  md.u_rows = lights * views * 3;
  const float thetas[] = {0.0f, 0.5f, 1.0f, 1.3f};
  for (uint32_t i = 0; i < std::max(lights, views); ++i) {
    const float t = thetas[i % 4], p = 1.7f * static_cast<float>(i);
    const float xyz[3] = {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
    for (int k = 0; k < 3; ++k) {
      if (i < lights) md.light_directions.push_back(xyz[k]);
      if (i < views) md.view_directions.push_back(xyz[k]);
    }
  }
  return md;
}

// Value of U at (row, component) in the producer's encoding of the test.
float u_value(size_t row, uint32_t c) { return static_cast<float>(row) * 0.01f + static_cast<float>(c); }

void check_scatter(AngularRowOrder order) {
  const uint32_t L = 2, V = 3, C = 5;
  BsvtfMetadata md = small_metadata(L, V, C);
  md.u_row_order = order;
  std::vector<float> rgba(static_cast<size_t>(L) * V * C * 4, -1.0f), u(static_cast<size_t>(md.u_rows) * C, -1.0f);
  for (uint32_t g = 0; g < 2; ++g) {
    std::vector<float> packet(static_cast<size_t>(md.u_rows) * 4);
    for (size_t r = 0; r < md.u_rows; ++r)
      for (uint32_t k = 0; k < 4; ++k) packet[r * 4 + k] = u_value(r, 4 * g + k);
    web::scatter_u_packet(md, g, packet, rgba, u, md.u_row_order);
  }
  for (uint32_t l = 0; l < L; ++l)
    for (uint32_t v = 0; v < V; ++v)
      for (uint32_t col = 0; col < 3; ++col) {
        const size_t row = order == AngularRowOrder::view_major ? (static_cast<size_t>(v) * L + l) * 3 + col
                                                                : (static_cast<size_t>(l) * V + v) * 3 + col;
        for (uint32_t c = 0; c < C; ++c) {
          // eigen_abrdfs texel (light, view), layer c, channel colour; E's U is light-major.
          EXPECT_FLOAT_EQ(rgba[((static_cast<size_t>(c) * V + v) * L + l) * 4 + col], u_value(row, c));
          EXPECT_FLOAT_EQ(u[((static_cast<size_t>(l) * V + v) * 3 + col) * C + c], u_value(row, c));
        }
      }
}

TEST(WebMaterial, UPacketsLightMajor) { check_scatter(AngularRowOrder::light_major); }
TEST(WebMaterial, UPacketsViewMajor) { check_scatter(AngularRowOrder::view_major); }

TEST(WebMaterial, AngularTablesAreBarycentric) {
  const BsvtfMetadata md = small_metadata(7, 5, 4);
  auto a = web::build_angular_textures(md, 16);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_EQ(a->index_rgba.size(), 16u * 16u * 2u * 4u);
  for (size_t t = 0; t < 16u * 16u * 2u; ++t) {
    const uint32_t count = t < 256 ? 7u : 5u;
    float sum = 0;
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT(a->index_rgba[t * 4 + k], count);
      EXPECT_GE(a->weight_rgba[t * 4 + k], -1e-5f);
      sum += a->weight_rgba[t * 4 + k];
    }
    EXPECT_NEAR(sum, 1.0f, 1e-4f);
  }
}

TEST(WebMaterial, RejectsUnsupportedU) {
  BsvtfMetadata md = small_metadata(2, 3, 4);
  EXPECT_TRUE(web::check_u_layout(md).ok());
  md.u_rows += 3;  // rows that do not match lights × views × 3
  EXPECT_FALSE(web::check_u_layout(md).ok());
  md = small_metadata(2, 3, 4);
  md.color_mode = ColorMode::ycbcr;
  EXPECT_FALSE(web::check_u_layout(md).ok());
}

TEST(WebMaterial, DecodeCheckRefusesGarbageAndTruncation) {
  std::vector<uint8_t> garbage(4096, 0x5a);
  EXPECT_NE(web::decode_container_tiles(garbage, InflateBackend::zlib, 1).status, Status::success);
  std::vector<uint8_t> empty;
  EXPECT_NE(web::decode_container_tiles(empty, InflateBackend::zlib, 1).status, Status::success);
}

}  // namespace
