// Tests for offline/factor/fmf_stream.hpp: an FMF's eigen-textures are its V·Σ and U exactly; its
// container (build_bsvtf_from_fmf) records U's view-major order, the FMF's directions and their
// set names, and a Streamer accepts it and loads its roots and U′ packets.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "btflod/offline/factor/fmf_stream.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"

namespace {

using namespace btflod;

// A rank-3 BTF of 40×24 texels on five named light directions and UBO2003's views.
BtfFloat low_rank_btf() {
  std::vector<std::pair<float, float>> l = {{0.0f, 0.0f}, {0.4f, 1.0f}, {0.8f, 2.0f}, {1.1f, -1.0f}, {0.6f, 3.0f}};
  BtfFloat btf(40, 24, DirectionSet::ubo2003(), DirectionSet::from_radians("five", l));
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> d(0.05f, 1.0f);
  const size_t rows = btf.view_count() * btf.light_count();
  for (int c = 0; c < 3; ++c)
    for (int j = 0; j < 3; ++j) {
      std::vector<float> a(rows), b(btf.texel_count());
      for (auto& x : a) x = d(rng);
      for (auto& x : b) x = d(rng);
      for (size_t r = 0; r < rows; ++r)
        for (size_t t = 0; t < b.size(); ++t) btf.samples()[(r * b.size() + t) * 3 + c] += a[r] * b[t] / 3;
    }
  return btf;
}

// Each colour channel has rank 3, so U·(VΣ)ᵀ has rank ≤ 9 over the three channels' rows.
Fmf small_fmf() {
  FmfOptions o;
  o.components = 9;
  return factorize_fmf(low_rank_btf(), o).value();
}

}  // namespace

TEST(FmfStream, EigenTexturesAreTheFmfFactorsExactly) {
  const Fmf f = small_fmf();
  const EigenTextures e = eigen_textures_from_fmf(f);
  ASSERT_TRUE(e.valid());
  ASSERT_EQ(e.components(), 9u);
  EXPECT_EQ(e.light_count, 5u);
  EXPECT_EQ(e.view_count, 81u);
  EXPECT_EQ(e.angular, f.u);
  // The eigen-textures say their rows are the FMF's view-major ones, and u() reads them so.
  EXPECT_EQ(e.row_order, AngularRowOrder::view_major);
  EXPECT_EQ(e.u(3, 17, 2, 4), f.u[((17 * 5 + 3) * 3 + 2) * 9 + 4]);
  for (int y = 0; y < f.shape.height; ++y)
    for (int x = 0; x < f.shape.width; ++x)
      for (int k = 0; k < 9; ++k)
        ASSERT_EQ(e.textures.at(x, y, k), f.v[(static_cast<size_t>(y) * 40 + static_cast<size_t>(x)) * 9 + k]);
  // Independent of the copy: the factors rebuild a sample of the BTF (paper 000 eq. 5).
  const BtfFloat btf = low_rank_btf();
  const uint32_t view = 17, light = 3, x = 11, y = 7;
  for (uint32_t colour = 0; colour < 3; ++colour) {
    double sum = 0;
    for (uint32_t k = 0; k < 9; ++k)
      sum += static_cast<double>(e.angular[((view * 5 + light) * 3 + colour) * 9 + k]) *
             e.textures.at(x, y, static_cast<int>(k));
    EXPECT_NEAR(sum, btf.at(static_cast<int>(x), static_cast<int>(y), view, light, static_cast<int>(colour)), 1e-3);
  }
}

