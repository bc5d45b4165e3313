// libFuzzer target for runtime/vt/cache_bc5.hpp: the BC4/BC5 reference decoder reads any bytes,
// and the encoder any floats. Byte 0 is a selector: bit 0 clear, the rest of the input is BC5
// blocks of an 8 × 8 slot (128 bytes, zero-padded) decoded under a map made of the next 32 bytes
// as floats: every output is offset + scale · u with u in [0, 1], so finite for a finite map,
// and the squared error encode_bc4_block returns for each 16-byte run of unorm8 values equals the
// reference decoder's. Bit 0 set: the rest is 8 × 8 × 4 floats (zero-padded, NaN and ±∞
// included), encoded into the two-plane layout and decoded again: a finite map, and every finite
// value within the slot's range comes back within the encoder's bound: a block's squared error
// never exceeds that of its extreme endpoints, 16 · (range / 14)², so no value is off by more than
// 2/7 of the component's scale, plus the unorm8 step. Static buffers: no allocation per input.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "btflod/runtime/vt/cache_bc5.hpp"

namespace {

constexpr uint32_t kSide = 8;
constexpr size_t kValues = size_t{kSide} * kSide * 4;

void check_decode(const uint8_t* data, size_t size) {
  static uint8_t blocks[btflod::cache_bc5_tile_bytes(kSide)];
  static float values[kValues];
  float map_floats[8] = {};
  std::memcpy(map_floats, data, std::min<size_t>(size, sizeof map_floats));
  const size_t used = std::min<size_t>(size, sizeof map_floats);
  std::memset(blocks, 0, sizeof blocks);
  std::memcpy(blocks, data + used, std::min(size - used, sizeof blocks));
  btflod::CacheSlotMap map;
  bool finite = true;
  for (int c = 0; c < 4; ++c) {
    map.offset[c] = map_floats[c], map.scale[c] = map_floats[4 + c];
    finite = finite && std::isfinite(map.offset[c]) && std::isfinite(map.scale[c]) &&
             std::fabs(map.offset[c]) < 1e30f && std::fabs(map.scale[c]) < 1e30f;
  }
  btflod::decode_cache_tile_bc5(blocks, kSide, map, values);
  for (size_t i = 0; i < kValues; ++i) {
    const size_t c = i % 4;
    if (!finite) continue;
    const double lo = std::min(map.offset[c], map.offset[c] + map.scale[c]);
    const double hi = std::max(map.offset[c], map.offset[c] + map.scale[c]);
    const double slack = 1e-5 * (std::fabs(lo) + std::fabs(hi) + 1.0);
    if (!(values[i] >= lo - slack && values[i] <= hi + slack)) std::abort();
  }
  // The encoder's reported error is the reference decoder's, for any 16 unorm8 values.
  for (size_t run = 0; run + 16 <= sizeof blocks; run += 16) {
    uint8_t block[8];
    float decoded[16];
    const float err = btflod::encode_bc4_block(blocks + run, block);
    btflod::decode_bc4_block(block, decoded);
    double check = 0;
    for (int t = 0; t < 16; ++t) check += std::pow(blocks[run + t] - decoded[t] * 255.0, 2);
    if (std::fabs(err - check) > 1e-2 * (1.0 + check)) std::abort();
  }
}

void check_round_trip(const uint8_t* data, size_t size) {
  static float values[kValues];
  static float back[kValues];
  static uint8_t scratch[kValues];
  static uint8_t blocks[btflod::cache_bc5_tile_bytes(kSide)];
  std::memset(values, 0, sizeof values);
  std::memcpy(values, data, std::min(size, sizeof values));
  const btflod::CacheSlotMap map = btflod::encode_cache_tile_bc5(values, kSide, scratch, blocks);
  for (int c = 0; c < 4; ++c)
    if (!std::isfinite(map.offset[c]) || !std::isfinite(map.scale[c]) || map.scale[c] < 0.0f) std::abort();
  btflod::decode_cache_tile_bc5(blocks, kSide, map, back);
  for (size_t i = 0; i < kValues; ++i) {
    const size_t c = i % 4;
    const float v = values[i];
    // Values the map covers (finite, inside the slot's range); the others saturate or map to the offset.
    if (!std::isfinite(v) || v < map.offset[c] || v > map.offset[c] + map.scale[c]) continue;
    const double bound = map.scale[c] * (2.0 / 7.0 + 1.0 / 255.0) + 1e-5 * (std::fabs(v) + map.scale[c] + 1.0);
    if (!(std::fabs(static_cast<double>(back[i]) - v) <= bound)) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  if (data[0] & 1)
    check_round_trip(data + 1, size - 1);
  else
    check_decode(data + 1, size - 1);
  return 0;
}
