// Tests for SchedulerConfig's defaults in runtime/vt/scheduler.hpp: the U' packet the scheduler budgets
// for is the packet the container stores for a UBO2014 material (151 × 151 direction pairs × RGB
// rows, four components as halves).
#include <gtest/gtest.h>

#include <vector>

#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/vt/scheduler.hpp"

namespace {

using namespace btflod;

TEST(SchedulerConfigDefaults, UPacketBytesMatchTheContainersPacketForUbo2014) {
  BsvtfMetadata md;
  md.material_name = "ubo2014-sized";
  md.tile_size = 16;
  md.border = 4;
  md.level_count = 1;
  md.width = md.height = 16;
  md.component_count = 4;  // one virtual texture: one U' packet
  md.u_rows = 151 * 151 * 3;
  md.component_ranges.assign(4, 1.0f);
  md.component_scales.assign(4, 1.0f);
  const std::vector<float> u(size_t{md.u_rows} * md.component_count, 0.25f);
  const std::vector<uint8_t> payload(64, 1);  // the reader checks sizes, not tile contents
  const BsvtfEncodedTile root{TileId{0, 0, 0, 0}, payload, 1.0f};
  auto file = write_bsvtf(md, u, std::span<const BsvtfEncodedTile>(&root, 1));
  ASSERT_TRUE(file.ok()) << file.message();
  auto dir = read_bsvtf(file.value());
  ASSERT_TRUE(dir.ok()) << dir.message();
  ASSERT_EQ(dir.value().packets.size(), 1u);
  EXPECT_EQ(dir.value().packets[0].size, 547224u);
  EXPECT_EQ(SchedulerConfig{}.u_packet_bytes, uint64_t{dir.value().packets[0].size});
}

}  // namespace
