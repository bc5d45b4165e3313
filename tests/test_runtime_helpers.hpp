// Shared by the runtime tests (test_runtime_streamer.cpp, test_runtime_equivalence.cpp): the
// reference texels of a tile, decoded straight from its container.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "btflod/codec/container.hpp"
#include "btflod/codec/tile_codec.hpp"
#include "btflod/core/half.hpp"
#include "btflod/vt/tile_id.hpp"

namespace btflod_test {

/// Decodes tile t (container-local ids) of a container directly — the chain root → t, each
/// level against its decoded parent — and returns its half texels: the reference the runtime's
/// uploads must equal. Fails the calling test (EXPECT) when a payload does not decode.
inline std::vector<uint16_t> decode_direct(const std::vector<uint8_t>& file, const btflod::BsvtfDirectory& d,
                                           btflod::TileId t) {
  using namespace btflod;
  const TileLayout layout = d.metadata.layout();
  TileDecoder dec(layout);
  std::vector<float> parent(layout.sample_count()), out(layout.sample_count());
  for (uint32_t l = 0; l <= t.level; ++l) {
    const TileId a = t.ancestor(l);
    const BsvtfTileEntry* e = d.find(a);
    EXPECT_EQ(dec.decode(std::span<const uint8_t>(file.data() + e->offset, e->size),
                         l > 0 ? std::span<const float>(parent) : std::span<const float>(), a.x & 1u, a.y & 1u, out),
              Status::success);
    std::swap(parent, out);
  }
  std::vector<uint16_t> h(layout.sample_count());
  float_to_half(parent, h);
  return h;
}

}  // namespace btflod_test