TEST(FmfStream, ContainerRecordsTheOrderAndDirectionsAndStreams) {
  const Fmf f = small_fmf();
  BsvtfFromEigenOptions o;
  o.tile_size = 16;
  o.border = 4;
  o.material_name = "low-rank";
  auto file = build_bsvtf_from_fmf(f, o);
  ASSERT_TRUE(file) << file.message();
  auto dir = read_bsvtf(*file);
  ASSERT_TRUE(dir) << dir.message();
  const BsvtfMetadata& md = dir->metadata;
  EXPECT_EQ(md.u_row_order, AngularRowOrder::view_major);
  EXPECT_EQ(md.width, 40u);
  EXPECT_EQ(md.height, 24u);
  EXPECT_EQ(md.component_count, 9u);
  EXPECT_EQ(md.u_rows, 81u * 5u * 3u);
  EXPECT_EQ(md.light_set, "five");
  EXPECT_EQ(md.view_set, DirectionSet::ubo2003().name());
  EXPECT_EQ(md.material_name, "low-rank");
  ASSERT_EQ(md.light_directions.size(), 15u);
  const Direction& l1 = f.shape.lights[1];
  EXPECT_FLOAT_EQ(md.light_directions[3], l1.vector[0]);
  EXPECT_FLOAT_EQ(md.light_directions[4], l1.vector[1]);
  EXPECT_FLOAT_EQ(md.light_directions[5], l1.vector[2]);

  // A Streamer takes it as it is (no assumed row order needed) and loads roots and packets.
  MemorySource source{std::span<const uint8_t>(*file)};
  const StreamerMaterial material{&dir.value(), &source, nullptr};
  StreamerConfig config;
  config.cache = CacheConfig{4, 4, 1u << 12, 16, 4, 1};
  auto s = Streamer::create(std::span<const StreamerMaterial>(&material, 1), config);
  ASSERT_TRUE(s) << s.error().message;
  std::vector<StreamerTileUpload> tiles(s.value().tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(s.value().packet_uploads_bound());
  std::vector<PageTableWrite> writes(1024);
  std::vector<ResidencyEvent> events(64);
  size_t packet_uploads = 0;
  for (int frame = 0; frame < 10 && !s.value().material_ready(0); ++frame) {
    StreamerOutputs out{tiles, packets, writes, events};
    ASSERT_EQ(s.value().update({}, out), Status::success);
    packet_uploads += out.packet_upload_count;
    s.value().pump();
  }
  EXPECT_TRUE(s.value().material_ready(0));
  EXPECT_EQ(packet_uploads, 3u);  // ⌈9 / 4⌉ U′ packets
}

// The CPU shading reads U through the eigen-textures' row order: a light-major copy of the same
// factors shades the same radiance, and the view-major U read as if light-major would not.
TEST(FmfStream, ShadingHonoursTheRowOrder) {
  const Fmf f = small_fmf();
  const EigenTextures vm = eigen_textures_from_fmf(f);
  EigenTextures lm = vm;
  lm.row_order = AngularRowOrder::light_major;
  for (uint32_t l = 0; l < vm.light_count; ++l)
    for (uint32_t v = 0; v < vm.view_count; ++v)
      for (uint32_t c = 0; c < 3; ++c)
        for (uint32_t k = 0; k < 9; ++k)
          lm.angular[((size_t{l} * vm.view_count + v) * 3 + c) * 9 + k] = vm.u(l, v, c, k);
  AngularSample light, view;
  light.index = {1, 3, 4};
  light.weight = {0.2f, 0.5f, 0.3f};
  view.index = {17, 40, 2};
  view.weight = {0.6f, 0.1f, 0.3f};
  std::vector<float> comps(9);
  for (int k = 0; k < 9; ++k) comps[static_cast<size_t>(k)] = vm.textures.at(11, 7, k);
  const glm::vec3 a = shade_fmf(vm, light, view, comps), b = shade_fmf(lm, light, view, comps);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-5f * (1.0f + std::fabs(a[c])));
  EigenTextures misread = vm;
  misread.row_order = AngularRowOrder::light_major;  // view-major rows, wrong label
  const glm::vec3 m = shade_fmf(misread, light, view, comps);
  EXPECT_GT(std::fabs(m[0] - a[0]) + std::fabs(m[1] - a[1]) + std::fabs(m[2] - a[2]), 1e-3f);
}
