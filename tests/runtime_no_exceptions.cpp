// The runtime compiled with -fno-exceptions -fno-rtti (tests/CMakeLists.txt sets the flags on
// this file only): streams one material through runtime/streamer.hpp until every tile of the
// finest level is resident and checks the outputs. Exit code 0 on success.
#include <cstdint>
#include <cstdio>
#include <vector>

#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"

#if defined(__cpp_exceptions) || defined(__cpp_rtti)
#error "this file must be compiled with -fno-exceptions -fno-rtti"
#endif

std::vector<uint8_t> btflod_no_exceptions_container();

int main() {
  using namespace btflod;
  const std::vector<uint8_t> file = btflod_no_exceptions_container();
  auto dir = read_bsvtf(file);
  if (!dir) {
    std::fprintf(stderr, "container: %s\n", dir.message().c_str());
    return 1;
  }
  MemorySource source{std::span<const uint8_t>(file)};
  const StreamerMaterial material{&dir.value(), &source, nullptr};
  StreamerConfig cfg;
  cfg.cache = CacheConfig{6, 6, 1u << 12, 32, 4, 1};
  cfg.vote_window_frames = 1;
  auto created = Streamer::create({&material, 1}, cfg);
  if (!created) {
    std::fprintf(stderr, "create: %s\n", created.message().c_str());
    return 1;
  }
  Streamer s = std::move(created.value());
  std::vector<StreamerTileUpload> tiles(s.tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(s.packet_uploads_bound());
  std::vector<PageTableWrite> writes(1024);
  std::vector<ResidencyEvent> events(16);
  std::vector<uint32_t> feedback;
  const VtLevelTable& lv = s.cache().set().material(0).levels;
  const uint32_t L = lv.finest_level();
  for (uint32_t y = 0; y < lv.tiles_y[L]; ++y)
    for (uint32_t x = 0; x < lv.tiles_x[L]; ++x) feedback.push_back(pack_feedback(FeedbackTile{0, L, x, y}));
  size_t uploads = 0, packet_uploads = 0, page_writes = 0;
  for (int f = 0; f < 30; ++f) {
    StreamerOutputs out{tiles, packets, writes, events};
    if (s.update(feedback, out) != Status::success) return 1;
    uploads += out.tile_upload_count;
    packet_uploads += out.packet_upload_count;
    page_writes += out.page_table_write_count;
    s.pump();
  }
  uint32_t finest_resident = 0;
  for (uint32_t i = lv.offset[L]; i < lv.tile_count(); ++i)
    finest_resident += s.cache().resident(lv.tile(0, i)) ? 1 : 0;
  std::printf(
      "runtime without exceptions/RTTI: %zu tile uploads, %zu U' packets, %zu page-table writes, %u/%u finest tiles\n",
      uploads, packet_uploads, page_writes, finest_resident, lv.tile_count() - lv.offset[L]);
  const bool ok = s.material_ready(0) && packet_uploads == 2 && finest_resident == lv.tile_count() - lv.offset[L] &&
                  uploads >= lv.tile_count() * 2 - 0 && page_writes > 0;
  return ok ? 0 : 1;
}
