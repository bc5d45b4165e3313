// libFuzzer target for runtime/codec/container.hpp: parse a whole `.bsvtf` file from the input; when
// the directory is accepted, verify every payload and decode up to 64 tiles down the hierarchy
// (parents first) and every U packet, as a client would. Nothing may crash, hang or read
// outside the input; every rejection explains itself. The deepest tile decoded is decoded again
// by decode_bsvtf_tile (the whole chain from the root), which must give the same floats, and
// put into an rgba8_affine cache slot (runtime/vt/cache_format.hpp), whose map must be finite and whose
// bytes must decode within half a step of every finite value.
//
// Speed: tile decoders are kept per layout (at most 8 layouts, then the cache starts over) and
// the decoded-tile and U buffers are reused, so an input allocates only what read_bsvtf itself
// allocates (the directory).
//
// Mutation: structure-aware (structure_mutators.hpp: mutate_bsvtf, cross_over_bsvtf), so that
// mutated tiles, U packets and sections get past their CRCs; with BTFLOD_FUZZ_BYTES=1 in the
// environment libFuzzer's plain byte-level mutation and a plain splice cross-over are used.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/vt/cache_format.hpp"
#include "structure_mutators.hpp"

namespace {
using namespace btflod;

TileDecoder& decoder_for(const TileLayout& layout) {
  static std::vector<std::pair<TileLayout, std::unique_ptr<TileDecoder>>> decoders;
  for (auto& [l, d] : decoders)
    if (l == layout) return *d;
  if (decoders.size() >= 8) decoders.clear();
  decoders.emplace_back(layout, std::make_unique<TileDecoder>(layout));
  return *decoders.back().second;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> file(data, size);
  auto dir = read_bsvtf(file);
  if (!dir) {
    if (dir.message().empty()) std::abort();
    return 0;
  }
  static std::vector<float> u;
  for (const auto& p : dir->packets) {
    const auto bytes = file.subspan(p.offset, p.size);
    if (verify_bsvtf_payload(p.size, p.crc, bytes) != Status::success) continue;
    u.resize(std::max(u.size(), bytes.size() / 2));
    unpack_bsvtf_packet(bytes, u);
  }
  const TileLayout layout = dir->metadata.layout();
  TileDecoder& decoder = decoder_for(layout);
  static std::vector<float> pool[64];  // decoded tiles, grown once per layout size
  std::pair<uint64_t, size_t> decoded[64];
  size_t decoded_count = 0, budget = 64;
  TileId deepest;  // the last tile decoded (levels ascend: the deepest)
  for (uint32_t level = 0; level < dir->metadata.level_count && budget > 0; ++level) {
    for (const auto& e : dir->tiles) {
      if (e.id.level != level || budget == 0) continue;
      --budget;
      const auto bytes = file.subspan(e.offset, e.size);
      if (verify_bsvtf_payload(e.size, e.crc, bytes) != Status::success) continue;
      std::span<const float> parent;
      if (level > 0) {
        const uint64_t pk = e.id.parent().key();
        const auto* it = std::find_if(decoded, decoded + decoded_count, [&](const auto& d) { return d.first == pk; });
        if (it == decoded + decoded_count) continue;
        parent = std::span<const float>(pool[it->second].data(), layout.sample_count());
      }
      std::vector<float>& out = pool[decoded_count];
      if (out.size() < layout.sample_count()) out.resize(layout.sample_count());
      if (decoder.decode(bytes, parent, e.id.x & 1, e.id.y & 1, std::span<float>(out).first(layout.sample_count())) ==
          Status::success) {
        decoded[decoded_count] = {e.id.key(), decoded_count};
        ++decoded_count;
        deepest = e.id;
      }
    }
  }
  if (decoded_count == 0) return 0;
  static std::vector<float> chain, scratch;
  static std::vector<uint8_t> unorm8;
  chain.resize(layout.sample_count());
  scratch.resize(layout.sample_count());
  if (decode_bsvtf_tile(*dir, file, deepest, decoder, scratch, chain) != Status::success) std::abort();
  const std::vector<float>& incremental = pool[decoded_count - 1];
  for (size_t i = 0; i < layout.sample_count(); ++i)  // bit-identical, NaN included
    if (std::memcmp(&chain[i], &incremental[i], sizeof(float)) != 0) std::abort();
  unorm8.resize(layout.sample_count());
  const CacheSlotMap map = encode_cache_tile_unorm8(chain, unorm8);
  for (uint32_t c = 0; c < 4; ++c)
    if (!std::isfinite(map.offset[c]) || !std::isfinite(map.scale[c]) || map.scale[c] < 0.0f) std::abort();
  for (size_t i = 0; i < layout.sample_count(); ++i) {
    const uint32_t c = static_cast<uint32_t>(i % 4);
    const float v = chain[i];
    if (!std::isfinite(v) || std::fabs(v) > 32000.0f) continue;
    const double err = std::fabs(static_cast<double>(decode_cache_unorm8(map, c, unorm8[i])) - v);
    if (err > map.scale[c] / 510.0 * 1.001 + 1e-6) std::abort();
  }
  return 0;
}

BTFLOD_FUZZ_STRUCTURE_AWARE(btflod_fuzz::mutate_bsvtf, btflod_fuzz::cross_over_bsvtf)
