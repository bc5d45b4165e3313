// The tile payload fuzz_tile_zstd.cpp decodes in its decode mode, written once for the fuzzer
// and for the test that checks its seeds (tests/test_codec_tile_zstd.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "btflod/runtime/codec/tile_codec.hpp"

namespace btflod_fuzz {

// Writes into payload (reusing its storage) the tile fuzz_tile_zstd decodes for the input
// data[0, size) in decode mode: an otherwise valid format-3 zstd header for `layout` whose
// declared symbol byte count is bytes 1–2 (little-endian) folded into the range
// tile_peek_header accepts, residual when bit 1 of byte 0 is set, then bytes 3… as the zstd
// frame. Precondition: size ≥ 1.
inline void tile_zstd_decode_payload(const btflod::TileLayout& layout, const uint8_t* data, size_t size,
                                     std::vector<uint8_t>& payload) {
  using namespace btflod;
  const size_t blocks = tile_block_count(layout.stored_size(), layout.channels);
  const uint32_t lo = static_cast<uint32_t>(blocks * kTileMinBlockCode);
  const uint32_t hi = static_cast<uint32_t>(blocks * kTileMaxBlockCode);
  uint32_t declared = size >= 3 ? uint32_t{data[1]} | uint32_t{data[2]} << 8 : lo;
  declared = lo + declared % (hi - lo + 1);
  const size_t header = tile_header_size(layout.channels);
  payload.assign(header, 0);
  payload[0] = kTileFormatVersionCoder;
  payload[1] = kTileBlock;
  payload[2] = static_cast<uint8_t>(layout.channels);
  payload[3] = static_cast<uint8_t>((data[0] >> 1 & 1u) | static_cast<uint32_t>(TileEntropyCoder::zstd) << 4);
  const uint16_t stored = static_cast<uint16_t>(layout.stored_size());
  std::memcpy(payload.data() + 4, &stored, 2);
  std::memcpy(payload.data() + 6, &stored, 2);
  for (uint32_t c = 0; c < layout.channels; ++c) {
    const float t = 0.01f * static_cast<float>(c + 1);
    std::memcpy(payload.data() + 8 + 4 * c, &t, 4);
  }
  std::memcpy(payload.data() + header - 4, &declared, 4);
  if (size > 3) payload.insert(payload.end(), data + 3, data + size);
}

}  // namespace btflod_fuzz
