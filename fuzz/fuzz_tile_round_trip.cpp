// libFuzzer target for codec/tile_codec.hpp's encoder → decoder round trip. Byte 0: bits 1–3 the
// frequency weighting (quarters 0..7, values above 4 are treated as 4 by the encoder), bit 4 the
// entropy coder (deflate, or zstd when the build has it); the rest
// seeds a 24×24×4 tile and a tolerance. encode → decode must succeed and reproduce the
// encoder's reconstruction bit for bit.
//
// Speed: the encoder (deflate and zstd at the fast level 1: the target is after the codec's quantiser,
// token writer and closed loop, not zlib's match finder), the decoder and every buffer are
// made once; an input costs one encode (forward DCT, quantisation, deflate, the encoder's own
// decode) and one decode.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "btflod/codec/tile_codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace btflod;
  if (size == 0) return 0;
  static const TileLayout layout{16, 4, 4};
  static TileEncoder encoder(layout, 1);
  static TileDecoder decoder(layout);
  static std::vector<float> tile(layout.sample_count()), recon(layout.sample_count()), out(layout.sample_count());
  static std::vector<uint8_t> payload(encoder.bound());
  const uint8_t selector = data[0];
  ++data;
  --size;
  for (size_t i = 0; i < tile.size(); ++i) {
    const uint8_t b = size ? data[i % size] : 0;
    tile[i] = (static_cast<float>(b) - 128.0f) * (1.0f + static_cast<float>(i % 7));
  }
  const float t = 0.01f + (size ? data[0] : 0) * 0.5f;
  const float tol[4] = {t, t * 2, t * 0.5f, t};
  encoder.set_weight_quarters(selector >> 1 & 7u);
  const bool zstd = (selector >> 4 & 1u) && tile_entropy_coder_available(TileEntropyCoder::zstd);
  if (!encoder.set_entropy_coder(zstd ? TileEntropyCoder::zstd : TileEntropyCoder::deflate, 1)) std::abort();
  size_t written = 0;
  if (encoder.encode(tile, {}, 0, 0, tol, payload, written, recon) != Status::success) std::abort();
  if (decoder.decode(std::span<const uint8_t>(payload).first(written), {}, 0, 0, out) != Status::success) std::abort();
  if (std::memcmp(out.data(), recon.data(), out.size() * sizeof(float)) != 0) std::abort();
  return 0;
}
