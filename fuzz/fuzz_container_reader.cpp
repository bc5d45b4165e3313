// libFuzzer target for codec/container.hpp: parse a whole `.bsvtf` file from the input; when
// the directory is accepted, verify every payload and decode up to 64 tiles down the hierarchy
// (parents first) and every U packet, as a client would. Nothing may crash, hang or read
// outside the input.
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "btflod/codec/container.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace btflod;
  const std::span<const uint8_t> file(data, size);
  auto dir = read_bsvtf(file);
  if (!dir) return 0;
  for (const auto& p : dir->packets) {
    const auto bytes = file.subspan(p.offset, p.size);
    if (verify_bsvtf_payload(p.size, p.crc, bytes) != Status::success) continue;
    std::vector<float> u(bytes.size() / 2);
    unpack_bsvtf_packet(bytes, u);
  }
  const TileLayout layout = dir->metadata.layout();
  TileDecoder decoder(layout);
  std::unordered_map<uint64_t, std::vector<float>> decoded;
  size_t budget = 64;
  for (uint32_t level = 0; level < dir->metadata.level_count && budget > 0; ++level) {
    for (const auto& e : dir->tiles) {
      if (e.id.level != level || budget == 0) continue;
      --budget;
      const auto bytes = file.subspan(e.offset, e.size);
      if (verify_bsvtf_payload(e.size, e.crc, bytes) != Status::success) continue;
      std::span<const float> parent;
      if (level > 0) {
        auto it = decoded.find(e.id.parent().key());
        if (it == decoded.end()) continue;
        parent = it->second;
      }
      std::vector<float> out(layout.sample_count());
      if (decoder.decode(bytes, parent, e.id.x & 1, e.id.y & 1, out) == Status::success) decoded[e.id.key()] = std::move(out);
    }
  }
  return 0;
}
