// libFuzzer target for codec/tile_codec.hpp.
// Byte 0 selects the mode:
//   even: the rest is a tile payload, decoded with a 24×24 or 72×72 decoder (chosen from the
//         header; bit 3 picks the zlib or the libdeflate backend), with a parent tile when the
//         header asks for one; the output span ends exactly
//         at the end of its allocation so ASan catches any over-write.
//   odd:  round trip: the rest seeds a 24×24×4 tile and a tolerance, bits 1–3 of byte 0 the
//         frequency weighting (quarters 0..4, larger values = 4); encode → decode must succeed
//         and reproduce the encoder's reconstruction bit for bit.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "btflod/codec/tile_codec.hpp"

namespace {
using namespace btflod;

void decode_mode(const uint8_t* data, size_t size, uint8_t selector) {
  TileHeaderInfo info;
  const uint32_t stored = (tile_peek_header({data, size}, info) == Status::success) ? info.stored_size : 24;
  const TileLayout layout{stored == 72 ? 64u : 16u, 4, info.channels >= 1 && info.channels <= 4 ? info.channels : 4};
  // Bit 3 of the selector picks the inflate backend: zlib, or libdeflate when the build has it
  // (BTFLOD_WITH_LIBDEFLATE, the default), so both entropy stages see the fuzzer's streams.
  const uint32_t backend = selector >> 3 & 1u;
  static std::unique_ptr<TileDecoder> decoders[2][2][5];
  auto& dec = decoders[backend][stored == 72][layout.channels];
  if (!dec) dec = std::make_unique<TileDecoder>(layout, backend ? InflateBackend::libdeflate : InflateBackend::zlib);
  std::vector<float> parent(layout.sample_count());
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<float>(i % 17) * 0.125f;
  std::vector<float> out(layout.sample_count());
  const Status s = dec->decode({data, size}, parent, selector >> 1 & 1u, selector >> 2 & 1u, out);
  if (s == Status::success)
    for (float v : out)
      if (!std::isfinite(v)) std::abort();  // bounded tolerances and symbols keep values finite
}

void round_trip_mode(const uint8_t* data, size_t size, uint8_t selector) {
  static const TileLayout layout{16, 4, 4};
  static TileEncoder encoder(layout, 1);  // fast deflate level: the fuzzer is after the decoder
  static TileDecoder decoder(layout);
  std::vector<float> tile(layout.sample_count());
  for (size_t i = 0; i < tile.size(); ++i) {
    const uint8_t b = size ? data[i % size] : 0;
    tile[i] = (static_cast<float>(b) - 128.0f) * (1.0f + static_cast<float>(i % 7));
  }
  const float t = 0.01f + (size ? data[0] : 0) * 0.5f;
  const float tol[4] = {t, t * 2, t * 0.5f, t};
  encoder.set_weight_quarters(selector >> 1 & 7u);
  std::vector<uint8_t> payload(encoder.bound());
  std::vector<float> recon(layout.sample_count()), out(layout.sample_count());
  size_t written = 0;
  if (encoder.encode(tile, {}, 0, 0, tol, payload, written, recon) != Status::success) std::abort();
  if (decoder.decode(std::span<const uint8_t>(payload).first(written), {}, 0, 0, out) != Status::success) std::abort();
  if (std::memcmp(out.data(), recon.data(), out.size() * sizeof(float)) != 0) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  if (data[0] & 1) {
    round_trip_mode(data + 1, size - 1, data[0]);
  } else {
    decode_mode(data + 1, size - 1, data[0]);
  }
  return 0;
}
